//! The design driver: fixed (α, γ), α = max at fixed γ, and the γ search.
//!
//! * Fixed (α, γ): one solve with the default objective (½ w Σ‖Γ̂_l‖_F²,
//!   moderate gains), then the independent certificate; if its point fails
//!   the certificate, the α search below at that γ, whose certified point
//!   covering α is reported at exactly α.
//! * α = max at fixed γ: feasibility is monotone in α
//!   (the γαP term with P ≻ 0), so the largest certified α is bracketed
//!   [lo, hi] with lo certified and hi not, until hi ≤ lo·(1 + tol)
//!   (tol = [`Settings::bisection_rel_tol`], 1e-3). Each trial solves the
//!   *max-margin* problem (maximise t with every rate LMI ⪯ −t W, W the
//!   best P so far): its point lies deep inside the feasible set, and the
//!   exact largest α the *same* (P, Γ_l) satisfy
//!   ([`crate::certificate::alpha_capacity`], re-certified) becomes the new
//!   lower bound — a Dinkelbach-type step for this generalised-eigenvalue
//!   problem. Trials: from lo while that gains more than tol; the secant
//!   root of the optimal margin t̂(α) once it has been seen on both sides
//!   (Illinois-damped, nudged by 0.3·tol across the root); bisection of
//!   [lo, hi] otherwise. Typically 5–10 solves instead of ~20 for plain
//!   bisection.
//! * γ = search over (0, γ_hi], γ_hi = min(1, γ_max)·(1 − 1e-6) in sound
//!   mode (γ_max from (S4)), 1 − 1e-6 in paper mode ([`gamma`]): a
//!   logarithmic grid of [`Settings::gamma_grid`] points over
//!   [γ_hi / [`Settings::gamma_span`], γ_hi], visited top down, every point
//!   valued by α_max to a coarse tolerance (10·tol), seeded by the
//!   neighbouring points found; the grid extends downwards while its lowest
//!   point is still the best; every local maximum of the grid values within
//!   reach of the best ([`Settings::gamma_reach`]) is refined by
//!   golden-section steps in ln γ ([`Settings::gamma_refine`]); if the
//!   point below the best certified nothing, a seeded walk continues down
//!   from the best ([`gamma`], step 4); then α_max to the full tolerance at
//!   the best γ. α_max(γ) is not assumed unimodal
//!   and no point is discarded on an estimate; the result is the best
//!   *certified* (α, γ) found, not a proof of global optimality in γ, and
//!   the report states what was searched (range, points, local maxima).
//!
//! Rate conditions: `conditions = full` solves all N p² blocks (S5)/(26);
//! `conditions = decoupled` solves N·2p blocks with one slack Z_l per
//! θ-vertex ([`crate::lmi`] documents the split), which imply the full
//! family. Either way every point is certified on the full family, and the
//! capacity lift is the full family's, so the search itself is unchanged.
//!
//! Solver outcomes: only Clarabel's `PrimalInfeasible` counts as
//! infeasible; every other non-`Solved` status is *unknown*. A point is
//! accepted only through the independent certificate (an unknown status
//! with a point that certifies is accepted, and noted); in the search,
//! infeasible, unknown and not-certified are all "not certified" (an upper
//! bound), and the report counts the unknowns. The final (α, γ) is solved
//! once more with the default objective; if that point does not certify,
//! the search's certified point at the same (α, γ) is reported instead.

mod attempt;
mod driver;
mod gain_walk;
pub mod gamma;
mod global;
pub mod noise;
mod practical;
pub mod region_cost;
pub mod rms;
mod setup;
pub(crate) mod skew;
mod verdict;

use attempt::{Attempt, Point, Solve};
pub use driver::{alpha_profile, ProfilePoint};

use crate::backend::Status;
use crate::error::SolveError;
use crate::linalg::matrix_to_rows;
use crate::lmi::{Objective, Problem};
use crate::model::ObserverKind;
use crate::report::{Design, GammaSearchInfo, SearchStep};
use crate::settings::Settings;
use crate::vocab::{Candidate, Phase};
use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, PolytopicModel, Split};
use std::time::Instant;

