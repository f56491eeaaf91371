//! The design driver: fixed (α, γ), α = max at fixed γ, and the γ search.
//!
//! * Fixed (α, γ): one solve with the default objective (½ w Σ‖Γ̂_l‖_F²,
//!   moderate gains), then the independent certificate.
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
//!   mode (γ_max from (S4)), 1 − 1e-6 in paper mode: a coarse grid
//!   γ_hi·k/n ([`Settings::gamma_grid`]) visited top down, each point
//!   ranked by a short certified estimate of α_max (a few max-margin solves
//!   seeded by the best point so far, [`Settings::gamma_steps`]), then
//!   golden-section refinement between the neighbours of the best grid
//!   point ([`Settings::gamma_refine`] evaluations), then α_max to the full
//!   tolerance at the best γ. The result is the best *certified* (α, γ)
//!   found; α_max(γ) is not assumed unimodal, so it is a search, not a proof
//!   of global optimality in γ.
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

pub mod skew;

use crate::backend::Status;
use crate::certificate::{
    alpha_capacity, alpha_capacity_cube, check, check_cube, data_checks, Certificate, DataCheck,
};
use crate::conditions::cube::CubeSlacks;
use crate::conditions::ConditionSet;
use crate::error::SolveError;
use crate::linalg::matrix_to_rows;
use crate::lmi::{Objective, Problem};
use crate::model::{gamma_max, ObserverModel, ObserverOptions, StateBoundClaim};
use crate::report::{Design, SearchStep, SolverInfo};
use crate::settings::Settings;
use crate::vocab::{BoundSource, Candidate, Family, Phase};
use nalgebra::DMatrix;
use qpv_dsl::{
    AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, PolytopicModel, Split, StateBound,
};
use std::collections::BTreeMap;
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

/// A candidate observer: P, Γ_l, L_l and its certificate at (α, γ).
#[derive(Debug, Clone)]
struct Point {
    alpha: f64,
    gamma: f64,
    p: DMatrix<f64>,
    gammas: Vec<DMatrix<f64>>,
    l: Vec<DMatrix<f64>>,
    cert: Certificate,
    solver: SolverInfo,
    /// The slacks of cube conditions (checked with the point).
    cube: Option<CubeSlacks>,
}

/// The result of one attempt at (α, γ).
struct Attempt {
    status: Status,
    /// The returned point (certified or not), if any.
    point: Option<Point>,
    /// Whether `point` passed the certificate at the tested α.
    certified: bool,
    /// The max-margin optimum t̂ (NaN for other objectives / no point).
    margin: f64,
    /// Solver statistics of this attempt.
    solver: SolverInfo,
}

