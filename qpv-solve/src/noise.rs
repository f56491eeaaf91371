//! Noise and disturbances: a certified bound on how much measurement noise
//! (and process disturbance) gets through a design, and the design that
//! minimises it.
//!
//! With measurement noise v (y_meas = y + v on the noisy outputs) and a
//! process disturbance w (x' = … + B_w(θ) w) the observer is unchanged and
//! its error obeys e' = F(θ, e, x) e + B_w(θ) w − L(θ) v. A design carries
//! the claim
//!
//! ```text
//!     V' + αV ≤ σ (|w|² + |v|²)     for e ∈ E, x ∈ F, θ ∈ Θ and all w, v,     V = eᵀPe,
//! ```
//!
//! which follows from the block LMI (written like the rate LMI, multiplied by γ)
//!
//! ```text
//!     [ S_{l,i,j}       γ P B_w,l    −γ Γ_l E ]
//!     [ γ B_w,lᵀ P      −γσ I         0       ]  ≺ 0
//!     [ −γ Eᵀ Γ_lᵀ      0            −γσ I    ]
//! ```
//!
//! at every θ-vertex l and region-vertex pair (i, j), S_{l,i,j} being the
//! rate block of (S5) and E the columns of the noisy outputs (the same
//! combinations as the rate family when the output map depends on θ). For
//! fixed P, Γ_l it holds iff S ≺ 0 and σ > γ λ_max(Gᵀ(−S)⁻¹G) with
//! G = [P B_w,l, −Γ_l E] (a Schur complement): [`sigma_for`] computes σ so,
//! maximised over the blocks, with a small relative margin; [`check_noise`]
//! re-checks the block LMI itself by the eigenvalues of the whole block, from
//! the model and the gains only. [`design_noise`] minimises σ over
//! (P, Γ_l, σ) at fixed α (and fixed or searched γ), one SDP per γ, and
//! [`tradeoff`] sweeps α.
//!
//! What σ guarantees, for noise bounded in amplitude |w(t)|² + |v(t)|² ≤ ν²
//! (and x(t) in F, Assumption 2, for the disturbed plant):
//! * E stays invariant while σν² < α: the largest tolerated amplitude is
//!   ν_max = √(α/σ) (`max_amplitude`);
//! * V(t) ≤ e^{−αt}V(0) + (σν²/α)(1 − e^{−αt}), so the error ends in
//!   {V ≤ σν²/α}: ‖e(∞)‖ ≤ ν √(σ/(α λ_min(P))) (`error_bound`, per unit ν)
//!   and |e_k(∞)| ≤ ν √(σ (P⁻¹)_kk / α) (`per_state`).
//!
//! The method page docs/method.md states the model; this module is its
//! solver side.

use crate::backend::{clarabel_settings, run_sdp, Sdp, Status};
use crate::certificate::{check, combo_lmi, Certificate};
use crate::conditions::{rate_combos, Combo, ConditionSet};
use crate::linalg::csc::Columns;
use crate::linalg::svec::svec_index;
use crate::lmi::{tri, Objective, Problem};
use crate::model::output_filter::OutputRouteInfo;
use crate::model::state_bound::StateBoundInfo;
use crate::model::{ObserverModel, ObserverOptions, StateBoundClaim};
use crate::report::{Design, ReportedMatrices, SearchStep, SolverInfo};
use crate::vocab::{BoundSource, Phase};
use crate::{Settings, SolveError};
use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;
use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, PolytopicModel, Split};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Where noise and disturbances enter: which outputs are measured with
/// noise (all by default) and, optionally, a process-disturbance matrix
/// B_w,l per θ-vertex (nx × n_w, the same n_w at every vertex).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NoiseChannels {
    /// Indices (0-based) of the outputs that carry measurement noise;
    /// `None` = every output.
    pub outputs: Option<Vec<usize>>,
    /// B_w,l per θ-vertex (model order); `None` = no process disturbance.
    pub b_w: Option<Vec<DMatrix<f64>>>,
}

impl NoiseChannels {
    /// Noise on every output, no process disturbance (the default).
    pub fn all_outputs() -> Self {
        NoiseChannels::default()
    }

    /// The channels a model declares: noise on the outputs named by its
    /// `noise` declaration (every output without one), and its process
    /// disturbances B_w,l, if any.
    pub fn from_model(model: &PolytopicModel) -> Self {
        NoiseChannels {
            outputs: model.noise.outputs.clone(),
            b_w: (!model.noise.disturbances.is_empty()).then(|| model.noise.b_w.clone()),
        }
    }

    /// The noisy output indices for a model with `ny` outputs.
    pub fn noisy_outputs(&self, ny: usize) -> Vec<usize> {
        match &self.outputs {
            Some(o) => o.clone(),
            None => (0..ny).collect(),
        }
    }

