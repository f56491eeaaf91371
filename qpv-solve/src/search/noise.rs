//! The noise-optimal design (`noise = min`) and the rate–noise trade-off:
//! a γ search of noise-optimal SDPs at fixed α, and a sweep of α.

use crate::backend::Status;
use crate::certificate::noise::{bound_from, sigma_for, NoiseBound, NoiseCheck};
use crate::certificate::{check, Certificate, Gains};
use crate::conditions::ConditionSet;
use crate::error::SolveError;
use crate::lmi::noise::solve_noise_sdp;
use crate::lmi::Problem;
use crate::model::noise::NoiseChannels;
use crate::model::output_filter::OutputRouteInfo;
use crate::model::state_bound::StateBoundInfo;
use crate::model::{ObserverModel, ObserverOptions, StateBoundClaim};
use crate::report::{Design, ReportedMatrices, SearchStep, SolverInfo};
use crate::settings::Settings;
use crate::vocab::{BoundSource, Candidate, Phase};
use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, PolytopicModel, Split};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// L_l = P⁻¹ Γ_l (Cholesky of the symmetric part); None if P is not
/// positive definite.
fn gains_of(p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> Option<Vec<DMatrix<f64>>> {
    let ch = ((p + p.transpose()) * 0.5).cholesky()?;
    Some(gammas.iter().map(|g| ch.solve(g)).collect())
}

/// One certified noise-optimal point.
#[derive(Debug, Clone)]
struct NoisePoint {
    gamma: f64,
    p: DMatrix<f64>,
    gammas: Vec<DMatrix<f64>>,
    l: Vec<DMatrix<f64>>,
    cert: Certificate,
    bound: NoiseBound,
    solver: SolverInfo,
}

struct NoiseCtx<'a, 'm> {
    model: &'m PolytopicModel,
    channels: &'a NoiseChannels,
    alpha: f64,
    settings: &'a Settings,
    prob: Problem<'m>,
    steps: Vec<SearchStep>,
    progress: &'a mut dyn FnMut(&SearchStep),
    last_uncertified: Option<NoisePoint>,
    last_status: Status,
}

impl NoiseCtx<'_, '_> {
    /// Solves at γ and certifies (S1)–(S5) and the noise block LMI; the
    /// certified point, if any.
    fn at(&mut self, gamma: f64, phase: Phase) -> Result<Option<NoisePoint>, SolveError> {
        let t0 = Instant::now();
        let res = solve_noise_sdp(&self.prob, self.channels, self.alpha, gamma, self.settings)?;
        let mut solver = SolverInfo {
            status: res.status,
            detail: res.detail.clone(),
            iterations: res.iterations,
            seconds: res.solve_seconds,
            assembly_seconds: res.assembly_seconds,
            certify_seconds: 0.0,
        };
        self.last_status = res.status;
        let mut out = None;
        if let Some((p, gammas)) = res.point {
            let tc = Instant::now();
            if let Some(l) = gains_of(&p, &gammas) {
                let cert = check(
                    self.model,
                    &Gains::new(&p, &l),
                    &Candidate::new(self.alpha, gamma),
                    Mode::Sound,
                );
                let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| &p * li).collect();
                let bound = sigma_for(self.model, self.channels, self.alpha, gamma, &p, &gammas)
                    .and_then(|(s, c)| bound_from(self.model, self.channels, self.alpha, &p, s, c));
                solver.certify_seconds = tc.elapsed().as_secs_f64();
                match bound {
                    Some(bound) if cert.passed => {
                        out = Some(NoisePoint {
                            gamma,
                            p,
                            gammas,
                            l,
                            cert,
                            bound,
                            solver: solver.clone(),
                        })
                    }
                    _ => {
                        let bound = bound.unwrap_or(NoiseBound {
                            sigma: f64::NAN,
                            max_amplitude: f64::NAN,
                            error_bound: f64::NAN,
                            per_state: vec![],
                            noisy_outputs: vec![],
                            disturbances: 0,
                            check: NoiseCheck {
                                margin: -f64::MAX,
                                guard: 0.0,
                                passed: false,
                                worst_at: String::new(),
                                count: 0,
                            },
                        });
                        self.last_uncertified = Some(NoisePoint {
                            gamma,
                            p,
                            gammas,
                            l,
                            cert,
                            bound,
                            solver: solver.clone(),
                        });
                    }
                }
            }
        }
        let step = SearchStep {
            gamma,
            alpha: self.alpha,
            status: res.status,
            detail: match &out {
                Some(pt) => format!("{} (σ = {:.6e})", res.detail, pt.bound.sigma),
                None => res.detail.clone(),
            },
            certified: out.is_some(),
            alpha_certified: if out.is_some() { self.alpha } else { 0.0 },
            iterations: res.iterations,
            seconds: t0.elapsed().as_secs_f64(),
            solver_seconds: res.solve_seconds,
            phase,
        };
        (self.progress)(&step);
        self.steps.push(step);
        Ok(out)
    }

    /// γ with the smallest certified error bound per unit noise
    /// √(σ/(α λ_min(P))), each γ's point minimising σ: a grid γ_hi·k/4
    /// (k = 1..4), then golden-section refinement between the neighbours of
    /// the best grid point (`refine` evaluations). A search, not a proof of
    /// optimality in γ. Across γ the error bound is ranked, not σ: σ scales
    /// with P (V = eᵀPe), and a small γ allows a small P, hence a small σ,
    /// with a larger error (on the paper example σ falls from 590 at γ_max
    /// to 138 at γ ≈ 0.05 while ‖e(∞)‖/ν grows from 1.27 to 2.28).
    fn search(&mut self, gamma_hi: f64, refine: usize) -> Result<Option<NoisePoint>, SolveError> {
        let grid: Vec<f64> = (1..=4).map(|k| gamma_hi * k as f64 / 4.0).collect();
        let mut best: Option<NoisePoint> = None;
        let mut memo: Vec<(f64, f64)> = Vec::new();
        let keep = |best: &mut Option<NoisePoint>, pt: Option<NoisePoint>| -> f64 {
            match pt {
                Some(p) => {
                    let s = p.bound.error_bound;
                    if best.as_ref().map_or(true, |b| s < b.bound.error_bound) {
                        *best = Some(p);
                    }
                    s
                }
                None => f64::INFINITY,
            }
        };
        for &g in grid.iter().rev() {
            let pt = self.at(g, Phase::NoiseGrid)?;
            let s = keep(&mut best, pt);
            memo.push((g, s));
        }
        let Some(b) = best.as_ref() else {
            return Ok(None);
        };
        let kb = grid.iter().position(|&g| g == b.gamma).unwrap_or(0);
        let mut a = if kb == 0 {
            grid[0] * 0.25
        } else {
            grid[kb - 1]
        };
        let mut c = if kb + 1 < grid.len() {
            grid[kb + 1]
        } else {
            gamma_hi
        };
        let phi = (5f64.sqrt() - 1.0) / 2.0;
        if c > a && refine >= 2 {
            let mut x1 = c - phi * (c - a);
            let mut x2 = a + phi * (c - a);
            let pt = self.at(x1, Phase::NoiseRefine)?;
            let mut f1 = keep(&mut best, pt);
            let pt = self.at(x2, Phase::NoiseRefine)?;
            let mut f2 = keep(&mut best, pt);
            for _ in 2..refine {
                if f1 <= f2 {
                    c = x2;
                    x2 = x1;
                    f2 = f1;
                    x1 = c - phi * (c - a);
                    let pt = self.at(x1, Phase::NoiseRefine)?;
                    f1 = keep(&mut best, pt);
                } else {
                    a = x1;
                    x1 = x2;
                    f1 = f2;
                    x2 = a + phi * (c - a);
                    let pt = self.at(x2, Phase::NoiseRefine)?;
                    f2 = keep(&mut best, pt);
                }
            }
        }
        Ok(best)
    }
}