/// A design request with the given α, γ and mode (every other setting at
/// its default, no source span): the one place that builds the struct, for
/// tests, benchmarks and programmatic use.
pub fn request(alpha: AlphaSpec, gamma: GammaSpec, mode: Mode) -> DesignRequest {
    DesignRequest {
        alpha,
        gamma,
        mode,
        split: qpv_dsl::Split::default_for(mode),
        ..Default::default()
    }
}

/// Runs the design requested: fixed (α, γ), α = max by bisection at fixed γ,
/// or a γ search maximising α. See [`design_with_progress`].
pub fn design(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
) -> Result<Design, SolveError> {
    design_with_progress(model, request, settings, &mut |_| {})
}

/// The search's working state: the problem, its solves so far, and the
/// rules of the current search.
struct Ctx<'a, 'm> {
    model: &'m PolytopicModel,
    mode: Mode,
    settings: &'a Settings,
    prob: Problem<'m>,
    steps: Vec<SearchStep>,
    progress: &'a mut dyn FnMut(&SearchStep),
    /// In the γ search's coarse α searches: a max-margin problem that the
    /// solver solves with a negative optimal margin is a failure without
    /// the regularised retry (the retry is for numerical trouble, which a
    /// solved negative optimum is not); the final α search at the best γ
    /// keeps the retry.
    lean: bool,
    /// `max_gain = G`: the certificate's required data check on every
    /// ‖L_l‖₂ (the problem imposes it too).
    max_gain: Option<f64>,
    /// The practical α = max's tolerance (0: the fastest point, the walk
    /// below a cliff runs to its end).
    within: f64,
    /// The γ search's walk ended because the gains exploded (practical
    /// α = max only): α_sup is the fastest point found, not the supremum.
    walk_stopped: bool,
    /// A smaller relative margin of the solves than the settings' (the
    /// practical design's retry where the default margin exceeds what the
    /// conditions leave); None: the settings' own.
    margin_rel: Option<f64>,
    /// The smallest cut margin at which a practical min-gain solve
    /// certified ([`practical::MARGIN_CUTS`]), for the report's note.
    margin_cut: Option<f64>,
    /// The points the solver returned as satisfying the problem's
    /// conditions, and how many of them the certificate rejected.
    claims: Claims,
    /// `sample = h`: points are certified on the discrete decrease (S5d)
    /// and lifted by its capacity (the problem assembles it too).
    sample: Option<f64>,
}

/// The points the solver returned with status solved, and those of them
/// that failed the certificate: with decoupled conditions, all of them
/// failing says that the decoupled problem (sufficient for the full
/// family, and more conservative) gave nothing the full family accepts.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Claims {
    /// Points returned with status solved.
    pub solved: usize,
    /// Of those, points that failed the certificate.
    pub rejected: usize,
}

impl Claims {
    /// The finding for a design that certified nothing, when every point
    /// that satisfied the decoupled conditions failed the full certificate.
    pub fn finding(&self, conditions: Conditions) -> Option<crate::model::diagnosis::Finding> {
        (conditions == Conditions::Decoupled && self.solved > 0 && self.rejected == self.solved)
            .then(|| crate::model::diagnosis::Finding {
                kind: "conditions".into(),
                blocking: false,
                message: format!(
                    "every point the solver returned for the decoupled conditions failed the full certificate ({} of {}): the decoupled rate conditions (one slack per rate combination) are sufficient for the full family but more conservative; try `conditions = full` (every vertex pair solved as it is certified)",
                    self.rejected, self.solved
                ),
            })
    }
}