    /// Number of disturbance inputs n_w.
    pub fn n_w(&self) -> usize {
        self.b_w
            .as_ref()
            .and_then(|b| b.first())
            .map_or(0, |b| b.ncols())
    }

    /// Checks the channels against `model`: output indices in range and
    /// without repeats, one finite nx × n_w matrix B_w,l per vertex, and at
    /// least one channel.
    pub fn validate(&self, model: &PolytopicModel) -> Result<(), SolveError> {
        let bad = |s: String| Err(SolveError::Dimensions(format!("noise channels: {s}")));
        let (nx, ny) = (model.nx(), model.ny());
        let outs = self.noisy_outputs(ny);
        for (k, &o) in outs.iter().enumerate() {
            if o >= ny {
                return bad(format!("output index {o} but the model has {ny} outputs"));
            }
            if outs[..k].contains(&o) {
                return bad(format!("output index {o} listed twice"));
            }
        }
        if let Some(b) = &self.b_w {
            if b.len() != model.nv() {
                return bad(format!(
                    "{} matrices B_w given, the model has {} vertices",
                    b.len(),
                    model.nv()
                ));
            }
            let nw = self.n_w();
            for (l, bl) in b.iter().enumerate() {
                if bl.shape() != (nx, nw) {
                    return bad(format!(
                        "B_w at vertex {} is {:?}, expected ({nx}, {nw})",
                        l + 1,
                        bl.shape()
                    ));
                }
                if bl.iter().any(|v| !v.is_finite()) {
                    return bad(format!("B_w at vertex {} has non-finite entries", l + 1));
                }
            }
        }
        if outs.is_empty() && self.n_w() == 0 {
            return bad("no noisy output and no disturbance: nothing to bound".into());
        }
        Ok(())
    }

    /// The channels of the observer model of an output-filter design: noise
    /// on output k enters the filter state k through the filter gain b (a
    /// process disturbance of the augmented plant, x_{y,k}' = −a x_{y,k} +
    /// b (y_k + v_k)), and the filter states themselves are measured exactly.
    /// `plant_nx` is the plant's state count, `gain` the filter gain b;
    /// `self` must have passed [`NoiseChannels::validate`] on the plant.
    pub fn through_filter(&self, plant_nx: usize, ny: usize, nv: usize, gain: f64) -> Self {
        let outs = self.noisy_outputs(ny);
        let nw = self.n_w();
        let n = plant_nx + ny;
        let b_w = (0..nv)
            .map(|l| {
                let mut m = DMatrix::zeros(n, nw + outs.len());
                if let Some(b) = &self.b_w {
                    m.view_mut((0, 0), (plant_nx, nw)).copy_from(&b[l]);
                }
                for (c, &k) in outs.iter().enumerate() {
                    m[(plant_nx + k, nw + c)] = gain;
                }
                m
            })
            .collect();
        NoiseChannels {
            outputs: Some(Vec::new()),
            b_w: Some(b_w),
        }
    }
}

/// The noise bound's report types live with the report (the report carries
/// them); they are re-exported here, where they are computed.
pub use crate::report::{NoiseBound, NoiseCheck};

/// The pieces of one block: the rate matrix S (≺ 0 required), the coupling
/// G = Σ_t w_t [γ P B_w,l_t, −γ Γ_l_t E] and the weight W = Σ_t w_t (the
/// bottom-right block is −γσW I).
struct BlockParts {
    s: DMatrix<f64>,
    g: DMatrix<f64>,
    w: f64,
}

fn block_parts(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    (alpha, gamma): (f64, f64),
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    combo: &Combo,
    (i, j): (usize, usize),
) -> BlockParts {
    let s = combo_lmi(model, Mode::Sound, alpha, gamma, p, gammas, combo, i, j);
    let outs = channels.noisy_outputs(model.ny());
    let nw = channels.n_w();
    let nx = model.nx();
    let mut g = DMatrix::zeros(nx, nw + outs.len());
    for &(l, _, w) in &combo.terms {
        if let Some(b) = &channels.b_w {
            let pb = p * &b[l] * (gamma * w);
            let mut v = g.view_mut((0, 0), (nx, nw));
            v += pb;
        }
        for (c, &k) in outs.iter().enumerate() {
            for r in 0..nx {
                g[(r, nw + c)] -= gamma * w * gammas[l][(r, k)];
            }
        }
    }
    BlockParts {
        s,
        g,
        w: combo.weight(),
    }
}