/// The noise-optimal design (`noise = min`): at the request's fixed α,
/// minimise the certified σ over (P, Γ_l, σ) subject to (S1)–(S4) and the
/// block LMI at every vertex pair — one SDP at a fixed γ; with γ = search,
/// the γ whose σ-minimal point has the smallest error bound per unit noise
/// is chosen (σ itself is not comparable across γ; [`NoiseCtx::search`]: a grid and a
/// golden-section refinement). The result is `feasible`/`certifies` only if
/// the independent certificate of (S1)–(S5) and [`check_noise`] at the
/// reported σ both pass; the report's `noise` key carries σ and its bounds.
///
/// Needs sound mode, a fixed α (α = max is the fastest design, not a noise
/// trade-off) and a split other than `skew_slack`. `conditions = decoupled`
/// is accepted; the noise SDP always uses the full family.
pub fn design_noise(
    model: &PolytopicModel,
    request: &DesignRequest,
    channels: &NoiseChannels,
    settings: &Settings,
) -> Result<Design, SolveError> {
    design_noise_with_progress(model, request, channels, settings, &mut |_| {})
}

/// The fixed α of a `noise = min` request, after checking that the request
/// is one the noise SDP can answer (sound mode, no skew slack, fixed α, γ in
/// (0, 1) if fixed).
fn noise_request_alpha(request: &DesignRequest) -> Result<f64, SolveError> {
    // The combinations `noise = min` refuses are the language's
    // (DesignRequest::validate); the request asks for σ either way.
    let request = &DesignRequest {
        noise: qpv_dsl::NoiseObjective::Min,
        ..request.clone()
    };
    request
        .validate()
        .map_err(|c| SolveError::Unsupported(c.to_string()))?;
    let alpha = match request.alpha {
        AlphaSpec::Fixed(a) if a.is_finite() && a > 0.0 => a,
        AlphaSpec::Fixed(a) => return Err(SolveError::BadAlpha(a)),
        AlphaSpec::Max => {
            return Err(SolveError::Unsupported(
                qpv_dsl::Clash::NoiseMinAlphaMax.to_string(),
            ))
        }
    };
    if let GammaSpec::Fixed(g) = request.gamma {
        if !(g.is_finite() && g > 0.0 && g < 1.0) {
            return Err(SolveError::BadGamma(g));
        }
    }
    Ok(alpha)
}