impl Ctx<'_, '_> {
    /// Largest certified α at this γ, to relative tolerance `tol`. `seed`: a
    /// point found elsewhere (its capacity at this γ is a free lower bound;
    /// its α the first guess).
    ///
    /// Each step solves the max-margin problem at a trial α (metric: the
    /// best P so far). A certified solution is lifted to its exact capacity
    /// α_c ≥ α (a Dinkelbach-type step for this generalised-eigenvalue
    /// problem) and raises the lower bound lo; a non-certified one is an
    /// upper bound hi. Trial points: once the optimal margin t̂(α) is known
    /// on both sides, the secant root of t̂ (shifted by 0.3·tol to cross the
    /// root); else from lo while lifts gain more than `tol`; else bisection
    /// of [lo, hi] or a probe at lo·(1 + 0.9·tol) (a larger step after
    /// points only a regularised retry certified). Stops when
    /// hi ≤ lo·(1 + tol): lo is certified, hi was not.
    fn alpha_max(
        &mut self,
        gamma: f64,
        seed: Option<&Point>,
        tol: f64,
        phase: Phase,
    ) -> Result<Option<Point>, SolveError> {
        let cap = self.settings.alpha_cap;
        let floor = self.settings.alpha_floor;
        let mut lo: Option<Point> = seed.and_then(|sp| self.lift(sp, gamma));
        let mut hi: Option<f64> = None;
        let mut a = match (&lo, seed) {
            (Some(p), _) => p.alpha,
            (None, Some(sp)) => sp.alpha.clamp(floor, cap),
            (None, None) => floor,
        };
        let mut big_gain;
        // Last trial with a positive (uncapped) margin, and the lowest
        // trial with a negative margin: (α, t̂).
        let mut pos: Option<(f64, f64)> = None;
        let mut neg: Option<(f64, f64)> = None;
        let mut last_ok;
        // Illinois factor on the retained positive end after repeated failures.
        let mut fails_in_row = 0i32;
        // Trials in a row certified only by the regularised retry. Such a
        // point has no margin to lift with, so without an upper bound the
        // search would creep up by 0.9·tol per pair of solves (hundreds on
        // an output-filter design with a slow pole); instead each one
        // doubles the next step, up to 8 × 0.9·tol.
        let mut retried = 0i32;
        loop {
            let metric = lo.as_ref().or(seed).map(|p| p.p.clone());
            let (at, by_retry) = self.trial(Candidate::new(a, gamma), metric.as_ref(), phase)?;
            retried = if by_retry { retried + 1 } else { 0 };
            let t = at.margin;
            if at.certified {
                last_ok = true;
                fails_in_row = 0;
                if t.is_finite() && t > 0.0 && t < 0.999 {
                    pos = Some((a, t));
                }
                let pt = at.point.expect("certified attempts carry a point");
                let l = lo.as_ref().map_or(0.0, |p| p.alpha);
                // (A retried point gains only if it lies beyond the trial.)
                big_gain =
                    pt.alpha > l * (1.0 + tol) && (retried == 0 || pt.alpha > a * (1.0 + tol));
                if hi.is_some_and(|h| pt.alpha >= h) {
                    // An earlier "not certified" was spurious.
                    hi = None;
                    neg = None;
                }
                if pt.alpha > l {
                    lo = Some(pt);
                }
            } else {
                if at.status == Status::Infeasible {
                    // Max-margin problems are infeasible only through the
                    // region conditions, which do not depend on α.
                    return Ok(lo);
                }
                last_ok = false;
                fails_in_row += 1;
                big_gain = false;
                if t.is_finite() && t < 0.0 && neg.map_or(true, |(na, _)| a < na) {
                    neg = Some((a, t));
                }
                hi = Some(hi.map_or(a, |h| h.min(a)));
                if lo.is_none() {
                    if a <= floor {
                        return Ok(None);
                    }
                    a = if a > 16.0 * floor {
                        (a / 8.0).max(floor)
                    } else {
                        floor
                    };
                    continue;
                }
            }
            let l = lo.as_ref().map_or(0.0, |p| p.alpha);
            if l >= cap {
                break;
            }
            let h = match hi {
                Some(h) if h <= l * (1.0 + tol) => break,
                h => h,
            };
            let secant = match (pos, neg) {
                (Some((ap, tp)), Some((an, tn))) if ap < an && tp > tn => {
                    let tp = tp * 0.5f64.powi((fails_in_row - 1).max(0));
                    let r = ap + tp * (an - ap) / (tp - tn);
                    let d = 0.3 * tol * l;
                    let r = if last_ok { r + d } else { r - d };
                    let top = h.map_or(f64::INFINITY, |h| h - d);
                    Some(r.min(top).max(l * (1.0 + 0.3 * tol)))
                }
                _ => None,
            };
            a = match (secant, h) {
                _ if big_gain => l,
                (Some(r), _) => r,
                (_, Some(h)) if h > 4.0 * l => (l * h).sqrt(),
                (_, Some(h)) => (0.5 * (l + h)).max(l * (1.0 + 0.9 * tol)),
                (_, None) => l * (1.0 + 0.9 * tol * 2f64.powi(retried.min(4) - 1).max(1.0)),
            }
            .min(cap);
        }
        Ok(lo)
    }

