//! The certified f32 error floor (docs/method.md §15, "The f32 error
//! floor"): the ultimate bound on the estimation error that the rounding of
//! the generated f32 arithmetic leaves, computed from the baked P and L_l.
//!
//! The rounding of one evaluation of the observer's right-hand side is
//! δ with |δ_k| ≤ d₀_k + d₁_k ρ on E_ρ = {eᵀPe ≤ ρ²}, ρ ≤ 1 (the code
//! generator's forward error bound, [`RhsRounding`]). Then e' = F e − δ and
//! V = eᵀPe obeys
//!
//! ```text
//!     V' ≤ −αV + 2|eᵀPδ| ≤ −αV + 2ρ (D₀ + D₁ρ),     D_i = max_{|v_k| ≤ d_i,k} √(vᵀPv),
//! ```
//!
//! so ρ' ≤ −(α − 2D₁)/2 · ρ + D₀: the proportional part lowers the rate to
//! α' = α − 2D₁, the constant part is a bounded disturbance, and
//! lim sup ρ ≤ ρ* = 2D₀/α' (provided α' > 0 and ρ* < 1, which keeps E
//! invariant). The constant part may instead go through the noise bound
//! (B_w = diag(d₀), |w_k| ≤ 1: V' + αV ≤ σ n_w + 2D₁V, ρ*² = σ n_w/α'); the
//! smaller of the two certified ρ* is kept. ‖e‖ ≤ ρ/√λ_min(P).
//!
//! For explicit Euler at h ≤ h_max (the certified step, contraction
//! V(e⁺) ≤ (1 − h_max β)V(e)) the state update x̂ + h·k adds its own
//! rounding η, |η_k| ≤ u|x̂_k| + u(2 + u) h |k_k|, and
//! √V(e⁺) ≤ (1 − κh)ρ + h(D₀ + D₁ρ) + ‖η‖_P with
//! κ = (1 − √(1 − h_max β))/h_max (√V is a norm, convex along h); hence
//! lim sup ρ ≤ (D₀ + H_b + H_a/h)/(κ − D₁), H_a = ‖u x̂‖_P, H_b = ‖u(2+u)k‖_P.
//!
//! **A sampled design's `step`** (`sample = h`: S5d certifies
//! V(e_{k+1}) ≤ (1 − hα)V(e_k) for the exact Euler recursion at exactly
//! h, on the same sets): the same recursion with h_max = h and β = α, no
//! convexity argument needed, ρ_{k+1} ≤ √(1 − hα)ρ_k + h(D₀ + D₁ρ_k) +
//! H_a + hH_b. Its fixed point ρ* = (D₀ + H_b + H_a/h)/(κ − D₁),
//! κ = (1 − √(1 − hα))/h, is the floor when it is below 1 (then ρ_k ≤ 1
//! keeps ρ_{k+1} ≤ 1: the map is affine with slope below 1, so E stays
//! invariant and the rounding bounds, computed on it, keep holding);
//! [`RoundingFloor::sampled`].

use crate::model::noise::NoiseChannels;
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// The rounding of one evaluation of the generated right-hand side, per
/// observer state (from the code generator's forward error bound).
#[derive(Debug, Clone, PartialEq)]
pub struct RhsRounding {
    /// d₀: the part independent of the estimation error.
    pub constant: Vec<f64>,
    /// d₁: the part per unit ρ = √(eᵀPe).
    pub proportional: Vec<f64>,
    /// A bound on |computed derivative| on E (for the state update).
    pub derivative: Vec<f64>,
    /// A bound on |x̂_k| on E (for the state update).
    pub state: Vec<f64>,
}

/// The f32 floor under explicit Euler steps h with `min_step` < h ≤ the
/// certified Euler step: lim sup ‖e‖ ≤ `base` + `per_step`/h.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EulerFloor {
    /// The part of the floor that does not depend on h.
    pub base: f64,
    /// The state update's rounding, divided by h in the floor.
    pub per_step: f64,
    /// Below this step the update's rounding is too large to certify anything.
    pub min_step: f64,
}

