//! The certified envelopes a run is compared with: ‖e(t)‖ ≤ √cond(P)
//! ‖e(0)‖ e^{−αt/2} ([`envelope_factor`], as RK4 resolves it), the bound
//! under measurement noise ([`NoiseEnvelope`]), and the arithmetic's floor
//! below which nothing is compared.

use nalgebra::DMatrix;

/// √cond(P) = √(λ_max/λ_min) of a Lyapunov matrix: V(t) ≤ V(0)e^{−αt} with
/// V = eᵀPe gives ‖e(t)‖ ≤ √cond(P) ‖e(0)‖ e^{−αt/2}, the certified error
/// envelope drawn in the figures. `None` if P is not positive definite.
pub fn envelope_factor(p: &DMatrix<f64>) -> Option<f64> {
    if p.is_empty() || !p.is_square() || !p.iter().all(|v| v.is_finite()) {
        return None;
    }
    let eig = nalgebra::SymmetricEigen::new(p.clone()).eigenvalues;
    let (lo, hi) = (eig.min(), eig.max());
    (lo > 0.0).then(|| (hi / lo).sqrt())
}

/// Units in the last place the rounding of one step of a run may leave
/// in the computed error x − x̂ (per state, relative to the state scale).
const FLOOR_ULPS: f64 = 16.0;

/// The resolution of a run in f64 below which a certified envelope or
/// bound is not compared: the computed error x − x̂ carries a rounding of
/// a few ulps of the state scale at each step (`scale` = the largest |x_i|
/// or |x̂_i| seen so far), which the error dynamics, contracting at α/2 per
/// second in the P-norm, accumulate to at most that per-step rounding
/// times 1 + 2/(α·dt) steps, and √cond(P) (`kf`) turns back into the
/// Euclidean norm. A run whose error is below this floor has converged to
/// the arithmetic's resolution and is never reported as leaving its
/// envelope.
pub(crate) fn arithmetic_floor(kf: f64, alpha: f64, dt: f64, scale: f64) -> f64 {
    let steps = 1.0 + 2.0 / (alpha * dt).max(f64::MIN_POSITIVE);
    kf * FLOOR_ULPS * f64::EPSILON * scale * steps
}

/// The certified bound on ‖e(t)‖ of a design with a noise bound
/// ([`crate::report::NoiseBound`]: V' + αV ≤ σ|v|²) under measurement
/// noise of amplitude ν ≤ ν_max: V(t) ≤ e^{−αt}V(0) + (σν²/α)(1 − e^{−αt})
/// and ‖e‖ ≤ √(V/λ_min(P)), which tends to ν times the bound's
/// `error_bound` per unit amplitude.
#[derive(Debug, Clone, Copy)]
pub struct NoiseEnvelope {
    /// V(0) = e(0)ᵀ P e(0).
    v0: f64,
    /// Decay rate α.
    alpha: f64,
    /// λ_min(P).
    lambda_min: f64,
    /// The ultimate bound lim sup ‖e‖ ≤ ν · error_bound.
    ultimate: f64,
}

impl NoiseEnvelope {
    /// The envelope of P (the design's, as its noise bound was computed
    /// with), e(0), α and the bound at amplitude ν; `None` if P is not
    /// positive definite or does not fit e(0).
    pub fn new(
        p: &DMatrix<f64>,
        e0: &[f64],
        alpha: f64,
        bound: &crate::certificate::noise::NoiseBound,
        nu: f64,
    ) -> Option<Self> {
        if p.is_empty() || !p.is_square() || e0.len() != p.nrows() {
            return None;
        }
        if !p.iter().all(|v| v.is_finite()) {
            return None;
        }
        let ps = (p + p.transpose()) * 0.5;
        let lambda_min = ps.symmetric_eigenvalues().min();
        if lambda_min.is_nan() || lambda_min <= 0.0 {
            return None;
        }
        let e = nalgebra::DVector::from_column_slice(e0);
        Some(NoiseEnvelope {
            v0: e.dot(&(p * &e)),
            alpha,
            lambda_min,
            ultimate: nu * bound.error_bound,
        })
    }

    /// The bound on ‖e(t)‖.
    pub fn at(&self, t: f64) -> f64 {
        let d = (-self.alpha * t).exp();
        (d * self.v0 / self.lambda_min + (1.0 - d) * self.ultimate * self.ultimate).sqrt()
    }

    /// The ultimate bound lim sup ‖e(t)‖ ≤ ν √(σ/(α λ_min(P))).
    pub fn ultimate(&self) -> f64 {
        self.ultimate
    }
}

/// The envelope's decay e^{−αt/2} as RK4 at step `dt` resolves it: a mode
/// decaying at α/2 is multiplied by R(−dtα/2) per step, R(z) = 1 + z +
/// z²/2 + z³/6 + z⁴/24, which lies above e^z for z < 0 (on the real modes
/// RK4 resolves, |z| < 1.5, every faster mode falls faster still): the run
/// is compared with what its own integrator can show, never with less.
pub(crate) fn resolved_decay(alpha: f64, dt: f64, t: f64) -> f64 {
    let exact = (-alpha * t / 2.0).exp();
    let z = -alpha * dt / 2.0;
    let r = 1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)));
    if !(r > 0.0 && r < 1.0) {
        return exact;
    }
    exact.max(r.powf(t / dt))
}
