//! One attempt at a candidate (α, γ), the same for every objective: the
//! solve, the gains L_l = P⁻¹Γ_l, the independent certificate, what the
//! objective adds to a certified point (a max-margin point's lift to its
//! capacity, a noise-optimal point's certified σ), and the search step
//! recorded (docs/method.md, "The search").

use super::{Claims, Ctx};
use crate::backend::Status;
use crate::certificate::noise::{bound_from, sigma_for, NoiseBound};
use crate::certificate::noise_sampled::SampledNoise;
use crate::certificate::{
    alpha_capacity, alpha_capacity_cube, alpha_capacity_sampled, check, data_checks, Certificate,
    Gains,
};
use crate::conditions::cube::CubeSlacks;
use crate::error::SolveError;
use crate::linalg::gains;
use crate::lmi::noise::solve_noise_sdp;
use crate::lmi::{Objective, Problem, SolveResult};
use crate::model::noise::NoiseChannels;
use crate::report::{Design, Note, ReportedMatrices, SearchStep, SolverInfo};
use crate::settings::Settings;
use crate::vocab::{Candidate, Phase, Verdict};
use nalgebra::DMatrix;
use qpv_dsl::{DesignRequest, Mode, PolytopicModel};
use std::time::Instant;

/// A candidate observer: P, Γ_l, L_l and its certificate at (α, γ).
#[derive(Debug, Clone)]
pub(super) struct Point {
    pub alpha: f64,
    pub gamma: f64,
    pub p: DMatrix<f64>,
    /// Γ_l as the certificate sees them (P L_l).
    pub gammas: Vec<DMatrix<f64>>,
    pub l: Vec<DMatrix<f64>>,
    pub cert: Certificate,
    pub solver: SolverInfo,
    /// The slacks of cube conditions (checked with the point).
    pub cube: Option<CubeSlacks>,
    /// The certified noise bound of a noise-optimal point.
    pub noise: Option<NoiseBound>,
}

impl Point {
    /// The point's (α, γ).
    pub fn at(&self) -> Candidate {
        Candidate::new(self.alpha, self.gamma)
    }
}

/// The result of one attempt at (α, γ).
pub(super) struct Attempt {
    pub status: Status,
    /// The returned point (certified or not), if any.
    pub point: Option<Point>,
    /// Whether `point` passed the certificate at the tested α (and, for the
    /// noise objective, has a certified σ).
    pub certified: bool,
    /// The max-margin optimum t̂ (NaN for other objectives / no point).
    pub margin: f64,
    /// Solver statistics of this attempt.
    pub solver: SolverInfo,
}