/// The certified f32 error floor of a design ([`rounding_floor`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RoundingFloor {
    /// D₀ = ‖d₀‖_P over the box |v_k| ≤ d₀_k.
    pub constant: f64,
    /// D₁ = ‖d₁‖_P: the decay rate of V drops from α to α − 2D₁.
    pub proportional: f64,
    /// The certified bound on lim sup ‖e(t)‖ (continuous time).
    pub error_bound: f64,
    /// Which bound of the constant part gave `error_bound`: "direct" (2D₀/α')
    /// or "noise" (through σ of B_w = diag(d₀)).
    pub via: &'static str,
    /// The floor with the explicit Euler state update, when the design has
    /// a certified Euler step and some step is certified.
    pub euler: Option<EulerFloor>,
    /// A sampled design: the certified bound on lim sup ‖e_k‖ of its fixed
    /// step at the sample period (the update's rounding included), when
    /// one is certified (module docs).
    pub sampled: Option<f64>,
}

/// The inputs of [`rounding_floor`]: a certified design's numbers as baked.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FloorInputs<'a> {
    /// The observer's model the numbers are certified on.
    pub model: &'a PolytopicModel,
    /// The certified rate α.
    pub alpha: f64,
    /// The certified γ.
    pub gamma: f64,
    /// The Lyapunov matrix P.
    pub p: &'a DMatrix<f64>,
    /// The vertex gains L_l.
    pub l: &'a [DMatrix<f64>],
    /// The certified Euler step h_max and its contraction rate β, if any.
    pub euler: Option<(f64, f64)>,
    /// A sampled design's period h (certified V(e_{k+1}) ≤ (1 − hα)V(e_k)).
    pub sample: Option<f64>,
}

/// The unit roundoff of IEEE single precision, 2⁻²⁴.
const U: f64 = 1.0 / 16_777_216.0;
/// Relative pad on the bound's own f64 arithmetic.
const PAD: f64 = 1e-9;

/// max over |v_k| ≤ d_k of √(vᵀPv): exact over the box's corners up to 12
/// states, √(dᵀ|P|d) beyond.
pub fn box_p_norm(p: &DMatrix<f64>, d: &[f64]) -> f64 {
    let n = d.len();
    let quad = |s: &dyn Fn(usize) -> f64| {
        let mut q = 0.0;
        for i in 0..n {
            for j in 0..n {
                q += s(i) * d[i] * p[(i, j)] * s(j) * d[j];
            }
        }
        q
    };
    let q = if n <= 12 {
        (0..1usize << n.saturating_sub(1))
            .map(|mask| quad(&|i| if mask >> i & 1 == 1 { -1.0 } else { 1.0 }))
            .fold(0.0, f64::max)
    } else {
        let mut q = 0.0;
        for i in 0..n {
            for j in 0..n {
                q += d[i] * d[j] * p[(i, j)].abs();
            }
        }
        q
    };
    q.max(0.0).sqrt() * (1.0 + PAD)
}

/// A certified lower bound on λ_min of the symmetric part of P (the
/// eigensolver's error subtracted).
fn lambda_min(p: &DMatrix<f64>) -> f64 {
    let ps = (p + p.transpose()) * 0.5;
    let n = ps.nrows() as f64;
    let guard = 32.0 * f64::EPSILON * (n + 1.0) * ps.norm();
    ps.symmetric_eigenvalues().min() - guard
}

/// ρ*² through the noise bound: σ of the disturbance B_w = diag(d₀) (checked
/// block LMI), times the number of disturbed states, over α'.
fn via_noise(inp: &FloorInputs<'_>, d0: &[f64], alpha_eff: f64) -> Option<f64> {
    let n = inp.model.nx();
    let cols: Vec<usize> = (0..n).filter(|&k| d0[k] > 0.0).collect();
    if cols.is_empty() {
        return Some(0.0);
    }
    let mut bw = DMatrix::zeros(n, cols.len());
    for (c, &k) in cols.iter().enumerate() {
        bw[(k, c)] = d0[k];
    }
    let channels = NoiseChannels {
        outputs: Some(Vec::new()),
        b_w: Some(vec![bw; inp.model.nv()]),
    };
    let b = super::noise::noise_bound(inp.model, &channels, inp.alpha, inp.gamma, inp.p, inp.l)
        .filter(|b| b.check.passed)?;
    Some(b.sigma * cols.len() as f64 / alpha_eff * (1.0 + PAD))
}

