//! The certified RMS bound of a `noise = rms` design: the steady-state
//! mean-square error under white output (and process) noise, recomputed
//! from P and the gains L_l alone (docs/method.md, "RMS-optimal gains").
//!
//! With white output noise v of intensity R = diag(s_k² dt) on the noisy
//! outputs and white process noise w of intensity Q = diag(q_k² dt) (samples
//! of standard deviation s_k, q_k drawn every dt and held), the error obeys
//! de = F(θ, e, x) e dt − L(θ) dv + dw. By Itô's formula on V = eᵀPe,
//!
//! ```text
//!     d E[V]/dt = E[eᵀ He{P F} e] + E[tr(P (Q + L(θ) R L(θ)ᵀ))].
//! ```
//!
//! At every θ-vertex l and region-vertex pair (i, j) the rate block of (S5)
//! at α = 0 is S_lij = γ He{P F_lij}. With A_lij = −S_lij/γ ≻ 0,
//! κ = max λ_max(A_lij⁻¹) and κ_k = max (A_lij⁻¹)_kk, the blocks give
//! He{P F} ⪯ −I/κ and He{P F} ⪯ −e_k e_kᵀ/κ_k for every e in the region
//! scaled by 1/γ, x in F and θ in Θ (the blocks are affine in e, x and μ;
//! A ⪰ s u uᵀ iff s uᵀA⁻¹u ≤ 1). The noise term is convex in L, so with
//! c = max_l tr(P (Q + L_l R L_lᵀ)):
//!
//! ```text
//!     d E[V]/dt ≤ −E|e|²/κ + c,   d E[V]/dt ≤ −E[e_k²]/κ_k + c,
//! ```
//!
//! and since V ≥ 0 the time-averaged mean-square error is at most κc in
//! total and κ_k c per state: the bounds [`rms_bound`] computes (their
//! square roots are the RMS bounds the report carries). The argument is
//! pathwise (Itô), so it holds although F depends on e itself; it needs
//! the QPV terms inside their polytope, i.e. x ∈ F and e in the region
//! scaled by 1/γ, for as long as the average is taken (Gaussian noise
//! leaves any bounded set eventually: the claim is for the time before).

use crate::certificate::combo_lmi;
use crate::conditions::{is_double_sum, rate_combos};
use crate::vocab::Candidate;
use nalgebra::DMatrix;
use qpv_dsl::{Mode, PolytopicModel};
use serde::{Deserialize, Serialize};

/// The white noise an RMS bound is for: standard deviations of samples
/// drawn every `period` seconds and held (intensity std²·period).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RmsNoise {
    /// The noisy outputs (0-based), in order.
    pub outputs: Vec<usize>,
    /// The standard deviation of each noisy output's noise (one per entry
    /// of `outputs`), in the output's units.
    pub output_std: Vec<f64>,
    /// The standard deviation of the process noise on each state (empty:
    /// none), in the state's units.
    #[serde(default)]
    pub process_std: Vec<f64>,
    /// The period (seconds) at which the noise samples are drawn.
    pub period: f64,
}

impl RmsNoise {
    /// The noise of a request: `output_std` (one value for all, or one per
    /// noisy output), `process_std` (empty, one value, or one per state)
    /// and the period; an error naming what does not fit.
    pub fn new(
        outputs: Vec<usize>,
        output_std: &[f64],
        process_std: &[f64],
        period: f64,
        nx: usize,
    ) -> Result<RmsNoise, String> {
        let expand = |v: &[f64], n: usize, what: &str| -> Result<Vec<f64>, String> {
            match v.len() {
                0 => Ok(Vec::new()),
                1 => Ok(vec![v[0]; n]),
                k if k == n => Ok(v.to_vec()),
                k => Err(format!(
                    "{k} values of {what} given: expected one value for all or {n}"
                )),
            }
        };
        let no = outputs.len();
        let os = expand(output_std, no, "output_std (one per noisy output)")?;
        let ps = expand(process_std, nx, "process_std (one per state)")?;
        let good = |v: &[f64]| v.iter().all(|s| s.is_finite() && *s > 0.0);
        if os.is_empty() || !good(&os) || !good(&ps) {
            return Err("every standard deviation must be positive and finite, and \
                        output_std must be given"
                .into());
        }
        if !(period.is_finite() && period > 0.0) {
            return Err(format!(
                "noise_period = {period}: expected a positive period"
            ));
        }
        Ok(RmsNoise {
            outputs,
            output_std: os,
            process_std: ps,
            period,
        })
    }

    /// The intensity R (ny × ny, zero on noise-free outputs).
    fn r(&self, ny: usize) -> DMatrix<f64> {
        let mut r = DMatrix::zeros(ny, ny);
        for (&o, &s) in self.outputs.iter().zip(&self.output_std) {
            r[(o, o)] = s * s * self.period;
        }
        r
    }

    /// The intensity Q (nx × nx, zero without process noise).
    fn q(&self, nx: usize) -> DMatrix<f64> {
        let mut q = DMatrix::zeros(nx, nx);
        for (k, &s) in self.process_std.iter().enumerate() {
            q[(k, k)] = s * s * self.period;
        }
        q
    }

