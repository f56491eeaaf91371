//! The RMS-optimal SDP of `noise = rms` (docs/method.md, "RMS-optimal
//! gains"): at (α, γ) and a margin m̂, the region conditions (S1)–(S3), the
//! full rate family with He{P̂K − Γ̂H} ⪯ −m̂ I at every combination and
//! region-vertex pair, and the noise power t̂ ≥ tr(P̂Q) + tr Ŵ_l with
//! [Ŵ_l, R^½Γ̂_lᵀ; Γ̂_l R^½, P̂] ⪰ 0 per θ-vertex; minimise t̂. The mean-square
//! bound of the point is then at most γ t̂/m̂ (the certificate recomputes
//! the exact one from P and L_l, [`crate::certificate::rms`]).

use super::blocks::RateMargins;
use super::Problem;
use crate::backend::builder::SdpBuilder;
use crate::backend::{clarabel_settings, run_sdp};
use crate::error::SolveError;
use crate::linalg::svec::svec_index;
use crate::settings::Settings;
use std::time::Instant;

/// The noise intensities of the SDP, normalised: R (per noisy output) and
/// Q (per state, empty without process noise) divided by their largest
/// entry (the bound scales back by it).
pub(crate) struct RmsWeights {
    /// The noisy outputs and √R_kk (normalised) of each.
    pub(crate) outs: Vec<(usize, f64)>,
    /// Q_kk (normalised) per state; empty: none.
    pub(crate) q: Vec<f64>,
}

/// One solve of the RMS SDP: its status and, when the solver returned a
/// point, (P, Γ_l) in model units (the noise SDP's record).
pub(crate) use super::noise::NoiseSolve as RmsSolve;

/// Solves the RMS SDP of `prob` at (α, γ) with margin m̂ = `margin` κ
/// (κ the rate family's data scale, [`Problem::rate_scale`]).
pub(crate) fn solve_rms_sdp(
    prob: &Problem,
    weights: &RmsWeights,
    (alpha, gamma, margin): (f64, f64, f64),
    settings: &Settings,
) -> Result<RmsSolve, SolveError> {
    let t0 = Instant::now();
    let kappa = prob.rate_scale(alpha, gamma);
    let eps = settings.margin_rel;
    let mut out = SdpBuilder::new();
    out.sym_var("P", prob.nx);
    out.vars("Gamma", prob.nv * prob.nx * prob.ny);
    let n_o = weights.outs.len();
    let w_first: Vec<usize> = (0..prob.nv).map(|_| out.sym_var("W", n_o)).collect();
    let tvar = out.var("power");
    prob.push_region(&mut out, (gamma, eps), false, false);
    let rate = RateMargins {
        eps: (margin * kappa).max(eps * kappa),
        slack_eps: eps * kappa,
        column: None,
    };
    prob.push_rate_full(&mut out, alpha, gamma, &rate);
    for (l, &w0) in w_first.iter().enumerate() {
        prob.push_power_block(&mut out, l, w0, weights);
        // t̂ − tr(P̂Q) − tr Ŵ_l ≥ 0: b = 0, A = −1 at t̂, +Q_kk at P̂_kk, +1 at Ŵ_kk.
        let row = out.nonneg(1);
        out.a(row, tvar, -1.0);
        for (k, &qk) in weights.q.iter().enumerate() {
            out.a(row, svec_index(k, k), qk);
        }
        for k in 0..n_o {
            out.a(row, w0 + svec_index(k, k), 1.0);
        }
    }
    out.cost(tvar, 1.0);
    let sdp = out.finish();
    let assembly_seconds = t0.elapsed().as_secs_f64();
    let run = run_sdp(sdp, clarabel_settings(settings))?;
    let point = run.x.as_ref().map(|x| prob.unpack(&x[..prob.n_vars()]));
    Ok(RmsSolve {
        status: run.status,
        detail: run.detail,
        iterations: run.iterations,
        solve_seconds: run.solve_seconds,
        assembly_seconds,
        point,
    })
}

impl Problem<'_> {
    /// [Ŵ_l, R^½Γ̂_lᵀ; Γ̂_l R^½, P̂] ⪰ 0 (side n_o + nx; Ŵ_l's upper triangle
    /// from variable `w0`), in A's sign convention (−1 adds the variable).
    fn push_power_block(&self, out: &mut SdpBuilder, l: usize, w0: usize, weights: &RmsWeights) {
        let n_o = weights.outs.len();
        let blk = out.psd(n_o + self.nx, 0.0);
        for c in 0..n_o {
            for r in 0..=c {
                out.entry(&blk, r, c, w0 + svec_index(r, c), -1.0);
            }
        }
        for c in 0..self.nx {
            for r in 0..=c {
                out.entry(&blk, n_o + r, n_o + c, svec_index(r, c), -1.0);
            }
        }
        // Entry (k, n_o + r) = Γ̂_l[r, o_k] √R_k.
        for (k, &(o, sr)) in weights.outs.iter().enumerate() {
            for r in 0..self.nx {
                out.entry(&blk, k, n_o + r, self.gvar(l, r, o), -sr);
            }
        }
    }
}