/// The certified f32 error floor of the baked numbers `inp` for the
/// rounding `r` of their generated right-hand side (module docs). `Err`
/// says why none is certified (the proportional part eats the rate, or the
/// floor would leave E).
pub(crate) fn rounding_floor(
    inp: &FloorInputs<'_>,
    r: &RhsRounding,
) -> Result<RoundingFloor, String> {
    let n = inp.model.nx();
    let sizes = [&r.constant, &r.proportional, &r.derivative, &r.state];
    if sizes.iter().any(|v| v.len() != n)
        || sizes
            .iter()
            .any(|v| v.iter().any(|x| !(x.is_finite() && *x >= 0.0)))
    {
        return Err(format!(
            "the rounding bounds are not {n} finite non-negative numbers per state"
        ));
    }
    let lmin = lambda_min(inp.p);
    if lmin.is_nan() || lmin <= 0.0 {
        return Err("P is not positive definite".into());
    }
    let d0 = box_p_norm(inp.p, &r.constant);
    let d1 = box_p_norm(inp.p, &r.proportional);
    let alpha_eff = inp.alpha - 2.0 * d1;
    if alpha_eff.is_nan() || alpha_eff <= 0.0 {
        return Err(format!(
            "the rounding proportional to the error (D₁ = {d1:.3e}) takes the whole rate \
             α = {} (α − 2D₁ ≤ 0)",
            inp.alpha
        ));
    }
    let direct = 2.0 * d0 / alpha_eff * (1.0 + PAD);
    let noise = via_noise(inp, &r.constant, alpha_eff).map(f64::sqrt);
    let (rho, via) = match noise {
        Some(v) if v < direct => (v, "noise"),
        _ => (direct, "direct"),
    };
    if rho.is_nan() || rho >= 1.0 {
        return Err(format!(
            "the rounding's ultimate bound ρ* = {rho:.3e} (in √(eᵀPe)) is not below 1: the \
             certified set need not stay invariant"
        ));
    }
    let scale = 1.0 / lmin.sqrt();
    Ok(RoundingFloor {
        constant: d0,
        proportional: d1,
        error_bound: rho * scale * (1.0 + PAD),
        via,
        euler: inp
            .euler
            .and_then(|e| euler_floor(inp.p, r, (d0, d1), e, scale)),
        sampled: inp.sample.and_then(|h| {
            euler_floor(inp.p, r, (d0, d1), (h, inp.alpha), scale)
                .map(|e| (e.base + e.per_step / h) * (1.0 + PAD))
        }),
    })
}

/// The Euler floor (module docs), `None` when no step is certified.
fn euler_floor(
    p: &DMatrix<f64>,
    r: &RhsRounding,
    (d0, d1): (f64, f64),
    (h_max, beta): (f64, f64),
    scale: f64,
) -> Option<EulerFloor> {
    let c = 1.0 - h_max * beta;
    if h_max.is_nan() || h_max <= 0.0 || !(0.0..1.0).contains(&c) {
        return None;
    }
    let kappa = (1.0 - c.sqrt()) / h_max * (1.0 - PAD);
    let slack = kappa - d1;
    let ha = box_p_norm(p, &r.state.iter().map(|x| U * x).collect::<Vec<_>>());
    let hb = box_p_norm(
        p,
        &r.derivative
            .iter()
            .map(|k| U * (2.0 + U) * k)
            .collect::<Vec<_>>(),
    );
    // ρ*(h) = (D₀ + H_b + H_a/h)/(κ − D₁) < 1  ⇔  h > H_a/(κ − D₁ − D₀ − H_b)
    let room = slack - d0 - hb;
    if slack.is_nan() || room.is_nan() || slack <= 0.0 || room <= 0.0 {
        return None;
    }
    let min_step = ha / room * (1.0 + PAD);
    (min_step < h_max).then(|| EulerFloor {
        base: (d0 + hb) / slack * scale * (1.0 + PAD),
        per_step: ha / slack * scale * (1.0 + PAD),
        min_step,
    })
}
