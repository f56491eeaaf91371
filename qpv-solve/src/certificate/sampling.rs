//! Sampled implementations: the largest Euler step for which a design's
//! Lyapunov function still contracts, and an RK4 step estimate.
//!
//! **Euler (a proof, for the vertex family).** When plant and observer are
//! both discretised by the same explicit Euler step h, the error obeys
//! exactly e⁺ = (I + hF(θ, e, x)) e, F the error-dynamics matrix of the
//! continuous design. V = eᵀPe contracts, V(e⁺) ≤ (1 − hβ)V(e), iff
//!
//! ```text
//!     [ (1 − hβ)P        (I + hF)ᵀP ]
//!     [ P(I + hF)         P         ]  ⪰ 0,
//! ```
//!
//! which is affine in F; F(θ, e, x) is a convex combination of the vertex
//! matrices F_{l,m,i,j} = A_l − L_l C_m + (R_{l,i,j} − L_l S_{m,i,j})/γ
//! (e = x_(i)/γ, x = x_(j)/γ, m = l unless the output map depends on θ), so
//! checking them suffices. We take β = α/2: the sampled observer keeps half
//! the certified continuous rate per unit time (V_k ≤ (1 − hα/2)^k V_0), and
//! β < α leaves room for the h² term, so every certified design has a
//! positive largest step. [`max_step_euler`] finds it by bisection on h,
//! each step checked by the eigenvalues of every block. What it covers: the
//! Euler-discretised plant together with the Euler-discretised observer
//! (the same step), with x_k in F and θ_k in the box; a continuous plant
//! sampled by a discrete observer is covered by simulation, not by this
//! proof.
//!
//! **RK4 (an estimate, not a proof).** The largest h with |R(hλ)| < 1 for
//! the RK4 stability polynomial R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 on every
//! eigenvalue λ of the frozen vertex matrices F_{l,m,i,j}: a linear,
//! frozen-parameter stability estimate ([`step_estimate_rk4`]).

use crate::conditions::{is_double_sum, pair_suffix, rows, rows_he};
use nalgebra::{Complex, DMatrix};
use qpv_dsl::{PolytopicModel, TimeUnit};
use serde::{Deserialize, Serialize};

/// The sampling figures of a design (the report's `sampling` key).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sampling {
    /// Largest explicit Euler step h for which V = eᵀPe contracts by
    /// (1 − hβ) per step on the whole vertex family (plant and observer
    /// discretised by the same Euler step).
    pub max_step_euler: f64,
    /// β of the contraction (α/2).
    pub beta: f64,
    /// An estimate (not a proof): the largest RK4 step that keeps every
    /// frozen vertex error dynamics stable.
    pub step_estimate_rk4: f64,
}

/// The sample period of a `sample = h` design (the report's `sample` key):
/// the design is certified for the explicit-Euler observer stepped at h,
/// V(e_{k+1}) ≤ (1 − hα)V(e_k) on the vertex family (docs/method.md §16).
///
/// Conventions: `alpha` is a rate per second, as for every design;
/// `decrease` = 1 − hα is the factor V contracts by per step. (A continuous
/// design's `sampling.beta` = α/2 is the per-second rate its gains keep at
/// the step `sampling.max_step_euler`; a sampled design keeps all of α.)
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SampleInfo {
    /// The sample period h, seconds.
    pub h: f64,
    /// The certified rate α per second (the design's α). The three
    /// figures derived from h and α may be left out of a hand-written
    /// report: a report's figures are recomputed, never read.
    #[serde(default)]
    pub alpha: f64,
    /// hα: the rate per step.
    #[serde(default)]
    pub alpha_per_step: f64,
    /// 1 − hα: V(e_{k+1}) ≤ decrease · V(e_k).
    #[serde(default)]
    pub decrease: f64,
    /// The bound for the *continuous* plant sampled at h (the Euler step's
    /// local truncation error as a bounded disturbance; docs/method.md
    /// §16), when it could be computed ([`crate::report::continuous`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub continuous_bound: Option<ContinuousBound>,
}