/// L_l = P⁻¹ Γ_l (Cholesky, else LU); None if P is singular.
fn gains(p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> Option<Vec<DMatrix<f64>>> {
    let ps = (p + p.transpose()) * 0.5;
    if let Some(ch) = ps.clone().cholesky() {
        return Some(gammas.iter().map(|g| ch.solve(g)).collect());
    }
    let lu = ps.lu();
    gammas.iter().map(|g| lu.solve(g)).collect()
}

struct Ctx<'a, 'm> {
    model: &'m PolytopicModel,
    mode: Mode,
    settings: &'a Settings,
    prob: Problem<'m>,
    steps: Vec<SearchStep>,
    progress: &'a mut dyn FnMut(&SearchStep),
}

impl Ctx<'_, '_> {
    /// Whether a certificate counts: every family and, in sound mode, (S4).
    fn accepts(&self, cert: &Certificate) -> bool {
        cert.passed
    }

    /// The certificate of (P, L_l) at (α, γ): the full family, or the cube's
    /// slack inequalities when the point carries cube slacks.
    fn certify(
        &self,
        alpha: f64,
        gamma: f64,
        p: &DMatrix<f64>,
        l: &[DMatrix<f64>],
        cube: Option<&CubeSlacks>,
    ) -> Certificate {
        match cube {
            Some(c) => check_cube(self.model, self.mode, alpha, gamma, p, l, c),
            None => check(self.model, self.mode, alpha, gamma, p, l),
        }
    }

    /// The largest α at which the point's (P, Γ_l, L_l) certify at `gamma`
    /// (exact capacity, times 1 − 1e-4, re-certified); None if they do not
    /// certify at any α > 0 there.
    fn lift(&self, base: &Point, gamma: f64) -> Option<Point> {
        let cap = match &base.cube {
            Some(c) => alpha_capacity_cube(self.model, self.mode, gamma, &base.p, &base.gammas, c),
            None => alpha_capacity(self.model, self.mode, gamma, &base.p, &base.gammas),
        };
        let a = cap * (1.0 - 1e-4);
        if !(a > 0.0 && a.is_finite()) {
            return None;
        }
        let a = a.min(self.settings.alpha_cap);
        let cert = self.certify(a, gamma, &base.p, &base.l, base.cube.as_ref());
        if self.accepts(&cert) {
            Some(Point {
                alpha: a,
                gamma,
                cert,
                ..base.clone()
            })
        } else {
            None
        }
    }

    /// [`Ctx::attempt`] with the regularised objective ([`Objective::Gains`]),
    /// its certified point lifted to its capacity like a max-margin point:
    /// the fall-back of the α searches where max-margin answers are unreliable.
    fn attempt_regularised(
        &mut self,
        cand: Candidate,
        phase: Phase,
    ) -> Result<Attempt, SolveError> {
        let Candidate { alpha, gamma } = cand;
        let mut at = self.attempt(cand, Objective::Gains, None, phase)?;
        if at.certified {
            if let Some(up) = at.point.as_ref().and_then(|p| self.lift(p, gamma)) {
                if up.alpha > alpha {
                    at.point = Some(up);
                }
            }
        }
        Ok(at)
    }

    /// One solve at (α, γ), certified. With [`Objective::MaxMargin`] a
    /// certified point is lifted to its capacity (its α may exceed `alpha`).
    fn attempt(
        &mut self,
        cand: Candidate,
        objective: Objective,
        metric: Option<&DMatrix<f64>>,
        phase: Phase,
    ) -> Result<Attempt, SolveError> {
        let Candidate { alpha, gamma } = cand;
        let t0 = Instant::now();
        let res = self
            .prob
            .solve_with_metric(alpha, gamma, self.settings, objective, metric)?;
        let mut solver = SolverInfo {
            status: res.status,
            detail: res.detail.clone(),
            iterations: res.iterations,
            seconds: res.solve_seconds,
            assembly_seconds: res.assembly_seconds,
            certify_seconds: 0.0,
        };
        let mut point = None;
        let mut certified = false;
        let mut alpha_certified = 0.0;
        if let Some(p) = res.p {
            if let Some(l) = gains(&p, &res.gammas) {
                let tc = Instant::now();
                let cert = self.certify(alpha, gamma, &p, &l, res.cube.as_ref());
                solver.certify_seconds = tc.elapsed().as_secs_f64();
                certified = self.accepts(&cert);
                // Γ_l as the certificate sees them (P L_l).
                let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| &p * li).collect();
                let mut pt = Point {
                    alpha,
                    gamma,
                    p,
                    gammas,
                    l,
                    cert,
                    solver: solver.clone(),
                    cube: res.cube.clone(),
                };
                if certified {
                    alpha_certified = alpha;
                    if objective == Objective::MaxMargin {
                        if let Some(up) = self.lift(&pt, gamma) {
                            if up.alpha > alpha {
                                pt = up;
                                alpha_certified = pt.alpha;
                            }
                        }
                        pt.solver.certify_seconds = tc.elapsed().as_secs_f64();
                    }
                }
                point = Some(pt);
            }
        }
        let mut detail = res.detail;
        if objective == Objective::MaxMargin && res.margin.is_finite() {
            detail = format!("{detail} (max margin t = {:.3e})", res.margin);
        }
        let step = SearchStep {
            gamma,
            alpha,
            status: res.status,
            detail,
            certified,
            alpha_certified,
            iterations: res.iterations,
            seconds: t0.elapsed().as_secs_f64(),
            solver_seconds: res.solve_seconds,
            phase,
        };
        (self.progress)(&step);
        self.steps.push(step);
        Ok(Attempt {
            status: res.status,
            point,
            certified,
            margin: res.margin,
            solver,
        })
    }

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
    /// of [lo, hi] or a probe at lo·(1 + 0.9·tol). Stops when
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
        loop {
            let metric = lo.as_ref().or(seed).map(|p| p.p.clone());
            let mut at = self.attempt(
                Candidate::new(a, gamma),
                Objective::MaxMargin,
                metric.as_ref(),
                phase,
            )?;
            if !at.certified {
                // A max-margin answer without a certified point (solved but
                // rejected by the certificate, unknown, or even reported
                // infeasible) can be numerical trouble — e.g. an unbounded
                // optimal face, as P's filter block of an output-filter
                // design — rather than infeasibility: retry this α with the
                // regularised objective before counting it as a failure.
                let retry = self.attempt_regularised(Candidate::new(a, gamma), Phase::Retry)?;
                if retry.certified {
                    at = retry;
                }
            }
            let t = at.margin;
            if at.certified {
                last_ok = true;
                fails_in_row = 0;
                if t.is_finite() && t > 0.0 && t < 0.999 {
                    pos = Some((a, t));
                }
                let pt = at.point.expect("certified attempts carry a point");
                let l = lo.as_ref().map_or(0.0, |p| p.alpha);
                big_gain = pt.alpha > l * (1.0 + tol);
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
                (_, None) => l * (1.0 + 0.9 * tol),
            }
            .min(cap);
        }
        Ok(lo)
    }

    /// A certified lower estimate of α_max(γ) from at most `steps`
    /// max-margin solves (Dinkelbach steps), starting from the best capacity
    /// at this γ of the points found so far (nearest γ below and above, and
    /// the best overall); stops early when a step gains less than `tol`.
    /// Used to rank γ.
    fn alpha_estimate(
        &mut self,
        gamma: f64,
        found: &[Point],
        steps: usize,
        tol: f64,
        phase: Phase,
    ) -> Result<Option<Point>, SolveError> {
        let floor = self.settings.alpha_floor;
        let cap = self.settings.alpha_cap;
        // Candidate seeds: nearest γ below, nearest above, best overall.
        let below = found
            .iter()
            .filter(|p| p.gamma <= gamma)
            .max_by(|a, b| a.gamma.total_cmp(&b.gamma));
        let above = found
            .iter()
            .filter(|p| p.gamma > gamma)
            .min_by(|a, b| a.gamma.total_cmp(&b.gamma));
        let best = found.iter().max_by(|a, b| a.alpha.total_cmp(&b.alpha));
        let nearest = match (below, above) {
            (Some(b), Some(a)) => Some(if gamma - b.gamma <= a.gamma - gamma {
                b
            } else {
                a
            }),
            (b, a) => b.or(a),
        };
        let mut lo: Option<Point> = None;
        for cand in [below, above, best].into_iter().flatten() {
            if let Some(pt) = self.lift(cand, gamma) {
                if lo.as_ref().map_or(true, |l| pt.alpha > l.alpha) {
                    lo = Some(pt);
                }
            }
        }
        let seed = nearest;
        let mut a = match (&lo, seed) {
            (Some(p), _) => p.alpha,
            // No seed certifies here: α_max is likely lower than the nearest.
            (None, Some(sp)) => (0.6 * sp.alpha).clamp(floor, cap),
            (None, None) => floor,
        };
        let mut done = 0;
        let mut misses = 0;
        while done < steps {
            let metric = lo.as_ref().or(seed).map(|p| p.p.clone());
            let at = self.attempt(
                Candidate::new(a, gamma),
                Objective::MaxMargin,
                metric.as_ref(),
                phase,
            )?;
            if at.certified {
                done += 1;
                let pt = at.point.expect("certified attempts carry a point");
                let l = lo.as_ref().map_or(0.0, |p| p.alpha);
                let mut gain = pt.alpha > l * (1.0 + tol);
                if pt.alpha > l {
                    lo = Some(pt);
                }
                if !gain && at.margin > 0.1 && done < steps {
                    // A large max-margin t that the capacity lift cannot turn
                    // into α (an ill-scaled metric, e.g. the unbounded filter
                    // block of P): probe a larger α with the regularised
                    // objective, certified like any point.
                    let probe = (a * (1.0 + at.margin.min(1.0))).min(cap);
                    let pr = self.attempt_regularised(Candidate::new(probe, gamma), phase)?;
                    if let Some(p) = pr.point.filter(|_| pr.certified) {
                        let l = lo.as_ref().map_or(0.0, |p| p.alpha);
                        gain = p.alpha > l * (1.0 + tol);
                        if p.alpha > l {
                            lo = Some(p);
                        }
                    }
                }
                if !gain {
                    break;
                }
                a = lo.as_ref().map_or(a, |p| p.alpha);
            } else {
                if at.status == Status::Infeasible || lo.is_some() || a <= floor {
                    break;
                }
                misses += 1;
                if misses > 6 {
                    break;
                }
                a = if a > 16.0 * floor {
                    (a / 8.0).max(floor)
                } else {
                    floor
                };
            }
        }
        Ok(lo)
    }

    /// γ search maximising α: a coarse grid (top down, each point a short
    /// [`Ctx::alpha_estimate`] seeded by the best point so far),
    /// golden-section refinement around the best grid point (same
    /// estimates), then α_max to the full tolerance at the best γ.
    fn gamma_search(&mut self, gamma_hi: f64) -> Result<Option<Point>, SolveError> {
        let tol = self.settings.bisection_rel_tol;
        let coarse = (10.0 * tol).min(0.05);
        let steps = self.settings.gamma_steps.max(1);
        let n = self.settings.gamma_grid.max(2);
        let grid: Vec<f64> = (1..=n).map(|k| gamma_hi * k as f64 / n as f64).collect();
        let mut memo: Vec<(f64, f64)> = Vec::new();
        let mut best: Option<Point> = None;
        let mut found: Vec<Point> = Vec::new();
        for &g in grid.iter().rev() {
            // The first point has no seed: give it more steps, so that it is
            // ranked fairly and seeds the others well.
            let st = if found.is_empty() { 6 } else { steps };
            let v = match self.alpha_estimate(g, &found, st, coarse, Phase::Grid)? {
                Some(pt) => {
                    let v = pt.alpha;
                    if best.as_ref().map_or(true, |b| v > b.alpha) {
                        best = Some(pt.clone());
                    }
                    found.push(pt);
                    v
                }
                None => 0.0,
            };
            memo.push((g, v));
        }
        let Some(b) = best.as_ref() else {
            return Ok(None);
        };
        // Refine between the neighbours of the best grid point.
        let kb = grid.iter().position(|&g| g == b.gamma).unwrap_or(0);
        let mut a = if kb == 0 {
            grid[0] * 0.25
        } else {
            grid[kb - 1]
        };
        let mut c = if kb + 1 < n { grid[kb + 1] } else { gamma_hi };
        let phi = (5f64.sqrt() - 1.0) / 2.0;
        let mut eval =
            |ctx: &mut Self, g: f64, best: &mut Option<Point>| -> Result<f64, SolveError> {
                if let Some(&(_, v)) = memo.iter().find(|(x, _)| (*x - g).abs() <= 1e-12 * g) {
                    return Ok(v);
                }
                let v = match ctx.alpha_estimate(g, &found, steps, coarse, Phase::Refine)? {
                    Some(pt) => {
                        let v = pt.alpha;
                        if best.as_ref().map_or(true, |b| v > b.alpha) {
                            *best = Some(pt.clone());
                        }
                        found.push(pt);
                        v
                    }
                    None => 0.0,
                };
                memo.push((g, v));
                Ok(v)
            };
        if c > a && self.settings.gamma_refine > 0 {
            let mut x1 = c - phi * (c - a);
            let mut x2 = a + phi * (c - a);
            let mut f1 = eval(self, x1, &mut best)?;
            let mut f2 = eval(self, x2, &mut best)?;
            for _ in 2..self.settings.gamma_refine {
                if f1 >= f2 {
                    c = x2;
                    x2 = x1;
                    f2 = f1;
                    x1 = c - phi * (c - a);
                    f1 = eval(self, x1, &mut best)?;
                } else {
                    a = x1;
                    x1 = x2;
                    f1 = f2;
                    x2 = a + phi * (c - a);
                    f2 = eval(self, x2, &mut best)?;
                }
            }
        }
        // Full precision at the best γ.
        let Some(b) = best.clone() else {
            return Ok(None);
        };
        let fine = self.alpha_max(b.gamma, Some(&b), tol, Phase::FinalBisect)?;
        Ok(match fine {
            Some(p) if p.alpha >= b.alpha => Some(p),
            _ => Some(b),
        })
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
        return Err(SolveError::Unsupported(
            "split = skew_slack needs mode = sound (the paper's conditions are reproduced as printed)"
                .into(),
        ));
    }
    let sym = DesignRequest {
        split: Split::Symmetric,
        ..request.clone()
    };
    let mut d = design_plain(model, &sym, settings, progress)?;
    d.split = Split::SkewSlack;
    if !d.certifies {
        d.notes.push(
            "split = skew_slack: the symmetric design did not certify, so no slack was searched"
                .into(),
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
            "split = skew_slack: the slack's design did not pass the re-check through the report, so the symmetric design is reported".into(),
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

/// As [`design`], calling `progress` after every solve. A request with
/// `noise = min` is the noise-optimal design of [`crate::noise::design_noise`]
/// on the model's declared channels.
pub fn design_with_progress(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    if request.noise == qpv_dsl::NoiseObjective::Min {
        let channels = crate::noise::NoiseChannels::from_model(model);
        return crate::noise::design_noise_with_progress(
            model, request, &channels, settings, progress,
        );
    }
    let mut d = if request.split == Split::SkewSlack {
        design_skew(model, request, settings, progress)?
    } else {
        design_plain(model, request, settings, progress)?
    };
    // The noise bound and the sampling figures of a certified design.
    crate::noise::attach(model, &mut d);
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

/// [`design_with_progress`] for every split but `skew_slack`, without the
/// noise and sampling figures.
fn design_plain(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    let t_start = Instant::now();
    let mode = request.mode;
    let set = ConditionSet::from_mode(mode);
    crate::model::validate(model)?;
    // `conditions = auto`: the choice by size (crate::size::choose), noted.
    let (chosen_conditions, auto_note) = crate::size::choose(model, request);
    let resolved = DesignRequest {
        conditions: chosen_conditions,
        ..request.clone()
    };
    let request = &resolved;
    // Size guard (crate::size): refuse before anything is assembled or solved.
    let size_note = match crate::size::guard(model, request) {
        crate::size::Verdict::TooLarge(m) => return Err(SolveError::TooLarge(m)),
        crate::size::Verdict::Slow(m) => Some(m),
        crate::size::Verdict::Fits => None,
    };
    // The observer's model: `state_bound auto` computed (then used as
    // given), the output route (the model itself or its augmentation by the
    // output post-filter), the requested representation of N_k, M_k.
    let prepared = ObserverModel::prepare(
        model,
        &ObserverOptions::for_request(request),
        StateBoundClaim::Compute(settings),
    )?;
    let (bound_info, route_info) = (prepared.state_bound, prepared.output_route);
    let model: &PolytopicModel = &prepared.model;
    let has_q = matches!(model.state_bound, StateBound::Given(_));
    if set.requires_s4() && !has_q {
        return Err(SolveError::MissingStateBound(model.name.clone()));
    }
    if let AlphaSpec::Fixed(a) = request.alpha {
        if !(a.is_finite() && a > 0.0) {
            return Err(SolveError::BadAlpha(a));
        }
    }
    if let GammaSpec::Fixed(g) = request.gamma {
        if !(g.is_finite() && g > 0.0 && g < 1.0) {
            return Err(SolveError::BadGamma(g));
        }
    }
    let gmax = gamma_max(model);
    let gamma_hi = match set {
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
    // Full: all N p² rate blocks; decoupled: N·2p blocks with a slack Z_l per
    // θ-vertex (sufficient). The certificate checks the full family either way.
    let prob = Problem::new(model, set)?.with_conditions(request.conditions)?;
    let mut ctx = Ctx {
        model,
        mode,
        settings,
        prob,
        steps: Vec::new(),
        progress,
    };

    // The search.
    let mut notes: Vec<String> = Vec::new();
    if !auto_note.is_empty() {
        notes.push(auto_note);
    }
    notes.extend(size_note); // size guard: the "slow" warning
    if bound_info.source == BoundSource::Auto {
        notes.push(format!(
            "state bound computed (state_bound auto): h = {:.6}, γ_max = {:.6}, in {} solves, {:.3} s",
            bound_info.h.unwrap_or(f64::NAN),
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
    if request.split == Split::Symmetric {
        notes.push(
            "N_k and M_k symmetrised ((T + Tᵀ)/2, the same plant); re-check with this split".into(),
        );
    }
    if request.conditions == Conditions::Decoupled {
        notes.push(format!(
            "conditions = decoupled: solved with {} rate blocks (one slack Z per rate combination, sufficient) instead of {}; the certificate checks the full family of {} blocks",
            ctx.prob.n_rate_blocks(),
            ctx.prob.n_full_rate_blocks(),
            ctx.prob.n_full_rate_blocks()
        ));
    }
    if request.conditions == Conditions::Cube {
        notes.push(format!(
            "conditions = cube: the region as a zonotope with {} generators; solved and certified with {} rate blocks (one pair of slacks Y, X per generator, sufficient) and D ⪰ GᵀPG, trace D ≤ 1 for the region's vertices, instead of {} vertex-pair blocks; the report's `cube` key carries the slacks",
            ctx.prob.n_generators(),
            ctx.prob.n_rate_blocks(),
            ctx.prob.n_full_rate_blocks()
        ));
    }
    let (alpha_t, gamma_t, searched): (Option<f64>, f64, Option<Point>) = match (
        request.alpha,
        request.gamma,
    ) {
        (AlphaSpec::Fixed(a), GammaSpec::Fixed(g)) => (Some(a), g, None),
        (AlphaSpec::Max, GammaSpec::Fixed(g)) => {
            let pt = ctx.alpha_max(g, None, settings.bisection_rel_tol, Phase::Bisect)?;
            (pt.as_ref().map(|p| p.alpha), g, pt)
        }
        (alpha, GammaSpec::Search) => {
            let pt = ctx.gamma_search(gamma_hi)?;
            let g = pt.as_ref().map(|p| p.gamma).unwrap_or(gamma_hi);
            match alpha {
                AlphaSpec::Max => (pt.as_ref().map(|p| p.alpha), g, pt),
                AlphaSpec::Fixed(a) => {
                    if let Some(p) = &pt {
                        if p.alpha < a {
                            notes.push(format!(
                                "the requested α = {a} exceeds the best certified α = {:.6} (at γ = {:.6})",
                                p.alpha, p.gamma
                            ));
                        }
                    }
                    // Keep the searched point only if it covers α.
                    let keep = pt.filter(|p| p.alpha >= a);
                    (Some(a), g, keep)
                }
            }
        }
    };

    // The final solve, with the gain regularisation.
    let mut chosen: Option<Point> = None;
    let mut last: Option<Point> = None;
    let mut final_status = Status::NotRun;
    let mut final_solver = SolverInfo::default();
    if let Some(a) = alpha_t {
        let at = ctx.attempt(
            Candidate::new(a, gamma_t),
            Objective::Gains,
            None,
            Phase::Final,
        )?;
        final_status = at.status;
        final_solver = at.solver.clone();
        if at.certified {
            chosen = at.point;
        } else {
            last = at.point;
            if let Some(mut sp) = searched.filter(|p| p.alpha >= a && p.gamma == gamma_t) {
                // Re-certify the search's point at exactly the reported α.
                sp.cert = ctx.certify(a, gamma_t, &sp.p, &sp.l, sp.cube.as_ref());
                if sp.cert.passed {
                    sp.alpha = a;
                    notes.push(format!(
                        "the regularised final solve did not certify ({}); the search's certified point at the same (α, γ) is reported (its gains are not regularised)",
                        at.status
                    ));
                    final_solver = sp.solver.clone();
                    chosen = Some(sp);
                }
            }
        }
    } else if let Some(s) = ctx.steps.last() {
        final_status = s.status;
        final_solver = SolverInfo {
            status: s.status,
            detail: s.detail.clone(),
            iterations: s.iterations,
            seconds: s.solver_seconds,
            ..SolverInfo::default()
        };
    }

    let feasible = chosen.is_some();
    let shown = chosen.or(last);
    let alpha_r = shown
        .as_ref()
        .map(|p| p.alpha)
        .or(alpha_t)
        .unwrap_or_else(|| {
            ctx.steps
                .iter()
                .map(|s| s.alpha)
                .fold(f64::INFINITY, f64::min)
                .min(settings.alpha_floor)
        });
    let gamma_r = shown.as_ref().map(|p| p.gamma).unwrap_or(gamma_t);
    let dchecks: BTreeMap<String, DataCheck> = match &shown {
        Some(p) => p.cert.data_checks.clone(),
        None => data_checks(model, mode, gamma_r),
    };
    let mut margins = shown.as_ref().map(|p| p.cert.margins()).unwrap_or_default();
    // Failure diagnosis (crate::diagnosis): without any point, the margins
    // of one attempt at the smallest α, then the cheap model tests.
    let diagnosis = if feasible {
        None
    } else {
        if margins.is_empty() {
            let (a, obj) = (settings.alpha_floor, Objective::MaxMargin);
            if let Some(p) = ctx
                .attempt(Candidate::new(a, gamma_r), obj, None, Phase::Diagnose)?
                .point
            {
                margins = p.cert.margins();
            }
        }
        Some(crate::diagnosis::diagnose(
            model,
            request,
            settings.alpha_floor,
        ))
    };

    // Notes and summary.
    let unknown = ctx
        .steps
        .iter()
        .filter(|s| s.status == Status::Unknown)
        .count();
    if unknown > 0 {
        let mut kinds: Vec<String> = ctx
            .steps
            .iter()
            .filter(|s| s.status == Status::Unknown)
            .map(|s| s.detail.clone())
            .collect();
        kinds.sort();
        kinds.dedup();
        notes.push(format!(
            "{unknown} of {} solves ended with an unknown status ({}): neither feasible nor infeasible, counted as not certified",
            ctx.steps.len(),
            kinds.join(", ")
        ));
    }
    if feasible && final_solver.status != Status::Solved {
        notes.push(format!(
            "the solver stopped with {} but its point passes the independent certificate",
            final_solver.detail
        ));
    }
    let uncert = ctx
        .steps
        .iter()
        .filter(|s| s.status == Status::Solved && !s.certified)
        .count();
    if uncert > 0 {
        notes.push(format!(
            "{uncert} solved points failed the independent certificate and were rejected"
        ));
    }
    let s4 = dchecks.get(Family::S4.name()).cloned();
    if mode == Mode::Paper {
        notes.insert(
            0,
            "REPRODUCTION MODE: the paper's printed conditions (13), (14), (26); they do not imply convergence (docs/method.md). This design certifies nothing.".to_string(),
        );
        match &s4 {
            Some(d) if !d.passed => notes.push(format!(
                "violated assumption (15)/(S4): max_k γ² a_kᵀ Q a_k = {:.4} > 1 at γ = {}",
                d.value, gamma_r
            )),
            Some(_) => {}
            None => notes.push("(15)/(S4) not checked: the model has no state bound Q".into()),
        }
    } else if let Some(d) = &s4 {
        if !d.passed {
            notes.push(format!(
                "(S4) fails: max_k γ² a_kᵀ Q a_k = {:.4} > 1 at γ = {} (γ_max = {:.5})",
                d.value,
                gamma_r,
                gmax.unwrap_or(f64::NAN)
            ));
        }
    }
    if let Some(d) = dchecks.get(Family::RegionInF.name()) {
        if !d.passed {
            notes.push(format!(
                "region_in_F fails: max_i x_(i)ᵀ Q⁻¹ x_(i) = {:.4} > 1 (the region is not inside the state bound F)",
                d.value
            ));
        }
    }
    let failed: Vec<String> = shown
        .as_ref()
        .map(|p| {
            p.cert
                .families
                .iter()
                .filter(|f| !f.passed)
                .map(|f| format!("{} ({:.3e} at {})", f.name, f.margin, f.worst_at))
                .collect()
        })
        .unwrap_or_default();

    let (p_rows, g_rows, l_rows, norms) = match &shown {
        Some(pt) => (
            matrix_to_rows(&pt.p),
            pt.gammas.iter().map(matrix_to_rows).collect(),
            pt.l.iter().map(matrix_to_rows).collect(),
            pt.l.iter()
                .map(|l| l.clone().singular_values().max())
                .collect::<Vec<f64>>(),
        ),
        None => (Vec::new(), Vec::new(), Vec::new(), Vec::new()),
    };
    let certifies = feasible && mode == Mode::Sound;
    let summary = {
        let head = match (mode, feasible) {
            (Mode::Sound, true) => format!(
                "CERTIFIED (sound conditions S1-S5): V' ≤ −αV with α = {alpha_r:.6}, γ = {gamma_r:.6}; every e(0) in the region converges. max ‖L_l‖₂ = {:.4}.",
                norms.iter().copied().fold(0.0, f64::max)
            ),
            (Mode::Sound, false) => format!(
                "NOT CERTIFIED (sound conditions) at α = {alpha_r:.6}, γ = {gamma_r:.6}: solver {}{}.",
                final_status,
                if failed.is_empty() { String::new() } else { format!("; failed: {}", failed.join(", ")) }
            ),
            (Mode::Paper, true) => format!(
                "PAPER MODE (certifies nothing): the printed conditions (13), (14), (26) hold at α = {alpha_r:.6}, γ = {gamma_r:.6}; max ‖L_l‖₂ = {:.4}.",
                norms.iter().copied().fold(0.0, f64::max)
            ),
            (Mode::Paper, false) => format!(
                "PAPER MODE (certifies nothing): the printed conditions are not satisfied at α = {alpha_r:.6}, γ = {gamma_r:.6}: solver {}{}.",
                final_status,
                if failed.is_empty() { String::new() } else { format!("; failed: {}", failed.join(", ")) }
            ),
        };
        let mut s = head;
        for n in &notes {
            s.push(' ');
            s.push_str(n);
            if !n.ends_with('.') {
                s.push('.');
            }
        }
        s
    };

    Ok(Design {
        model: model.name.clone(),
        mode,
        split: request.split,
        conditions: request.conditions,
        feasible,
        certifies,
        alpha: alpha_r,
        gamma: gamma_r,
        p: p_rows,
        gamma_l: g_rows,
        l: l_rows,
        gain_norms: norms,
        margins,
        data_checks: dchecks,
        solver: final_solver,
        seconds_total: t_start.elapsed().as_secs_f64(),
        search: ctx.steps,
        notes,
        summary,
        state_bound: Some(bound_info),
        output_route: Some(route_info),
        skew: None,
        diagnosis,
        noise: None,
        sampling: None,
        cube: shown
            .as_ref()
            .and_then(|p| p.cube.as_ref())
            .map(CubeSlacks::to_report),
    })
}