/// The smallest σ for which the block LMI holds at every block for these
/// (P, Γ_l), by the Schur complement: max over blocks of
/// λ_max(Gᵀ(−S)⁻¹G)/(γW) (no margin). `None` if some S is not negative
/// definite (no σ works) or the input is malformed.
pub fn sigma_min_for(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> Option<f64> {
    channels.validate(model).ok()?;
    if gammas.len() != model.nv() || p.shape() != (model.nx(), model.nx()) {
        return None;
    }
    let np = model.region.vertices.len();
    let mut worst: f64 = 0.0;
    for combo in rate_combos(model) {
        for i in 0..np {
            for j in 0..np {
                let b = block_parts(model, channels, (alpha, gamma), p, gammas, &combo, (i, j));
                let neg = -&b.s;
                let ch = neg.cholesky()?;
                let y = ch.l().solve_lower_triangular(&b.g)?;
                let m = y.transpose() * &y;
                let lmax = m.symmetric_eigenvalues().max();
                if !lmax.is_finite() {
                    return None;
                }
                worst = worst.max(lmax / (gamma * b.w));
            }
        }
    }
    Some(worst)
}

/// σ for these (P, Γ_l) with the margin the independent check needs:
/// [`sigma_min_for`] times (1 + δ), δ = 1e-6 raised tenfold (to 1e-2 at
/// most) until [`check_noise`] passes; `None` if it never does.
pub fn sigma_for(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> Option<(f64, NoiseCheck)> {
    let s0 = sigma_min_for(model, channels, alpha, gamma, p, gammas)?;
    let base = s0.max(f64::MIN_POSITIVE);
    let mut delta = 1e-6;
    while delta <= 1.01e-2 {
        let sigma = base * (1.0 + delta);
        let c = check_noise(model, channels, alpha, gamma, p, gammas, sigma);
        if c.passed {
            return Some((sigma, c));
        }
        delta *= 10.0;
    }
    None
}

/// The independent check of the noise claim: the whole block matrix
///
/// ```text
///     [ S        G      ]
///     [ Gᵀ   −γσW I     ]
/// ```
///
/// (S the rate block, G the noise coupling, see the module doc) at every
/// rate combination and region-vertex pair, by its largest eigenvalue —
/// not by the Schur formula. It reads only the model, P, Γ_l = P L_l and σ.
pub fn check_noise(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    sigma: f64,
) -> NoiseCheck {
    let mut out = NoiseCheck {
        margin: f64::INFINITY,
        guard: 0.0,
        passed: true,
        worst_at: String::new(),
        count: 0,
    };
    let fail = |why: String| NoiseCheck {
        margin: -f64::MAX,
        guard: 0.0,
        passed: false,
        worst_at: why,
        count: 0,
    };
    if let Err(e) = channels.validate(model) {
        return fail(e.to_string());
    }
    if let Err(e) = crate::conditions::validate(model) {
        return fail(e.to_string());
    }
    if gammas.len() != model.nv()
        || p.shape() != (model.nx(), model.nx())
        || gammas.iter().any(|g| g.shape() != (model.nx(), model.ny()))
    {
        return fail("P or the gains do not fit the model".into());
    }
    if !(sigma.is_finite() && sigma > 0.0 && alpha.is_finite() && gamma > 0.0 && gamma < 1.0) {
        return fail(format!(
            "σ = {sigma}, α = {alpha}, γ = {gamma} out of range"
        ));
    }
    let nx = model.nx();
    let double = crate::conditions::is_double_sum(model);
    let np = model.region.vertices.len();
    for combo in rate_combos(model) {
        for i in 0..np {
            for j in 0..np {
                let b = block_parts(model, channels, (alpha, gamma), p, gammas, &combo, (i, j));
                let k = b.g.ncols();
                let n = nx + k;
                let mut m = DMatrix::zeros(n, n);
                m.view_mut((0, 0), (nx, nx)).copy_from(&b.s);
                m.view_mut((0, nx), (nx, k)).copy_from(&b.g);
                m.view_mut((nx, 0), (k, nx)).copy_from(&b.g.transpose());
                for d in 0..k {
                    m[(nx + d, nx + d)] = -gamma * sigma * b.w;
                }
                let e = m.clone().symmetric_eigenvalues();
                let lmax = if e.iter().any(|v| v.is_nan()) {
                    f64::NAN
                } else {
                    e.max()
                };
                let margin = -lmax;
                let guard = 32.0 * f64::EPSILON * (n as f64 + 1.0) * m.norm();
                out.count += 1;
                if margin.is_nan() || margin <= guard {
                    out.passed = false;
                }
                if out.count == 1 || margin.is_nan() || margin < out.margin {
                    out.margin = if margin.is_nan() { -f64::MAX } else { margin };
                    out.guard = guard;
                    out.worst_at = format!("{} i={} j={}", combo.label(double), i + 1, j + 1);
                }
            }
        }
    }
    out.passed &= out.count > 0;
    out
}

/// The noise bound of a design with Lyapunov matrix `p` and gains L_l
/// (Γ_l = P L_l recomputed): σ from [`sigma_for`] (checked by
/// [`check_noise`]) and the derived amplitudes. `None` if the block LMI
/// cannot be certified for any σ (e.g. the rate LMIs themselves fail).
pub fn noise_bound(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
) -> Option<NoiseBound> {
    if l.iter().any(|li| li.nrows() != p.ncols()) {
        return None;
    }
    let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| p * li).collect();
    let (sigma, check) = sigma_for(model, channels, alpha, gamma, p, &gammas)?;
    bound_from(model, channels, alpha, p, sigma, check)
}

fn bound_from(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    p: &DMatrix<f64>,
    sigma: f64,
    check: NoiseCheck,
) -> Option<NoiseBound> {
    let ps = (p + p.transpose()) * 0.5;
    let lmin = ps.clone().symmetric_eigenvalues().min();
    let pinv = ps.cholesky()?.inverse();
    if lmin.is_nan() || lmin <= 0.0 {
        return None;
    }
    Some(NoiseBound {
        sigma,
        max_amplitude: (alpha / sigma).sqrt(),
        error_bound: (sigma / (alpha * lmin)).sqrt(),
        per_state: (0..p.nrows())
            .map(|k| (sigma * pinv[(k, k)] / alpha).sqrt())
            .collect(),
        noisy_outputs: channels
            .noisy_outputs(model.ny())
            .iter()
            .map(|&k| model.outputs[k].clone())
            .collect(),
        disturbances: channels.n_w(),
        check,
    })
}

/// The channels to use on a design's observer model: `channels` as given
/// for the double-sum route, mapped through the filter for the filter route
/// ([`NoiseChannels::through_filter`]).
fn channels_on_observer(
    plant: &PolytopicModel,
    design: &Design,
    channels: &NoiseChannels,
) -> NoiseChannels {
    match design.output_route.as_ref().and_then(|r| r.filter.as_ref()) {
        Some(f) => channels.through_filter(plant.nx(), plant.ny(), plant.nv(), f.gain),
        None => channels.clone(),
    }
}

/// Adds the noise bound (on the model's channels,
/// [`NoiseChannels::from_model`]) and the
/// sampling figures ([`crate::sampling`]) to a certified sound-mode design,
/// computed on its observer model; leaves other designs untouched. Nothing
/// is added that its check did not pass.
pub fn attach(plant: &PolytopicModel, design: &mut Design) {
    if !design.certifies {
        return;
    }
    let Ok(obs) = design.observer_model(plant) else {
        return;
    };
    // Both figures check every region-vertex pair; a cube design exists
    // to avoid that, so above the size the automatic choice solves
    // exactly they are left out (and said so).
    let pairs = obs.nv() * obs.region.vertices.len().pow(2);
    if design.conditions == qpv_dsl::Conditions::Cube && pairs > crate::size::AUTO_FULL_BLOCKS {
        design.notes.push(format!(
            "the noise bound and the sampling figures are not computed for this cube design: they check all {pairs} vertex-pair blocks"
        ));
        return;
    }
    let channels = channels_on_observer(plant, design, &NoiseChannels::from_model(plant));
    let (p, l) = (design.p_matrix(), design.l_matrices());
    design.noise = noise_bound(&obs, &channels, design.alpha, design.gamma, &p, &l);
    design.sampling = crate::sampling::sampling(&obs, design.alpha, design.gamma, &p, &l);
}

/// The noise-optimal SDP at (α, γ): minimise σ̂ = σ/s over (P̂, Γ̂_l, σ̂)
/// subject to (S1)–(S3) (assembled by [`Problem`]) and the block LMI at
/// every rate combination and region-vertex pair with the rate family's
/// margin ε κ. Returns (P, Γ_l, σ from the solver) in model units.
struct NoiseSolve {
    status: Status,
    detail: String,
    iterations: u32,
    solve_seconds: f64,
    assembly_seconds: f64,
    point: Option<(DMatrix<f64>, Vec<DMatrix<f64>>)>,
}

fn solve_noise_sdp(
    prob: &Problem,
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    settings: &Settings,
) -> Result<NoiseSolve, SolveError> {
    let t0 = Instant::now();
    let nv_prob = prob.n_vars();
    let svar = nv_prob;
    let n = nv_prob + 1;
    let (mut cols, mut b, mut cones) = without_rate_blocks(prob, model, alpha, gamma, settings, n)?;
    let outs = channels.noisy_outputs(model.ny());
    let block = NoiseBlock {
        nx: model.nx(),
        ny: model.ny(),
        nw: channels.n_w(),
        outs: &outs,
        svar,
        gamma,
        eps: settings.margin_rel * prob.rate_scale(alpha, gamma),
    };
    let np = model.region.vertices.len();
    for (c, combo) in prob.combos().iter().enumerate() {
        // B_w of the combination, and the weight of each Γ̂_l in −γΓ̂E.
        let mut bw = DMatrix::zeros(block.nx, block.nw);
        let mut wl = vec![0.0; model.nv()];
        for &(l, _, w) in &combo.terms {
            if let Some(bb) = &channels.b_w {
                bw += &bb[l] * w;
            }
            wl[l] += w;
        }
        for i in 0..np {
            for j in 0..np {
                let (kk, hs) = prob.rate_kh(alpha, gamma, c, i, j);
                block.push(&mut cols, &mut b, &kk, &hs, &bw, &wl, combo.weight());
                cones.push(SupportedConeT::PSDTriangleConeT(block.size()));
            }
        }
    }
    let mut q = vec![0.0; n];
    q[svar] = 1.0;
    let sdp = Sdp {
        p: CscMatrix::zeros((n, n)),
        q,
        a: cols.into_csc(b.len()),
        b,
        cones,
    };
    let assembly_seconds = t0.elapsed().as_secs_f64();
    let run = run_sdp(sdp, clarabel_settings(settings))?;
    let point = run.x.as_ref().map(|x| prob.unpack(&x[..nv_prob]));
    Ok(NoiseSolve {
        status: run.status,
        detail: run.detail,
        iterations: run.iterations,
        solve_seconds: run.solve_seconds,
        assembly_seconds,
        point,
    })
}

/// An SDP under construction: its constraint columns, right-hand side and cones.
type SdpParts = (Columns, Vec<f64>, Vec<SupportedConeT<f64>>);

/// The design SDP at (α, γ) without its rate blocks (they are replaced by
/// the noise blocks), as columns for `n` variables, right-hand side and cones.
fn without_rate_blocks(
    prob: &Problem,
    model: &PolytopicModel,
    alpha: f64,
    gamma: f64,
    settings: &Settings,
    n: usize,
) -> Result<SdpParts, SolveError> {
    let nx = model.nx();
    let base = prob.assemble(alpha, gamma, settings, Objective::Feasibility);
    let n_rate = prob.n_rate_blocks();
    let cut = base.b.len() - n_rate * tri(nx);
    let n_cones = base.cones.len() - n_rate;
    if base.cones[n_cones..]
        .iter()
        .any(|c| !matches!(c, SupportedConeT::PSDTriangleConeT(k) if *k == nx))
    {
        return Err(SolveError::Setup(
            "unexpected cone layout of the rate family".into(),
        ));
    }
    let mut cols = Columns::new(n);
    for c in 0..base.a.n {
        for k in base.a.colptr[c]..base.a.colptr[c + 1] {
            if base.a.rowval[k] < cut {
                cols.push(base.a.rowval[k], c, base.a.nzval[k]);
            }
        }
    }
    Ok((cols, base.b[..cut].to_vec(), base.cones[..n_cones].to_vec()))
}

/// One noise block of the SDP, in the variables (P̂, Γ̂_l, σ̂): the rate
/// block He{P̂K − Γ̂H} bordered by the disturbance columns γP̂B_w and the
/// noise columns −γΓ̂E, with −γσ̂I in the bottom-right corner, ⪯ −εI.
struct NoiseBlock<'a> {
    nx: usize,
    ny: usize,
    nw: usize,
    outs: &'a [usize],
    svar: usize,
    gamma: f64,
    eps: f64,
}