/// The notes of a `noise = min` report: what was minimised, on which
/// channels, and what of the request the noise SDP does not use.
fn noise_notes(
    request: &DesignRequest,
    alpha: f64,
    declared: &NoiseChannels,
    ch: &NoiseChannels,
    obs: &PolytopicModel,
    route_info: &OutputRouteInfo,
    bound_info: &StateBoundInfo,
) -> Vec<String> {
    let mut notes = vec![format!(
        "noise = min: σ of V' + αV ≤ σ(|w|² + |v|²) minimised at α = {alpha}{}; noise on {}{}",
        match request.gamma {
            GammaSpec::Fixed(_) => String::new(),
            GammaSpec::Search => ", γ searched for the smallest error bound √(σ/(α λ_min(P))) (grid and golden section)".to_string(),
        },
        if ch.noisy_outputs(obs.ny()).is_empty() && route_info.filter.is_some() {
            "the outputs, through the output filter".to_string()
        } else {
            format!("{} output(s)", ch.noisy_outputs(obs.ny()).len())
        },
        if declared.n_w() > 0 {
            format!(", {} disturbance input(s)", declared.n_w())
        } else {
            String::new()
        }
    )];
    if matches!(
        request.conditions,
        qpv_dsl::Conditions::Decoupled | qpv_dsl::Conditions::Cube
    ) {
        notes.push(format!("conditions = {} is not used by noise = min: its SDP solves the full family of vertex pairs", request.conditions.name()));
    }
    if bound_info.source == BoundSource::Auto {
        notes.push(format!(
            "state bound computed (state_bound auto): h = {:.6}, γ_max = {:.6}",
            bound_info.h.unwrap_or(f64::NAN),
            bound_info.gamma_max.unwrap_or(f64::NAN)
        ));
    }
    notes
}