/// What an attempt solves.
#[derive(Clone, Copy)]
pub(super) enum Solve<'s> {
    /// The design SDP with this objective (and the max-margin metric P_ref).
    Lmi(Objective, Option<&'s DMatrix<f64>>),
    /// The noise-optimal SDP on these channels (sound mode).
    Noise(&'s NoiseChannels),
}

impl SolverInfo {
    /// The statistics of a solve (certification time still 0).
    fn of(res: &SolveResult) -> SolverInfo {
        SolverInfo {
            status: res.status,
            detail: res.detail.clone(),
            iterations: res.iterations,
            seconds: res.solve_seconds,
            assembly_seconds: res.assembly_seconds,
            certify_seconds: 0.0,
        }
    }
}

impl<'a, 'm> Ctx<'a, 'm> {
    /// A search on `prob` with every rule at its default (no gain bound,
    /// no practical tolerance, continuous time, the settings' margin).
    pub(super) fn new(
        model: &'m PolytopicModel,
        mode: Mode,
        settings: &'a Settings,
        prob: Problem<'m>,
        progress: &'a mut dyn FnMut(&SearchStep),
    ) -> Self {
        Ctx {
            model,
            mode,
            settings,
            prob,
            steps: Vec::new(),
            progress,
            lean: false,
            max_gain: None,
            within: 0.0,
            walk_stopped: false,
            margin_rel: None,
            margin_cut: None,
            claims: Claims::default(),
            sample: None,
        }
    }
}

impl Ctx<'_, '_> {
    /// Whether a certificate counts: every family and, in sound mode, (S4).
    fn accepts(&self, cert: &Certificate) -> bool {
        cert.passed
    }

    /// The certificate of (P, L_l) at (α, γ): the full family, or the cube's
    /// slack inequalities when the point carries cube slacks.
    pub(super) fn certify(
        &self,
        at: Candidate,
        p: &DMatrix<f64>,
        l: &[DMatrix<f64>],
        cube: Option<&CubeSlacks>,
    ) -> Certificate {
        let gains = Gains::new(p, l).with_cube(cube);
        let at = at.at_sample(self.sample);
        check(self.model, &gains, &at, self.mode)
            .with_gain_bound(l, self.max_gain)
            .with_poles(self.model, &gains, &at, self.prob.poles())
    }

    /// The largest α at which the point's (P, Γ_l, L_l) certify at `gamma`
    /// (exact capacity, times 1 − 1e-4, re-certified); None if they do not
    /// certify at any α > 0 there.
    pub(super) fn lift(&self, base: &Point, gamma: f64) -> Option<Point> {
        let cap = match (&base.cube, self.sample) {
            (_, Some(h)) => alpha_capacity_sampled(self.model, gamma, h, &base.p, &base.gammas),
            (Some(c), None) => {
                alpha_capacity_cube(self.model, self.mode, gamma, &base.p, &base.gammas, c)
            }
            (None, None) => alpha_capacity(self.model, self.mode, gamma, &base.p, &base.gammas),
        };
        let a = cap * (1.0 - 1e-4);
        if !(a > 0.0 && a.is_finite()) {
            return None;
        }
        let a = a.min(self.settings.alpha_cap);
        let cert = self.certify(
            Candidate::new(a, gamma),
            &base.p,
            &base.l,
            base.cube.as_ref(),
        );
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
    pub(super) fn attempt_regularised(
        &mut self,
        cand: Candidate,
        phase: Phase,
    ) -> Result<Attempt, SolveError> {
        let gamma = cand.gamma;
        let mut at = self.attempt(cand, Solve::Lmi(Objective::Gains, None), phase)?;
        if at.certified {
            if let Some(up) = at.point.as_ref().and_then(|p| self.lift(p, gamma)) {
                if up.alpha > cand.alpha {
                    at.point = Some(up);
                }
            }
        }
        Ok(at)
    }

    /// The solve of `solve` at (α, γ), in the form every objective shares.
    fn solve(&self, cand: Candidate, solve: Solve<'_>) -> Result<SolveResult, SolveError> {
        let Candidate { alpha, gamma, .. } = cand;
        match solve {
            Solve::Lmi(objective, metric) => {
                let relaxed = self.margin_rel.map(|m| Settings {
                    margin_rel: m,
                    ..self.settings.clone()
                });
                let settings = relaxed.as_ref().unwrap_or(self.settings);
                self.prob
                    .solve_with_metric(alpha, gamma, settings, objective, metric)
            }
            Solve::Noise(channels) => {
                let res = solve_noise_sdp(&self.prob, channels, alpha, gamma, self.settings)?;
                let (p, gammas) = res.point.map_or((None, Vec::new()), |(p, g)| (Some(p), g));
                Ok(SolveResult {
                    status: res.status,
                    detail: res.detail,
                    iterations: res.iterations,
                    solve_seconds: res.solve_seconds,
                    assembly_seconds: res.assembly_seconds,
                    p,
                    gammas,
                    margin: f64::NAN,
                    cube: None,
                })
            }
        }
    }

    /// What the objective adds to a point that passed the certificate: a
    /// max-margin point is lifted to its capacity (its α may exceed the
    /// candidate's); a noise-optimal point gets its certified σ, without
    /// which it does not count. Returns whether the point counts.
    fn complete(&self, pt: &mut Point, solve: Solve<'_>) -> bool {
        match solve {
            Solve::Lmi(Objective::MaxMargin, _) => {
                if let Some(up) = self.lift(pt, pt.gamma).filter(|up| up.alpha > pt.alpha) {
                    *pt = up;
                }
                true
            }
            Solve::Lmi(..) => true,
            Solve::Noise(ch) => {
                let (m, a) = (self.model, pt.alpha);
                pt.noise = match self.sample {
                    // The discrete noise claim (docs/method.md §16).
                    Some(h) => SampledNoise {
                        model: m,
                        channels: ch,
                        alpha: a,
                        gamma: pt.gamma,
                        h,
                    }
                    .bound(&pt.p, &pt.l),
                    None => sigma_for(m, ch, a, pt.gamma, &pt.p, &pt.gammas)
                        .and_then(|(s, c)| bound_from(m, ch, a, &pt.p, s, c)),
                };
                pt.noise.is_some()
            }
        }
    }

    /// One solve at (α, γ), certified, completed as its objective asks
    /// ([`Ctx::complete`]), and recorded as a search step.
    pub(super) fn attempt(
        &mut self,
        cand: Candidate,
        solve: Solve<'_>,
        phase: Phase,
    ) -> Result<Attempt, SolveError> {
        let Candidate { alpha, gamma, .. } = cand;
        let t0 = Instant::now();
        let res = self.solve(cand, solve)?;
        let mut solver = SolverInfo::of(&res);
        let mut point = None;
        let mut certified = false;
        if let Some(p) = res.p.clone() {
            if let Some(l) = gains(&p, &res.gammas) {
                let tc = Instant::now();
                let cert = self.certify(Candidate::new(alpha, gamma), &p, &l, res.cube.as_ref());
                let passed = self.accepts(&cert);
                if res.status == Status::Solved {
                    self.claims.solved += 1;
                    self.claims.rejected += usize::from(!passed);
                }
                let mut pt = Point {
                    alpha,
                    gamma,
                    gammas: l.iter().map(|li| &p * li).collect(),
                    p,
                    l,
                    cert,
                    solver: solver.clone(),
                    cube: res.cube.clone(),
                    noise: None,
                };
                certified = passed && self.complete(&mut pt, solve);
                solver.certify_seconds = tc.elapsed().as_secs_f64();
                pt.solver.certify_seconds = solver.certify_seconds;
                point = Some(pt);
            }
        }
        let mut detail = res.detail.clone();
        if matches!(solve, Solve::Lmi(Objective::MaxMargin, _)) && res.margin.is_finite() {
            detail = format!("{detail} (max margin t = {:.3e})", res.margin);
        }
        let pt = point.as_ref().filter(|_| certified);
        if let Some(nb) = pt.and_then(|p| p.noise.as_ref()) {
            detail = format!("{detail} (σ = {:.6e})", nb.sigma);
        }
        let step = SearchStep {
            gamma,
            alpha,
            status: res.status,
            detail,
            certified,
            alpha_certified: pt.map_or(0.0, |p| p.alpha),
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
}

/// The point a design shows: the certified one (`feasible`), else the last
/// uncertified one for diagnosis, else none; at the reported (α, γ), with
/// the statistics of the solve that produced it.
pub(super) struct Shown<'p> {
    pub point: Option<&'p Point>,
    pub feasible: bool,
    pub at: Candidate,
    pub solver: SolverInfo,
}

/// The report around the point shown, the one place a [`Design`] is built
/// from a search's point ([`Design::claimed`] filled in): its matrices, margins, data checks (the model's
/// own at γ when there is no point), cube slacks and noise bound, the
/// request's mode, split, conditions, gain bound and sample period, and
/// every search step. Notes, summary, time and the figures of a
/// particular design (state bound, output route, γ search, practical,
/// diagnosis, sampling) are left empty for the caller.
pub(super) fn design_of(
    model: &PolytopicModel,
    request: &DesignRequest,
    shown: Shown<'_>,
    steps: Vec<SearchStep>,
) -> Design {
    let Shown {
        point,
        feasible,
        at,
        solver,
    } = shown;
    let mode = request.mode;
    let matrices = point
        .map(|pt| ReportedMatrices::of(&pt.p, &pt.gammas, &pt.l))
        .unwrap_or_default();
    let mut d = Design::claimed(
        &model.name,
        mode,
        at.alpha,
        at.gamma,
        matrices.p,
        matrices.l,
    );
    d.split = request.split;
    d.conditions = request.conditions;
    d.verdict = Verdict::of(feasible, mode);
    d.gamma_l = matrices.gamma_l;
    d.gain_norms = matrices.gain_norms;
    d.solver = solver;
    d.search = steps;
    d.max_gain = request.max_gain;
    d.poles = request.poles.clone();
    d.sample = request
        .sample
        .map(|h| crate::certificate::sampling::SampleInfo::new(h, at.alpha));
    d.time_unit = model.time_unit;
    let Some(pt) = point else {
        d.data_checks = data_checks(model, mode, at.gamma);
        return d;
    };
    d.margins = pt.cert.margins();
    d.data_checks = pt.cert.data_checks.clone();
    d.cube = pt.cube.as_ref().map(CubeSlacks::to_report);
    d.noise = pt.noise.clone().filter(|_| feasible);
    d
}

/// Appends every note to a summary, each as a sentence of its own.
pub(super) fn append_notes(summary: &mut String, notes: &[Note]) {
    for n in notes {
        let n = n.to_string();
        summary.push(' ');
        summary.push_str(&n);
        if !n.ends_with('.') {
            summary.push('.');
        }
    }
}