    /// One trial of [`Ctx::alpha_max`]: the max-margin solve at α (metric
    /// P_ref), and where it certified nothing without a clear "no" (a solved
    /// negative margin in the lean γ search), the regularised retry at the
    /// same α. Returns the attempt that counts and whether it is the retry.
    fn trial(
        &mut self,
        cand: Candidate,
        metric: Option<&DMatrix<f64>>,
        phase: Phase,
    ) -> Result<(Attempt, bool), SolveError> {
        let at = self.attempt(cand, Solve::Lmi(Objective::MaxMargin, metric), phase)?;
        let clear_no = self.lean && at.status == Status::Solved && at.margin < 0.0;
        if at.certified || clear_no {
            return Ok((at, false));
        }
        // A max-margin answer without a certified point (solved but
        // rejected by the certificate, unknown, or even reported
        // infeasible) can be numerical trouble — e.g. an unbounded
        // optimal face, as P's filter block of an output-filter
        // design — rather than infeasibility: retry this α with the
        // regularised objective before counting it as a failure.
        let retry = self.attempt_regularised(cand, Phase::Retry)?;
        Ok(if retry.certified {
            (retry, true)
        } else {
            (at, false)
        })
    }

    /// The largest certified α at `gamma` to relative tolerance `tol`
    /// ([`Ctx::alpha_max`]), seeded by the point of `found` whose capacity
    /// at `gamma` is largest (an eigenvalue computation per point, no
    /// solve: near the small-γ end of some plants the solver's α search
    /// from scratch fails where a neighbour's P still certifies far up).
    fn alpha_seeded(
        &mut self,
        gamma: f64,
        found: &[Point],
        tol: f64,
        phase: Phase,
    ) -> Result<Option<Point>, SolveError> {
        let mut seed: Option<(&Point, f64)> = None;
        for cand in found {
            if let Some(up) = self.lift(cand, gamma) {
                if seed.map_or(true, |(_, a)| up.alpha > a) {
                    seed = Some((cand, up.alpha));
                }
            }
        }
        // Without a seed that certifies here, start from the smallest α:
        // its max-margin point's capacity is a good first bound, and if it
        // fails nothing certifies at this γ (feasibility is monotone in α).
        self.alpha_max(gamma, seed.map(|(p, _)| p), tol, phase)
    }

