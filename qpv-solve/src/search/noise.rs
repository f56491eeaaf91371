//! The noise-optimal design (`noise = min`) and the rate–noise trade-off:
//! a γ search of noise-optimal SDPs at fixed α, and a sweep of α.

use super::attempt::{design_of, Point, Shown, Solve};
use super::Ctx;
use crate::backend::Status;
use crate::conditions::ConditionSet;
use crate::error::SolveError;
use crate::line_search::{Line, Scale, Stage};
use crate::lmi::Problem;
use crate::model::noise::NoiseChannels;
use crate::model::output_filter::OutputRouteInfo;
use crate::model::state_bound::StateBoundInfo;
use crate::model::ObserverKind;
use crate::report::{Design, Note, Notes, SearchStep, SolverInfo};
use crate::settings::Settings;
use crate::vocab::{BoundSource, Candidate, Phase};
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, PolytopicModel};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The noise-optimal search at a fixed α: the attempts of a [`Ctx`] on
/// the noise SDP, and the last point that did not certify (shown, for
/// diagnosis, when none does).
struct NoiseSearch<'a, 'm> {
    ctx: Ctx<'a, 'm>,
    channels: &'a NoiseChannels,
    alpha: f64,
    last_uncertified: Option<Point>,
}

impl NoiseSearch<'_, '_> {
    /// Solves the noise SDP at γ and certifies (S1)–(S5) and the noise
    /// block LMI; the certified point, if any.
    fn at(&mut self, gamma: f64, phase: Phase) -> Result<Option<Point>, SolveError> {
        let cand = Candidate::new(self.alpha, gamma);
        let at = self.ctx.attempt(cand, Solve::Noise(self.channels), phase)?;
        if at.certified {
            return Ok(at.point);
        }
        if at.point.is_some() {
            self.last_uncertified = at.point;
        }
        Ok(None)
    }

    /// γ with the smallest certified error bound per unit noise
    /// √(σ/(α λ_min(P))), each γ's point minimising σ: a grid γ_hi·k/4
    /// (k = 1..4), then golden-section refinement in γ between the
    /// neighbours of the best grid point (`refine` evaluations; below the
    /// lowest, γ_hi/16), by [`Line::minimise`]. A search, not a proof of
    /// optimality in γ. Across γ the error bound is ranked, not σ: σ scales
    /// with P (V = eᵀPe), and a small γ allows a small P, hence a small σ,
    /// with a larger error (on the paper example σ falls from 590 at γ_max
    /// to 138 at γ ≈ 0.05 while ‖e(∞)‖/ν grows from 1.27 to 2.28).
    fn search(&mut self, gamma_hi: f64, refine: usize) -> Result<Option<Point>, SolveError> {
        let grid: Vec<f64> = (1..=4).map(|k| gamma_hi * k as f64 / 4.0).collect();
        let line = Line {
            scale: Scale::Linear,
            descending: true,
            refine,
            below: Some(grid[0] * 0.25),
            probe_first: true,
            ..Line::default()
        };
        let mut best: Option<Point> = None;
        let mut bound_at = |g: f64, stage: Stage| -> Result<Option<f64>, SolveError> {
            let phase = match stage {
                Stage::Grid => Phase::NoiseGrid,
                Stage::Refine | Stage::Walk => Phase::NoiseRefine,
            };
            let Some(pt) = self.at(g, phase)? else {
                return Ok(None);
            };
            let e = error_bound(&pt);
            if best.as_ref().map_or(true, |b| e < error_bound(b)) {
                best = Some(pt);
            }
            Ok(Some(e))
        };
        line.minimise(&grid, &mut bound_at, &|| false)?;
        Ok(best)
    }
}

/// The certified error bound per unit noise of a noise-optimal point.
fn error_bound(pt: &Point) -> f64 {
    pt.noise.as_ref().map_or(f64::INFINITY, |nb| nb.error_bound)
}

