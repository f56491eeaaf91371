//! The decoupled form of the discrete decrease (docs/method.md §16, "The
//! decoupled discrete family"): 2p blocks per rate combination in place of
//! the p² of the full family, sufficient for it.
//!
//! The full block [W(1 − hα)P, Mᵀ; M, WP] with M = WP + hΦ is congruent
//! (T = [I, 0; −I, I], constant) to h·[−He(Φ) − WαP, Φᵀ; Φ, WP/h], Φ the
//! combination's Σ_t w_t Φ_t. Φ is a sum of an e-vertex part Φ_e(x_i)
//! (the linear part, the gains' and the rows(N, x_i) terms) and an
//! x-vertex part Φ_x(x_j) (the rowsHe(N, x_j) terms). With
//! (a + b)ᵀP⁻¹(a + b) ⪯ (1 + t)aᵀP⁻¹a + (1 + 1/t)bᵀP⁻¹b (t > 0) and a
//! symmetric slack Z per combination, the two families
//!
//! ```text
//!     [ −He(Φ_e(x_i)) − WαP − Z    Φ_e(x_i)ᵀ       ]
//!     [ Φ_e(x_i)                   WP/(h(1 + t))   ]  ⪰ 0     i = 1..p
//!     [ −He(Φ_x(x_j)) + Z          Φ_x(x_j)ᵀ       ]
//!     [ Φ_x(x_j)                   WP/(h(1 + 1/t)) ]  ⪰ 0     j = 1..p
//! ```
//!
//! give, by their Schur complements added, −He(Φ) − WαP − (h/W)ΦᵀP⁻¹Φ ⪰ 0
//! at every pair (i, j): the full block. In the scaled variables, times
//! γ/s, the top-left blocks are the continuous decoupled blocks
//! ([`Problem::decoupled_e_kh`], [`Problem::decoupled_x_kh`]), the
//! off-diagonal ones P̂K₀ − Σ_l Γ̂_l H_l (K₀ at α = 0) and the bottom-right
//! ones γWP̂/(h(1 + t)) and γWP̂/(h(1 + 1/t)). The certificate re-checks the
//! full discrete family, never this relaxation.

use super::blocks::{p_units, Kh, RateMargins};
use super::Problem;
use crate::backend::builder::{Psd, SdpBuilder};

impl Problem<'_> {
    /// The decoupled discrete family at (α, γ, h): per combination c, the
    /// e-vertex blocks (the margin and the max-margin column sit there)
    /// and the x-vertex blocks, sharing the slack Ẑ_c.
    pub(super) fn push_rate_sampled_decoupled(
        &self,
        out: &mut SdpBuilder,
        (alpha, gamma, h): (f64, f64, f64),
        rate: &RateMargins,
    ) {
        let (nx, p_reg) = (self.nx, self.xs_hat.len());
        let t = self.quadratic_split(gamma);
        let mut df = vec![0.0; nx * nx];
        for c in 0..self.combos.len() {
            let w = self.combos[c].weight();
            for i in 0..p_reg {
                let blk = out.psd(2 * nx, rate.eps);
                let top = self.decoupled_e_kh(alpha, gamma, c, i);
                self.push_he_block(out, &blk, &top, &mut df);
                self.push_sym_var(out, &blk, self.zvar(c, 0), 1.0);
                let off = self.decoupled_e_kh(0.0, gamma, c, i);
                self.push_schur_columns(out, &blk, &off, gamma * w / (h * (1.0 + t)));
                rate.push_column(out, &blk);
            }
            for j in 0..p_reg {
                let blk = out.psd(2 * nx, 0.0);
                let kx = self.decoupled_x_kh(c, j);
                self.push_he_block(out, &blk, &kx, &mut df);
                self.push_sym_var(out, &blk, self.zvar(c, 0), -1.0);
                self.push_schur_columns(out, &blk, &kx, gamma * w / (h * (1.0 + 1.0 / t)));
            }
        }
    }

    /// t of the split of the quadratic term: the expected size of the
    /// x-vertex part against the e-vertex part (rowsHe(N, x_j) is about
    /// twice rows(N, x_i), whose sum the problem's `max_r_fro` bounds),
    /// in [10⁻², 1]; it changes how conservative the relaxation is, never
    /// what is certified.
    fn quadratic_split(&self, gamma: f64) -> f64 {
        let r = self.max_r_fro();
        let e = gamma * self.max_a_fro + r / 3.0;
        if e > 0.0 {
            (2.0 * r / 3.0 / e).clamp(1e-2, 1.0)
        } else {
            1.0
        }
    }

    /// The columns of the off-diagonal block P̂K₀ − Σ_l Γ̂_l H_l (rows nx..2nx,
    /// columns 0..nx) and of the bottom-right block `br`·P̂ of a 2nx block.
    fn push_schur_columns(&self, out: &mut SdpBuilder, blk: &Psd, off: &Kh, br: f64) {
        let nx = self.nx;
        let (k0, hs) = off;
        for (v, e) in p_units(nx) {
            let ek = &e * k0;
            for a in 0..nx {
                for b in 0..nx {
                    if ek[(a, b)] != 0.0 {
                        out.entry(blk, nx + a, b, v, -ek[(a, b)]);
                    }
                }
                for b in a..nx {
                    if e[(a, b)] != 0.0 {
                        out.entry(blk, nx + a, nx + b, v, -br * e[(a, b)]);
                    }
                }
            }
        }
        for (l, hl) in hs {
            for gr in 0..nx {
                for gc in 0..self.ny {
                    let var = self.gvar(*l, gr, gc);
                    for b in 0..nx {
                        if hl[(gc, b)] != 0.0 {
                            out.entry(blk, nx + gr, b, var, hl[(gc, b)]);
                        }
                    }
                }
            }
        }
    }
}