impl NoiseBlock<'_> {
    /// Side of the block: states, disturbances, noisy outputs.
    fn size(&self) -> usize {
        self.nx + self.nw + self.outs.len()
    }

    /// Appends the block of one (combination, region-vertex pair): `kk` and
    /// `hs` from [`Problem::rate_kh`], the combination's B_w, the weight of
    /// each Γ̂_l, and the combination's total weight.
    #[allow(clippy::too_many_arguments)]
    fn push(
        &self,
        cols: &mut Columns,
        b: &mut Vec<f64>,
        kk: &DMatrix<f64>,
        hs: &[(usize, DMatrix<f64>)],
        bw: &DMatrix<f64>,
        wl: &[f64],
        wsum: f64,
    ) {
        let (nx, ny, nw, nb, gamma) = (self.nx, self.ny, self.nw, self.size(), self.gamma);
        let row0 = b.len();
        b.resize(row0 + tri(nb), 0.0);
        for d in 0..nb {
            b[row0 + svec_index(d, d)] = -self.eps;
        }
        let mut coef = DMatrix::<f64>::zeros(nb, nb);
        // P̂ variables: top-left He{E K}, top-right γ E B_w.
        for pc in 0..nx {
            for pr in 0..=pc {
                coef.fill(0.0);
                let mut e = DMatrix::<f64>::zeros(nx, nx);
                e[(pr, pc)] = 1.0;
                e[(pc, pr)] = 1.0;
                let ek = &e * kk;
                let he = &ek + ek.transpose();
                coef.view_mut((0, 0), (nx, nx)).copy_from(&he);
                if nw > 0 {
                    let eb = &e * bw * gamma;
                    coef.view_mut((0, nx), (nx, nw)).copy_from(&eb);
                    coef.view_mut((nx, 0), (nw, nx)).copy_from(&eb.transpose());
                }
                cols.push_svec(row0, svec_index(pr, pc), &coef, 1.0);
            }
        }
        // Γ̂_l variables: top-left −He{D H_l}, noise columns −γ w_l D E.
        for (l, &wl_l) in wl.iter().enumerate() {
            let h = hs.iter().find(|(g, _)| *g == l).map(|(_, h)| h);
            if h.is_none() && wl_l == 0.0 {
                continue;
            }
            for gr in 0..nx {
                for gc in 0..ny {
                    coef.fill(0.0);
                    if let Some(h) = h {
                        let mut d = DMatrix::<f64>::zeros(nx, ny);
                        d[(gr, gc)] = 1.0;
                        let dh = &d * h;
                        let he = -(&dh + dh.transpose());
                        coef.view_mut((0, 0), (nx, nx)).copy_from(&he);
                    }
                    if let Some(pos) = self.outs.iter().position(|&o| o == gc) {
                        let v = -gamma * wl_l;
                        coef[(gr, nx + nw + pos)] = v;
                        coef[(nx + nw + pos, gr)] = v;
                    }
                    let var = tri(nx) + l * nx * ny + gr * ny + gc;
                    cols.push_svec(row0, var, &coef, 1.0);
                }
            }
        }
        // σ̂: bottom-right −γ W σ̂ I.
        coef.fill(0.0);
        for d in nx..nb {
            coef[(d, d)] = -gamma * wsum;
        }
        cols.push_svec(row0, self.svar, &coef, 1.0);
    }
}

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
        let res = solve_noise_sdp(
            &self.prob,
            self.model,
            self.channels,
            self.alpha,
            gamma,
            self.settings,
        )?;
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
                let cert = check(self.model, Mode::Sound, self.alpha, gamma, &p, &l);
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
        d.sampling = crate::sampling::sampling(obs, alpha, d.gamma, &p, &l);
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
    /// ([`crate::sampling::Sampling::max_step_euler`]; None if not
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

