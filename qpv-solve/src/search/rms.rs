//! The RMS-optimal design (`noise = rms`): the γ and margin searches of
//! the RMS SDP ([`crate::lmi::rms`]), each point certified by (S1)–(S5) and
//! its RMS bound recomputed from P and L_l ([`crate::certificate::rms`]).

use super::attempt::{design_of, Point, Shown};
use super::Ctx;
use crate::backend::Status;
use crate::certificate::alpha_capacity;
use crate::certificate::noise::{bound_from, sigma_for};
use crate::certificate::rms::{rms_bound, rms_check, RmsBound, RmsNoise};
use crate::conditions::{is_double_sum, ConditionSet};
use crate::error::SolveError;
use crate::linalg::gains;
use crate::lmi::rms::{solve_rms_sdp, RmsWeights};
use crate::lmi::Problem;
use crate::model::noise::NoiseChannels;
use crate::report::{Design, Notes, SearchStep, SolverInfo};
use crate::settings::Settings;
use crate::vocab::{Candidate, Phase};
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, PolytopicModel};
use std::time::Instant;

/// The margins m̂/κ of the first pass at each γ (κ the rate family's data
/// scale): the golden refinement then works between the best one's
/// neighbours.
const MARGIN_GRID: [f64; 5] = [1e-4, 1e-3, 1e-2, 1e-1, 0.5];
/// Golden-section steps of the margin refinement (in log m̂).
const MARGIN_REFINE: usize = 4;

/// The search of an RMS design: the attempts of a [`Ctx`], the noise, the
/// requested minimum rate (0: any certified rate) and the best point.
struct RmsSearch<'a, 'm> {
    ctx: Ctx<'a, 'm>,
    noise: RmsNoise,
    weights: RmsWeights,
    alpha: f64,
    best: Option<(Point, RmsBound)>,
    last: Option<Point>,
}

impl RmsSearch<'_, '_> {
    /// One solve at (γ, margin): certified at the requested α (or, without
    /// one, at the capacity of its gains), its RMS bound recomputed; the
    /// bound's total, or None when the point does not certify.
    fn at(&mut self, gamma: f64, margin: f64, phase: Phase) -> Result<Option<f64>, SolveError> {
        let t0 = Instant::now();
        let res = solve_rms_sdp(
            &self.ctx.prob,
            &self.weights,
            (self.alpha, gamma, margin),
            self.ctx.settings,
        )?;
        let solver = SolverInfo {
            status: res.status,
            detail: res.detail.clone(),
            iterations: res.iterations,
            seconds: res.solve_seconds,
            assembly_seconds: res.assembly_seconds,
            certify_seconds: 0.0,
        };
        let mut found = None;
        let mut alpha_cert = 0.0;
        if let Some((p, gs)) = res.point {
            if let Some(l) = gains(&p, &gs) {
                let gammas: Vec<_> = l.iter().map(|li| &p * li).collect();
                let alpha = match self.alpha {
                    a if a > 0.0 => a,
                    _ => {
                        alpha_capacity(self.ctx.model, Mode::Sound, gamma, &p, &gammas)
                            * (1.0 - 1e-4)
                    }
                };
                let cand = Candidate::new(alpha.min(self.ctx.settings.alpha_cap), gamma);
                let cert = self.ctx.certify(cand, &p, &l, None);
                let bound = rms_bound(self.ctx.model, &self.noise, gamma, &p, &l);
                let pt = Point {
                    alpha: cand.alpha,
                    gamma,
                    gammas,
                    p,
                    l,
                    cert,
                    solver: solver.clone(),
                    cube: None,
                    noise: None,
                };
                let ok = pt.cert.passed && cand.alpha > 0.0;
                match bound.filter(|_| ok) {
                    Some(b) => {
                        alpha_cert = pt.alpha;
                        found = Some(b.total);
                        let better = self.best.as_ref().map_or(true, |(_, o)| b.total < o.total);
                        if better {
                            self.best = Some((pt, b));
                        }
                    }
                    None => self.last = Some(pt),
                }
            }
        }
        let step = SearchStep {
            gamma,
            alpha: self.alpha,
            status: res.status,
            detail: match found {
                Some(t) => format!("{} (margin {margin:.3e}; RMS bound {t:.6e})", res.detail),
                None => format!("{} (margin {margin:.3e})", res.detail),
            },
            certified: found.is_some(),
            alpha_certified: alpha_cert,
            iterations: res.iterations,
            seconds: t0.elapsed().as_secs_f64(),
            solver_seconds: res.solve_seconds,
            phase,
        };
        (self.ctx.progress)(&step);
        self.ctx.steps.push(step);
        Ok(found)
    }

