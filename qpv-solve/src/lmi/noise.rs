//! The noise-optimal SDP: the design SDP whose rate family is the noise
//! block family (docs/method.md, "Noise and disturbances"), in the
//! variables (P̂, Γ̂_l, σ̂).

use super::blocks::{p_units, RateFamily};
use super::Problem;
use crate::backend::builder::SdpBuilder;
use crate::backend::{clarabel_settings, run_sdp, Status};
use crate::conditions::Combo;
use crate::error::SolveError;
use crate::linalg::svec::svec_len;
use crate::lmi::Objective;
use crate::model::noise::NoiseChannels;
use crate::settings::Settings;
use nalgebra::DMatrix;
use std::time::Instant;

/// One solve of a noise objective's SDP (σ of `noise = min`, or the RMS
/// bound of `noise = rms`): its status and, when the solver returned a
/// point, (P, Γ_l) in model units.
pub(crate) struct NoiseSolve {
    pub(crate) status: Status,
    pub(crate) detail: String,
    pub(crate) iterations: u32,
    pub(crate) solve_seconds: f64,
    pub(crate) assembly_seconds: f64,
    pub(crate) point: Option<(DMatrix<f64>, Vec<DMatrix<f64>>)>,
}

/// Solves the noise-optimal SDP of `prob` at (α, γ) on `channels`:
/// minimise σ̂ = σ/s over (P̂, Γ̂_l, σ̂) subject to (S1)–(S3) (assembled by
/// [`Problem`]) and the block LMI at every rate combination and
/// region-vertex pair with the rate family's margin ε κ; (P, Γ_l) are
/// returned in model units.
pub(crate) fn solve_noise_sdp(
    prob: &Problem,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    settings: &Settings,
) -> Result<NoiseSolve, SolveError> {
    let t0 = Instant::now();
    // A problem posed in balanced coordinates (the global observer's,
    // docs/method.md §17) gets its channels there too, and its point back.
    let in_z = prob.scaling().map(|s| channels.in_z(s));
    let channels = in_z.as_ref().unwrap_or(channels);
    let sdp = prob.assemble_family(
        (alpha, gamma),
        settings,
        Objective::Feasibility,
        None,
        RateFamily::Noise(channels),
    );
    let assembly_seconds = t0.elapsed().as_secs_f64();
    let run = run_sdp(sdp, clarabel_settings(settings))?;
    let point = run.x.as_ref().and_then(|x| {
        let (p, g) = prob.unpack(&x[..prob.n_vars()]);
        let (p, g, _) = prob.in_user_coordinates((Some(p), g, None));
        p.map(|p| (p, g))
    });
    Ok(NoiseSolve {
        status: run.status,
        detail: run.detail,
        iterations: run.iterations,
        solve_seconds: run.solve_seconds,
        assembly_seconds,
        point,
    })
}

/// What one rate combination contributes to its noise blocks: its B_w
/// (Σ_t w_t B_w,l_t), the weight of each Γ̂_l in the noise columns −γΓ̂E,
/// and its total weight W.
pub(super) struct ComboNoise {
    pub(super) bw: DMatrix<f64>,
    pub(super) wl: Vec<f64>,
    pub(super) wsum: f64,
}

impl ComboNoise {
    /// The data of `combo` on `channels` (None: no channels, B_w empty)
    /// for nx states and nv θ-vertices.
    pub(super) fn of(
        combo: &Combo,
        channels: Option<&NoiseChannels>,
        nx: usize,
        nv: usize,
    ) -> Self {
        let nw = channels.map_or(0, NoiseChannels::n_w);
        let mut cn = ComboNoise {
            bw: DMatrix::zeros(nx, nw),
            wl: vec![0.0; nv],
            wsum: combo.weight(),
        };
        for &(l, _, w) in &combo.terms {
            if let Some(bb) = channels.and_then(|ch| ch.b_w.as_ref()) {
                cn.bw += &bb[l] * w;
            }
            cn.wl[l] += w;
        }
        cn
    }
}

impl Problem<'_> {
    /// The noise block family in place of the rate family: one block per
    /// rate combination and region-vertex pair (see [`NoiseBlock`]), with
    /// margin `eps` (ε κ) and σ̂ the variable `svar`.
    pub(super) fn push_rate_noise(
        &self,
        out: &mut SdpBuilder,
        (alpha, gamma): (f64, f64),
        channels: &NoiseChannels,
        svar: usize,
        eps: f64,
    ) {
        let outs = channels.noisy_outputs(self.ny);
        let block = NoiseBlock {
            nx: self.nx,
            ny: self.ny,
            nw: channels.n_w(),
            outs: &outs,
            svar,
            gamma,
            eps,
        };
        let cn: Vec<ComboNoise> = self
            .combos
            .iter()
            .map(|combo| ComboNoise::of(combo, Some(channels), self.nx, self.nv))
            .collect();
        for site in self.rate_sites(false) {
            let (kk, hs) = self.site_kh(alpha, gamma, site);
            block.push(out, (&kk, &hs), &cn[site.c], |l, r, c| self.gvar(l, r, c));
        }
    }
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
    /// `hs` from [`Problem::site_kh`], the combination's data `cn`, the
    /// index of each Γ̂_l entry from `gvar`.
    fn push(
        &self,
        out: &mut SdpBuilder,
        (kk, hs): (&DMatrix<f64>, &[(usize, DMatrix<f64>)]),
        cn: &ComboNoise,
        gvar: impl Fn(usize, usize, usize) -> usize,
    ) {
        let (nx, ny, nw, nb, gamma) = (self.nx, self.ny, self.nw, self.size(), self.gamma);
        let blk = out.psd(nb, self.eps);
        let mut coef = DMatrix::<f64>::zeros(nb, nb);
        // P̂ variables: top-left He{E K}, top-right γ E B_w.
        for (v, e) in p_units(nx) {
            coef.fill(0.0);
            let ek = &e * kk;
            let he = &ek + ek.transpose();
            coef.view_mut((0, 0), (nx, nx)).copy_from(&he);
            if nw > 0 {
                let eb = &e * &cn.bw * gamma;
                coef.view_mut((0, nx), (nx, nw)).copy_from(&eb);
                coef.view_mut((nx, 0), (nw, nx)).copy_from(&eb.transpose());
            }
            out.matrix(&blk, v, &coef, 1.0);
        }
        // Γ̂_l variables: top-left −He{D H_l}, noise columns −γ w_l D E.
        for (l, &wl_l) in cn.wl.iter().enumerate() {
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
                    out.matrix(&blk, gvar(l, gr, gc), &coef, 1.0);
                }
            }
        }
        // σ̂: bottom-right −γ W σ̂ I.
        coef.fill(0.0);
        for d in nx..nb {
            coef[(d, d)] = -gamma * cn.wsum;
        }
        out.matrix(&blk, self.svar, &coef, 1.0);
        debug_assert_eq!(out.n_rows(), blk.row0 + svec_len(nb));
    }
}