    /// γ search maximising α ([`gamma::maximise`]: a logarithmic grid,
    /// downward extension, golden-section refinement of every local maximum
    /// within reach), each γ valued by [`Ctx::alpha_seeded`] to a coarse
    /// tolerance; then α_max to the full tolerance at the best γ. Returns
    /// the best certified point and the statement of what was searched.
    fn gamma_search(
        &mut self,
        gamma_hi: f64,
    ) -> Result<(Option<Point>, GammaSearchInfo, practical::Trace), SolveError> {
        let tol = self.settings.bisection_rel_tol;
        let coarse = (10.0 * tol).min(0.05);
        let plan = gamma::GammaPlan::from_settings(gamma_hi, self.settings);
        let solves_before = self.steps.len();
        let mut found: Vec<Point> = Vec::new();
        self.lean = true;
        // The practical α = max (within > 0) ends the walk below a cliff
        // once a point's gain exceeds WALK_GAIN_LIMIT times the walk's
        // start: the design it returns lies far below such points.
        let stop = std::cell::Cell::new(false);
        let mut walk_start: Option<f64> = None;
        let practical = self.within > 0.0;
        let out = gamma::maximise_until(
            &plan,
            &mut |g, phase| {
                if phase == Phase::Continue && walk_start.is_none() {
                    walk_start = found
                        .iter()
                        .max_by(|a, b| a.alpha.total_cmp(&b.alpha))
                        .map(practical::max_gain);
                }
                Ok(match self.alpha_seeded(g, &found, coarse, phase)? {
                    Some(pt) => {
                        let a = pt.alpha;
                        if let (true, Phase::Continue, Some(g0)) = (practical, phase, walk_start) {
                            if practical::max_gain(&pt) > practical::WALK_GAIN_LIMIT * g0 {
                                stop.set(true);
                            }
                        }
                        found.push(pt);
                        a
                    }
                    None => 0.0,
                })
            },
            &|| stop.get(),
        );
        if stop.get() {
            self.walk_stopped = true;
        }
        self.lean = false;
        let out = out?;
        let mut samples: Vec<(f64, f64)> = found.iter().map(|p| (p.gamma, p.alpha)).collect();
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        // The α search's certified point at each γ of the walk (the
        // α–gain curve the knee is taken on).
        let walk_points: Vec<Point> = out
            .walk
            .iter()
            .filter_map(|&(g, _)| {
                found
                    .iter()
                    .filter(|p| (p.gamma - g).abs() <= 1e-12 * g)
                    .max_by(|a, b| a.alpha.total_cmp(&b.alpha))
                    .cloned()
            })
            .collect();
        let trace = practical::Trace {
            samples,
            still_rising: out.still_rising,
            walk_points,
        };
        let mut info = out.info;
        let best = found
            .iter()
            .filter(|p| p.gamma == out.gamma)
            .max_by(|a, b| a.alpha.total_cmp(&b.alpha))
            .cloned();
        let result = match best {
            None => None,
            Some(b) => {
                // Full precision at the best γ.
                let fine = self.alpha_max(b.gamma, Some(&b), tol, Phase::FinalBisect)?;
                Some(match fine {
                    Some(p) if p.alpha >= b.alpha => p,
                    _ => b,
                })
            }
        };
        info.solves = self.steps.len() - solves_before;
        Ok((result, info, trace))
    }
}

/// Rounds of the skew-slack alternation of `split = skew_slack`.
const SKEW_ROUNDS: usize = 8;

/// `split = skew_slack`: the symmetric design, then the skew-slack
/// alternation from it at its γ ([`skew_search`]); the report
/// carries K (`Design::skew`), and is re-checked through
/// [`Design::recheck`] before it is returned.
fn design_skew(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    let t_start = Instant::now();
    if request.mode != Mode::Sound {
        return Err(SolveError::SkewNeedsSound);
    }
    // The alternation maximises α from the fastest symmetric point: the
    // practical tolerance does not apply to it (noted).
    let sym = DesignRequest {
        split: Split::Symmetric,
        within: 0.0,
        ..request.clone()
    };
    let mut d = design_plain(model, &sym, settings, progress)?;
    d.split = Split::SkewSlack;
    if request.alpha == AlphaSpec::Max && request.within > 0.0 {
        d.notes.push(format!(
            "split = skew_slack maximises α: `within = {}` (the practical α = max) is not applied to it",
            request.within
        ));
    }
    if !d.certifies() {
        d.notes.push(
            "split = skew_slack: the symmetric design did not certify, so no slack was searched",
        );
        return Ok(d);
    }
    let r = skew_search(model, &d, SKEW_ROUNDS, settings, d.conditions)?;
    let mut out = r.design.clone();
    if r.alpha_best() > d.alpha {
        out.skew = Some(
            r.k.iter()
                .map(|kl| kl.iter().map(matrix_to_rows).collect())
                .collect(),
        );
        out.model = d.model.clone();
        out.split = Split::SkewSlack;
        out.conditions = d.conditions;
        out.state_bound = d.state_bound.clone();
        out.output_route = d.output_route.clone();
        let mut notes = d.notes.clone();
        let rounds: Vec<String> = r.rounds.iter().map(|x| format!("{:.5}", x.alpha)).collect();
        let note = format!(
            "split = skew_slack: a skew-symmetric slack K_k (N_k + K_k, the same plant; max ‖K_k,l‖_F = {:.4}) raised the certified α from {:.6} to {:.6} at γ = {:.6} in {} alternating rounds (α per round: {}); P and L_l are certified on N_k + K_k, which the report's `skew` key carries",
            r.rounds.last().map_or(0.0, |x| x.k_norm),
            d.alpha,
            out.alpha,
            out.gamma,
            r.rounds.len(),
            rounds.join(", ")
        );
        notes.push(note.clone());
        notes.extend(out.notes.iter().cloned());
        out.notes = notes;
        let mut search = d.search.clone();
        search.extend(out.search.iter().cloned());
        out.search = search;
        out.summary = format!("{} {note}.", out.summary);
        out.seconds_total = t_start.elapsed().as_secs_f64();
        if out.recheck(model).passed {
            return Ok(out);
        }
        d.notes.push(
            "split = skew_slack: the slack's design did not pass the re-check through the report, so the symmetric design is reported",
        );
    } else {
        d.notes.push(format!(
            "split = skew_slack: the skew-symmetric slack gained nothing over α = {:.6} ({} rounds); K = 0",
            d.alpha,
            r.rounds.len()
        ));
    }
    d.seconds_total = t_start.elapsed().as_secs_f64();
    Ok(d)
}