    /// The margin search at γ: the grid [`MARGIN_GRID`], then golden
    /// section in log m̂ around its best point; the best total found.
    fn at_gamma(&mut self, gamma: f64) -> Result<Option<f64>, SolveError> {
        let mut vals = Vec::new();
        for &m in &MARGIN_GRID {
            vals.push((m, self.at(gamma, m, Phase::Rms)?));
        }
        let best = vals
            .iter()
            .enumerate()
            .filter_map(|(k, (_, v))| v.map(|v| (k, v)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((k, v)) = best else {
            return Ok(None);
        };
        let lo = if k == 0 {
            MARGIN_GRID[0] * 0.1
        } else {
            MARGIN_GRID[k - 1]
        };
        let hi = if k + 1 == MARGIN_GRID.len() {
            1.0
        } else {
            MARGIN_GRID[k + 1]
        };
        let (mut a, mut b) = (lo.ln(), hi.ln());
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let mut best = v;
        let f = |s: &mut Self, x: f64| -> Result<f64, SolveError> {
            Ok(s.at(gamma, x.exp(), Phase::RmsRefine)?
                .unwrap_or(f64::INFINITY))
        };
        let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
        let (mut fc, mut fd) = (f(self, c)?, f(self, d)?);
        for _ in 2..MARGIN_REFINE {
            if fc < fd {
                b = d;
                d = c;
                fd = fc;
                c = b - g * (b - a);
                fc = f(self, c)?;
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + g * (b - a);
                fd = f(self, d)?;
            }
        }
        best = best.min(fc).min(fd);
        Ok(Some(best))
    }
}

/// The RMS-optimal design (`noise = rms`): minimise the certified bound on
/// the time-averaged mean-square error for the request's white noise
/// (`output_std`, `process_std`, `noise_period`) over the gains, at the
/// request's α (`alpha = max`: no minimum rate; the design reports the
/// largest α its gains certify) and fixed or searched γ. Certified only
/// when (S1)–(S5) pass and the RMS bound is recomputed from P and L_l.
///
/// Needs sound mode, a region (not the global observer), a constant output
/// map and the double-sum route; `conditions` is not used (the full family
/// is solved).
pub fn design_rms(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
) -> Result<Design, SolveError> {
    design_rms_with_progress(model, request, settings, &mut |_| {})
}

/// The noise of an RMS request on `model`, and the SDP's normalised weights.
fn rms_noise(
    model: &PolytopicModel,
    request: &DesignRequest,
) -> Result<(RmsNoise, RmsWeights, f64), SolveError> {
    let outs = NoiseChannels::from_model(model).noisy_outputs(model.ny());
    let period = request.noise_period.unwrap_or(f64::NAN);
    let noise = RmsNoise::new(
        outs,
        &request.output_std,
        &request.process_std,
        period,
        model.nx(),
    )
    .map_err(|e| SolveError::Dimensions(format!("noise = rms: {e}")))?;
    let scale = noise
        .output_std
        .iter()
        .chain(&noise.process_std)
        .map(|s| s * s * period)
        .fold(0.0, f64::max);
    let weights = RmsWeights {
        outs: noise
            .outputs
            .iter()
            .zip(&noise.output_std)
            .map(|(&o, &s)| (o, (s * s * period / scale).sqrt()))
            .collect(),
        q: noise
            .process_std
            .iter()
            .map(|s| s * s * period / scale)
            .collect(),
    };
    Ok((noise, weights, scale))
}

/// As [`design_rms`], calling `progress` after every solve.
pub(crate) fn design_rms_with_progress(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    let t_start = Instant::now();
    request.validate().map_err(SolveError::Clash)?;
    let alpha = match request.alpha {
        AlphaSpec::Fixed(a) if a.is_finite() && a > 0.0 => a,
        AlphaSpec::Fixed(a) => return Err(SolveError::BadAlpha(a)),
        AlphaSpec::Max => 0.0,
    };
    let full = DesignRequest {
        conditions: qpv_dsl::Conditions::Full,
        ..request.clone()
    };
    // The resolved request: a Jacobian box on the set S fixes γ there.
    let (resolved, setup, _) = super::setup::prepare(model, &full, settings, None)?;
    let refuse = |s: &str| Err(SolveError::Unsupported(format!("noise = rms {s}")));
    if setup.kind.is_global() {
        return refuse("needs a region (the plant is LPV: its observer is the global one, which has no RMS design yet)");
    }
    if setup.route_info.filter.is_some() {
        return refuse("is designed on the plant's own outputs: use output_route = double_sum");
    }
    let obs: &PolytopicModel = &setup.model;
    if is_double_sum(obs) {
        return refuse("needs an output map C, M_k that does not depend on θ (the double sum is not a convex combination of its blocks)");
    }
    let (noise, weights, _) = rms_noise(obs, request)?;
    let prob = Problem::new(obs, ConditionSet::Sound)?;
    let ctx = Ctx::new(obs, Mode::Sound, settings, prob, progress);
    let mut search = RmsSearch {
        ctx,
        noise,
        weights,
        alpha,
        best: None,
        last: None,
    };
    let gamma_hi = setup.gamma_hi;
    let grid: Vec<f64> = match resolved.gamma {
        GammaSpec::Fixed(g) if g > 0.0 && g < 1.0 => vec![g],
        GammaSpec::Fixed(g) => return Err(SolveError::BadGamma(g)),
        GammaSpec::Search => (1..=4).map(|k| gamma_hi * k as f64 / 4.0).collect(),
    };
    // From the largest γ down, while the best bound at each γ improves (a
    // search, not a proof of optimality in γ).
    let mut prev = f64::INFINITY;
    for &g in grid.iter().rev() {
        let here = search.at_gamma(g)?.unwrap_or(f64::INFINITY);
        if here > prev {
            break;
        }
        prev = prev.min(here);
    }
    let mut d = rms_report(search, request, grid[grid.len() - 1]);
    d.state_bound = Some(setup.bound_info.clone());
    d.output_route = Some(setup.route_info.clone());
    d.seconds_total = t_start.elapsed().as_secs_f64();
    Ok(d)
}

/// The report of an RMS search: the best certified point with its `rms`
/// key (and the "rms" data check of its claim), else the last uncertified
/// point for diagnosis.
fn rms_report(search: RmsSearch<'_, '_>, request: &DesignRequest, gamma_req: f64) -> Design {
    let RmsSearch {
        ctx,
        best,
        last,
        alpha,
        noise,
        ..
    } = search;
    let status = ctx.steps.last().map_or(Status::NotRun, |s| s.status);
    let obs = ctx.model;
    let feasible = best.is_some();
    let (shown, bound) = match best {
        Some((pt, b)) => (Some(pt), Some(b)),
        None => (last, None),
    };
    let solver = shown.as_ref().map_or(
        SolverInfo {
            status,
            ..SolverInfo::default()
        },
        |pt| pt.solver.clone(),
    );
    let solved = DesignRequest {
        conditions: qpv_dsl::Conditions::Full,
        ..request.clone()
    };
    let at = shown
        .as_ref()
        .map_or(Candidate::new(alpha, gamma_req), Point::at);
    let mut d = design_of(
        obs,
        &solved,
        Shown {
            point: shown.as_ref(),
            feasible,
            at,
            solver,
        },
        ctx.steps,
    );
    // The claim is recomputed from the matrices the report carries (what
    // `qpv check` reads), so that the report's bound is exactly its own.
    let (pr, lr) = (d.p_matrix(), d.l_matrices());
    let bound = bound.and_then(|b| rms_bound(obs, &b.noise, d.gamma, &pr, &lr));
    let feasible = feasible && bound.is_some();
    d.verdict = crate::vocab::Verdict::of(feasible, Mode::Sound);
    let mut notes = vec![rms_note(
        (request, obs.time_unit),
        &noise,
        alpha,
        bound.as_ref(),
    )];
    notes.push("conditions: the RMS SDP solves the full family of region-vertex pairs".to_string());
    if let Some(b) = &bound {
        let check = rms_check(obs, b, d.gamma, &pr, &lr);
        d.data_checks.insert("rms".to_string(), check);
    }
    d.rms = bound;
    let notes: Notes = notes.into();
    d.summary = super::verdict::Verdict {
        kind: crate::model::ObserverKind::Regional,
        mode: Mode::Sound,
        certified: feasible,
        alpha: d.alpha,
        gamma: d.gamma,
        sample: None,
        unit: obs.time_unit,
        status,
        failed: &[],
        max_gain: d.max_gain_norm(),
        noise: None,
    }
    .summary(&notes);
    d.notes = notes;
    if d.certifies() {
        let (p, l) = (d.p_matrix(), d.l_matrices());
        let gammas: Vec<_> = l.iter().map(|li| &p * li).collect();
        let ch = NoiseChannels::from_model(obs);
        d.noise = sigma_for(obs, &ch, d.alpha, d.gamma, &p, &gammas)
            .and_then(|(s, c)| bound_from(obs, &ch, d.alpha, &p, s, c));
        d.sampling = crate::certificate::sampling::sampling(obs, d.alpha, d.gamma, &p, &l);
    }
    d
}

/// The note of an RMS design: what was minimised, for which noise, and the
/// certified bound.
fn rms_note(
    (request, unit): (&DesignRequest, qpv_dsl::TimeUnit),
    noise: &RmsNoise,
    alpha: f64,
    bound: Option<&RmsBound>,
) -> String {
    let rate = if alpha > 0.0 {
        format!("at α ≥ {alpha}")
    } else {
        "at any certified α > 0 (the design reports the largest α its gains certify)".to_string()
    };
    let gamma = match request.gamma {
        GammaSpec::Search => ", γ searched (grid γ_max·k/4 from the top, while the bound improves)",
        GammaSpec::Fixed(_) => "",
    };
    let process = if noise.process_std.is_empty() {
        String::new()
    } else {
        format!(", process noise std {:?}", noise.process_std)
    };
    let what = match bound {
        Some(b) => format!(
            "; certified RMS error ≤ {:.4e} in total, per state {:?} (time-averaged, while x ∈ F and e stays in the region scaled by 1/γ)",
            b.total,
            b.per_state.iter().map(|v| format!("{v:.3e}")).collect::<Vec<_>>()
        ),
        None => "; no point certified".to_string(),
    };
    format!(
        "noise = rms: the certified bound on the time-averaged mean-square error minimised {rate}{gamma}, for white output noise of std {:?} on output(s) {:?}{process}, samples every {} {}{what}",
        noise.output_std, noise.outputs.iter().map(|o| o + 1).collect::<Vec<_>>(), noise.period, unit.symbol()
    )
}
