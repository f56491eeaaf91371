//! The design driver of every split but `skew_slack`: preparation, the
//! requested α/γ search, the final regularised solve, the notes and the
//! summary, each a function of its own.

use super::attempt::{append_notes, design_of, Point, Shown, Solve};
use super::Ctx;
use crate::backend::Status;
use crate::certificate::poles::disk_gain_bound;
use crate::certificate::DataCheck;
use crate::conditions::ConditionSet;
use crate::error::SolveError;
use crate::lmi::{Objective, Problem};
use crate::model::output_filter::OutputRouteInfo;
use crate::model::state_bound::StateBoundInfo;
use crate::model::{gamma_max, ObserverModel, ObserverOptions, StateBoundClaim, StateScaling};
use crate::report::{Design, GammaSearchInfo, Note, Notes, SearchStep, SolverInfo};
use crate::settings::Settings;
use crate::vocab::{BoundSource, Candidate, Family, Phase};
use qpv_dsl::{
    AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, PolytopicModel, Split, StateBound,
};
use std::collections::BTreeMap;
use std::time::Instant;

/// A request checked and its observer's model built, before any solve.
pub(super) struct Setup {
    /// The model the conditions are solved and certified on.
    pub model: PolytopicModel,
    /// The state bound used, for the report.
    pub bound_info: StateBoundInfo,
    /// The output route used, for the report.
    pub route_info: OutputRouteInfo,
    /// The size guard's "slow" warning, if any.
    pub size_note: Option<String>,
    /// γ_max from (S4), if the model has a state bound.
    pub gmax: Option<f64>,
    /// The top of the γ search's range.
    pub gamma_hi: f64,
    /// The global observer of an LPV plant ([`crate::model::is_global`]).
    pub global: bool,
    /// A badly scaled model in balanced coordinates x = D z, with D
    /// ([`StateScaling`]): the problem is solved there, its points mapped
    /// back, and certified on `model`.
    pub scaled: Option<(PolytopicModel, StateScaling)>,
}

impl Setup {
    /// Validates the model and the request, applies the size guard, and
    /// builds the observer's model: `state_bound auto` computed (then used
    /// as given), the output route (the model itself or its augmentation by
    /// the output post-filter), the requested representation of N_k, M_k.
    pub fn new(
        model: &PolytopicModel,
        request: &DesignRequest,
        settings: &Settings,
    ) -> Result<Setup, SolveError> {
        let set = ConditionSet::from_mode(request.mode);
        crate::model::validate(model)?;
        let global = crate::model::is_global(model, request.mode);
        if request.mode == Mode::Paper && !model.has_region() {
            return Err(SolveError::Unsupported(format!(
                "model `{}`: paper mode reproduces the printed conditions on a region, and this LPV plant has none; its sound design is the global observer (docs/method.md §17)",
                model.name
            )));
        }
        let global_model = crate::model::global_model(model);
        let model: &PolytopicModel = if global { &global_model } else { model };
        // Refuse before anything is assembled or solved.
        let size_note = match crate::model::size::guard(model, request) {
            crate::model::size::Verdict::TooLarge(m) => return Err(SolveError::TooLarge(m)),
            crate::model::size::Verdict::Slow(m) => Some(m),
            crate::model::size::Verdict::Fits => None,
        };
        let prepared = ObserverModel::prepare(
            model,
            &ObserverOptions::for_request(request),
            StateBoundClaim::Compute(settings),
        )?;
        let model = prepared.model;
        let has_q = matches!(model.state_bound, StateBound::Given(_));
        if set.requires_s4() && !has_q && !global {
            return Err(SolveError::MissingStateBound(model.name.clone()));
        }
        if let AlphaSpec::Fixed(a) = request.alpha {
            if !(a.is_finite() && a > 0.0) {
                return Err(SolveError::BadAlpha(a));
            }
            if let Some(h) = request.sample.filter(|h| h * a >= 1.0) {
                return Err(SolveError::StepTooLong { h, alpha: a });
            }
        }
        if let (GammaSpec::Fixed(g), false) = (request.gamma, global) {
            if !(g.is_finite() && g > 0.0 && g < 1.0) {
                return Err(SolveError::BadGamma(g));
            }
        }
        let gmax = gamma_max(&model);
        let gamma_hi = match set {
            ConditionSet::Sound if global => 1.0,
            ConditionSet::Sound => {
                let gm = gmax.unwrap_or(f64::NAN);
                let usable = gm.is_finite() && gm > 0.0;
                if !usable && matches!(request.gamma, GammaSpec::Search) {
                    return Err(SolveError::NoGammaRange(gm));
                }
                gm.min(1.0) * (1.0 - 1e-6)
            }
            ConditionSet::Paper => 1.0 - 1e-6,
        };
        let scaled = StateScaling::of(&model, request.mode)
            .and_then(|sc| sc.model(&model).map(|zm| (zm, sc)));
        Ok(Setup {
            scaled,
            global,
            model,
            bound_info: prepared.state_bound,
            route_info: prepared.output_route,
            size_note,
            gmax,
            gamma_hi,
        })
    }