/// The outcome of [`falsify_noise`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseFalsification {
    /// σ that was checked.
    pub sigma: f64,
    /// α that was checked.
    pub alpha: f64,
    /// The sampler's seed (same seed, same samples).
    pub seed: u64,
    /// Points evaluated (e = 0 excluded).
    pub samples: usize,
    /// Points with r ≥ 0 (or a non-finite r).
    pub counterexamples: usize,
    /// The largest r = (V' + αV − σ(|w|² + |v|²))/V found.
    pub worst_ratio: f64,
    /// The point with the largest ratio.
    pub worst: Option<NoiseSample>,
}

/// One evaluated point of [`falsify_noise`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseSample {
    /// The estimation error e (eᵀPe ≤ 1).
    pub e: Vec<f64>,
    /// The plant state x.
    pub x: Vec<f64>,
    /// The parameter vector θ.
    pub theta: Vec<f64>,
    /// The noise on the noisy outputs, then the disturbance w.
    pub noise: Vec<f64>,
    /// r at this point.
    pub ratio: f64,
}

impl NoiseFalsification {
    /// True if points were evaluated and none was a counterexample.
    pub fn passed(&self) -> bool {
        self.samples > 0 && self.counterexamples == 0
    }
}

/// Samples the noise claim V' + αV ≤ σ(|w|² + |v|²) of a design with a
/// `noise` bound on the true nonlinear error dynamics
/// e' = f(x) − f(x̂) − L(θ)(h(x) − h(x̂)) + B_w(θ) w − L(θ) E v:
/// e in E, x in F and θ in the box drawn like [`crate::falsify::falsify`]
/// does; (v, w) the worst case for that (e, x, θ) (v = −EᵀLᵀPe/σ,
/// w = B_wᵀPe/σ, the maximiser of the right-hand side) in a quarter of the
/// draws, otherwise uniform in the ball of radius 2ν_max. Any r ≥ 0 is a
/// counterexample.
pub fn falsify_noise(
    plant: &PolytopicModel,
    design: &Design,
    channels: &NoiseChannels,
    samples: usize,
    seed: u64,
) -> Result<NoiseFalsification, crate::simulate::SimError> {
    use crate::falsify::{draw_e, draw_theta, draw_x, factor, Rng};
    use crate::simulate::{check_gains, check_model, Frozen, SimError};
    use nalgebra::DVector;
    let nb = design
        .noise
        .as_ref()
        .ok_or_else(|| SimError::Argument("the design carries no noise bound".into()))?;
    let model = design
        .observer_model(plant)
        .map_err(|e| SimError::Model(e.to_string()))?;
    channels
        .validate(plant)
        .map_err(|e| SimError::Argument(e.to_string()))?;
    let ch = channels_on_observer(plant, design, channels);
    ch.validate(&model)
        .map_err(|e| SimError::Argument(e.to_string()))?;
    check_model(&model)?;
    let (p, gains) = (design.p_matrix(), design.l_matrices());
    check_gains(&model, &gains)?;
    let (nx, ny) = (model.nx(), model.ny());
    let (alpha, sigma) = (design.alpha, nb.sigma);
    let rp = factor("P", &p, nx)?;
    let rp_t = rp.transpose();
    let to_e = |z: &DVector<f64>| rp_t.solve_upper_triangular(z);
    let e_vertices: Vec<DVector<f64>> = model
        .region
        .vertices
        .iter()
        .filter_map(|v| {
            let vpv = v.dot(&(&p * v));
            (vpv > 0.0).then(|| v * (1.0 / vpv.sqrt()).min(1.0))
        })
        .collect();
    let qpv_dsl::StateBound::Given(q) = &model.state_bound else {
        return Err(SimError::Model(
            "the design's model has no state bound Q".into(),
        ));
    };
    let rq = factor("state bound Q", q, nx)?;
    let x_vertices: Vec<DVector<f64>> = model
        .region
        .vertices
        .iter()
        .filter_map(|v| {
            let r = rq.solve_lower_triangular(v)?.norm();
            (r > 0.0).then(|| v / r)
        })
        .collect();
    let outs = ch.noisy_outputs(ny);
    let nw = ch.n_w();
    let nvw = outs.len() + nw;
    let radius = 2.0 * nb.max_amplitude;
    let mut frozen = Frozen::new(&model);
    let mut rng = Rng(seed);
    let mut z = DVector::zeros(nx);
    let mut zv = vec![0.0; nvw];
    let mut theta = vec![0.0; model.ntheta()];
    let (mut fx, mut fxh, mut hx, mut hxh) =
        (vec![0.0; nx], vec![0.0; nx], vec![0.0; ny], vec![0.0; ny]);
    let mut out = NoiseFalsification {
        sigma,
        alpha,
        seed,
        samples: 0,
        counterexamples: 0,
        worst_ratio: f64::NEG_INFINITY,
        worst: None,
    };
    for _ in 0..samples {
        let e = draw_e(&mut rng, &mut z, &e_vertices, &to_e);
        let x = draw_x(&mut rng, &mut z, Some(&rq), &x_vertices);
        draw_theta(&mut rng, &model, &mut theta);
        frozen.set(&model, &gains, &theta);
        let xh = &x - &e;
        frozen.drift(x.as_slice(), &mut fx);
        frozen.drift(xh.as_slice(), &mut fxh);
        frozen.output(x.as_slice(), &mut hx);
        frozen.output(xh.as_slice(), &mut hxh);
        // L(θ) and B_w(θ) at this θ.
        let mut lt = DMatrix::zeros(nx, ny);
        let mut bw = DMatrix::zeros(nx, nw);
        for (l, &mu) in frozen.mu.iter().enumerate() {
            lt += &gains[l] * mu;
            if let Some(b) = &ch.b_w {
                bw += &b[l] * mu;
            }
        }
        let pe = &p * &e;
        // (v, w): the maximiser, or random in the ball.
        let vw: Vec<f64> = if rng.uniform() < 0.25 {
            let ltpe = lt.transpose() * &pe;
            let bwpe = bw.transpose() * &pe;
            outs.iter()
                .map(|&k| -ltpe[k] / sigma)
                .chain(bwpe.iter().map(|b| b / sigma))
                .collect()
        } else {
            rng.ball(&mut zv, false);
            zv.iter().map(|c| c * radius).collect()
        };
        // e' = f(x) − f(x̂) − L (h(x) − h(x̂) + E v) + B_w w
        let mut innov = DVector::from_fn(ny, |k, _| hx[k] - hxh[k]);
        for (c, &k) in outs.iter().enumerate() {
            innov[k] += vw[c];
        }
        let w = DVector::from_fn(nw, |c, _| vw[outs.len() + c]);
        let de = DVector::from_fn(nx, |k, _| fx[k] - fxh[k]) - &lt * innov + &bw * w;
        let v = e.dot(&pe);
        if v <= 0.0 {
            continue;
        }
        let vdot = 2.0 * pe.dot(&de);
        let n2: f64 = vw.iter().map(|c| c * c).sum();
        let r = (vdot + alpha * v - sigma * n2) / v;
        out.samples += 1;
        let key = if r.is_nan() { f64::INFINITY } else { r };
        if r.is_nan() || r >= 0.0 {
            out.counterexamples += 1;
        }
        if key > out.worst_ratio {
            out.worst_ratio = key;
            out.worst = Some(NoiseSample {
                e: e.iter().copied().collect(),
                x: x.iter().copied().collect(),
                theta: theta.clone(),
                noise: vw,
                ratio: r,
            });
        }
    }
    Ok(out)
}

