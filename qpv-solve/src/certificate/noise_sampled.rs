//! The discrete noise bound of a `sample = h` design (docs/method.md §16,
//! "Noise at the sample period"), recomputed from P and the gains.
//!
//! With measurement noise v on the noisy outputs (columns E) and a process
//! disturbance w, both held over a step, the Euler error map is
//! e⁺ = (I + hF)e + hGd, d = (w, v), G = [B_w, −L E]. The claim
//!
//! ```text
//!     V(e⁺) − (1 − hα) V(e) ≤ h σ (|w|² + |v|²)     for e ∈ E, x ∈ F, θ ∈ Θ, all w, v
//! ```
//!
//! is, after a Schur complement and the congruence diag(I, I/√h, I), the
//! block LMI (model units, rate combination with weights w_t, W = Σ w_t)
//!
//! ```text
//!     [ W(1 − hα)P     0        Mᵀ    ]
//!     [ 0              WσI      √h Gᵀ ]  ⪰ 0,
//!     [ M              √h G     WP    ]
//! ```
//!
//! M = WP + hΣ_t w_t Φ_t the discrete decrease's (S5d) and
//! G = Σ_t w_t [P B_w,l_t, −Γ_l_t E]. For fixed P, Γ_l it holds iff
//! (Schur complement on WP) S₁₁ = W(1 − hα)P − R₁₁ ≻ 0 and
//! σ ≥ λ_max(R₂₂ + R₂₁S₁₁⁻¹R₁₂)/W, R = XᵀP⁻¹X/W, X = [M, √h G]:
//! [`SampledNoise::sigma_min`]. [`SampledNoise::check`] re-checks the
//! whole block by its smallest eigenvalue, not by that formula. The bound's
//! figures are those of the continuous claim: V_k ≤ (1 − hα)^k V_0 +
//! (σν²/α)(1 − (1 − hα)^k), {V ≤ 1} invariant for ν ≤ √(α/σ).

use super::noise::{bound_from, BalancedGlobal, NoiseBound, NoiseCheck};
use super::rate::Terms;
use super::sampled::block;
use crate::conditions::{pair_suffix, rate_combos, Combo};
use crate::model::is_double_sum;
use crate::model::noise::NoiseChannels;
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// The discrete noise claim at (α, γ, h) on a model's noise channels.
#[derive(Debug, Clone, Copy)]
pub struct SampledNoise<'a> {
    /// The observer model the gains belong to.
    pub model: &'a PolytopicModel,
    /// Where noise and disturbances enter.
    pub channels: &'a NoiseChannels,
    /// The rate α per second.
    pub alpha: f64,
    /// The region scaling γ.
    pub gamma: f64,
    /// The sample period h.
    pub h: f64,
}

/// One block's pieces: the 3 × 3 block matrix at σ = 0, the sizes.
struct Parts {
    m: DMatrix<f64>,
    nx: usize,
    k: usize,
    w: f64,
    size: f64,
}