    /// The problem of the request's conditions. Full: all N p² rate blocks;
    /// decoupled: N·2p blocks with a slack Z_l per θ-vertex (sufficient).
    /// The certificate checks the full family either way.
    pub fn problem(&self, request: &DesignRequest) -> Result<Problem<'_>, SolveError> {
        let (model, scaling) = match &self.scaled {
            Some((zm, sc)) => (zm, Some(sc.clone())),
            None => (&self.model, None),
        };
        Problem::new(model, ConditionSet::from_mode(request.mode))?
            .with_conditions(request.conditions)?
            .with_max_gain(request.max_gain)
            .with_poles(&request.poles)
            .with_scaling(scaling)
            .with_sample(request.sample)
    }

    /// The notes that follow from the setup alone: the size warning, the
    /// computed state bound, the output route, the split, the conditions.
    fn notes(&self, request: &DesignRequest, prob: &Problem<'_>) -> Vec<String> {
        let (bound_info, route_info) = (&self.bound_info, &self.route_info);
        let mut notes: Vec<String> = Vec::new();
        notes.extend(self.size_note.clone());
        let global = crate::model::is_global(&self.model, request.mode);
        if let Some((_, sc)) = self.scaled.as_ref().filter(|_| !global) {
            let d: Vec<String> = sc.d.iter().map(|v| format!("{v:e}")).collect();
            notes.push(format!(
                "units: the region's extents per state are far from 1, so the conditions were solved in balanced coordinates x = D z, D = diag({}) (exact: powers of two), and P, L_l mapped back and certified in the model's own coordinates",
                d.join(", ")
            ));
        }
        if bound_info.source == BoundSource::Auto {
            notes.push(format!(
                "state bound computed (state_bound auto): h = {}, γ_max = {:.6}, in {} solver calls, {:.3} s",
                qpv_dsl::fmt_sig(bound_info.h.unwrap_or(f64::NAN), 6),
                bound_info.gamma_max.unwrap_or(f64::NAN),
                bound_info.solves,
                bound_info.seconds
            ));
            notes.extend(bound_info.notes.iter().cloned());
        }
        if let Some(f) = &route_info.filter {
            let bound: Vec<String> = f.bound.iter().map(|h| format!("{h:.4e}")).collect();
            notes.push(format!(
                "output post-filter x_y' = −{} x_y + {} y on every output: designed for the augmented plant ({} states: {}), measurement ỹ = x_y; region extended as (x_(i), 0) for the errors (the observer starts its filter estimate at the filter state) and P × R^ny for E and F, exact since no condition reads the filter coordinates; filter-state bound |x_y| ≤ [{}]",
                f.pole,
                f.gain,
                route_info.states.len(),
                route_info.states.join(", "),
                bound.join(", ")
            ));
        } else if route_info.output_varies {
            notes.push(format!(
                "C or M_k depend on θ: double-sum relaxation, {} rate combinations per vertex pair (Ξ_ll ≺ 0, (2/(r−1))Ξ_ll + Ξ_lm + Ξ_ml ≺ 0)",
                route_info.combinations
            ));
        }
        // An LPV plant has no N_k or M_k to symmetrise.
        if request.split == Split::Symmetric && !self.global {
            notes.push(
                "N_k and M_k symmetrised ((T + Tᵀ)/2, the same plant); re-check with this split"
                    .into(),
            );
        }
        if request.conditions == Conditions::Decoupled {
            notes.push(format!(
                "conditions = decoupled: solved with {} rate blocks (one slack Z per rate combination, sufficient) instead of {}; the certificate checks the full family of {} blocks",
                prob.n_rate_blocks(),
                prob.n_full_rate_blocks(),
                prob.n_full_rate_blocks()
            ));
        }
        if request.conditions == Conditions::Cube {
            let r = prob.n_generators();
            notes.push(format!(
                "conditions = cube: the region as a zonotope with {r} generators; certified with {} rate blocks (one pair of slacks Y, X per generator, sufficient) and D ⪰ GᵀPG, trace D ≤ 1 for the region's vertices, instead of {} vertex-pair blocks; solved with {} rate blocks{}; the report's `cube` key carries the slacks",
                prob.combos().len() * (4 * r + 1),
                prob.n_full_rate_blocks(),
                prob.n_rate_blocks(),
                if prob.cube_one_slack() {
                    " (N_k, M_k symmetric: H = −2G, one slack W = Y + X per generator)"
                } else {
                    ""
                }
            ));
        }
        notes
    }
}

/// What the request's α/γ search settled on, before the final solve.
struct Target {
    /// The α of the final solve (None: nothing to solve, no α certified).
    alpha: Option<f64>,
    /// The γ of the final solve.
    gamma: f64,
    /// The search's certified point, kept if it covers `alpha` at `gamma`.
    searched: Option<Point>,
    /// What a γ search searched.
    gamma_search: Option<GammaSearchInfo>,
    /// The practical α = max's design, final as it is (no regularised
    /// solve after it: that would trade its smallest gain for another
    /// objective's).
    ready: Option<Point>,
    /// How the practical α = max chose it.
    practical: Option<crate::report::Practical>,
}

/// The outcome of the final solve.
struct Final {
    /// The certified point reported.
    chosen: Option<Point>,
    /// The final solve's point when it did not certify.
    last: Option<Point>,
    status: Status,
    solver: SolverInfo,
}

impl Ctx<'_, '_> {
    /// Runs the α/γ search the request asks for: none (fixed α and γ), α =
    /// max at a fixed γ, or the γ search (with α = max, or a fixed α that the
    /// best point must cover).
    fn target(
        &mut self,
        request: &DesignRequest,
        gamma_hi: f64,
        notes: &mut Notes,
    ) -> Result<Target, SolveError> {
        let tol = self.settings.bisection_rel_tol;
        Ok(match (request.alpha, request.gamma) {
            (AlphaSpec::Fixed(a), GammaSpec::Fixed(g)) => Target {
                alpha: Some(a),
                gamma: g,
                searched: None,
                gamma_search: None,
                ready: None,
                practical: None,
            },
            (AlphaSpec::Max, GammaSpec::Fixed(g)) => {
                let pt = self.alpha_max(g, None, tol, Phase::Bisect)?;
                let trace = pt
                    .as_ref()
                    .map(|p| super::practical::Trace::at_fixed_gamma(p.gamma, p.alpha));
                let mut t = Target {
                    alpha: pt.as_ref().map(|p| p.alpha),
                    gamma: g,
                    searched: pt,
                    gamma_search: None,
                    ready: None,
                    practical: None,
                };
                if let Some(trace) = trace {
                    self.make_practical(request, &mut t, &trace, notes)?;
                }
                t
            }
            (alpha, GammaSpec::Search) => {
                let (pt, info, trace) = self.gamma_search(gamma_hi)?;
                notes.push(Note::GammaSearch(info.clone()));
                let g = pt.as_ref().map(|p| p.gamma).unwrap_or(gamma_hi);
                let (alpha, searched) = match alpha {
                    AlphaSpec::Max => (pt.as_ref().map(|p| p.alpha), pt),
                    AlphaSpec::Fixed(a) => {
                        if let Some(p) = pt.as_ref().filter(|p| p.alpha < a) {
                            notes.push(format!(
                                "the requested α = {a} exceeds the best certified α = {:.6} (at γ = {:.6})",
                                p.alpha, p.gamma
                            ));
                        }
                        // Keep the searched point only if it covers α.
                        (Some(a), pt.filter(|p| p.alpha >= a))
                    }
                };
                let mut t = Target {
                    alpha,
                    gamma: g,
                    searched,
                    gamma_search: Some(info),
                    ready: None,
                    practical: None,
                };
                if request.alpha == AlphaSpec::Max {
                    self.make_practical(request, &mut t, &trace, notes)?;
                }
                t
            }
        })
    }

    /// The practical α = max ([`super::practical`]) below the searched
    /// fastest point, in sound mode with `within` > 0: the target becomes
    /// its smallest-gain design, final as it is.
    fn make_practical(
        &mut self,
        request: &DesignRequest,
        t: &mut Target,
        trace: &super::practical::Trace,
        notes: &mut Notes,
    ) -> Result<(), SolveError> {
        let Some(sup) = t.searched.clone() else {
            return Ok(());
        };
        let cap = self.settings.alpha_cap;
        if sup.alpha >= cap * (1.0 - 1e-9) {
            notes.push(format!(
                "α reached the search's cap α = {cap:e} (`Settings::alpha_cap`, `qpv design --alpha-cap`): a larger α may certify; the cap is a setting, not a property of the plant"
            ));
        }
        if request.mode != Mode::Sound || request.within <= 0.0 {
            return Ok(());
        }
        let out = self.practical(&sup, request.within, trace)?;
        notes.extend(out.notes);
        t.practical = Some(out.info);
        if let Some(p) = out.point {
            t.alpha = Some(p.alpha);
            t.gamma = p.gamma;
            t.ready = Some(p);
        }
        Ok(())
    }