    /// Whether the noise fits a model of `nx` states and `ny` outputs.
    fn fits(&self, nx: usize, ny: usize) -> bool {
        self.outputs.len() == self.output_std.len()
            && self.outputs.iter().all(|&o| o < ny)
            && (self.process_std.is_empty() || self.process_std.len() == nx)
            && self.period.is_finite()
            && self.period > 0.0
    }
}

/// The certified RMS bound of a design ([`rms_bound`]): what the report's
/// `rms` key carries.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RmsBound {
    /// The noise the bound is for.
    pub noise: RmsNoise,
    /// √(time-averaged E|e|²) ≤ this: the certified RMS of the whole error.
    pub total: f64,
    /// √(time-averaged E[e_k²]) ≤ per_state[k], per state.
    pub per_state: Vec<f64>,
    /// κ: He{P F} ⪯ −I/κ on the polytope (from P and the gains).
    pub kappa: f64,
    /// c = max_l tr(P (Q + L_l R L_lᵀ)): the noise power V receives.
    pub power: f64,
}

/// The RMS bound of (P, L_l) at γ for `noise`, from the rate blocks of (S5)
/// at α = 0 and the vertex gains (module doc). None if a block is not
/// negative definite, the output map depends on θ (the double sum is not a
/// convex combination of its blocks), or the input does not fit.
pub fn rms_bound(
    model: &PolytopicModel,
    noise: &RmsNoise,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
) -> Option<RmsBound> {
    let (nx, ny) = (model.nx(), model.ny());
    let shapes =
        p.shape() == (nx, nx) && l.len() == model.nv() && l.iter().all(|li| li.shape() == (nx, ny));
    if !shapes || !noise.fits(nx, ny) || is_double_sum(model) || gamma.is_nan() || gamma <= 0.0 {
        return None;
    }
    if !p.iter().chain(l.iter().flatten()).all(|v| v.is_finite()) {
        return None;
    }
    let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| p * li).collect();
    let np = model.region.vertices.len().max(1);
    let mut kappa: f64 = 0.0;
    let mut kappa_k = vec![0.0f64; nx];
    for combo in rate_combos(model) {
        for i in 0..np {
            for j in 0..np {
                let s = combo_lmi(
                    model,
                    Mode::Sound,
                    Candidate::new(0.0, gamma),
                    p,
                    &gammas,
                    &combo,
                    (i, j),
                );
                let a = (-s / (gamma * combo.weight())).symmetrize();
                let inv = a.clone().cholesky()?.inverse();
                let lmin = a.symmetric_eigenvalues().min();
                if lmin.is_nan() || lmin <= 0.0 {
                    return None;
                }
                kappa = kappa.max(1.0 / lmin);
                for (k, kk) in kappa_k.iter_mut().enumerate() {
                    *kk = kk.max(inv[(k, k)]);
                }
            }
        }
    }
    let (r, q) = (noise.r(ny), noise.q(nx));
    let tq = (p * &q).trace();
    let power = l
        .iter()
        .map(|li| tq + (li.transpose() * p * li * &r).trace())
        .fold(0.0, f64::max);
    let total_ms = kappa.min(kappa_k.iter().sum()) * power;
    let per_state: Vec<f64> = kappa_k.iter().map(|k| (k * power).sqrt()).collect();
    let total = total_ms.sqrt();
    (total.is_finite() && per_state.iter().all(|v| v.is_finite())).then(|| RmsBound {
        noise: noise.clone(),
        total,
        per_state,
        kappa,
        power,
    })
}

trait Symmetrize {
    fn symmetrize(self) -> Self;
}

impl Symmetrize for DMatrix<f64> {
    /// (M + Mᵀ)/2.
    fn symmetrize(self) -> Self {
        (&self + self.transpose()) * 0.5
    }
}

/// The data check "rms" of a report's claimed bound: the bound recomputed
/// from P and L_l ([`rms_bound`]) must not exceed the claim, in total and
/// per state (a relative tolerance of 1e-9 for the rounding of the JSON).
pub fn rms_check(
    model: &PolytopicModel,
    claimed: &RmsBound,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
) -> crate::certificate::DataCheck {
    let desc = "rms: the RMS bound recomputed from P and L_l (Itô on V = eᵀPe, docs/method.md) \
                ≤ the claimed one, in total and per state";
    let got = rms_bound(model, &claimed.noise, gamma, p, l);
    // The worst ratio recomputed/claimed over the total and the states.
    let ratio = match &got {
        Some(b) if b.per_state.len() == claimed.per_state.len() => {
            std::iter::once((b.total, claimed.total))
                .chain(
                    b.per_state
                        .iter()
                        .copied()
                        .zip(claimed.per_state.iter().copied()),
                )
                .map(|(g, c)| {
                    if c > 0.0 && c.is_finite() {
                        g / c
                    } else {
                        f64::INFINITY
                    }
                })
                .fold(0.0, f64::max)
        }
        _ => f64::INFINITY,
    };
    let value = if ratio.is_finite() { ratio } else { f64::MAX };
    let bound = 1.0 + 1e-9;
    crate::certificate::DataCheck {
        value,
        bound,
        margin: bound - value,
        passed: value <= bound,
        required: true,
        description: desc.to_string(),
    }
}
