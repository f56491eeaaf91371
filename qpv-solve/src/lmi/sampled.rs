//! The discrete decrease family of a `sample = h` design (docs/method.md
//! §16), assembled in place of the continuous rate family (S5).
//!
//! In model units the block of rate combination c (weights w_t, W = Σ w_t)
//! at the pair (i, j) is [W(1 − hα)P, Mᵀ; M, WP] ⪰ 0 with
//! M = WP + h Σ_t w_t Φ_t, Φ = PA_l − Γ_l C_m + (P R_{l,i,j} − Γ_l S_{m,i,j})/γ.
//! In the scaled variables (P = sP̂, Γ_l = sΓ̂_l, divided by s) and in the
//! notation of [`Problem::site_kh`] at α = 0 (K₀ = Σ_t w_t(γA_l + R),
//! H_l = Σ_t w_t(γC_m + S)), γΦ/s = P̂K₀ − Σ_l Γ̂_l H_l, so
//!
//! ```text
//!     [ W(1 − hα)P̂                    Mᵀ ]
//!     [ M = WP̂ + (h/γ)(P̂K₀ − Σ Γ̂_l H_l)   WP̂ ]  − δ I ⪰ 0,
//! ```
//!
//! a PSD(2nx) block. Its Schur complement is, to first order in h,
//! (h/γ)·(−He{P̂K − Γ̂H}) — the continuous block times h/γ — so the margin
//! δ = ε t/(1 + t) with t = hκ/γ (κ = [`Problem::rate_scale`]) matches the
//! continuous margin εκ for small h and stays below the scale of P̂ for
//! large h. The max-margin column (if any) sits on the top-left block:
//! [W(1 − hα)P̂ − t̂ c Ŵ, Mᵀ; M, WP̂] ⪰ 0 with c = t/(1 + t), Ŵ the metric
//! of [`super::Objective::MaxMargin`]: t̂ > 0 leaves room for a larger α.

use super::blocks::{p_units, RateMargins};
use super::noise::ComboNoise;
use super::Problem;
use crate::backend::builder::{Psd, SdpBuilder};
use crate::error::SolveError;
use crate::model::noise::NoiseChannels;
use nalgebra::DMatrix;
use qpv_dsl::Conditions;