    /// The final solve at the target, with the gain regularisation; if it
    /// does not certify, the search's certified point at the same (α, γ)
    /// (re-certified at exactly that α) is reported instead, with a note. A
    /// fixed request has no search point: if its solve returned a point that
    /// fails the certificate, the α search at its γ supplies one covering α.
    fn final_solve(&mut self, t: Target, notes: &mut Notes) -> Result<Final, SolveError> {
        let Some(a) = t.alpha else {
            let (status, solver) = match self.steps.last() {
                Some(s) => (
                    s.status,
                    SolverInfo {
                        status: s.status,
                        detail: s.detail.clone(),
                        iterations: s.iterations,
                        seconds: s.solver_seconds,
                        ..SolverInfo::default()
                    },
                ),
                None => (Status::NotRun, SolverInfo::default()),
            };
            return Ok(Final {
                chosen: None,
                last: None,
                status,
                solver,
            });
        };
        if let Some(p) = t.ready {
            return Ok(Final {
                status: p.solver.status,
                solver: p.solver.clone(),
                chosen: Some(p),
                last: None,
            });
        }
        let solve = Solve::Lmi(Objective::Gains, None);
        let at = self.attempt(Candidate::new(a, t.gamma), solve, Phase::Final)?;
        let mut out = Final {
            chosen: None,
            last: None,
            status: at.status,
            solver: at.solver.clone(),
        };
        if at.certified {
            out.chosen = at.point;
            return Ok(out);
        }
        out.last = at.point;
        let fixed = t.searched.is_none() && t.gamma_search.is_none();
        // The point reported instead: the search's at the same (α, γ), or,
        // for a fixed request whose regularised solve returned a point that
        // fails the certificate (not an infeasibility certificate, not a
        // numerical error without a point), the α search at its γ
        // (max-margin solves, whose points lie deep inside the feasible set,
        // and their capacities), as on ill-conditioned plants.
        let fallback = match t.searched.filter(|p| p.alpha >= a && p.gamma == t.gamma) {
            Some(sp) => Some((
                sp,
                "the search's certified point at the same (α, γ) is reported",
            )),
            None if fixed && out.last.is_some() => {
                let tol = self.settings.coarse_tol();
                self.alpha_max(t.gamma, None, tol, Phase::Bisect)?
                    .filter(|p| p.alpha >= a)
                    .map(|p| {
                        (
                            p,
                            "the α search at this γ certified a point that covers α and is reported",
                        )
                    })
            }
            None => None,
        };
        if let Some((mut p, how)) = fallback {
            p.cert = self.certify(a, t.gamma, &p.p, &p.l, p.cube.as_ref());
            if p.cert.passed {
                p.alpha = a;
                notes.push(format!(
                    "the regularised final solve did not certify ({}); {how} (its gains are not regularised)",
                    at.status
                ));
                out.solver = p.solver.clone();
                out.chosen = Some(p);
            }
        }
        Ok(out)
    }

    /// Why a `sample = h` request certified nothing: the largest α the
    /// discrete decrease certifies at this h and γ (an α search to a coarse
    /// tolerance), or that none does.
    fn sample_failure(
        &mut self,
        h: f64,
        requested: AlphaSpec,
        gamma: f64,
    ) -> Result<String, SolveError> {
        let tol = self.settings.coarse_tol();
        let best = self.alpha_max(gamma, None, tol, Phase::Diagnose)?;
        let at = crate::certificate::sampling::describe_period(h);
        let asked = match requested {
            AlphaSpec::Fixed(a) => format!("α = {a}"),
            AlphaSpec::Max => "any α".to_string(),
        };
        let target = match requested {
            AlphaSpec::Fixed(a) => a,
            AlphaSpec::Max => self.settings.alpha_floor,
        };
        let shorter = match self.longest_period(target, gamma, h)? {
            Some((hs, hf)) => format!(
                "α = {target} certifies at the shorter period {} at γ = {gamma:.6} and fails at {hf:.4e} s in this search (not a proof that no design certifies there)",
                crate::certificate::sampling::describe_period(hs),
            ),
            None => format!(
                "this search found no design certifying α = {target} at γ = {gamma:.6} at any period down to h = {:.3e} s (not a proof that none exists)",
                h / LONGEST_PERIOD_SHRINK.powi(LONGEST_PERIOD_DOWN as i32)
            ),
        };
        let tail = if target >= self.settings.alpha_cap {
            String::new()
        } else {
            format!(". {shorter}")
        };
        Ok(match best {
            Some(p) => format!(
                "not certified at {at}: {asked} was not certified by this search; the largest α certified at this h and γ = {gamma:.6} is {:.6} (decrease 1 − hα = {:.6} per step; coarse search){tail}",
                p.alpha,
                1.0 - h * p.alpha
            ),
            None => format!(
                "not certified at {at}: this search certified no α ≥ {} for the discrete decrease at this h and γ = {gamma:.6}: the step may be too long for this plant and region (the explicit Euler step itself must contract V){tail}",
                self.settings.alpha_floor
            ),
        })
    }

    /// The longest sample period h_ok < `h` at which α = `target` certifies
    /// at `gamma`, with the failed period just above it (within a factor
    /// [`LONGEST_PERIOD_RATIO`]): periods
    /// h/4, h/16, ... (at most [`LONGEST_PERIOD_DOWN`]) until one certifies,
    /// then bisection in ln h between it and the shortest failed one
    /// (feasibility is monotone in h only in practice, not by proof: the
    /// answer is a certified period and a failed one just above it). None:
    /// not even the shortest period tried certifies.
    fn longest_period(
        &mut self,
        target: f64,
        gamma: f64,
        h: f64,
    ) -> Result<Option<(f64, f64)>, SolveError> {
        let saved = self.sample;
        let probe = |ctx: &mut Self, hp: f64| -> Result<bool, SolveError> {
            ctx.sample = Some(hp);
            ctx.prob.set_sample(hp);
            let cand = Candidate::new(target, gamma);
            let solve = Solve::Lmi(Objective::MaxMargin, None);
            if ctx.attempt(cand, solve, Phase::Diagnose)?.certified {
                return Ok(true);
            }
            Ok(ctx.attempt_regularised(cand, Phase::Diagnose)?.certified)
        };
        let mut fail = h;
        let mut ok = None;
        for _ in 0..LONGEST_PERIOD_DOWN {
            let hp = fail / LONGEST_PERIOD_SHRINK;
            if probe(self, hp)? {
                ok = Some(hp);
                break;
            }
            fail = hp;
        }
        if let Some(mut lo) = ok {
            while fail / lo > LONGEST_PERIOD_RATIO {
                let mid = (lo * fail).sqrt();
                if probe(self, mid)? {
                    lo = mid;
                } else {
                    fail = mid;
                }
            }
            ok = Some(lo);
        }
        self.sample = saved;
        if let Some(hs) = saved {
            self.prob.set_sample(hs);
        }
        Ok(ok.map(|lo| (lo, fail)))
    }

