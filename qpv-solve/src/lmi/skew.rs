//! Step 1 of the skew-slack alternation: with P fixed, the largest α over
//! the gains Γ_l and the skew slack K_{k,l} jointly (one SDP).

use super::blocks::{add_term, sites};
use crate::backend::builder::{Psd, SdpBuilder};
use crate::backend::{clarabel_settings, run_sdp, Status};
use crate::conditions::rate_combos;
use crate::error::SolveError;
use crate::linalg::rows::{rows, rows_he};
use crate::settings::Settings;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::PolytopicModel;

/// The answer of [`max_alpha_fixed_p`]: α, the gains L_l and the skew
/// increments K_{k,l} (per θ-vertex l, per state k).
pub(crate) type FixedP = (f64, Vec<DMatrix<f64>>, Vec<Vec<DMatrix<f64>>>);

/// Step 1: with P fixed, the largest α (and the gains Γ_l, the skew
/// increments K_{k,l}) such that every rate block of `model` at γ holds,
/// He{P(γA_l + R − rows(K_l, x_i)) − Γ_l H} + γαP ⪯ −ε κ I. Returns
/// (α, L_l, K_{k,l}) or `None` if the solver found no usable point. The
/// caller certifies.
pub fn max_alpha_fixed_p(
    model: &PolytopicModel,
    p: &DMatrix<f64>,
    gamma: f64,
    settings: &Settings,
) -> Result<Option<FixedP>, SolveError> {
    // The LMIs are homogeneous in (P, Γ): work with P̂ = P/λ_max(P).
    let lmax = p.clone().symmetric_eigenvalues().max();
    let ph = p / lmax;
    let vars = Vars::of(model);
    let kappa = gamma
        * model
            .vertices
            .iter()
            .map(|v| v.a.norm())
            .fold(0.0, f64::max)
        + 1.0;
    let mut out = vars.builder();
    push_rate_blocks(
        &mut out,
        model,
        &ph,
        &vars,
        gamma,
        settings.margin_rel * kappa,
    );
    // α ≤ cap keeps the problem bounded.
    let row = out.nonneg(1);
    out.set_b(row, settings.alpha_cap);
    out.a(row, vars.alpha, 1.0);
    out.cost(vars.alpha, -1.0);
    // ½ w (‖Γ̂‖² + ‖K‖²) with a tiny w only keeps the problem bounded in
    // directions α does not care about (a weight like the design's gain
    // regularisation costs α here: measured 10.6 → 4.9); α's own column
    // has no quadratic term.
    for v in 0..vars.alpha {
        out.quadratic(v, 1e-9);
    }
    let run = run_sdp(out.finish(), clarabel_settings(settings))?;
    // Only a solved α is used here (the caller certifies it).
    let x = match run.x {
        Some(x) if run.status == Status::Solved => x,
        _ => return Ok(None),
    };
    Ok(vars.unpack(&x, p, lmax))
}

/// The variables of the fixed-P problem: Γ̂_l (nx × ny per θ-vertex, row
/// by row), then K_{k,l} (per θ-vertex, per state k, its nx(nx−1)/2
/// entries above the diagonal), then α.
struct Vars {
    nx: usize,
    ny: usize,
    nv: usize,
    /// Entries of one K_{k,l} above the diagonal.
    nskew: usize,
    /// Where the K entries start (after all Γ̂_l).
    k0: usize,
    /// α's column (the last).
    alpha: usize,
}

impl Vars {
    fn of(model: &PolytopicModel) -> Vars {
        let (nx, ny, nv) = (model.nx(), model.ny(), model.nv());
        let nskew = nx * (nx - 1) / 2;
        let k0 = nv * nx * ny;
        let alpha = k0 + nv * nx * nskew;
        Vars {
            nx,
            ny,
            nv,
            nskew,
            k0,
            alpha,
        }
    }

    /// A builder with these variables declared, in this order.
    fn builder(&self) -> SdpBuilder {
        let mut out = SdpBuilder::new();
        out.vars("Gamma", self.k0);
        out.vars("K", self.nv * self.nx * self.nskew);
        let alpha = out.var("alpha");
        debug_assert_eq!(alpha, self.alpha);
        out
    }

    /// Column of entry (r, c) of Γ̂_l.
    fn gamma_col(&self, l: usize, r: usize, c: usize) -> usize {
        l * self.nx * self.ny + r * self.ny + c
    }

    /// Column of the `idx`-th skew-basis entry of K_{·,l} (state-major).
    fn k_col(&self, l: usize, idx: usize) -> usize {
        self.k0 + l * self.nx * self.nskew + idx
    }