/// The noise-optimal design (`noise = min`): at the request's fixed α,
/// minimise the certified σ over (P, Γ_l, σ) subject to (S1)–(S4) and the
/// block LMI at every vertex pair — one SDP at a fixed γ; with γ = search,
/// the γ whose σ-minimal point has the smallest error bound per unit noise
/// is chosen (σ itself is not comparable across γ; a grid and a
/// golden-section refinement, [`crate::line_search`]). The result is
/// `feasible`/`certifies` only if the independent certificate of (S1)–(S5)
/// and [`crate::certificate::noise::check_noise`] at the reported σ both pass; the report's `noise` key carries σ and its bounds.
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
    request.validate().map_err(SolveError::Clash)?;
    let alpha = match request.alpha {
        AlphaSpec::Fixed(a) if a.is_finite() && a > 0.0 => a,
        AlphaSpec::Fixed(a) => return Err(SolveError::BadAlpha(a)),
        AlphaSpec::Max => return Err(SolveError::Clash(qpv_dsl::Clash::NoiseMinAlphaMax)),
    };
    if let GammaSpec::Fixed(g) = request.gamma {
        if !(g.is_finite() && g > 0.0 && g < 1.0) {
            return Err(SolveError::BadGamma(g));
        }
    }
    Ok(alpha)
}

/// The note of an LPV plant's noise design: the global observer's blocks
/// (no region terms, γ = 1), the claim for every e and every amplitude,
/// and what of the model and the request it does not use.
fn global_noise_note(model: &PolytopicModel, request: &DesignRequest) -> String {
    let mut s = "the plant is LPV (every N_k and M_k is zero): the global observer's noise design, P ⪰ cI (the blocks are homogeneous: min σ is the smallest error bound per unit noise) and the noise block LMI without region terms at every rate combination; the claim holds for every e(0) and every noise amplitude (docs/method.md §17)".to_string();
    if model.has_region() {
        s.push_str("; the model's region is not used");
    }
    if !matches!(model.state_bound, qpv_dsl::StateBound::None) {
        s.push_str("; its state bound is not used");
    }
    if let GammaSpec::Fixed(g) = request.gamma {
        s.push_str(&format!("; γ = {g} is not used"));
    }
    s
}