    /// Notes on the solves: unknown statuses, a certified point from an
    /// unsolved status, points the certificate rejected.
    fn solve_notes(&self, feasible: bool, final_solver: &SolverInfo, notes: &mut Notes) {
        let unknown: Vec<&SearchStep> = self
            .steps
            .iter()
            .filter(|s| s.status == Status::Unknown)
            .collect();
        if !unknown.is_empty() {
            let mut kinds: Vec<String> = unknown.iter().map(|s| s.detail.clone()).collect();
            kinds.sort();
            kinds.dedup();
            notes.push(Note::UnknownStatus {
                count: unknown.len(),
                solves: self.steps.len(),
                kinds,
            });
        }
        if feasible && final_solver.status != Status::Solved {
            notes.push(Note::StoppedShort {
                detail: final_solver.detail.clone(),
            });
        }
        let uncert = self
            .steps
            .iter()
            .filter(|s| s.status == Status::Solved && !s.certified)
            .count();
        if uncert > 0 {
            notes.push(Note::Rejected { count: uncert });
        }
    }
}

/// Notes on the data checks: the paper-mode disclaimer and (15)/(S4), or a
/// failed (S4) in sound mode, and a region outside F.
fn data_notes(
    mode: Mode,
    dchecks: &BTreeMap<String, DataCheck>,
    gamma: f64,
    gmax: Option<f64>,
    notes: &mut Notes,
) {
    let s4 = dchecks.get(Family::S4.name());
    if mode == Mode::Paper {
        notes.insert(
            0,
            "REPRODUCTION MODE: the paper's printed conditions (13), (14), (26); they do not imply convergence (docs/method.md). This design certifies nothing.".to_string(),
        );
        match s4 {
            Some(d) if !d.passed => notes.push(format!(
                "violated assumption (15)/(S4): max_k γ² a_kᵀ Q a_k = {:.4} > 1 at γ = {}",
                d.value, gamma
            )),
            Some(_) => {}
            None => notes.push("(15)/(S4) not checked: the model has no state bound Q"),
        }
    } else if let Some(d) = s4.filter(|d| !d.passed) {
        notes.push(format!(
            "(S4) fails: max_k γ² a_kᵀ Q a_k = {:.4} > 1 at γ = {} (γ_max = {:.5})",
            d.value,
            gamma,
            gmax.unwrap_or(f64::NAN)
        ));
    }
    if let Some(d) = dchecks.get(Family::RegionInF.name()).filter(|d| !d.passed) {
        notes.push(format!(
            "region_in_F fails: max_i x_(i)ᵀ Q⁻¹ x_(i) = {:.4} > 1 (the region is not inside the state bound F)",
            d.value
        ));
    }
}

impl Ctx<'_, '_> {
    /// The gain walk ([`super::gain_walk`]) of a `max_gain = G` request in
    /// sound mode at `gamma` (from the certified α `from` for α = max): its
    /// solves join the search log, and its point is returned re-certified
    /// by this search's certificate (with the bound), with the walk's
    /// solve count. None without a bound, in paper mode, or when nothing
    /// the walk found passes.
    fn walked(
        &mut self,
        setup: &Setup,
        request: &DesignRequest,
        gamma: f64,
        from: Option<f64>,
    ) -> Result<Option<(Point, f64, usize)>, SolveError> {
        let (Some(bound), Mode::Sound) = (request.max_gain, request.mode) else {
            return Ok(None);
        };
        let free = (&setup.model, setup.problem(&free_of(request))?);
        let w = super::gain_walk::walk(free, request, self.settings, (bound, gamma), from)?;
        let solves = w.steps.len();
        self.steps.extend(w.steps);
        Ok(w.point.and_then(|mut p| {
            p.cert = self.certify(p.alpha, p.gamma, &p.p, &p.l, p.cube.as_ref());
            p.cert.passed.then_some((p, bound, solves))
        }))
    }

    /// `max_gain = G` with α = max: the walk's design replaces the target
    /// when it is faster.
    fn gain_walk(
        &mut self,
        setup: &Setup,
        request: &DesignRequest,
        t: &mut Target,
        notes: &mut Notes,
    ) -> Result<(), SolveError> {
        let found = t.ready.as_ref().or(t.searched.as_ref()).map(|p| p.alpha);
        let Some((p, bound, solves)) = self
            .walked(setup, request, t.gamma, found)?
            .filter(|(p, _, _)| found.map_or(true, |a| p.alpha > a))
        else {
            return Ok(());
        };
        notes.push(format!(
            "max_gain = {bound}: the SDP's gain constraint (‖Γ_l‖₂ ≤ G·λ with P ⪰ λI) is sufficient, not necessary; the smallest-gain designs of the same conditions without it, each certified with ‖L_l‖₂ ≤ {bound} required, reach α = {:.6}{} (max ‖L_l‖₂ = {:.4e}; {solves} more solver calls, bisection in ln α to 1 %): that design is reported",
            p.alpha,
            found.map(|a| format!(" where the constrained search reached {a:.6}")).unwrap_or_default(),
            super::practical::max_gain(&p)
        ));
        t.alpha = Some(p.alpha);
        t.gamma = p.gamma;
        t.ready = Some(p);
        Ok(())
    }

    /// `max_gain = G` at a fixed α whose constrained solve certified
    /// nothing: the smallest-gain design at α without the constraint,
    /// reported if its actual gains meet G.
    fn gain_walk_fixed(
        &mut self,
        setup: &Setup,
        request: &DesignRequest,
        gamma: f64,
        fin: &mut Final,
        notes: &mut Notes,
    ) -> Result<(), SolveError> {
        let Some((p, bound, _)) = self.walked(setup, request, gamma, None)? else {
            return Ok(());
        };
        notes.push(format!(
            "max_gain = {bound}: the constrained solve certified nothing (its gain constraint ‖Γ_l‖₂ ≤ G·λ, P ⪰ λI, is sufficient, not necessary); the smallest-gain design at this α without it has max ‖L_l‖₂ = {:.4e} ≤ {bound}, certified with the bound required: reported",
            super::practical::max_gain(&p)
        ));
        fin.status = p.solver.status;
        fin.solver = p.solver.clone();
        fin.chosen = Some(p);
        fin.last = None;
        Ok(())
    }
}

/// `request` without its gain bound.
fn free_of(request: &DesignRequest) -> DesignRequest {
    DesignRequest {
        max_gain: None,
        ..request.clone()
    }
}