impl Problem<'_> {
    /// The same problem at the sample period h (None: continuous time):
    /// the rate family becomes the discrete decrease: the full family, or
    /// its decoupled form (lmi/sampled_decoupled.rs). The cube relaxation
    /// has no discrete form.
    pub fn with_sample(mut self, h: Option<f64>) -> Result<Self, SolveError> {
        if let Some(h) = h {
            if !(h.is_finite() && h > 0.0) {
                return Err(SolveError::Unsupported(format!(
                    "sample = {h}: the sample period must be a positive finite number of seconds"
                )));
            }
            if !matches!(self.conditions, Conditions::Full | Conditions::Decoupled) {
                return Err(SolveError::Unsupported(format!(
                    "sample = {h} needs the full or decoupled vertex conditions, not conditions = {}: the discrete decrease has no cube form in qpv",
                    self.conditions.name()
                )));
            }
        }
        self.sample = h;
        Ok(self)
    }

    /// Moves a problem already validated for a sampled design to another
    /// sample period (the failure note's search over h; positive finite h).
    pub(crate) fn set_sample(&mut self, h: f64) {
        debug_assert!(self.sample.is_some() && h.is_finite() && h > 0.0);
        self.sample = Some(h);
    }

    /// The sample period of a sampled design, if any.
    pub fn sample(&self) -> Option<f64> {
        self.sample
    }

    /// c = t/(1 + t), t = hκ/γ: the margin factor of the discrete blocks.
    fn sampled_factor(&self, alpha: f64, gamma: f64, h: f64) -> f64 {
        let t = h * self.rate_scale(alpha, gamma) / gamma;
        t / (1.0 + t)
    }

    /// The margin δ of a discrete block, in the block's units, for the
    /// rate margin `eps` = εκ: δ = (eps/κ)·c with c the margin factor
    /// (0 where κ is 0).
    fn sampled_margin(&self, eps: f64, alpha: f64, gamma: f64, h: f64) -> f64 {
        let kappa = self.rate_scale(alpha, gamma);
        if kappa > 0.0 {
            eps / kappa * self.sampled_factor(alpha, gamma, h)
        } else {
            0.0
        }
    }

    /// The discrete family: one block per (combination, i, j), PSD(2nx)
    /// [W(1 − hα)P̂, Mᵀ; M, WP̂] − δI ⪰ 0 (the max-margin column, if any, on
    /// its top-left block), or with `noise` the PSD(2nx + k) noise block
    /// [W(1 − hα)P̂, 0, Mᵀ; 0, Wσ̂I, √h Ĝᵀ; M, √h Ĝ, WP̂] − δI ⪰ 0 with
    /// Ĝ = [P̂ B_w, −Σ_l w_l Γ̂_l E] (the model-unit block divided by s;
    /// σ̂ = σ/s; docs/method.md §16, "Noise at the sample period").
    pub(super) fn push_rate_sampled(
        &self,
        out: &mut SdpBuilder,
        (alpha, gamma, h): (f64, f64, f64),
        rate: &RateMargins,
        noise: Option<&SampledNoise<'_>>,
    ) {
        let nx = self.nx;
        let outs = noise.map_or(Vec::new(), |n| n.channels.noisy_outputs(self.ny));
        let nw = noise.map_or(0, |n| n.channels.n_w());
        let k = nw + outs.len();
        let (d, x2, sh) = (2 * nx + k, nx + k, h.sqrt());
        let kappa = self.rate_scale(alpha, gamma);
        let c = self.sampled_factor(alpha, gamma, h);
        // rate.eps is ε κ (0 for the max-margin objective).
        let delta = self.sampled_margin(rate.eps, alpha, gamma, h);
        let cn: Vec<ComboNoise> = self
            .combos
            .iter()
            .map(|combo| ComboNoise::of(combo, noise.map(|n| n.channels), nx, self.nv))
            .collect();
        let mut dm = DMatrix::<f64>::zeros(d, d);
        for site in self.rate_sites(false) {
            let cn = &cn[site.c];
            let (k0, hs) = self.site_kh(0.0, gamma, site);
            let blk = out.psd(d, delta);
            let at = PColumns {
                w: cn.wsum,
                k0: &k0,
                alpha,
                gamma,
                h,
                x2,
            };
            // P̂ columns: −∂block/∂P̂_v (with the noise block's P̂ B_w column).
            self.push_p_columns(out, &blk, &mut dm, &at, |e, dm| {
                if nw > 0 {
                    let eb = e * &cn.bw * sh;
                    dm.view_mut((x2, nx), (nx, nw)).copy_from(&eb);
                    dm.view_mut((nx, x2), (nw, nx)).copy_from(&eb.transpose());
                }
            });
            // Γ̂_l columns: ∂M/∂Γ̂_l[gr, gc] = −(h/γ) E_{gr,gc} H_l, and the
            // noise columns −√h w_l E.
            for (l, &wl_l) in cn.wl.iter().enumerate() {
                let hl = hs.iter().find(|(g, _)| *g == l).map(|(_, h)| h);
                if hl.is_none() && wl_l == 0.0 {
                    continue;
                }
                for gr in 0..nx {
                    for gc in 0..self.ny {
                        dm.fill(0.0);
                        if let Some(hl) = hl {
                            for b in 0..nx {
                                let v = -(h / gamma) * hl[(gc, b)];
                                dm[(x2 + gr, b)] = v;
                                dm[(b, x2 + gr)] = v;
                            }
                        }
                        if let Some(pos) = outs.iter().position(|&o| o == gc) {
                            let v = -sh * wl_l;
                            dm[(x2 + gr, nx + nw + pos)] = v;
                            dm[(nx + nw + pos, x2 + gr)] = v;
                        }
                        out.matrix(&blk, self.gvar(l, gr, gc), &dm, -1.0);
                    }
                }
            }
            if let Some(noise) = noise {
                dm.fill(0.0);
                for t in nx..nx + k {
                    dm[(t, t)] = cn.wsum;
                }
                out.matrix(&blk, noise.svar, &dm, -1.0);
            }
            if let Some(mc) = rate.column {
                // The top-left nx block of a 2nx svec has the same packed
                // indices as an nx svec: coef = svec(κŴ), times c/κ.
                let scale = if kappa > 0.0 { c / kappa } else { 0.0 };
                for (idx, &v) in mc.coef.iter().enumerate() {
                    out.a(blk.row0 + idx, mc.var, v * scale);
                }
            }
        }
    }
}

/// Where a discrete block's P̂ columns are written: the combination's
/// weight w, the rate term K₀ of the pair, (α, γ, h), and the first row x2
/// of the block's last nx rows (the P̂ that closes the Schur complement).
struct PColumns<'a> {
    w: f64,
    k0: &'a DMatrix<f64>,
    alpha: f64,
    gamma: f64,
    h: f64,
    x2: usize,
}

impl Problem<'_> {
    /// The P̂ columns of one discrete block, −∂block/∂P̂_v for every packed
    /// entry v = (r, c): W(1 − hα)E top left, WE bottom right and
    /// M = WE + (h/γ)E K₀ off the diagonal, plus what `extra` writes for
    /// the same E (the noise block's P̂ B_w column).
    fn push_p_columns(
        &self,
        out: &mut SdpBuilder,
        blk: &Psd,
        dm: &mut DMatrix<f64>,
        at: &PColumns<'_>,
        extra: impl Fn(&DMatrix<f64>, &mut DMatrix<f64>),
    ) {
        let (nx, x2, w) = (self.nx, at.x2, at.w);
        for (v, e) in p_units(nx) {
            dm.fill(0.0);
            let m = &e * w + &e * at.k0 * (at.h / at.gamma);
            dm.view_mut((0, 0), (nx, nx))
                .copy_from(&(&e * (w * (1.0 - at.h * at.alpha))));
            dm.view_mut((x2, x2), (nx, nx)).copy_from(&(&e * w));
            dm.view_mut((x2, 0), (nx, nx)).copy_from(&m);
            dm.view_mut((0, x2), (nx, nx)).copy_from(&m.transpose());
            extra(&e, dm);
            out.matrix(blk, v, dm, -1.0);
        }
    }
}

/// The noise part of a discrete noise block: the channels and σ̂'s column.
pub(super) struct SampledNoise<'a> {
    pub(super) channels: &'a NoiseChannels,
    pub(super) svar: usize,
}