/// The report of a `noise = min` design: the certified point (`feasible`),
/// else the last uncertified one for diagnosis, else the data checks only.
fn noise_report(
    ctx: &mut NoiseCtx<'_, '_>,
    split: Split,
    gamma_req: f64,
    best: Option<NoisePoint>,
    notes: Vec<String>,
) -> Design {
    let (obs, alpha, status) = (ctx.model, ctx.alpha, ctx.last_status);
    let feasible = best.is_some();
    let shown = best.or(ctx.last_uncertified.take());
    let shown_matrices = shown
        .as_ref()
        .map(|pt| ReportedMatrices::of(&pt.p, &pt.gammas, &pt.l))
        .unwrap_or_default();
    let (margins, dchecks, solver, gamma_r, noise) = match &shown {
        Some(pt) => (
            pt.cert.margins(),
            pt.cert.data_checks.clone(),
            pt.solver.clone(),
            pt.gamma,
            feasible.then(|| pt.bound.clone()),
        ),
        None => (
            Default::default(),
            crate::certificate::data_checks(obs, Mode::Sound, gamma_req),
            SolverInfo {
                status,
                ..SolverInfo::default()
            },
            gamma_req,
            None,
        ),
    };
    let max_gain = shown_matrices
        .gain_norms
        .iter()
        .copied()
        .fold(0.0, f64::max);
    let summary = match &noise {
        Some(nb) => format!(
            "CERTIFIED (sound conditions S1-S5 and the noise block LMI): V' + αV ≤ σ(|w|² + |v|²) with α = {alpha:.6}, γ = {gamma_r:.6}, σ = {:.6e}; E stays invariant for noise amplitude up to ν_max = {:.4e}; ‖e(∞)‖ ≤ {:.4}·ν. max ‖L_l‖₂ = {max_gain:.4}.",
            nb.sigma, nb.max_amplitude, nb.error_bound
        ),
        None => format!(
            "NOT CERTIFIED (noise = min) at α = {alpha:.6}, γ = {gamma_r:.6}: solver {status}."
        ),
    };
    let mut summary = summary;
    for n in &notes {
        summary.push(' ');
        summary.push_str(n);
        if !n.ends_with('.') {
            summary.push('.');
        }
    }
    let mut d = Design {
        model: obs.name.clone(),
        mode: Mode::Sound,
        split,
        conditions: qpv_dsl::Conditions::Full,
        cube: None,
        feasible,
        certifies: feasible,
        alpha,
        gamma: gamma_r,
        p: shown_matrices.p,
        gamma_l: shown_matrices.gamma_l,
        l: shown_matrices.l,
        gain_norms: shown_matrices.gain_norms,
        margins,
        data_checks: dchecks,
        solver,
        seconds_total: 0.0,
        search: std::mem::take(&mut ctx.steps),
        notes: notes.into(),
        summary,
        state_bound: None,
        output_route: None,
        skew: None,
        diagnosis: None,
        noise,
        max_gain: None,
        practical: None,
        sampling: None,
        sample: None,
        gamma_search: None,
        global: false,
    };
    if d.certifies {
        let (p, l) = (d.p_matrix(), d.l_matrices());
        d.sampling = crate::certificate::sampling::sampling(obs, alpha, d.gamma, &p, &l);
    }
    d
}

/// As [`design_noise`], calling `progress` after every solve.
pub fn design_noise_with_progress(
    model: &PolytopicModel,
    request: &DesignRequest,
    channels: &NoiseChannels,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    let t_start = Instant::now();
    if crate::model::is_global(model, request.mode) {
        return Err(SolveError::Unsupported(format!(
            "model `{}`: noise = min is not built for an LPV plant, whose observer is the global one (docs/method.md §17); design with a fixed α or alpha = max",
            model.name
        )));
    }
    let alpha = noise_request_alpha(request)?;
    let prepared = ObserverModel::prepare(
        model,
        &ObserverOptions::for_request(request),
        StateBoundClaim::Compute(settings),
    )?;
    let (bound_info, route_info) = (prepared.state_bound, prepared.output_route);
    let obs: &PolytopicModel = &prepared.model;
    channels.validate(model)?;
    let ch = match &route_info.filter {
        Some(f) => channels.through_filter(model.nx(), model.ny(), model.nv(), f.gain),
        None => channels.clone(),
    };
    ch.validate(obs)?;
    let gmax = crate::conditions::gamma_max(obs)
        .ok_or_else(|| SolveError::MissingStateBound(obs.name.clone()))?;
    if !(gmax.is_finite() && gmax > 0.0) && matches!(request.gamma, GammaSpec::Search) {
        return Err(SolveError::NoGammaRange(gmax));
    }
    let gamma_hi = gmax.min(1.0) * (1.0 - 1e-6);
    let prob = Problem::new(obs, ConditionSet::Sound)?;
    let mut ctx = NoiseCtx {
        model: obs,
        channels: &ch,
        alpha,
        settings,
        prob,
        steps: Vec::new(),
        progress,
        last_uncertified: None,
        last_status: Status::NotRun,
    };
    let best = match request.gamma {
        GammaSpec::Fixed(g) => ctx.at(g, Phase::Noise)?,
        GammaSpec::Search => ctx.search(gamma_hi, settings.gamma_refine.max(2))?,
    };
    let gamma_req = match request.gamma {
        GammaSpec::Fixed(g) => g,
        GammaSpec::Search => gamma_hi,
    };
    let notes = noise_notes(request, alpha, channels, &ch, obs, &route_info, &bound_info);
    let mut d = noise_report(&mut ctx, request.split, gamma_req, best, notes);
    d.state_bound = Some(bound_info);
    d.output_route = Some(route_info);
    d.seconds_total = t_start.elapsed().as_secs_f64();
    Ok(d)
}