/// Why a `max_gain = G` request certified nothing: the smallest gain the
/// same conditions certify without the bound at the requested α (the α
/// floor for α = max; one min-gain solve at γ), or that none certifies
/// even there.
fn gain_bound_failure(
    setup: &Setup,
    request: &DesignRequest,
    settings: &Settings,
    bound: f64,
    gamma: f64,
) -> Result<String, SolveError> {
    let mut quiet = |_: &SearchStep| {};
    let prob = setup.problem(&free_of(request))?;
    let mut ctx = Ctx::new(&setup.model, request.mode, settings, prob, &mut quiet);
    ctx.sample = request.sample;
    let a = match request.alpha {
        AlphaSpec::Fixed(a) => a,
        AlphaSpec::Max => settings.alpha_floor,
    };
    let p = ctx.min_gain_at(a, gamma, None)?;
    Ok(match p {
        // Never a bound below G: a gain that meets it would have been
        // reported (the gain walk), so this one is above it.
        Some(p) if super::practical::max_gain(&p) > bound => format!(
            "max_gain = {bound} is not reached: the smallest gain this search certified without the bound at α = {a}, γ = {gamma:.6} is max ‖L_l‖₂ = {:.4e} (a design with that gain exists; a bound of at least that much admits it)",
            super::practical::max_gain(&p)
        ),
        Some(p) => format!(
            "max_gain = {bound}: a design at α = {a}, γ = {gamma:.6} with max ‖L_l‖₂ = {:.4e} certifies without the bound in the problem, but not with every check of this request",
            super::practical::max_gain(&p)
        ),
        None => format!(
            "max_gain = {bound}: no design was found to certify at α = {a}, γ = {gamma:.6} even without the bound (not found by this search)"
        ),
    })
}

/// The human summary: the verdict line, then every note. `sample`: the
/// sample period of a `sample = h` design (its verdict names the discrete
/// decrease and the rate).
fn summary(
    mode: Mode,
    feasible: bool,
    (alpha, gamma, sample): (f64, f64, Option<f64>),
    final_status: Status,
    failed: &[String],
    norms: &[f64],
    notes: &Notes,
) -> String {
    let max_norm = norms.iter().copied().fold(0.0, f64::max);
    let failed = if failed.is_empty() {
        String::new()
    } else {
        format!("; failed: {}", failed.join(", "))
    };
    let mut s = match (mode, feasible) {
        (Mode::Sound, true) if sample.is_some() => {
            let h = sample.unwrap_or(f64::NAN);
            format!(
                "CERTIFIED at {} (sound conditions S1-S4 and the discrete decrease S5d): the Euler-stepped observer has V(e_(k+1)) ≤ (1 − hα)V(e_k) = {:.6}·V(e_k) with α = {alpha:.6} per second, γ = {gamma:.6}; every e(0) in the region converges. max ‖L_l‖₂ = {max_norm:.4}.",
                crate::certificate::sampling::describe_period(h),
                1.0 - h * alpha
            )
        }
        (Mode::Sound, false) if sample.is_some() => format!(
            "NOT CERTIFIED at {} (sound conditions S1-S4 and the discrete decrease S5d) at α = {alpha:.6}, γ = {gamma:.6}: solver {final_status}{failed}.",
            crate::certificate::sampling::describe_period(sample.unwrap_or(f64::NAN))
        ),
        (Mode::Sound, true) => format!(
            "CERTIFIED (sound conditions S1-S5): V' ≤ −αV with α = {alpha:.6}, γ = {gamma:.6}; every e(0) in the region converges. max ‖L_l‖₂ = {max_norm:.4}."
        ),
        (Mode::Sound, false) => format!(
            "NOT CERTIFIED (sound conditions) at α = {alpha:.6}, γ = {gamma:.6}: solver {final_status}{failed}."
        ),
        (Mode::Paper, true) => format!(
            "PAPER MODE (certifies nothing): the printed conditions (13), (14), (26) hold at α = {alpha:.6}, γ = {gamma:.6}; max ‖L_l‖₂ = {max_norm:.4}."
        ),
        (Mode::Paper, false) => format!(
            "PAPER MODE (certifies nothing): the printed conditions are not satisfied at α = {alpha:.6}, γ = {gamma:.6}: solver {final_status}{failed}."
        ),
    };
    append_notes(&mut s, notes);
    s
}

/// The request of a global design (an LPV plant in sound mode,
/// [`crate::model::is_global`]): γ is fixed at 1 (unused: the conditions are
/// homogeneous), the conditions are the full family (one block per rate
/// combination: decoupled and cube conditions have nothing to split), and
/// what the plant's own statements asked for that the global observer does
/// not use is noted. At `sample = h` the rate family is the discrete
/// decrease without region terms (docs/method.md, "The global observer").
/// Refused elsewhere: the skew slack (not built for the global observer).
fn global_request(
    model: &PolytopicModel,
    request: DesignRequest,
    notes: &mut Notes,
) -> Result<DesignRequest, SolveError> {
    let family = match request.sample {
        None => "He{P A_l − Γ_l C_m} + αP ≺ 0 at every rate combination (certificate family G5)"
            .to_string(),
        Some(h) => format!(
            "at sample = {h:e} the discrete decrease [(1 − hα)P, (P + hΦ)ᵀ; P + hΦ, P] ⪰ 0, Φ = P A_l − Γ_l C_m, at every rate combination (certificate family S5d without region terms)"
        ),
    };
    let mut used = vec![format!(
        "the plant is LPV (every N_k and M_k is zero): the global observer, P ⪰ I and {family}, with no region, state bound or γ"
    )];
    if model.has_region() {
        used.push("the model's region is not used".into());
    }
    if !matches!(model.state_bound, StateBound::None) {
        used.push(if request.sample.is_some() {
            "its state bound is not used by the certificate (only as the operating envelope of the continuous-plant bound)".into()
        } else {
            "its state bound is not used".into()
        });
    }
    if let GammaSpec::Fixed(g) = request.gamma {
        used.push(format!("γ = {g} is not used"));
    }
    if !matches!(request.conditions, Conditions::Full | Conditions::Auto) {
        used.push(format!(
            "conditions = {:?} is replaced by the full family (one block per rate combination)",
            request.conditions
        ));
    }
    notes.push(used.join("; "));
    Ok(DesignRequest {
        gamma: GammaSpec::Fixed(1.0),
        conditions: Conditions::Full,
        ..request
    })
}

/// The summary of a global design: its verdict line (the discrete decrease
/// per step at a sample period h), then every note.
fn global_summary(
    feasible: bool,
    (alpha, sample): (f64, Option<f64>),
    status: Status,
    failed: &[String],
    norms: &[f64],
    notes: &Notes,
) -> String {
    let max_norm = norms.iter().copied().fold(0.0, f64::max);
    let head = match (feasible, sample) {
        (true, None) => format!(
            "CERTIFIED, GLOBAL (LPV plant: P ≻ 0 and G5): V' ≤ −αV with α = {alpha:.6} for every e(0) and every θ(t) in the box; max ‖L_l‖₂ = {max_norm:.4}."
        ),
        (true, Some(h)) => format!(
            "CERTIFIED, GLOBAL at {} (LPV plant: P ≻ 0 and the discrete decrease S5d): the Euler-stepped observer has V(e_(k+1)) ≤ (1 − hα)V(e_k) = {:.6}·V(e_k) with α = {alpha:.6} per second for every e(0) and every θ_k in the box; max ‖L_l‖₂ = {max_norm:.4}.",
            crate::certificate::sampling::describe_period(h),
            1.0 - h * alpha
        ),
        (false, _) => {
            let failed = if failed.is_empty() {
                String::new()
            } else {
                format!("; failed: {}", failed.join(", "))
            };
            let at = sample
                .map(|h| format!(" at {}", crate::certificate::sampling::describe_period(h)))
                .unwrap_or_default();
            format!("NOT CERTIFIED, GLOBAL (LPV plant){at} at α = {alpha:.6}: solver {status}{failed}.")
        }
    };
    let mut s = head;
    append_notes(&mut s, notes);
    s
}

