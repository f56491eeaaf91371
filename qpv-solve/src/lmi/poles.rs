//! Pole regions in the SDP: the blocks of [`crate::conditions::poles`] at
//! every rate combination and region-vertex pair (one pair for a
//! combination whose N and M vanish), written through the one builder
//! (docs/method.md §18, "Pole regions").

use super::blocks::{p_units, sites};
use super::Problem;
use crate::backend::builder::{Psd, SdpBuilder};
use crate::conditions::poles::{blocks, data_size};
use nalgebra::DMatrix;
use qpv_dsl::PoleRegion;

/// The relative step by which the SDP tightens every region (radius and
/// sector angle × (1 − step), strip edges moved inward by step·(hi − lo)):
/// a margin in the metric of P (the blocks are homogeneous in (P, Γ_l)),
/// which the solver's point keeps whatever the scale of P, so that the
/// certificate, which checks the region as written, sees it inside. Small
/// enough not to move a disk tangent to the imaginary axis off the decay
/// rates searched (its right edge moves by step·radius).
pub(crate) const POLE_BACKOFF: f64 = 1e-6;

/// `region` tightened by [`POLE_BACKOFF`] (see there).
pub(crate) fn tightened(region: &PoleRegion) -> PoleRegion {
    let s = POLE_BACKOFF;
    match *region {
        PoleRegion::Disk { centre, radius } => PoleRegion::Disk {
            centre,
            radius: radius * (1.0 - s),
        },
        PoleRegion::Sector { angle } => PoleRegion::Sector {
            angle: angle * (1.0 - s),
        },
        PoleRegion::Strip { lo, hi } => {
            let d = s * (hi - lo);
            PoleRegion::Strip {
                lo: lo + d,
                hi: hi - d,
            }
        }
    }
}

impl<'m> Problem<'m> {
    /// The same problem with the eigenvalues of the frozen error dynamics
    /// confined to every region of `poles` (their intersection), imposed
    /// with the problem's P at every rate combination and region-vertex pair.
    pub fn with_poles(mut self, poles: &[PoleRegion]) -> Self {
        self.poles = poles.to_vec();
        self
    }

    /// The pole regions imposed (empty: none).
    pub fn poles(&self) -> &[PoleRegion] {
        &self.poles
    }

    /// The pole-region blocks at γ (see the module documentation) of the
    /// tightened regions ([`tightened`]), each −B − ε κ_D I ⪰ 0 with κ_D
    /// the size of the rate data and the region's constants; with `margin`
    /// (the max-margin objective, whose P̂ ⪯ I may need eigenvalues far
    /// below any fixed margin) −B ⪰ 0, the tightening as the only margin.
    pub(super) fn push_poles(&self, out: &mut SdpBuilder, gamma: f64, eps: f64, max_margin: bool) {
        if self.poles.is_empty() {
            return;
        }
        // One site for a combination whose N and M vanish (or without
        // region vertices): its blocks are the same at every pair.
        let np = self.xs_hat.len();
        let sites = sites(self.combos.len(), np, |c| self.linear[c] || np == 0);
        for site in sites {
            let g = gamma * self.combos[site.c].weight();
            let (k, hs) = self.site_kh(0.0, gamma, site);
            self.push_pole_pair(out, (&k, &hs), (g, gamma), eps, max_margin);
        }
    }

    /// Every region's blocks for one rate block X = P̂K − Σ_l Γ̂_l H_l:
    /// each block's column of a variable is the block evaluated at that
    /// variable's unit direction (the blocks are linear in (X, P̂)).
    fn push_pole_pair(
        &self,
        out: &mut SdpBuilder,
        (k, hs): (&DMatrix<f64>, &[(usize, DMatrix<f64>)]),
        (g, gamma): (f64, f64),
        eps: f64,
        max_margin: bool,
    ) {
        let nx = self.nx;
        for region in &self.poles {
            let region = tightened(region);
            let kappa = self.rate_scale(0.0, gamma) + gamma * data_size(&region);
            let eps = if max_margin { 0.0 } else { eps * kappa };
            let blks: Vec<Psd> = (0..region.n_blocks())
                .map(|_| out.psd(region.block_side(nx), eps))
                .collect();

            let push = |out: &mut SdpBuilder, var: usize, x: &DMatrix<f64>, p: &DMatrix<f64>| {
                for (blk, m) in blks.iter().zip(blocks(&region, x, p, g)) {
                    out.matrix(blk, var, &m, 1.0);
                }
            };
            for (v, e) in p_units(nx) {
                push(out, v, &(&e * k), &e);
            }
            let zero = DMatrix::zeros(nx, nx);
            for (l, h) in hs {
                for gr in 0..nx {
                    for gc in 0..self.ny {
                        if h.row(gc).iter().all(|v| *v == 0.0) {
                            continue;
                        }
                        let mut x = DMatrix::zeros(nx, nx);
                        for col in 0..nx {
                            x[(gr, col)] = -h[(gc, col)];
                        }
                        push(out, self.gvar(*l, gr, gc), &x, &zero);
                    }
                }
            }
        }
    }
}