/// The notes of a `noise = min` report: what was minimised, on which
/// channels, and what of the request the noise SDP does not use.
fn noise_notes(
    request: &DesignRequest,
    (kind, alpha): (ObserverKind, f64),
    declared: &NoiseChannels,
    ch: &NoiseChannels,
    obs: &PolytopicModel,
    route_info: &OutputRouteInfo,
    bound_info: &StateBoundInfo,
) -> Vec<String> {
    let claim = match request.sample {
        Some(_) => "V(e_k+1) − (1 − hα)V(e_k) ≤ hσ(|w_k|² + |v_k|²) (noise held over each step, docs/method.md §16)",
        None => "V' + αV ≤ σ(|w|² + |v|²)",
    };
    let mut notes = vec![format!(
        "noise = min: σ of {claim} minimised at α = {alpha}{}; noise on {}{}",
        match request.gamma {
            _ if kind.is_global() => String::new(),
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
/// else the last uncertified one for diagnosis, else the data checks only
/// ([`design_of`] builds it; the full family is what the noise SDP solves).
fn noise_report(
    search: NoiseSearch<'_, '_>,
    request: &DesignRequest,
    (kind, gamma_req): (ObserverKind, f64),
    best: Option<Point>,
    notes: Vec<String>,
) -> Design {
    let NoiseSearch {
        ctx,
        alpha,
        last_uncertified,
        ..
    } = search;
    let status = ctx.steps.last().map_or(Status::NotRun, |s| s.status);
    let obs = ctx.model;
    let feasible = best.is_some();
    let shown = best.or(last_uncertified);
    let solver = match &shown {
        Some(pt) => pt.solver.clone(),
        None => SolverInfo {
            status,
            ..SolverInfo::default()
        },
    };
    let solved = DesignRequest {
        conditions: qpv_dsl::Conditions::Full,
        max_gain: None,
        ..request.clone()
    };
    let at = Candidate::new(alpha, shown.as_ref().map_or(gamma_req, |pt| pt.gamma));
    let shown = Shown {
        point: shown.as_ref(),
        feasible,
        at,
        solver,
    };
    let mut d = design_of(obs, &solved, shown, ctx.steps);
    let notes: Notes = notes.into();
    d.global = kind.is_global();
    d.summary = super::verdict::Verdict {
        kind,
        mode: Mode::Sound,
        certified: d.noise.is_some(),
        alpha,
        gamma: d.gamma,
        sample: request.sample,
        unit: obs.time_unit,
        status,
        failed: &[],
        max_gain: d.max_gain_norm(),
        noise: Some(d.noise.as_ref()),
    }
    .summary(&notes);
    d.notes = notes;
    // (A sampled design's continuous-plant bound is attached by the caller,
    // on the plant: the observer's model of a global design has no state
    // bound, the plant's declared one is its operating envelope.)
    if d.certifies() && d.sample.is_none() {
        let (p, l) = (d.p_matrix(), d.l_matrices());
        d.sampling = crate::certificate::sampling::sampling(obs, alpha, d.gamma, &p, &l);
    }
    d
}

/// As [`design_noise`], calling `progress` after every solve.
pub(crate) fn design_noise_with_progress(
    model: &PolytopicModel,
    request: &DesignRequest,
    channels: &NoiseChannels,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    let t_start = Instant::now();
    let alpha = noise_request_alpha(request)?;
    // The one setup of every design ([`super::setup::prepare`]) on the full
    // vertex family the noise blocks are solved on, whatever the request's
    // conditions: the size guard, the observer's kind and model, the α, γ
    // and hα < 1 checks, the γ range; for an LPV plant the global observer's request (γ = 1, unused)
    // and its balanced units (pilot solves at α).
    let full = DesignRequest {
        conditions: qpv_dsl::Conditions::Full,
        ..request.clone()
    };
    let (resolved, setup, setup_notes) = super::setup::prepare(model, &full, settings, None)?;
    let kind = setup.kind;
    let global = kind.is_global();
    let obs: &PolytopicModel = &setup.model;
    let (bound_info, route_info) = (&setup.bound_info, &setup.route_info);
    channels.validate(model)?;
    let ch = match &route_info.filter {
        Some(f) => channels.through_filter(model.nx(), model.ny(), model.nv(), f.gain),
        None => channels.clone(),
    };
    ch.validate(obs)?;
    let gamma_hi = setup.gamma_hi;
    // The regional noise SDP is solved in the model's own units.
    let prob = match kind {
        ObserverKind::Global => setup.problem(&resolved)?,
        ObserverKind::Regional => {
            Problem::new(obs, ConditionSet::Sound)?.with_sample(request.sample)?
        }
    };
    let mut ctx = Ctx::new(obs, Mode::Sound, settings, prob, progress);
    ctx.sample = request.sample;
    let mut search = NoiseSearch {
        ctx,
        channels: &ch,
        alpha,
        last_uncertified: None,
    };
    let mut own_units = false;
    let (best, gamma_req) = match request.gamma {
        _ if global => {
            let mut best = search.at(1.0, Phase::Noise)?;
            if best.is_none() && search.ctx.prob.scaling().is_some() {
                // The units balanced by the rate pilots need not suit the
                // noise design: once more in the model's own.
                search.ctx.prob =
                    Problem::new(obs, ConditionSet::Sound)?.with_sample(request.sample)?;
                best = search.at(1.0, Phase::Noise)?;
                own_units = true;
            }
            (best, 1.0)
        }
        GammaSpec::Fixed(g) => (search.at(g, Phase::Noise)?, g),
        GammaSpec::Search => {
            let refine = settings.gamma_refine.max(2);
            (search.search(gamma_hi, refine)?, gamma_hi)
        }
    };
    let mut notes = noise_notes(
        request,
        (kind, alpha),
        channels,
        &ch,
        obs,
        route_info,
        bound_info,
    );
    if !global {
        notes.extend(setup.size_note.clone());
    } else {
        notes.insert(0, global_noise_note(model, request));
        // The balanced units, if any (the global request's own note is
        // replaced by the noise design's).
        let units = setup_notes
            .iter()
            .filter(|n| matches!(n, Note::BalancedUnits { .. }))
            .map(Note::to_string);
        match own_units {
            false => notes.extend(units),
            true => notes.push("the noise design in balanced units did not certify; solved again in the model's own units".into()),
        }
    }
    let mut d = noise_report(search, request, (kind, gamma_req), best, notes);
    d.state_bound = Some(bound_info.clone());
    d.output_route = Some(route_info.clone());
    if d.certifies() && d.sample.is_some() {
        crate::report::continuous::attach(model, &mut d);
    }
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

/// The sweep extends below its lowest α while that point's gain is more
/// than this factor below the next one's (the gain still falls steeply as
/// α falls) ...
const GAIN_FALL: f64 = 2.0;
/// ... by at most this many points (each a fifth of the previous α).
const EXTEND: usize = 3;

/// The α values of a trade-off sweep, and whether it extends below them
/// where the gain is still falling steeply.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    /// The α values, ascending.
    pub alphas: Vec<f64>,
    /// The certified supremum the range is measured against: the sweep
    /// never extends below 10⁻⁴ of it.
    pub top: f64,
    /// At most this many points below `alphas[0]`, each a fifth of the
    /// previous α, added while the lowest point's largest gain is below
    /// the next one's by more than a factor 2 (0: no extension).
    pub extend_below: usize,
}

impl Sweep {
    /// Exactly the α values given, no extension.
    pub fn fixed(alphas: &[f64]) -> Self {
        Sweep {
            alphas: alphas.to_vec(),
            top: alphas.iter().copied().fold(0.0, f64::max),
            extend_below: 0,
        }
    }

    /// `qpv tradeoff`'s sweep under the certified supremum `alpha_sup`:
    /// `n` points of [`default_alphas`], extended below 5 % of it (at most
    /// three points) while the gain still falls steeply.
    pub fn under(alpha_sup: f64, n: usize) -> Self {
        Sweep {
            alphas: default_alphas(alpha_sup, n),
            top: alpha_sup,
            extend_below: EXTEND,
        }
    }
}

/// Where a trade-off sweep is, for a progress display: called before each
/// point's design.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SweepStep {
    /// Point `index` (0-based) of the `of` given α values.
    Point {
        /// Which point.
        index: usize,
        /// How many α values were given.
        of: usize,
        /// Its α.
        alpha: f64,
    },
    /// A point below the given range ([`Sweep::extend_below`]).
    Below {
        /// Its α.
        alpha: f64,
    },
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
    let sweep = Sweep::fixed(alphas);
    tradeoff_with_progress(model, request_base, channels, &sweep, settings, &mut |_| {})
}

/// As [`tradeoff`] over a [`Sweep`] (extended below its range where it
/// says so; the extension keeps only certified points, first in the
/// result), calling `progress` before every point's design.
pub fn tradeoff_with_progress(
    model: &PolytopicModel,
    request_base: &DesignRequest,
    channels: &NoiseChannels,
    sweep: &Sweep,
    settings: &Settings,
    progress: &mut dyn FnMut(&SweepStep),
) -> Result<Tradeoff, SolveError> {
    let point = |a: f64| tradeoff_point(model, request_base, channels, a, settings);
    let mut points = Vec::with_capacity(sweep.alphas.len() + sweep.extend_below);
    for (index, &alpha) in sweep.alphas.iter().enumerate() {
        let of = sweep.alphas.len();
        progress(&SweepStep::Point { index, of, alpha });
        points.push(point(alpha)?);
    }
    for _ in 0..sweep.extend_below {
        let (Some(g0), Some(g1)) = (points[0].max_gain, points.get(1).and_then(|p| p.max_gain))
        else {
            break;
        };
        if g0 > g1 / GAIN_FALL || points[0].alpha < sweep.top * 1e-4 {
            break;
        }
        let alpha = points[0].alpha / 5.0;
        progress(&SweepStep::Below { alpha });
        let p = point(alpha)?;
        if !p.certified {
            break;
        }
        points.insert(0, p);
    }
    let knee = knee_of(&points);
    Ok(Tradeoff { points, knee })
}

/// The noise-optimal design at `alpha` as a point of the trade-off.
fn tradeoff_point(
    model: &PolytopicModel,
    request_base: &DesignRequest,
    channels: &NoiseChannels,
    alpha: f64,
    settings: &Settings,
) -> Result<TradeoffPoint, SolveError> {
    let req = DesignRequest {
        alpha: AlphaSpec::Fixed(alpha),
        ..request_base.clone()
    };
    let d = design_noise(model, &req, channels, settings)?;
    let nb = d.noise.as_ref().filter(|_| d.certifies());
    Ok(TradeoffPoint {
        alpha,
        gamma: d.gamma,
        certified: nb.is_some(),
        sigma: nb.map(|n| n.sigma),
        error_bound: nb.map(|n| n.error_bound),
        max_amplitude: nb.map(|n| n.max_amplitude),
        max_gain: nb.map(|_| d.max_gain_norm()),
        max_step_euler: d
            .sampling
            .as_ref()
            .filter(|_| nb.is_some())
            .map(|sp| sp.max_step_euler),
        seconds: d.seconds_total,
    })
}

/// The knee of a sweep (see [`Tradeoff::knee`]).
pub(crate) fn knee_of(points: &[TradeoffPoint]) -> Option<usize> {
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