/// [`super::design_with_progress`] for every split but `skew_slack`,
/// without the noise and sampling figures.
pub(super) fn design_plain(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    let global = crate::model::is_global(model, request.mode);
    if !(global && request.alpha == AlphaSpec::Max) {
        let first = design_plain_with(model, request, settings, progress, None)?;
        if !global || first.certifies() {
            return Ok(first);
        }
        // The units the pilots balanced by need not suit the request (near
        // the plant's own decay the gain-objective pilot's P is
        // degenerate): once more in the model's own units (D = I).
        let own = nalgebra::DMatrix::identity(model.nx(), model.nx());
        let mut second = design_plain_with(model, request, settings, progress, Some(&own))?;
        if !second.certifies() {
            return Ok(first);
        }
        second
            .notes
            .0
            .retain(|n| !matches!(n, Note::BalancedUnits { .. }));
        second.notes.push(format!(
            "the design in the pilots' balanced units did not certify ({} solver calls); solved again in the model's own units",
            first.search.len()
        ));
        return Ok(second);
    }
    // The global α = max: the units the first search balanced by (a pilot
    // at a small α) need not suit its result, so the search runs once
    // more in the units of the P it certified, and the better design is
    // kept.
    let t0 = Instant::now();
    let first = design_plain_with(model, request, settings, progress, None)?;
    if !first.certifies() {
        return Ok(first);
    }
    let hint = first.p_matrix();
    let second = design_plain_with(model, request, settings, progress, Some(&hint))?;
    let (n1, n2) = (first.search.len(), second.search.len());
    // The search log holds every solver call of the request: the other
    // search's calls first, then the kept one's.
    let (mut out, other) = if second.certifies() && second.alpha >= first.alpha {
        (second, first)
    } else {
        (first, second)
    };
    out.search.splice(0..0, other.search);
    out.notes.push(format!(
        "global α = max: searched twice, the second time in the units of the first result's P ({n1} + {n2} solver calls, all in the search log)"
    ));
    // A gain bound, a pole region (a disk bounds the gain) or a sample
    // period (h‖LC‖ must stay small) already limit the gain.
    let limited = request.max_gain.is_some() || !request.poles.is_empty();
    if request.within > 0.0 && !limited && request.sample.is_none() {
        out = global_knee(model, request, settings, progress, out)?;
    }
    out.seconds_total = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// Bisection steps in ln α for the global knee.
const KNEE_STEPS: usize = 8;

/// The practical α = max of the global observer (docs/method.md §17, "High
/// gain and the knee"): an observable LPV plant reaches any α with large
/// enough gains, so its α–gain curve has no supremum of its own and the
/// search stops where the numerics do. With g(α) the largest gain of the
/// smallest-gain design at α and α_ref = α_t/KNEE_FACTOR² (a rate a hundred
/// times slower), the design at α_t is *high gain* if g(α_t) >
/// KNEE_FACTOR³·g(α_ref) (faster than linear growth over those two decades:
/// the high-gain regime), g(α_ref) taken at least ‖A_l‖₂/‖C_l‖₂. Then the design returned is the knee: the fastest
/// α in [α_ref, α_t] with g(α) ≤ KNEE_FACTOR·g(α_ref), by bisection in ln α.
/// Otherwise `design` is returned unchanged.
fn global_knee(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
    design: Design,
) -> Result<Design, SolveError> {
    use super::practical::KNEE_FACTOR;
    let (Some(mut info), true) = (design.practical.clone(), design.certifies()) else {
        return Ok(design);
    };
    let gain = Design::max_gain_norm;
    let mut solves = 0;
    let mut log = design.search.clone();
    let mut at = |a: f64| -> Result<Option<Design>, SolveError> {
        let fixed = DesignRequest {
            alpha: AlphaSpec::Fixed(a),
            ..request.clone()
        };
        let d = design_plain(model, &fixed, settings, progress)?;
        solves += d.search.len();
        log.extend(d.search.iter().cloned());
        Ok(d.certifies().then_some(d))
    };
    let (alpha_t, g_t) = (design.alpha, gain(&design));
    let alpha_ref = alpha_t / KNEE_FACTOR.powi(2);
    let Some(reference) = at(alpha_ref)? else {
        return Ok(Design {
            search: log,
            ..design
        });
    };
    // Not below a gain of the plant's own size, ‖A_l‖₂/‖C_l‖₂: a reference
    // in the gain-free range (α below the plant's own decay) says nothing.
    let own = model.vertices.iter().map(|v| {
        let c = crate::linalg::norm2(&v.c);
        crate::linalg::norm2(&v.a) / c.max(f64::MIN_POSITIVE)
    });
    let g_ref = gain(&reference).max(own.fold(0.0, f64::max));
    if g_t <= KNEE_FACTOR.powi(3) * g_ref {
        return Ok(Design {
            search: log,
            ..design
        });
    }
    let (mut lo, mut hi, mut knee) = (alpha_ref, alpha_t, reference);
    for _ in 0..KNEE_STEPS {
        let mid = (lo * hi).sqrt();
        match at(mid)? {
            Some(d) if gain(&d) <= KNEE_FACTOR * g_ref => {
                lo = mid;
                knee = d;
            }
            _ => hi = mid,
        }
    }
    info.high_gain = true;
    info.solves += solves;
    // The α = max search's notes, but the units the returned design was
    // solved in are its own.
    let units = |n: &Note| matches!(n, Note::BalancedUnits { .. });
    let mut notes = design.notes.clone();
    notes.0.retain(|n| !units(n));
    notes
        .0
        .extend(knee.notes.0.iter().filter(|n| units(n)).cloned());
    notes.push(format!(
        "high gain: the global observer reaches α = {alpha_t:.6} only with max ‖L_l‖₂ = {g_t:.4e}, {:.1e} times the gain at α = {alpha_ref:.6} ({g_ref:.4e}); returned the knee of the α–gain curve, the fastest α with at most {KNEE_FACTOR} times that gain: α = {:.6}, max ‖L_l‖₂ = {:.4e} ({solves} more solver calls). On an LPV plant any α is reachable with gain enough: `max_gain = G` or a sample period sets the real limit (docs/method.md §17)",
        g_t / g_ref.max(f64::MIN_POSITIVE),
        knee.alpha,
        gain(&knee)
    ));
    let mut out = knee;
    // every solver call of the request, in the order made
    out.search = log;
    out.summary = format!(
        "{} (high gain: the knee of the α–gain curve, α_sup = {:.6})",
        out.summary, info.alpha_sup
    );
    out.practical = Some(info);
    out.notes = notes;
    Ok(out)
}

/// The balancing of a global design's units ([`StateScaling::of_p`]): the
/// problem is posed in coordinates where P's diagonal is near 1, from the
/// P of `hint` or of pilot solves at the requested α (a feasibility solve, then the gain objective in its units) (for
/// α = max at 0.1·max_l ‖A_l‖_F), up to two rounds. Returns the number
/// of pilot solves.
fn global_balance(
    setup: &mut Setup,
    request: &DesignRequest,
    settings: &Settings,
    hint: Option<&nalgebra::DMatrix<f64>>,
) -> Result<usize, SolveError> {
    let alpha = match request.alpha {
        AlphaSpec::Fixed(a) => a,
        AlphaSpec::Max => {
            0.1 * setup
                .model
                .vertices
                .iter()
                .map(|v| v.a.norm())
                .fold(settings.alpha_floor, f64::max)
        }
    };
    let mut p = hint.cloned();
    let mut pilots = 0;
    for _ in 0..2 {
        let p_now = match p.take() {
            Some(p) => p,
            None => {
                pilots += 1;
                // The first pilot only needs some feasible P; the next one
                // the smallest-gain point in the units it gave.
                let objective = if pilots == 1 {
                    Objective::Feasibility
                } else {
                    Objective::Gains
                };
                // A pilot without a point is retried at smaller α (the
                // units that suit a smaller α are a better start than none),
                // and with pole regions, that give none in unbalanced units
                // when the region cuts α far down, without them.
                let mut found = None;
                let free = DesignRequest {
                    poles: Vec::new(),
                    ..request.clone()
                };
                let mut tries = vec![request];
                if !request.poles.is_empty() {
                    tries.push(&free);
                }
                'pilot: for req in tries {
                    let prob = setup.problem(req)?;
                    for k in 0..4 {
                        let a = alpha * 0.5f64.powi(k);
                        if let Some(p) = prob.solve(a, 1.0, settings, objective)?.p {
                            found = Some(p);
                            break 'pilot;
                        }
                    }
                }
                match found {
                    Some(p) => p,
                    None => break,
                }
            }
        };
        // The unit: the state the output map weighs most (C D keeps its size).
        let c = &setup.model.vertices[0].c;
        let unit = (0..c.ncols()).max_by(|&a, &b| {
            let w = |i: usize| c.column(i).abs().sum();
            w(a).total_cmp(&w(b))
        });
        let Some(sc) = StateScaling::of_p_relative(&p_now, unit) else {
            break;
        };
        if setup.scaled.as_ref().is_some_and(|(_, s)| *s == sc) {
            break;
        }
        match sc.model(&setup.model) {
            Some(zm) => setup.scaled = Some((zm, sc)),
            None => break,
        }
    }
    Ok(pilots)
}