impl SampleInfo {
    /// The sample key of a design certified at (h, α).
    pub fn new(h: f64, alpha: f64) -> SampleInfo {
        SampleInfo {
            h,
            alpha,
            alpha_per_step: h * alpha,
            decrease: 1.0 - h * alpha,
            continuous_bound: None,
        }
    }

    /// "h = 1e-4 s (10 kHz)": the period and its rate, in the model's
    /// unit of time.
    pub fn describe(&self, unit: TimeUnit) -> String {
        unit.describe_period(self.h)
    }
}

/// The error-dynamics matrices at every vertex (l, m, i, j), labelled
/// (1-based): F = A_l − L_l C_m + (rowsHe(N_l, x_j) − rows(N_l, x_i))/γ
/// − L_l (rowsHe(M_m, x_j) − rows(M_m, x_i))/γ.
pub fn vertex_dynamics(
    model: &PolytopicModel,
    gamma: f64,
    l: &[DMatrix<f64>],
) -> Vec<(String, DMatrix<f64>)> {
    let xs = &model.region.vertices;
    let nv = model.nv();
    let double = is_double_sum(model);
    let mut out = Vec::new();
    for (li, vl) in model.vertices.iter().enumerate() {
        let ms: Vec<usize> = if double { (0..nv).collect() } else { vec![li] };
        for m in ms {
            let vm = &model.vertices[m];
            for (i, xi) in xs.iter().enumerate() {
                for (j, xj) in xs.iter().enumerate() {
                    let r = rows_he(&vl.n, xj) - rows(&vl.n, xi);
                    let s = rows_he(&vm.m, xj) - rows(&vm.m, xi);
                    let f = &vl.a - &l[li] * &vm.c + (r - &l[li] * s) / gamma;
                    let label = if double {
                        format!("l={} m={}{}", li + 1, m + 1, pair_suffix(model, i, j))
                    } else {
                        format!("l={}{}", li + 1, pair_suffix(model, i, j))
                    };
                    out.push((label, f));
                }
            }
        }
    }
    out
}

/// The worst λ_min over the Euler blocks at step h, and where (positive =
/// the contraction holds there with the floating-point guard to spare).
pub fn euler_margin(
    p: &DMatrix<f64>,
    fs: &[(String, DMatrix<f64>)],
    beta: f64,
    h: f64,
) -> (f64, bool, String) {
    euler_scan(p, fs, beta, h, false)
}

/// [`euler_margin`], stopping at the first failing block if `stop`.
fn euler_scan(
    p: &DMatrix<f64>,
    fs: &[(String, DMatrix<f64>)],
    beta: f64,
    h: f64,
    stop: bool,
) -> (f64, bool, String) {
    let n = p.nrows();
    let eye = DMatrix::<f64>::identity(n, n);
    let mut worst = f64::INFINITY;
    let mut ok = true;
    let mut at = String::new();
    for (label, f) in fs {
        let step = &eye + f * h;
        let pm = p * &step;
        let mut m = DMatrix::zeros(2 * n, 2 * n);
        m.view_mut((0, 0), (n, n))
            .copy_from(&(p * (1.0 - h * beta)));
        m.view_mut((0, n), (n, n)).copy_from(&pm.transpose());
        m.view_mut((n, 0), (n, n)).copy_from(&pm);
        m.view_mut((n, n), (n, n)).copy_from(p);
        let e = m.clone().symmetric_eigenvalues();
        let lmin = if e.iter().any(|v| v.is_nan()) {
            f64::NAN
        } else {
            e.min()
        };
        let guard = 32.0 * f64::EPSILON * (2.0 * n as f64 + 1.0) * m.norm();
        if lmin.is_nan() || lmin <= guard {
            ok = false;
        }
        if lmin.is_nan() || lmin < worst {
            worst = if lmin.is_nan() {
                f64::NEG_INFINITY
            } else {
                lmin
            };
            at = label.clone();
        }
        if stop && !ok {
            break;
        }
    }
    (worst, ok, at)
}

