//! Step 1 of the skew-slack alternation: with P fixed, the largest α over
//! the gains Γ_l and the skew slack K_{k,l} jointly (one SDP).

use crate::backend::{clarabel_settings, run_sdp, Sdp, Status};
use crate::conditions::rate_combos;
use crate::error::SolveError;
use crate::linalg::csc::Columns;
use crate::linalg::rows::{rows, rows_he};
use crate::linalg::svec::svec_into;
use crate::settings::Settings;
use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// The answer of [`max_alpha_fixed_p`]: α, the gains L_l and the skew
/// increments K_{k,l} (per θ-vertex l, per state k).
pub type FixedP = (f64, Vec<DMatrix<f64>>, Vec<Vec<DMatrix<f64>>>);

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
    let (nx, ny, nv) = (model.nx(), model.ny(), model.nv());
    // The LMIs are homogeneous in (P, Γ): work with P̂ = P/λ_max(P).
    let lmax = p.clone().symmetric_eigenvalues().max();
    let ph = p / lmax;
    let nskew = nx * (nx - 1) / 2;
    let n_g = nv * nx * ny;
    let n_k = nv * nx * nskew;
    let n = n_g + n_k + 1; // …, α
    let avar = n - 1;
    let xs = &model.region.vertices;
    let t = nx * (nx + 1) / 2;
    let kappa = gamma
        * model
            .vertices
            .iter()
            .map(|v| v.a.norm())
            .fold(0.0, f64::max)
        + 1.0;
    let eps = settings.margin_rel * kappa;
    // Column-wise sparse A, b, cones: one PSD(nx) block per (combination, i, j).
    let mut cols = Columns::new(n);
    let mut b: Vec<f64> = Vec::new();
    let mut cones = Vec::new();
    let he = |x: &DMatrix<f64>| x + x.transpose();
    let push = |cols: &mut Columns, row0: usize, var: usize, mat: &DMatrix<f64>| {
        cols.push_svec(row0, var, &((mat + mat.transpose()) * 0.5), 1.0)
    };
    // −He{P̂ rows(E_ab^k, x)} for the skew basis E_ab − E_ba (a < b) of K_k,
    // per region vertex: the K columns of every block at that e-vertex.
    let k_basis: Vec<Vec<DMatrix<f64>>> = xs
        .iter()
        .map(|xi| {
            let mut out = Vec::with_capacity(nx * nskew);
            for k in 0..nx {
                for a in 0..nx {
                    for bb in a + 1..nx {
                        let mut kk = vec![DMatrix::zeros(nx, nx); nx];
                        kk[k][(a, bb)] = 1.0;
                        kk[k][(bb, a)] = -1.0;
                        out.push(-he(&(&ph * rows(&kk, xi))));
                    }
                }
            }
            out
        })
        .collect();
    // The problem is small (this is an experiment on small models): the
    // blocks are built densely, one unit variable at a time.
    for combo in rate_combos(model) {
        for (i, xi) in xs.iter().enumerate() {
            for xj in xs {
                // s = −F − εI ⪰ 0 with F = F0 + Σ x_v F_v: b = svec(−F0 − εI), A col v = svec(F_v).
                let mut f0 = DMatrix::zeros(nx, nx);
                let mut fg: Vec<(usize, DMatrix<f64>)> = Vec::new(); // (l, Σ w H_m)
                let mut fk: Vec<(usize, f64)> = Vec::new(); // (l, Σ w)
                for &(l, m, w) in &combo.terms {
                    let (vl, vm) = (&model.vertices[l], &model.vertices[m]);
                    let r = rows_he(&vl.n, xj) - rows(&vl.n, xi);
                    let h = &vm.c * gamma + (rows_he(&vm.m, xj) - rows(&vm.m, xi));
                    f0 += he(&(&ph * (&vl.a * gamma + &r))) * w;
                    match fg.iter_mut().find(|(g, _)| *g == l) {
                        Some((_, acc)) => *acc += h * w,
                        None => fg.push((l, h * w)),
                    }
                    match fk.iter_mut().find(|(g, _)| *g == l) {
                        Some((_, acc)) => *acc += w,
                        None => fk.push((l, w)),
                    }
                }
                let row0 = b.len();
                let mut rhs = -f0;
                for d in 0..nx {
                    rhs[(d, d)] -= eps;
                }
                b.resize(row0 + t, 0.0);
                svec_into(&rhs, &mut b[row0..row0 + t]);
                fg.sort_by_key(|(l, _)| *l);
                fk.sort_by_key(|(l, _)| *l);
                // Γ_l entries: −He{E_rc H}.
                for (l, h) in &fg {
                    for gr in 0..nx {
                        for gc in 0..ny {
                            let mut e = DMatrix::zeros(nx, ny);
                            e[(gr, gc)] = 1.0;
                            push(
                                &mut cols,
                                row0,
                                l * nx * ny + gr * ny + gc,
                                &(-he(&(e * h))),
                            );
                        }
                    }
                }
                // K_{k,l} entries.
                for &(l, w) in &fk {
                    for (idx, term) in k_basis[i].iter().enumerate() {
                        push(&mut cols, row0, n_g + l * nx * nskew + idx, &(term * w));
                    }
                }
                // α: (Σ w) γP̂.
                push(&mut cols, row0, avar, &(&ph * (gamma * combo.weight())));
                cones.push(SupportedConeT::PSDTriangleConeT(nx));
            }
        }
    }
    // α ≤ cap keeps the problem bounded.
    let row = b.len();
    b.push(settings.alpha_cap);
    cols.push(row, avar, 1.0);
    cones.push(SupportedConeT::NonnegativeConeT(1));
    let a = cols.into_csc(b.len());
    // Objective: −α + ½ w (‖Γ̂‖² + ‖K‖²) with a tiny w: it only keeps the
    // problem bounded in directions α does not care about (a weight like
    // the design's gain regularisation costs α here: measured 10.6 → 4.9).
    let w = 1e-9;
    let pdiag = CscMatrix::new(
        n,
        n,
        (0..=n).map(|i| i.min(n - 1)).collect(),
        (0..n - 1).collect(),
        vec![w; n - 1],
    );
    let mut q = vec![0.0; n];
    q[avar] = -1.0;
    let sdp = Sdp {
        p: pdiag,
        q,
        a,
        b,
        cones,
    };
    let run = run_sdp(sdp, clarabel_settings(settings))?;
    // Only a solved α is used here (the caller certifies it).
    let x = match run.x {
        Some(x) if run.status == Status::Solved => x,
        _ => return Ok(None),
    };
    let pinv = match p.clone().cholesky() {
        Some(ch) => ch.inverse(),
        None => return Ok(None),
    };
    let gains = (0..nv)
        .map(|l| {
            let g = DMatrix::from_fn(nx, ny, |r, c| x[l * nx * ny + r * ny + c] * lmax);
            &pinv * g
        })
        .collect();
    let k = (0..nv)
        .map(|l| {
            (0..nx)
                .map(|kk| {
                    let mut km = DMatrix::zeros(nx, nx);
                    let mut idx = 0;
                    for a in 0..nx {
                        for bb in a + 1..nx {
                            let v = x[n_g + l * nx * nskew + kk * nskew + idx];
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
    Ok(Some((x[avar], gains, k)))
}