/// [`design_plain`] with a balancing hint for the global observer: the
/// request prepared ([`prepare`]), the α/γ search and the final solve, then
/// the report ([`Ctx::report`]).
fn design_plain_with(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
    hint: Option<&nalgebra::DMatrix<f64>>,
) -> Result<Design, SolveError> {
    let t_start = Instant::now();
    let (resolved, setup, mut notes) = prepare(model, request, settings, hint)?;
    let request = &resolved;
    let mode = request.mode;
    let prob = setup.problem(request)?;
    notes.extend(setup.notes(request, &prob));
    let mut ctx = Ctx::new(&setup.model, mode, settings, prob, progress);
    ctx.max_gain = request.max_gain;
    ctx.sample = request.sample;
    if request.alpha == AlphaSpec::Max && mode == Mode::Sound {
        ctx.within = request.within;
    }
    let mut target = ctx.target(request, setup.gamma_hi, &mut notes)?;
    if request.alpha == AlphaSpec::Max {
        ctx.gain_walk(&setup, request, &mut target, &mut notes)?;
    }
    let requested = (target.alpha, target.gamma);
    let (gamma_search, practical) = (target.gamma_search.clone(), target.practical.clone());
    let mut fin = ctx.final_solve(target, &mut notes)?;
    if fin.chosen.is_none() && matches!(request.alpha, AlphaSpec::Fixed(_)) {
        ctx.gain_walk_fixed(&setup, request, requested.1, &mut fin, &mut notes)?;
    }
    let mut d = ctx.report(&setup, request, fin, requested, notes)?;
    d.gamma_search = gamma_search;
    d.practical = practical;
    d.seconds_total = t_start.elapsed().as_secs_f64();
    Ok(d)
}

/// The request as it is solved, its setup and the notes so far:
/// `conditions = auto` chosen by size (crate::model::size::choose; a
/// sampled design has the full vertex family only), the global observer's
/// request ([`global_request`]) and its units ([`global_balance`]).
pub(super) fn prepare(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    hint: Option<&nalgebra::DMatrix<f64>>,
) -> Result<(DesignRequest, Setup, Notes), SolveError> {
    let (chosen_conditions, auto_note) = match request.sample {
        Some(h) if request.conditions == Conditions::Auto => (
            Conditions::Full,
            Some(Note::Text(format!(
                "sample = {h:e}: the discrete decrease is solved and certified on the full vertex family (conditions = full)"
            ))),
        ),
        _ => {
            let (c, why) = crate::model::size::choose(model, request);
            (c, (!why.is_empty()).then_some(Note::ConditionsChosen(why)))
        }
    };
    let resolved = DesignRequest {
        conditions: chosen_conditions,
        ..request.clone()
    };
    let global = crate::model::is_global(model, request.mode);
    let mut notes = Notes::default();
    if let Some(n) = auto_note.filter(|_| !global) {
        notes.push(n);
    }
    if !global {
        let setup = Setup::new(model, &resolved, settings)?;
        return Ok((resolved, setup, notes));
    }
    let resolved = global_request(model, resolved, &mut notes)?;
    let mut setup = Setup::new(model, &resolved, settings)?;
    let pilots = global_balance(&mut setup, &resolved, settings, hint)?;
    if let Some((_, sc)) = &setup.scaled {
        notes.push(Note::BalancedUnits {
            d: sc.d.clone(),
            from: if hint.is_some() && pilots == 0 {
                "the first search's P".to_string()
            } else {
                format!("{pilots} pilot solver call(s), not in the search log")
            },
        });
    }
    Ok((resolved, setup, notes))
}

