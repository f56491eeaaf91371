//! The family of blocks that holds the rate of decay, chosen once per
//! assembly: the full vertex-pair family, its decoupled or cube
//! relaxation, the discrete decrease of a sampled design, or the noise
//! blocks (continuous or sampled) in its place.

use super::blocks::{RateFamily, RateMargins};
use super::sampled::SampledNoise;
use super::Problem;
use crate::backend::builder::SdpBuilder;
use qpv_dsl::Conditions;

impl Problem<'_> {
    /// The rate family at (α, γ): the noise blocks (continuous or at the
    /// sample period) with σ̂ declared after the other variables and
    /// minimised, or the decay family of the problem's
    /// conditions (the discrete decrease for a sampled design).
    pub(super) fn push_rate(
        &self,
        out: &mut SdpBuilder,
        (alpha, gamma): (f64, f64),
        family: RateFamily,
        rate: &RateMargins,
    ) {
        match family {
            RateFamily::Noise(channels) => {
                let svar = out.var("sigma");
                match self.sample {
                    Some(h) => {
                        let noise = SampledNoise { channels, svar };
                        self.push_rate_sampled(out, (alpha, gamma, h), rate, Some(&noise));
                    }
                    None => self.push_rate_noise(out, (alpha, gamma), channels, svar, rate.eps),
                }
                out.cost(svar, 1.0);
            }
            RateFamily::Decay => match (self.conditions, self.sample) {
                (Conditions::Full | Conditions::Auto, Some(h)) => {
                    self.push_rate_sampled(out, (alpha, gamma, h), rate, None)
                }
                (Conditions::Full | Conditions::Auto, None) => {
                    self.push_rate_full(out, alpha, gamma, rate)
                }
                (Conditions::Decoupled, Some(h)) => {
                    self.push_rate_sampled_decoupled(out, (alpha, gamma, h), rate)
                }
                (Conditions::Decoupled, None) => self.push_rate_decoupled(out, alpha, gamma, rate),
                (Conditions::Cube, _) => self.push_rate_cube(out, alpha, gamma, rate),
            },
        }
    }

    /// Full rate family: −He{P̂K − Γ̂H} − ε κ I ⪰ 0 per (combination, i, j),
    /// one block for a linear combination (every pair has the same block):
    /// b = −ε_rate svec(I), A[v] = svec(∂F/∂v).
    pub(super) fn push_rate_full(
        &self,
        out: &mut SdpBuilder,
        alpha: f64,
        gamma: f64,
        rate: &RateMargins,
    ) {
        let mut df = vec![0.0; self.nx * self.nx];
        for site in self.rate_sites(true) {
            let kh = self.site_kh(alpha, gamma, site);
            let blk = out.psd(self.nx, rate.eps);
            self.push_he_block(out, &blk, &kh, &mut df);
            rate.push_column(out, &blk);
        }
    }

    /// Decoupled rate family, per combination c: F0_c + G_c(x_i) + Ẑ_c ⪯ −ε κ I
    /// (the margin, and the max-margin column, sit here), then
    /// H_c(x_j) − Ẑ_c ⪯ 0.
    fn push_rate_decoupled(
        &self,
        out: &mut SdpBuilder,
        alpha: f64,
        gamma: f64,
        rate: &RateMargins,
    ) {
        let p_reg = self.xs_hat.len();
        let mut df = vec![0.0; self.nx * self.nx];
        for c in 0..self.combos.len() {
            for i in 0..p_reg {
                let kh = self.decoupled_e_kh(alpha, gamma, c, i);
                let blk = out.psd(self.nx, rate.eps);
                self.push_he_block(out, &blk, &kh, &mut df);
                self.push_sym_var(out, &blk, self.zvar(c, 0), 1.0);
                rate.push_column(out, &blk);
            }
            for j in 0..p_reg {
                let kh = self.decoupled_x_kh(c, j);
                let blk = out.psd(self.nx, 0.0);
                self.push_he_block(out, &blk, &kh, &mut df);
                self.push_sym_var(out, &blk, self.zvar(c, 0), -1.0);
            }
        }
    }
}