impl SampledNoise<'_> {
    /// The inputs fit the model and the claim's ranges.
    fn fits(&self, p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> Result<(), String> {
        let m = self.model;
        self.channels.validate(m).map_err(|e| e.to_string())?;
        crate::conditions::validate(m).map_err(|e| e.to_string())?;
        if gammas.len() != m.nv()
            || p.shape() != (m.nx(), m.nx())
            || gammas.iter().any(|g| g.shape() != (m.nx(), m.ny()))
        {
            return Err("P or the gains do not fit the model".into());
        }
        let (a, g, h) = (self.alpha, self.gamma, self.h);
        let g_ok = super::noise::gamma_in_range(m, g);
        if !(a.is_finite() && a > 0.0 && g_ok && h > 0.0 && h * a < 1.0) {
            return Err(format!("α = {a}, γ = {g}, h = {h} out of range"));
        }
        Ok(())
    }

    /// Every block at σ = 0, with its label.
    fn blocks(&self, p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> Vec<(Parts, String)> {
        let model = self.model;
        let (nx, h) = (model.nx(), self.h);
        let outs = self.channels.noisy_outputs(model.ny());
        let nw = self.channels.n_w();
        let k = nw + outs.len();
        let xs = &model.region.vertices;
        let terms = Terms::new(model, xs, p, gammas, &[], self.gamma);
        let double = is_double_sum(model);
        let mut out = Vec::new();
        for combo in rate_combos(model) {
            let g = self.coupling(p, gammas, &combo, &outs);
            let w = combo.weight();
            for i in 0..xs.len() {
                for j in 0..xs.len() {
                    let (b, size) = block(&terms, &combo, self.alpha, h, (i, j));
                    let n = 2 * nx + k;
                    let mut m = DMatrix::zeros(n, n);
                    m.view_mut((0, 0), (nx, nx))
                        .copy_from(&b.view((0, 0), (nx, nx)));
                    m.view_mut((nx + k, 0), (nx, nx))
                        .copy_from(&b.view((nx, 0), (nx, nx)));
                    m.view_mut((0, nx + k), (nx, nx))
                        .copy_from(&b.view((0, nx), (nx, nx)));
                    m.view_mut((nx + k, nx + k), (nx, nx))
                        .copy_from(&b.view((nx, nx), (nx, nx)));
                    let sg = &g * h.sqrt();
                    m.view_mut((nx + k, nx), (nx, k)).copy_from(&sg);
                    m.view_mut((nx, nx + k), (k, nx)).copy_from(&sg.transpose());
                    let label = format!("{}{}", combo.label(double), pair_suffix(model, i, j));
                    let size = size + 2.0 * sg.norm();
                    out.push((Parts { m, nx, k, w, size }, label));
                }
            }
        }
        out
    }

    /// G = Σ_t w_t [P B_w,l_t, −Γ_l_t E] of a combination (model units).
    fn coupling(
        &self,
        p: &DMatrix<f64>,
        gammas: &[DMatrix<f64>],
        combo: &Combo,
        outs: &[usize],
    ) -> DMatrix<f64> {
        let nx = p.nrows();
        let nw = self.channels.n_w();
        let mut g = DMatrix::zeros(nx, nw + outs.len());
        for &(l, _, w) in &combo.terms {
            if let Some(b) = &self.channels.b_w {
                let mut v = g.view_mut((0, 0), (nx, nw));
                v += p * &b[l] * w;
            }
            for (c, &o) in outs.iter().enumerate() {
                for r in 0..nx {
                    g[(r, nw + c)] -= w * gammas[l][(r, o)];
                }
            }
        }
        g
    }

    /// The smallest σ for which every block holds for these (P, Γ_l), by
    /// the Schur complements of the module doc (no margin); None if some
    /// block fails for every σ (the discrete decrease itself fails) or the
    /// input does not fit.
    pub(crate) fn sigma_min(&self, p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> Option<f64> {
        self.fits(p, gammas).ok()?;
        let mut worst: f64 = 0.0;
        for (b, _) in self.blocks(p, gammas) {
            let (nx, k) = (b.nx, b.k);
            let wp = b.m.view((nx + k, nx + k), (nx, nx)).into_owned();
            let x = b.m.view((nx + k, 0), (nx, nx + k)).into_owned();
            let ch = wp.cholesky()?;
            let y = ch.l().solve_lower_triangular(&x)?;
            let r = y.transpose() * &y;
            let s11 = b.m.view((0, 0), (nx, nx)) - r.view((0, 0), (nx, nx));
            let s11 = s11.cholesky()?;
            let r12 = r.view((0, nx), (nx, k)).into_owned();
            let z = s11.l().solve_lower_triangular(&r12)?;
            let t = r.view((nx, nx), (k, k)) + z.transpose() * &z;
            let lmax = if k == 0 {
                0.0
            } else {
                t.symmetric_eigenvalues().max()
            };
            if !lmax.is_finite() {
                return None;
            }
            worst = worst.max(lmax / b.w);
        }
        Some(worst)
    }

    /// The independent check of the block LMI at σ: the smallest
    /// eigenvalue of every whole block (positive margin = satisfied).
    pub fn check(&self, p: &DMatrix<f64>, gammas: &[DMatrix<f64>], sigma: f64) -> NoiseCheck {
        let fail = |why: String| NoiseCheck {
            margin: -f64::MAX,
            guard: 0.0,
            passed: false,
            worst_at: why,
            count: 0,
        };
        if let Err(e) = self.fits(p, gammas) {
            return fail(e);
        }
        if !(sigma.is_finite() && sigma > 0.0) {
            return fail(format!("σ = {sigma} out of range"));
        }
        let mut out = NoiseCheck {
            margin: f64::INFINITY,
            guard: 0.0,
            passed: true,
            worst_at: String::new(),
            count: 0,
        };
        for (mut b, label) in self.blocks(p, gammas) {
            for d in b.nx..b.nx + b.k {
                b.m[(d, d)] = b.w * sigma;
            }
            let n = b.m.nrows();
            let e = b.m.clone().symmetric_eigenvalues();
            let margin = if e.iter().any(|v| v.is_nan()) {
                f64::NAN
            } else {
                e.min()
            };
            let size = b.size + (b.w * sigma).abs() * (b.k as f64).sqrt();
            let guard = 32.0 * f64::EPSILON * (n as f64 + 1.0) * (size + b.m.norm());
            out.record(margin, guard, || label);
        }
        out.passed &= out.count > 0;
        out
    }

    /// σ for these (P, Γ_l) with the margin the check needs:
    /// [`SampledNoise::sigma_min`] times (1 + δ), δ = 1e-6 raised tenfold
    /// (to 1e-2 at most) until [`SampledNoise::check`] passes.
    pub(crate) fn sigma_for(
        &self,
        p: &DMatrix<f64>,
        gammas: &[DMatrix<f64>],
    ) -> Option<(f64, NoiseCheck)> {
        // A global observer's blocks in balanced coordinates, exactly
        // congruent (certificate::noise::BalancedGlobal), else as given.
        BalancedGlobal::of(self.model, self.channels, p, gammas)
            .and_then(|z| {
                let zs = SampledNoise {
                    model: &z.model,
                    channels: &z.channels,
                    ..*self
                };
                zs.sigma_for_plain(&z.p, &z.gammas)
            })
            .or_else(|| self.sigma_for_plain(p, gammas))
    }

    /// [`SampledNoise::sigma_for`] in the coordinates given.
    fn sigma_for_plain(
        &self,
        p: &DMatrix<f64>,
        gammas: &[DMatrix<f64>],
    ) -> Option<(f64, NoiseCheck)> {
        let base = self.sigma_min(p, gammas)?.max(f64::MIN_POSITIVE);
        let mut delta = 1e-6;
        while delta <= 1.01e-2 {
            let sigma = base * (1.0 + delta);
            let c = self.check(p, gammas, sigma);
            if c.passed {
                return Some((sigma, c));
            }
            delta *= 10.0;
        }
        None
    }

    /// The noise bound of gains L_l with Lyapunov matrix P (Γ_l = P L_l
    /// recomputed): σ from [`SampledNoise::sigma_for`], checked, and the
    /// figures of the report's `noise` key.
    pub fn bound(&self, p: &DMatrix<f64>, l: &[DMatrix<f64>]) -> Option<NoiseBound> {
        if l.iter().any(|li| li.nrows() != p.ncols()) {
            return None;
        }
        let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| p * li).collect();
        let (sigma, check) = self.sigma_for(p, &gammas)?;
        bound_from(self.model, self.channels, self.alpha, p, sigma, check)
    }
}