impl Ctx<'_, '_> {
    /// The report of the final solve's outcome ([`design_of`]): the point
    /// shown (the certified one, else the final solve's for diagnosis), at
    /// its (α, γ) or else the `requested` one (α: else the smallest tried);
    /// for a design that does not certify, the diagnosis ([`Ctx::diagnose`]);
    /// the notes on the solves and the data checks; the summary.
    fn report(
        mut self,
        setup: &Setup,
        request: &DesignRequest,
        fin: Final,
        requested: (Option<f64>, f64),
        mut notes: Notes,
    ) -> Result<Design, SolveError> {
        let mode = request.mode;
        let feasible = fin.chosen.is_some();
        let shown = fin.chosen.or(fin.last);
        let alpha_r = shown.as_ref().map(|p| p.alpha).or(requested.0);
        let alpha_r = alpha_r.unwrap_or_else(|| {
            self.steps
                .iter()
                .map(|s| s.alpha)
                .fold(f64::INFINITY, f64::min)
                .min(self.settings.alpha_floor)
        });
        let at = Candidate::new(alpha_r, shown.as_ref().map_or(requested.1, |p| p.gamma));
        let mut margins = shown.as_ref().map(|p| p.cert.margins()).unwrap_or_default();
        let diagnosis = match feasible {
            true => None,
            false => Some(self.diagnose(setup, request, at.gamma, &mut margins, &mut notes)?),
        };
        self.solve_notes(feasible, &fin.solver, &mut notes);
        let failed: Vec<String> = shown.as_ref().map(failures).unwrap_or_default();
        let steps = std::mem::take(&mut self.steps);
        let shown = Shown {
            point: shown.as_ref(),
            feasible,
            at,
            solver: fin.solver,
        };
        let mut d = design_of(&setup.model, request, shown, steps);
        d.margins = margins;
        d.diagnosis = diagnosis;
        data_notes(mode, &d.data_checks, at.gamma, setup.gmax, &mut notes);
        if !request.poles.is_empty() {
            d.pole_gain_bound = feasible
                .then(|| disk_gain_bound(&setup.model, &d.p_matrix(), &request.poles))
                .flatten();
            notes.push(pole_note(&d, &request.poles));
        }
        let norms = &d.gain_norms;
        d.summary = match setup.global {
            true => {
                let at = (at.alpha, request.sample);
                global_summary(feasible, at, fin.status, &failed, norms, &notes)
            }
            false => {
                let at = (at.alpha, at.gamma, request.sample);
                summary(mode, feasible, at, fin.status, &failed, norms, &notes)
            }
        };
        d.notes = notes;
        d.global = setup.global;
        d.state_bound = Some(setup.bound_info.clone());
        d.output_route = Some(setup.route_info.clone());
        Ok(d)
    }

    /// Why a design certified nothing: without any margins, those of one
    /// attempt at the smallest α (into `margins`); the gain bound's and the
    /// sample period's reasons (noted); then the cheap model tests and the
    /// decoupled conditions' finding (crate::model::diagnosis).
    fn diagnose(
        &mut self,
        setup: &Setup,
        request: &DesignRequest,
        gamma: f64,
        margins: &mut BTreeMap<Family, f64>,
        notes: &mut Notes,
    ) -> Result<Vec<crate::model::diagnosis::Finding>, SolveError> {
        let settings = self.settings;
        if margins.is_empty() {
            let cand = Candidate::new(settings.alpha_floor, gamma);
            let solve = Solve::Lmi(Objective::MaxMargin, None);
            if let Some(p) = self.attempt(cand, solve, Phase::Diagnose)?.point {
                *margins = p.cert.margins();
            }
        }
        if let Some(g) = request.max_gain {
            notes.push(gain_bound_failure(setup, request, settings, g, gamma)?);
        }
        if let Some(h) = request.sample {
            notes.push(self.sample_failure(h, request.alpha, gamma)?);
        }
        let mut findings =
            crate::model::diagnosis::diagnose(&setup.model, request, settings.alpha_floor);
        findings.extend(self.claims.finding(request.conditions));
        Ok(findings)
    }
}

/// The failure note's search for the longest period at which the asked α
/// certifies: steps down by this factor ...
const LONGEST_PERIOD_SHRINK: f64 = 4.0;
/// ... at most this many times ...
const LONGEST_PERIOD_DOWN: usize = 6;
/// ... then bisects in ln h until the certified and the failed period are
/// within this ratio.
const LONGEST_PERIOD_RATIO: f64 = 1.1;

/// The line a design with `poles = ...` carries: the regions, family D's
/// margin, and for a disk on an LPV plant the gain bound it implies.
fn pole_note(d: &Design, poles: &[qpv_dsl::PoleRegion]) -> String {
    let list: Vec<String> = poles.iter().map(|r| r.to_string()).collect();
    let margin = d.margins.get(Family::D.name());
    let mut out = match (d.feasible(), margin) {
        (true, Some(m)) => format!(
            "pole regions {}: certified with the design's P (family D, worst margin {m:.3e}): every eigenvalue of the error dynamics frozen at a vertex lies in them",
            list.join(", ")
        ),
        _ => format!("pole regions {}: not certified", list.join(", ")),
    };
    if let Some(b) = d.pole_gain_bound {
        out.push_str(&format!(
            "; the disk bounds every ‖L_l‖₂ by {b:.4e} (through κ(P); docs/method.md §18)"
        ));
    }
    out
}

/// The condition families a point fails, with their worst margins.
fn failures(p: &Point) -> Vec<String> {
    p.cert
        .families
        .iter()
        .filter(|f| !f.passed)
        .map(|f| format!("{} ({:.3e} at {})", f.name, f.margin, f.worst_at))
        .collect()
}

/// One point of [`alpha_profile`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfilePoint {
    /// The region scaling γ.
    pub gamma: f64,
    /// The largest certified α at γ, to the full bisection tolerance (0 if
    /// no α > 0 certifies there).
    pub alpha: f64,
    /// Solves spent at this γ.
    pub solves: usize,
}

/// α_max(γ) at every γ of `gammas`, in the order given, each to the full
/// bisection tolerance and seeded by the certified point of the previous
/// γ (which only speeds the bisection up: every value is bracketed by a
/// certified α and a failed one). The request's α and γ are ignored; its
/// mode, split, conditions and output route are used. A dense profile to
/// check a γ search against, or to plot α(γ). `conditions = auto` is
/// resolved as a design resolves it.
pub fn alpha_profile(
    model: &PolytopicModel,
    request: &DesignRequest,
    gammas: &[f64],
    settings: &Settings,
) -> Result<Vec<ProfilePoint>, SolveError> {
    let req = DesignRequest {
        alpha: AlphaSpec::Max,
        gamma: GammaSpec::Search,
        conditions: crate::model::size::choose(model, request).0,
        ..request.clone()
    };
    let setup = Setup::new(model, &req, settings)?;
    let mut quiet = |_: &SearchStep| {};
    let prob = setup.problem(&req)?;
    let mut ctx = Ctx::new(&setup.model, req.mode, settings, prob, &mut quiet);
    ctx.max_gain = req.max_gain;
    ctx.sample = req.sample;
    let mut prev: Option<Point> = None;
    let mut out = Vec::with_capacity(gammas.len());
    for &g in gammas {
        if !(g.is_finite() && g > 0.0 && g < 1.0) {
            return Err(SolveError::BadGamma(g));
        }
        let n0 = ctx.steps.len();
        // The previous point seeds only if it certifies here.
        let seed = prev.as_ref().filter(|p| ctx.lift(p, g).is_some());
        let pt = ctx.alpha_max(g, seed, settings.bisection_rel_tol, Phase::Bisect)?;
        out.push(ProfilePoint {
            gamma: g,
            alpha: pt.as_ref().map_or(0.0, |p| p.alpha),
            solves: ctx.steps.len() - n0,
        });
        if pt.is_some() {
            prev = pt;
        }
    }
    Ok(out)
}