/// The largest Euler step (relative precision 1e-6) for which
/// [`euler_margin`] holds at every vertex, with β = α/2; `None` if P is not
/// positive definite or no positive step works.
pub fn max_step_euler(
    model: &PolytopicModel,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
) -> Option<f64> {
    if l.len() != model.nv() || p.shape() != (model.nx(), model.nx()) {
        return None;
    }
    let fs = vertex_dynamics(model, gamma, l);
    bisect_euler(p, &fs, alpha / 2.0)
}

fn bisect_euler(p: &DMatrix<f64>, fs: &[(String, DMatrix<f64>)], beta: f64) -> Option<f64> {
    p.clone().cholesky()?;
    let fmax = fs.iter().map(|(_, f)| f.norm()).fold(0.0, f64::max);
    if !(fmax.is_finite() && fmax > 0.0) {
        return None;
    }
    let ok = |h: f64| euler_scan(p, fs, beta, h, true).1;
    // A tight bracket from the Schur complement, confirmed by the block
    // checks; the doubling bracket below if it is not confirmed.
    if let Some(hc) = schur_step(p, fs, beta) {
        let (mut lo, mut hi) = (hc * (1.0 - 1e-4), hc * (1.0 + 1e-4));
        if ok(lo) && !ok(hi) {
            while hi - lo > 1e-6 * lo {
                let mid = 0.5 * (lo + hi);
                if ok(mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return Some(lo);
        }
    }
    // Bracket: lo passes, hi fails.
    let mut lo = 1.0 / fmax;
    let mut tries = 0;
    while !ok(lo) {
        lo *= 0.25;
        tries += 1;
        if tries > 40 {
            return None;
        }
    }
    let mut hi = lo * 2.0;
    while ok(hi) {
        lo = hi;
        hi *= 2.0;
        if hi > 1e12 {
            return Some(lo);
        }
    }
    while hi - lo > 1e-6 * lo {
        let mid = 0.5 * (lo + hi);
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

/// The largest h of the Euler condition by its Schur complement: with
/// M = −(He{PF} + βP) ≻ 0 the block is ⪰ 0 iff h FᵀPF ⪯ M, i.e.
/// h ≤ 1/λ_max(L⁻¹FᵀPFL⁻ᵀ) (M = LLᵀ); the minimum over the vertices.
/// Only a starting bracket: the reported step is confirmed by the blocks.
fn schur_step(p: &DMatrix<f64>, fs: &[(String, DMatrix<f64>)], beta: f64) -> Option<f64> {
    let mut best = f64::INFINITY;
    for (_, f) in fs {
        let pf = p * f;
        let m = -(&pf + pf.transpose() + p * beta);
        let linv = m.cholesky()?.l().try_inverse()?;
        let w = &linv * (f.transpose() * &pf) * linv.transpose();
        let lmax = w.symmetric_eigenvalues().max();
        if lmax > 0.0 {
            best = best.min(1.0 / lmax);
        }
    }
    (best.is_finite() && best > 0.0).then_some(best)
}

/// |R(z)|² for RK4's stability function R(z) = 1 + z + z²/2 + z³/6 + z⁴/24
/// (squared: the scan below only compares it with 1, and the square needs
/// no `hypot`, which was an eighth of a small design's run time).
fn rk4_gain_sq(z: Complex<f64>) -> f64 {
    let z2 = z * z;
    let r = Complex::new(1.0, 0.0) + z + z2 * 0.5 + z2 * z / 6.0 + z2 * z2 / 24.0;
    r.norm_sqr()
}

/// The largest h with |R(h'λ)| < 1 for all h' ∈ (0, h] (relative precision
/// 1e-6) for one eigenvalue λ; 0 if Re λ ≥ 0.
fn rk4_step_for(lambda: Complex<f64>) -> f64 {
    let mag = lambda.norm();
    if lambda.re.is_nan() || lambda.re >= 0.0 || mag == 0.0 {
        return 0.0;
    }
    // The RK4 region lies inside |z| < 3: scan for the first exit, then bisect.
    let n = 3000;
    let dh = 3.0 / mag / n as f64;
    let mut lo = 0.0;
    for k in 1..=n {
        let h = dh * k as f64;
        if rk4_gain_sq(lambda * h) >= 1.0 {
            let mut hi = h;
            while hi - lo > 1e-6 * hi {
                let mid = 0.5 * (lo + hi);
                if rk4_gain_sq(lambda * mid) < 1.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return lo;
        }
        lo = h;
    }
    lo
}

/// The RK4 step estimate on the frozen vertex dynamics: min over the
/// eigenvalues λ of every F_{l,m,i,j} of the largest stable step for
/// hλ. An estimate, labelled as such: frozen-parameter linear stability,
/// not a proof for the time-varying nonlinear error dynamics.
pub fn step_estimate_rk4(fs: &[(String, DMatrix<f64>)]) -> f64 {
    fs.iter()
        .flat_map(|(_, f)| f.complex_eigenvalues().iter().copied().collect::<Vec<_>>())
        .map(rk4_step_for)
        .fold(f64::INFINITY, f64::min)
}

/// The sampling figures of a design (β = α/2); `None` if no positive
/// Euler step can be proven (e.g. P not positive definite).
pub fn sampling(
    model: &PolytopicModel,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
) -> Option<Sampling> {
    if l.len() != model.nv()
        || p.shape() != (model.nx(), model.nx())
        || l.iter().any(|li| li.shape() != (model.nx(), model.ny()))
    {
        return None;
    }
    let fs = vertex_dynamics(model, gamma, l);
    let beta = alpha / 2.0;
    // A global observer's P may span many orders of magnitude (§17): the
    // step is checked in the coordinates z = D⁻¹x that balance it (P_z =
    // DPD, F_z = D⁻¹FD, exact powers of two), and failing that as given.
    let balanced = super::noise::is_global_model(model)
        .then(|| crate::model::StateScaling::of_p(p))
        .flatten()
        .and_then(|s| {
            let pz = s.p_to_z(p)?;
            let fz = fs
                .iter()
                .map(|(k, f)| {
                    let fz =
                        DMatrix::from_fn(f.nrows(), f.ncols(), |r, c| f[(r, c)] / s.d[r] * s.d[c]);
                    (k.clone(), fz)
                })
                .collect::<Vec<_>>();
            bisect_euler(&pz, &fz, beta)
        });
    let h = match balanced {
        Some(h) => h,
        None => bisect_euler(p, &fs, beta)?,
    };
    let rk4 = step_estimate_rk4(&fs);
    Some(Sampling {
        max_step_euler: h,
        beta,
        step_estimate_rk4: if rk4.is_finite() { rk4 } else { 0.0 },
    })
}

/// The bound for the continuous plant sampled at h (the report's
/// `sample.continuous_bound`), recomputed from the model and P by
/// [`crate::report::continuous`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContinuousBound {
    /// A bound on |ẍ| (2-norm of the componentwise bounds) over F × Θ and
    /// the declared rates.
    pub accel: f64,
    /// |r̄| = (h²/2)·accel: the Euler step's local truncation error bound.
    pub truncation: f64,
    /// δ = √λ_max(P)·|r̄|: the disturbance per step in the norm √V.
    pub delta: f64,
    /// True if δ ≤ 1 − √(1 − hα): the certified set {V ≤ 1} stays
    /// invariant for the continuous plant, and the bounds below hold.
    pub invariant: bool,
    /// The ultimate bound on √V(e_k): δ / (1 − √(1 − hα)).
    pub ultimate_v_sqrt: f64,
    /// The ultimate bound on ‖e_k‖ (2-norm): ultimate_v_sqrt / √λ_min(P).
    pub ultimate_error: f64,
    /// True if every scheduling parameter and every input declares a
    /// `rate`; false: those without one are assumed constant over each step.
    pub rates_declared: bool,
    /// True for the global observer of an LPV plant: its discrete decrease
    /// holds for every e, so the recursion, and the ultimate bound, hold
    /// from any e(0) without δ ≤ 1 − ρ (docs/method.md §16).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub global: bool,
    /// With the design's certified discrete noise bound (`noise = min` at
    /// h): the largest noise amplitude ν for which the bound with noise
    /// holds, ν_c = √(((1 − δ)² − ρ²)/(hσ)) (∞ for the global observer);
    /// then lim sup ‖e_k‖ ≤ `ultimate_error` + ν·`noise_per_unit`
    /// (docs/method.md §16). None: no noise bound.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "unlimited_opt"
    )]
    pub noise_amplitude_max: Option<f64>,
    /// The noise term per unit amplitude, √(σ/(α λ_min(P))): the design's
    /// own `noise.error_bound`, which adds to `ultimate_error`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_per_unit: Option<f64>,
}

/// Serde of an optional amplitude that may be unlimited: ∞ is written as
/// the string "unlimited" (JSON has no infinity).
mod unlimited_opt {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(x) if x.is_infinite() => s.serialize_str("unlimited"),
            Some(x) => s.serialize_f64(*x),
            None => s.serialize_none(),
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Amp {
        Num(f64),
        Word(String),
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        Ok(match Option::<Amp>::deserialize(d)? {
            Some(Amp::Num(x)) => Some(x),
            Some(Amp::Word(w)) if w == "unlimited" => Some(f64::INFINITY),
            Some(Amp::Word(w)) => {
                return Err(serde::de::Error::custom(format!(
                    "expected a number or \"unlimited\", found \"{w}\""
                )))
            }
            None => None,
        })
    }
}

impl ContinuousBound {
    /// Adds the design's certified discrete noise bound σ (docs/method.md
    /// §16, "with noise"): ‖e_{k+1}‖_P ≤ √(ρ²‖e_k‖²_P + hσν²) + δ, whose
    /// fixed point is at most δ/(1 − ρ) + ν√(σ/α) (the two bounds add), and
    /// {V ≤ 1} stays invariant while √(ρ² + hσν²) + δ ≤ 1.
    pub(crate) fn with_noise(mut self, (h, alpha): (f64, f64), sigma: f64, per_unit: f64) -> Self {
        self.noise_amplitude_max = Some(self.amplitude_limit((h, alpha), sigma));
        self.noise_per_unit = Some(per_unit);
        self
    }

    /// ν_c for a discrete noise bound σ at (h, α): the largest noise
    /// amplitude with √(ρ² + hσν²) + δ ≤ 1 (0 if none; ∞ for the global
    /// observer, whose recursion holds for every e).
    pub(crate) fn amplitude_limit(&self, (h, alpha): (f64, f64), sigma: f64) -> f64 {
        let room = (1.0 - self.delta).powi(2) - (1.0 - h * alpha);
        match (self.global, room > 0.0) {
            (true, _) => f64::INFINITY,
            (false, true) => (room / (h * sigma)).sqrt(),
            (false, false) => 0.0,
        }
    }

    /// Whether the ultimate bound holds: δ ≤ 1 − ρ (the certified set stays
    /// invariant), or the global observer, whose recursion holds for every e.
    pub fn holds(&self) -> bool {
        self.invariant || self.global
    }

    /// The assumptions behind the bound, in words.
    pub fn assumption(&self) -> &'static str {
        if self.rates_declared {
            "x(t) in F between samples, θ(t) in Θ and u(t) in its range within their declared rates, y, u and θ sampled at t_k"
        } else {
            "x(t) in F between samples; θ and u constant over each step where no `rate` is declared (sample-and-hold), u(t) in its declared range, y, u and θ sampled at t_k"
        }
    }
}
