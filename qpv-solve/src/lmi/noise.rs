//! The noise-optimal SDP: the design SDP with its rate blocks replaced by
//! the noise blocks (docs/method.md, "Noise and disturbances").

use crate::backend::{clarabel_settings, run_sdp, Sdp, Status};
use crate::error::SolveError;
use crate::linalg::csc::Columns;
use crate::linalg::svec::svec_index;
use crate::lmi::{tri, Objective, Problem};
use crate::model::noise::NoiseChannels;
use crate::settings::Settings;
use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;
use std::time::Instant;

/// The noise-optimal SDP at (α, γ): minimise σ̂ = σ/s over (P̂, Γ̂_l, σ̂)
/// subject to (S1)–(S3) (assembled by [`Problem`]) and the block LMI at
/// every rate combination and region-vertex pair with the rate family's
/// margin ε κ. Returns (P, Γ_l, σ from the solver) in model units.
pub(crate) struct NoiseSolve {
    pub(crate) status: Status,
    pub(crate) detail: String,
    pub(crate) iterations: u32,
    pub(crate) solve_seconds: f64,
    pub(crate) assembly_seconds: f64,
    pub(crate) point: Option<(DMatrix<f64>, Vec<DMatrix<f64>>)>,
}

pub(crate) fn solve_noise_sdp(
    prob: &Problem,
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    settings: &Settings,
) -> Result<NoiseSolve, SolveError> {
    let t0 = Instant::now();
    let nv_prob = prob.n_vars();
    let svar = nv_prob;
    let n = nv_prob + 1;
    let (mut cols, mut b, mut cones) = without_rate_blocks(prob, model, alpha, gamma, settings, n)?;
    let outs = channels.noisy_outputs(model.ny());
    let block = NoiseBlock {
        nx: model.nx(),
        ny: model.ny(),
        nw: channels.n_w(),
        outs: &outs,
        svar,
        gamma,
        eps: settings.margin_rel * prob.rate_scale(alpha, gamma),
    };
    let np = model.region.vertices.len();
    for (c, combo) in prob.combos().iter().enumerate() {
        // B_w of the combination, and the weight of each Γ̂_l in −γΓ̂E.
        let mut bw = DMatrix::zeros(block.nx, block.nw);
        let mut wl = vec![0.0; model.nv()];
        for &(l, _, w) in &combo.terms {
            if let Some(bb) = &channels.b_w {
                bw += &bb[l] * w;
            }
            wl[l] += w;
        }
        for i in 0..np {
            for j in 0..np {
                let (kk, hs) = prob.rate_kh(alpha, gamma, c, i, j);
                block.push(&mut cols, &mut b, &kk, &hs, &bw, &wl, combo.weight());
                cones.push(SupportedConeT::PSDTriangleConeT(block.size()));
            }
        }
    }
    let mut q = vec![0.0; n];
    q[svar] = 1.0;
    let sdp = Sdp {
        p: CscMatrix::zeros((n, n)),
        q,
        a: cols.into_csc(b.len()),
        b,
        cones,
    };
    let assembly_seconds = t0.elapsed().as_secs_f64();
    let run = run_sdp(sdp, clarabel_settings(settings))?;
    let point = run.x.as_ref().map(|x| prob.unpack(&x[..nv_prob]));
    Ok(NoiseSolve {
        status: run.status,
        detail: run.detail,
        iterations: run.iterations,
        solve_seconds: run.solve_seconds,
        assembly_seconds,
        point,
    })
}

/// An SDP under construction: its constraint columns, right-hand side and cones.
type SdpParts = (Columns, Vec<f64>, Vec<SupportedConeT<f64>>);

/// The design SDP at (α, γ) without its rate blocks (they are replaced by
/// the noise blocks), as columns for `n` variables, right-hand side and cones.
fn without_rate_blocks(
    prob: &Problem,
    model: &PolytopicModel,
    alpha: f64,
    gamma: f64,
    settings: &Settings,
    n: usize,
) -> Result<SdpParts, SolveError> {
    let nx = model.nx();
    let base = prob.assemble(alpha, gamma, settings, Objective::Feasibility);
    let n_rate = prob.n_rate_blocks();
    let cut = base.b.len() - n_rate * tri(nx);
    let n_cones = base.cones.len() - n_rate;
    if base.cones[n_cones..]
        .iter()
        .any(|c| !matches!(c, SupportedConeT::PSDTriangleConeT(k) if *k == nx))
    {
        return Err(SolveError::Setup(
            "unexpected cone layout of the rate family".into(),
        ));
    }
    let mut cols = Columns::new(n);
    for c in 0..base.a.n {
        for k in base.a.colptr[c]..base.a.colptr[c + 1] {
            if base.a.rowval[k] < cut {
                cols.push(base.a.rowval[k], c, base.a.nzval[k]);
            }
        }
    }
    Ok((cols, base.b[..cut].to_vec(), base.cones[..n_cones].to_vec()))
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
    /// `hs` from [`Problem::rate_kh`], the combination's B_w, the weight of
    /// each Γ̂_l, and the combination's total weight.
    #[allow(clippy::too_many_arguments)]
    fn push(
        &self,
        cols: &mut Columns,
        b: &mut Vec<f64>,
        kk: &DMatrix<f64>,
        hs: &[(usize, DMatrix<f64>)],
        bw: &DMatrix<f64>,
        wl: &[f64],
        wsum: f64,
    ) {
        let (nx, ny, nw, nb, gamma) = (self.nx, self.ny, self.nw, self.size(), self.gamma);
        let row0 = b.len();
        b.resize(row0 + tri(nb), 0.0);
        for d in 0..nb {
            b[row0 + svec_index(d, d)] = -self.eps;
        }
        let mut coef = DMatrix::<f64>::zeros(nb, nb);
        // P̂ variables: top-left He{E K}, top-right γ E B_w.
        for pc in 0..nx {
            for pr in 0..=pc {
                coef.fill(0.0);
                let mut e = DMatrix::<f64>::zeros(nx, nx);
                e[(pr, pc)] = 1.0;
                e[(pc, pr)] = 1.0;
                let ek = &e * kk;
                let he = &ek + ek.transpose();
                coef.view_mut((0, 0), (nx, nx)).copy_from(&he);
                if nw > 0 {
                    let eb = &e * bw * gamma;
                    coef.view_mut((0, nx), (nx, nw)).copy_from(&eb);
                    coef.view_mut((nx, 0), (nw, nx)).copy_from(&eb.transpose());
                }
                cols.push_svec(row0, svec_index(pr, pc), &coef, 1.0);
            }
        }
        // Γ̂_l variables: top-left −He{D H_l}, noise columns −γ w_l D E.
        for (l, &wl_l) in wl.iter().enumerate() {
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
                    let var = tri(nx) + l * nx * ny + gr * ny + gc;
                    cols.push_svec(row0, var, &coef, 1.0);
                }
            }
        }
        // σ̂: bottom-right −γ W σ̂ I.
        coef.fill(0.0);
        for d in nx..nb {
            coef[(d, d)] = -gamma * wsum;
        }
        cols.push_svec(row0, self.svar, &coef, 1.0);
    }
}