/// [`design_with_progress`] for every split but `skew_slack`, without the
/// noise and sampling figures: the global observer's design
/// ([`global::design`]) or the regional one ([`driver::design_plain_with`]),
/// by the observer's kind.
fn design_plain(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    match ObserverKind::of(model, request.mode) {
        ObserverKind::Global => global::design(model, request, settings, progress),
        ObserverKind::Regional => {
            driver::design_plain_with(model, request, settings, progress, None)
        }
    }
}

/// As [`design`], calling `progress` after every solve. A request with
/// `noise = min` is the noise-optimal design of [`noise::design_noise`]
/// on the model's declared channels; one with `noise = rms` the
/// RMS-optimal design of [`rms::design_rms`].
pub fn design_with_progress(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    if ObserverKind::of(model, request.mode).is_global() && request.split == Split::SkewSlack {
        return Err(SolveError::SkewOnLpv(model.name.clone()));
    }
    if request.noise == qpv_dsl::NoiseObjective::Rms {
        return rms::design_rms_with_progress(model, request, settings, progress);
    }
    if request.noise == qpv_dsl::NoiseObjective::Min {
        let channels = crate::model::noise::NoiseChannels::from_model(model);
        let mut d =
            noise::design_noise_with_progress(model, request, &channels, settings, progress)?;
        d.notes.extend(crate::certificate::measured::notes(model));
        return Ok(d);
    }
    let mut d = if request.split == Split::SkewSlack {
        design_skew(model, request, settings, progress)?
    } else {
        design_plain(model, request, settings, progress)?
    };
    region_cost::attach(model, request, settings, &mut d)?;
    // The noise bound and the sampling figures of a certified
    // continuous-time design (both are continuous-time analyses).
    if d.sample.is_none() {
        crate::report::figures::attach(model, &mut d);
    } else if d.certifies() {
        d.notes.push(
            "sample = h: the noise bound and the Euler-step figures are continuous-time analyses and are not computed for a sampled design",
        );
        crate::report::continuous::attach(model, &mut d);
    }
    d.notes.extend(crate::certificate::measured::notes(model));
    Ok(d)
}

/// The skew-slack alternation ([`skew::alternate`]) from `start`, with the
/// ordinary α search as its step 2.
pub fn skew_search(
    model: &PolytopicModel,
    start: &Design,
    rounds: usize,
    settings: &Settings,
    conditions: Conditions,
) -> Result<skew::SkewResult, SolveError> {
    skew::alternate(model, start, rounds, settings, conditions, &mut |m, r| {
        design_plain(m, r, settings, &mut |_| {})
    })
}
