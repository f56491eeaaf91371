//! The design driver of every split but `skew_slack`: the requested α/γ
//! search, the final regularised solve, the gain walk of `max_gain`, the
//! notes and the report, each a function of its own (the setup is
//! [`super::setup`], the global observer's own steps [`super::global`],
//! the verdict line [`super::verdict`]).

use super::attempt::{design_of, Point, Shown, Solve};
use super::setup::{prepare, Setup};
use super::Ctx;
use crate::backend::Status;
use crate::certificate::poles::disk_gain_bound;
use crate::certificate::DataCheck;
use crate::error::SolveError;
use crate::lmi::Objective;
use crate::report::{Design, GammaSearchInfo, Note, Notes, SearchStep, SolverInfo};
use crate::settings::Settings;
use crate::vocab::{Candidate, Family, Phase};
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, PolytopicModel};
use std::collections::BTreeMap;
use std::time::Instant;

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
            p.cert = self.certify(Candidate::new(a, t.gamma), &p.p, &p.l, p.cube.as_ref());
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
        let unit = self.model.time_unit;
        let at = unit.describe_period(h);
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
                "α = {target} certifies at the shorter period {} at γ = {gamma:.6} and fails at {hf:.4e} {} in this search (not a proof that no design certifies there)",
                unit.describe_period(hs),
                unit.symbol(),
            ),
            None => format!(
                "this search found no design certifying α = {target} at γ = {gamma:.6} at any period down to h = {:.3e} {} (not a proof that none exists)",
                h / LONGEST_PERIOD_SHRINK.powi(LONGEST_PERIOD_DOWN as i32),
                unit.symbol()
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
            p.cert = self.certify(p.at(), &p.p, &p.l, p.cube.as_ref());
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
    let p = ctx.min_gain_at(Candidate::new(a, gamma), None)?;
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

/// [`super::design_plain`] with a balancing hint for the global observer: the
/// request prepared ([`prepare`]), the α/γ search and the final solve, then
/// the report ([`Ctx::report`]).
pub(super) fn design_plain_with(
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
        d.summary = super::verdict::Verdict {
            kind: setup.kind,
            mode,
            certified: feasible,
            alpha: at.alpha,
            gamma: at.gamma,
            sample: request.sample,
            unit: setup.model.time_unit,
            status: fin.status,
            failed: &failed,
            max_gain: d.max_gain_norm(),
            noise: None,
        }
        .summary(&notes);
        d.notes = notes;
        d.global = setup.kind.is_global();
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