/// The certified ultimate error bound that a bounded disturbance entering
/// every state causes, e.g. the f32 rounding of the observer's right-hand
/// side: x̂' = f(x̂, …) + δ with |δ_k| ≤ d_k. It is a process disturbance
/// B_w w with B_w = diag(d) (the states with d_k > 0) and |w_k| ≤ 1, so
/// |w| ≤ ν = √(number of such states); [`noise_bound`] on those channels
/// (no measurement noise) gives σ, and lim sup ‖e‖ ≤ ν·√(σ/(α λ_min(P))).
#[derive(Debug, Clone, PartialEq)]
pub struct DisturbanceFloor {
    /// The per-state disturbance bound d_k.
    pub disturbance: Vec<f64>,
    /// σ of V' + αV ≤ σ|w|² on these channels (0 if d = 0).
    pub sigma: f64,
    /// ν = √(number of disturbed states): the amplitude of w.
    pub amplitude: f64,
    /// The certified bound on lim sup ‖e(t)‖ (Euclidean norm).
    pub error_bound: f64,
    /// The certified bound on lim sup |e_k(t)|, per state.
    pub per_state: Vec<f64>,
}

/// The [`DisturbanceFloor`] of a design (P, L_l certified at α, γ on
/// `model`) for the per-state disturbance bound `d`; `Err` if the block
/// LMI fails or ν exceeds the tolerated amplitude √(α/σ) (then the
/// certified set need not stay invariant).
pub fn disturbance_floor(
    model: &PolytopicModel,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
    d: &[f64],
) -> Result<DisturbanceFloor, String> {
    let n = model.nx();
    if d.len() != n || d.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
        return Err(format!(
            "{} disturbance bounds for {n} states, or a negative or non-finite one",
            d.len()
        ));
    }
    let cols: Vec<usize> = (0..n).filter(|&k| d[k] > 0.0).collect();
    if cols.is_empty() {
        return Ok(DisturbanceFloor {
            disturbance: d.to_vec(),
            sigma: 0.0,
            amplitude: 0.0,
            error_bound: 0.0,
            per_state: vec![0.0; n],
        });
    }
    let mut bw = DMatrix::zeros(n, cols.len());
    for (c, &k) in cols.iter().enumerate() {
        bw[(k, c)] = d[k];
    }
    let channels = NoiseChannels {
        outputs: Some(Vec::new()),
        b_w: Some(vec![bw; model.nv()]),
    };
    let b = noise_bound(model, &channels, alpha, gamma, p, l)
        .filter(|b| b.check.passed)
        .ok_or("the disturbance's block LMI could not be certified")?;
    let nu = (cols.len() as f64).sqrt();
    if nu > b.max_amplitude {
        return Err(format!(
            "the disturbance (amplitude {nu:.3e} on channels of σ = {:.3e}) exceeds the \
             tolerated amplitude {:.3e}: the certified set need not stay invariant",
            b.sigma, b.max_amplitude
        ));
    }
    Ok(DisturbanceFloor {
        disturbance: d.to_vec(),
        sigma: b.sigma,
        amplitude: nu,
        error_bound: b.error_bound * nu,
        per_state: b.per_state.iter().map(|v| v * nu).collect(),
    })
}