/// One point of the rate–noise trade-off.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TradeoffPoint {
    /// Decay rate α.
    pub alpha: f64,
    /// γ of the design.
    pub gamma: f64,
    /// Whether the noise-optimal design at this α certified.
    pub certified: bool,
    /// Certified σ (None if not certified).
    pub sigma: Option<f64>,
    /// ‖e(∞)‖ per unit noise amplitude (None if not certified).
    pub error_bound: Option<f64>,
    /// ν_max = √(α/σ) (None if not certified).
    pub max_amplitude: Option<f64>,
    /// max_l ‖L_l‖₂ (None if not certified).
    pub max_gain: Option<f64>,
    /// The certified Euler step of the point's design
    /// ([`crate::certificate::sampling::Sampling::max_step_euler`]; None if not
    /// certified or not computed).
    #[serde(default)]
    pub max_step_euler: Option<f64>,
    /// Wall time of this point's design, seconds.
    pub seconds: f64,
}

/// The rate–noise trade-off: one noise-optimal design per α.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tradeoff {
    /// The points, in the order of the α given.
    pub points: Vec<TradeoffPoint>,
    /// Index into `points` of the knee: the largest certified α whose error
    /// bound is within twice the smallest certified error bound of the
    /// sweep (beyond it, speed costs more than a factor 2 in noise
    /// amplification). None if no point certified.
    pub knee: Option<usize>,
}

/// Sweeps α (`alphas`) with `noise = min` designs at the γ of
/// `request_base` (fixed or searched), returning each point's σ, error
/// bound per unit noise and largest gain, and the knee (see
/// [`Tradeoff::knee`]). Points that do not certify are kept, marked.
pub fn tradeoff(
    model: &PolytopicModel,
    request_base: &DesignRequest,
    channels: &NoiseChannels,
    alphas: &[f64],
    settings: &Settings,
) -> Result<Tradeoff, SolveError> {
    let mut points = Vec::with_capacity(alphas.len());
    for &a in alphas {
        let req = DesignRequest {
            alpha: AlphaSpec::Fixed(a),
            ..request_base.clone()
        };
        let d = design_noise(model, &req, channels, settings)?;
        let nb = d.noise.as_ref().filter(|_| d.certifies);
        points.push(TradeoffPoint {
            alpha: a,
            gamma: d.gamma,
            certified: nb.is_some(),
            sigma: nb.map(|n| n.sigma),
            error_bound: nb.map(|n| n.error_bound),
            max_amplitude: nb.map(|n| n.max_amplitude),
            max_gain: nb.map(|_| d.gain_norms.iter().copied().fold(0.0, f64::max)),
            max_step_euler: d
                .sampling
                .as_ref()
                .filter(|_| nb.is_some())
                .map(|sp| sp.max_step_euler),
            seconds: d.seconds_total,
        });
    }
    let knee = knee_of(&points);
    Ok(Tradeoff { points, knee })
}

/// The knee of a sweep (see [`Tradeoff::knee`]).
pub fn knee_of(points: &[TradeoffPoint]) -> Option<usize> {
    let min = points
        .iter()
        .filter_map(|p| p.error_bound)
        .fold(f64::INFINITY, f64::min);
    if !min.is_finite() {
        return None;
    }
    points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.error_bound.is_some_and(|e| e <= 2.0 * min))
        .max_by(|a, b| a.1.alpha.total_cmp(&b.1.alpha))
        .map(|(k, _)| k)
}

/// α values for a sweep up to `alpha_max`: `n` points from 5 % to 99 % of
/// it, denser near the top (fractions 1 − (1 − f)² of an even grid).
pub fn default_alphas(alpha_max: f64, n: usize) -> Vec<f64> {
    let n = n.max(2);
    (0..n)
        .map(|k| {
            let f = k as f64 / (n - 1) as f64;
            let g = 1.0 - (1.0 - f) * (1.0 - f);
            alpha_max * (0.05 + (0.99 - 0.05) * g)
        })
        .collect()
}