    /// (α, L_l = P⁻¹Γ_l, K_{k,l}) from the solver's point (Γ = λ_max Γ̂);
    /// None if P is singular.
    fn unpack(&self, x: &[f64], p: &DMatrix<f64>, lmax: f64) -> Option<FixedP> {
        let (nx, ny) = (self.nx, self.ny);
        let gammas: Vec<DMatrix<f64>> = (0..self.nv)
            .map(|l| DMatrix::from_fn(nx, ny, |r, c| x[self.gamma_col(l, r, c)] * lmax))
            .collect();
        let gains = crate::linalg::gains(p, &gammas)?;
        let k = (0..self.nv)
            .map(|l| {
                (0..nx)
                    .map(|kk| {
                        let mut km = DMatrix::zeros(nx, nx);
                        let mut idx = 0;
                        for a in 0..nx {
                            for bb in a + 1..nx {
                                let v = x[self.k_col(l, kk * self.nskew + idx)];
                                km[(a, bb)] = v;
                                km[(bb, a)] = -v;
                                idx += 1;
                            }
                        }
                        km
                    })
                    .collect()
            })
            .collect();
        Some((x[self.alpha], gains, k))
    }
}

fn he(x: &DMatrix<f64>) -> DMatrix<f64> {
    x + x.transpose()
}

/// Adds `mat` (symmetrised) as variable `var`'s column of the block `blk`.
fn push(out: &mut SdpBuilder, blk: &Psd, var: usize, mat: &DMatrix<f64>) {
    out.matrix(blk, var, &((mat + mat.transpose()) * 0.5), 1.0)
}

/// One block s = −F − εI ⪰ 0 per (rate combination, e-vertex x_i,
/// x-vertex x_j), F = F0 + Σ_v x_v F_v: b = svec(−F0 − εI) and variable
/// v's column svec(F_v). The problem is small (an experiment on small
/// models), so the blocks are built densely, one unit variable at a time.
fn push_rate_blocks(
    out: &mut SdpBuilder,
    model: &PolytopicModel,
    ph: &DMatrix<f64>,
    vars: &Vars,
    gamma: f64,
    eps: f64,
) {
    let (nx, ny) = (vars.nx, vars.ny);
    let xs = &model.region.vertices;
    let k_basis = skew_basis(ph, xs, nx);
    let combos = rate_combos(model);
    for site in sites(combos.len(), xs.len(), |_| false) {
        let Some((i, j)) = site.pair else { continue };
        let combo = &combos[site.c];
        let (xi, xj) = (&xs[i], &xs[j]);
        let mut f0 = DMatrix::zeros(nx, nx);
        let mut fg: Vec<(usize, DMatrix<f64>)> = Vec::new(); // (l, Σ w H_m)
        let mut fk: Vec<(usize, f64)> = Vec::new(); // (l, Σ w)
        for &(l, m, w) in &combo.terms {
            let (vl, vm) = (&model.vertices[l], &model.vertices[m]);
            let r = rows_he(&vl.n, xj) - rows(&vl.n, xi);
            let h = &vm.c * gamma + (rows_he(&vm.m, xj) - rows(&vm.m, xi));
            f0 += he(&(ph * (&vl.a * gamma + &r))) * w;
            add_term(&mut fg, l, h * w);
            match fk.iter_mut().find(|(g, _)| *g == l) {
                Some((_, acc)) => *acc += w,
                None => fk.push((l, w)),
            }
        }
        let blk = out.psd(nx, 0.0);
        let mut rhs = -f0;
        for d in 0..nx {
            rhs[(d, d)] -= eps;
        }
        out.rhs_matrix(&blk, &rhs);
        fg.sort_by_key(|(l, _)| *l);
        fk.sort_by_key(|(l, _)| *l);
        // Γ_l entries: −He{E_rc H}.
        for (l, h) in &fg {
            for gr in 0..nx {
                for gc in 0..ny {
                    let mut e = DMatrix::zeros(nx, ny);
                    e[(gr, gc)] = 1.0;
                    push(out, &blk, vars.gamma_col(*l, gr, gc), &(-he(&(e * h))));
                }
            }
        }
        // K_{k,l} entries.
        for &(l, w) in &fk {
            for (idx, term) in k_basis[i].iter().enumerate() {
                push(out, &blk, vars.k_col(l, idx), &(term * w));
            }
        }
        // α: (Σ w) γP̂.
        push(out, &blk, vars.alpha, &(ph * (gamma * combo.weight())));
    }
}

/// −He{P̂ rows(E_ab^k, x)} for the skew basis E_ab − E_ba (a < b) of K_k,
/// per region vertex x: the K columns of every block at that e-vertex.
fn skew_basis(ph: &DMatrix<f64>, xs: &[DVector<f64>], nx: usize) -> Vec<Vec<DMatrix<f64>>> {
    xs.iter()
        .map(|xi| {
            let mut out = Vec::new();
            for k in 0..nx {
                for a in 0..nx {
                    for bb in a + 1..nx {
                        let mut kk = vec![DMatrix::zeros(nx, nx); nx];
                        kk[k][(a, bb)] = 1.0;
                        kk[k][(bb, a)] = -1.0;
                        out.push(-he(&(ph * rows(&kk, xi))));
                    }
                }
            }
            out
        })
        .collect()
}