/// A box, one interval [lo, hi] per state.
pub type Boxes = Vec<(f64, f64)>;

/// Boxes of the plant state x and of the estimate x̂ = x − e over which a
/// certified design's observer runs: x ∈ F (its state bound Q, |x_k| ≤
/// √Q_kk) ⊂ P̃ (the region scaled by 1/γ), e ∈ E = {eᵀPe ≤ 1}, |e_k| ≤
/// √((P⁻¹)_kk). Returns (box of x, box of x̂); None if P is not positive
/// definite.
pub fn observer_boxes(
    model: &PolytopicModel,
    gamma: f64,
    p: &DMatrix<f64>,
) -> Option<(Boxes, Boxes)> {
    let n = model.nx();
    let ps = (p + p.transpose()) * 0.5;
    let pinv = ps.cholesky()?.inverse();
    let vs = &model.region.vertices;
    let q = match &model.state_bound {
        qpv_dsl::StateBound::Given(q) if q.nrows() == n => Some(q),
        _ => None,
    };
    let mut xs = Vec::with_capacity(n);
    let mut xh = Vec::with_capacity(n);
    for k in 0..n {
        let lo = vs.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min) / gamma;
        let hi = vs.iter().map(|v| v[k]).fold(f64::NEG_INFINITY, f64::max) / gamma;
        let (lo, hi) = match q {
            Some(q) => {
                let r = q[(k, k)].max(0.0).sqrt();
                (lo.max(-r), hi.min(r))
            }
            None => (lo, hi),
        };
        let e = pinv[(k, k)].max(0.0).sqrt();
        xs.push((lo, hi));
        xh.push((lo - e, hi + e));
    }
    Some((xs, xh))
}
