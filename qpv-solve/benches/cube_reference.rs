//! The reference formulation of the cube conditions for `cube_scale --
//! compare`: the same relaxation as `conditions = cube` in sound mode
//! (docs/method.md, "Cube conditions: zonotope regions without vertex
//! enumeration"), written directly on Clarabel's standard form from the
//! model's data, without anything of `qpv_solve::lmi`. It is a yardstick for
//! the size and the solve time of the library's assembly, not part of it.
//!
//! Variables (scaled by s = 1/ρ², ρ the largest vertex norm of the zonotope,
//! so that P = sP̂, Γ_l = sΓ̂_l, Y = sŶ, X = sX̂): P̂, Γ̂_l, Ŷ_{l,k}, X̂_{l,k},
//! and d_k (the diagonal of D). Blocks, each with the margin ε (κε on the
//! rate blocks, κ the data size of the rate matrices):
//!
//! ```text
//!   P̂ ⪰ εI
//!   D − ĜᵀP̂Ĝ ⪰ εI (Ĝ = G/ρ),  1 − Σ_k d_k ≥ ε
//!   [1 γâᵀ; γâ P̂] ⪰ εI per facet (â = ρa)
//!   per θ-vertex l and generator k:
//!     Ŷ − G_l(g_k) ⪰ εκI,  Ŷ + G_l(g_k) ⪰ εκI,
//!     X̂ − H_l(g_k) ⪰ εκI,  X̂ + H_l(g_k) ⪰ εκI
//!   per θ-vertex l: −(F0_l + Σ_k Ŷ_{l,k} + Σ_k X̂_{l,k}) ⪰ εκI
//! ```
//!
//! F0 = He{P̂(γA_l + (γα/2)I) − γΓ̂_l C}, G(g) = He{−P̂ rows(N_l, g) +
//! Γ̂_l rows(M, g)}, H(g) = He{P̂ rowsHe(N_l, g) − Γ̂_l rowsHe(M, g)}
//! (sound mode, σ = +1); objective ½ w Σ_l ‖Γ̂_l‖_F², as the design's.
//! Only models with a constant output map (C and M_k the same at every
//! θ-vertex: one rate combination per θ-vertex) are written.
//!
//! The lean form ([`Form::Lean`], for N_k and M_k symmetric, so that
//! H(g) = −2G(g)) has one slack Ŵ = Ŷ + X̂ per θ-vertex and generator,
//! Ŵ ∓ 3G_l(g_k) ⪰ 2εκI and −(F0_l + Σ_k Ŵ_{l,k}) ⪰ εκI, and one facet block
//! per pair of opposite facets: the same relaxation, written as small as
//! its mathematics allows. Its Y and X are W/3 + aI and 2W/3 − aI, a = m/6
//! with m the smaller of λ_min(W ∓ 3G).

use nalgebra::{DMatrix, DVector};
use qpv_clarabel::clarabel::algebra::CscMatrix;
use qpv_clarabel::clarabel::solver::SupportedConeT;
use qpv_clarabel::Sdp;
use qpv_dsl::PolytopicModel;
use std::f64::consts::SQRT_2;

/// Which formulation of the relaxation.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Form {
    /// Four slack blocks per θ-vertex and generator, every facet.
    Pairs,
    /// One slack per θ-vertex and generator, one facet per opposite pair.
    Lean,
}

/// What it takes to read a solution of the reference problem.
pub struct Reference {
    /// Symmetric slack matrices per θ-vertex and generator: 2 or 1.
    per: usize,
    /// Lean form: (K, H) of G_l(g_k) = He{PK − Γ_l H}, per l and k.
    g_parts: Vec<Vec<(DMatrix<f64>, DMatrix<f64>)>>,
    nx: usize,
    ny: usize,
    nv: usize,
    r: usize,
    s: f64,
}

/// The point of a reference solution in model units.
pub struct Point {
    /// P.
    pub p: DMatrix<f64>,
    /// Γ_l.
    pub gammas: Vec<DMatrix<f64>>,
    /// Y_{l,k}.
    pub y: Vec<Vec<DMatrix<f64>>>,
    /// X_{l,k}.
    pub x: Vec<Vec<DMatrix<f64>>>,
    /// The diagonal of D.
    pub d: Vec<f64>,
}

fn tri(n: usize) -> usize {
    n * (n + 1) / 2
}

/// Position of (r, c), r ≤ c, in the upper triangle packed column by column
/// (Clarabel's PSD triangle order).
fn idx(r: usize, c: usize) -> usize {
    c * (c + 1) / 2 + r
}

/// Row k of the result is vᵀT_k.
fn rows_of(t: &[DMatrix<f64>], v: &DVector<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(t.len(), v.len(), |k, c| (v.transpose() * t[k].column(c))[0])
}

/// Row k of the result is vᵀ(T_k + T_kᵀ).
fn rows_he_of(t: &[DMatrix<f64>], v: &DVector<f64>) -> DMatrix<f64> {
    let sym: Vec<DMatrix<f64>> = t.iter().map(|m| m + m.transpose()).collect();
    rows_of(&sym, v)
}

/// The constraint rows under construction (triplets, right-hand side, cones).
struct Rows {
    i: Vec<usize>,
    j: Vec<usize>,
    v: Vec<f64>,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
}

impl Rows {
    /// C + Σ_v x_v M_v ⪰ 0 for a symmetric d × d constant C and
    /// coefficients M_v: s = svec(C + Σ x_v M_v), so b = svec(C) and the
    /// column of x_v is −svec(M_v).
    fn psd(&mut self, c: &DMatrix<f64>, terms: &[(usize, DMatrix<f64>)]) {
        let d = c.nrows();
        let row0 = self.b.len();
        for col in 0..d {
            for row in 0..=col {
                let sc = if row == col { 1.0 } else { SQRT_2 };
                self.b.push(sc * c[(row, col)]);
            }
        }
        for (var, m) in terms {
            for col in 0..d {
                for row in 0..=col {
                    let val = m[(row, col)];
                    if val != 0.0 {
                        let sc = if row == col { 1.0 } else { SQRT_2 };
                        self.i.push(row0 + idx(row, col));
                        self.j.push(*var);
                        self.v.push(-sc * val);
                    }
                }
            }
        }
        self.cones.push(SupportedConeT::PSDTriangleConeT(d));
    }
}

impl Reference {
    fn pvar(&self, r: usize, c: usize) -> usize {
        idx(r.min(c), r.max(c))
    }

    fn gvar(&self, l: usize, r: usize, c: usize) -> usize {
        tri(self.nx) + (l * self.nx + r) * self.ny + c
    }

    /// First variable of Ŷ_{l,k} (`x = false`) or X̂_{l,k} (`x = true`);
    /// of Ŵ_{l,k} in the lean form.
    fn slack(&self, l: usize, k: usize, x: bool) -> usize {
        let base = tri(self.nx) + self.nv * self.nx * self.ny;
        base + ((l * self.r + k) * self.per + usize::from(x)) * tri(self.nx)
    }

    fn dvar(&self, k: usize) -> usize {
        self.slack(self.nv, 0, false) + k
    }

    fn n_vars(&self) -> usize {
        self.dvar(self.r)
    }

    /// The coefficients of the linear map (P̂, Γ̂_l) ↦ He{P̂K − Γ̂_l H}.
    fn he_terms(&self, l: usize, k: &DMatrix<f64>, h: &DMatrix<f64>) -> Vec<(usize, DMatrix<f64>)> {
        let (nx, ny) = (self.nx, self.ny);
        let mut out = Vec::new();
        for c in 0..nx {
            for r in 0..=c {
                let mut e = DMatrix::zeros(nx, nx);
                e[(r, c)] = 1.0;
                e[(c, r)] = 1.0;
                let m = &e * k;
                out.push((self.pvar(r, c), &m + m.transpose()));
            }
        }
        for r in 0..nx {
            for c in 0..ny {
                let mut e = DMatrix::zeros(nx, ny);
                e[(r, c)] = 1.0;
                let m = &e * h;
                out.push((self.gvar(l, r, c), -(&m + m.transpose())));
            }
        }
        out
    }

    /// The coefficients of a symmetric variable (upper triangle from `first`).
    fn sym_terms(&self, first: usize, sign: f64) -> Vec<(usize, DMatrix<f64>)> {
        let nx = self.nx;
        let mut out = Vec::new();
        for c in 0..nx {
            for r in 0..=c {
                let mut e = DMatrix::zeros(nx, nx);
                e[(r, c)] = sign;
                e[(c, r)] = sign;
                out.push((first + idx(r, c), e));
            }
        }
        out
    }

    /// The reference problem of `model` (sound mode, a zonotope region, a
    /// constant output map) at (α, γ), with margin `eps` and gain weight `w`,
    /// in Clarabel's standard form.
    pub fn new(
        model: &PolytopicModel,
        (alpha, gamma): (f64, f64),
        eps: f64,
        w: f64,
        form: Form,
    ) -> (Reference, Sdp) {
        let gens = model
            .region
            .zonotope_generators()
            .expect("a zonotope region");
        let (nx, ny, nv, r) = (model.nx(), model.ny(), model.nv(), gens.len());
        let v0 = &model.vertices[0];
        assert!(
            model.vertices.iter().all(|v| v.c == v0.c && v.m == v0.m),
            "the reference is written for a constant output map"
        );
        let abs_sum = gens
            .iter()
            .fold(DVector::zeros(nx), |acc: DVector<f64>, g| acc + g.abs());
        let rho = abs_sum.norm();
        let lean = form == Form::Lean;
        let sym = |ms: &[DMatrix<f64>]| ms.iter().all(|m| m == &m.transpose());
        assert!(
            !lean || model.vertices.iter().all(|v| sym(&v.n) && sym(&v.m)),
            "the lean form needs N_k and M_k symmetric"
        );
        let me = Reference {
            per: if lean { 1 } else { 2 },
            g_parts: model
                .vertices
                .iter()
                .map(|v| {
                    gens.iter()
                        .map(|g| (-rows_of(&v.n, g), -rows_of(&v.m, g)))
                        .collect()
                })
                .collect(),
            nx,
            ny,
            nv,
            r,
            s: 1.0 / (rho * rho),
        };
        let mut out = Rows {
            i: Vec::new(),
            j: Vec::new(),
            v: Vec::new(),
            b: Vec::new(),
            cones: Vec::new(),
        };
        let id = |n: usize| DMatrix::<f64>::identity(n, n);
        // P̂ ⪰ εI.
        out.psd(&(-id(nx) * eps), &me.sym_terms(0, 1.0));
        // D − ĜᵀP̂Ĝ ⪰ εI.
        let gh = DMatrix::from_columns(&gens) / rho;
        let mut terms = Vec::new();
        for c in 0..nx {
            for rr in 0..=c {
                let mut e = DMatrix::zeros(nx, nx);
                e[(rr, c)] = 1.0;
                e[(c, rr)] = 1.0;
                terms.push((me.pvar(rr, c), -(gh.transpose() * e * &gh)));
            }
        }
        for k in 0..r {
            let mut e = DMatrix::zeros(r, r);
            e[(k, k)] = 1.0;
            terms.push((me.dvar(k), e));
        }
        out.psd(&(-id(r) * eps), &terms);
        // 1 − ε − Σ d_k ≥ 0.
        let row = out.b.len();
        out.b.push(1.0 - eps);
        for k in 0..r {
            out.i.push(row);
            out.j.push(me.dvar(k));
            out.v.push(1.0);
        }
        out.cones.push(SupportedConeT::NonnegativeConeT(1));
        // Facets: [1 γâᵀ; γâ P̂] ⪰ εI (lean: not for −a after a).
        let facets = &model.region.facets;
        for (fi, a) in facets.iter().enumerate() {
            if lean && facets[..fi].iter().any(|b| b == &(-a)) {
                continue;
            }
            let mut c = -id(nx + 1) * eps;
            c[(0, 0)] += 1.0;
            for i in 0..nx {
                c[(0, i + 1)] = gamma * rho * a[i];
                c[(i + 1, 0)] = gamma * rho * a[i];
            }
            let terms: Vec<(usize, DMatrix<f64>)> = me
                .sym_terms(0, 1.0)
                .into_iter()
                .map(|(v, m)| {
                    let mut big = DMatrix::zeros(nx + 1, nx + 1);
                    big.view_mut((1, 1), (nx, nx)).copy_from(&m);
                    (v, big)
                })
                .collect();
            out.psd(&c, &terms);
        }
        // κ: the data size of the rate matrices.
        let max_a = model
            .vertices
            .iter()
            .map(|v| v.a.norm())
            .fold(0.0, f64::max);
        let max_r = model
            .vertices
            .iter()
            .map(|v| {
                gens.iter()
                    .map(|g| rows_he_of(&v.n, g).norm() + rows_of(&v.n, g).norm())
                    .sum::<f64>()
            })
            .fold(0.0, f64::max);
        let eps_rate = eps * (gamma * (alpha + max_a) + max_r);
        let zero = DMatrix::zeros(nx, nx);
        for (l, v) in model.vertices.iter().enumerate() {
            let k0 = &v.a * gamma + id(nx) * (0.5 * gamma * alpha);
            let mut main = me.he_terms(l, &k0, &(&v.c * gamma));
            for (k, g) in gens.iter().enumerate() {
                if lean {
                    // Ŵ ∓ 3G ⪰ 2εκI.
                    let (kk, hh) = &me.g_parts[l][k];
                    let first = me.slack(l, k, false);
                    for sign in [1.0, -1.0] {
                        let mut t = me.sym_terms(first, 1.0);
                        t.extend(me.he_terms(l, &(kk * (-3.0 * sign)), &(hh * (-3.0 * sign))));
                        out.psd(&(-id(nx) * (2.0 * eps_rate)), &t);
                    }
                    main.extend(me.sym_terms(first, 1.0));
                    continue;
                }
                let parts = [
                    (-rows_of(&v.n, g), -rows_of(&v.m, g), false),
                    (rows_he_of(&v.n, g), rows_he_of(&v.m, g), true),
                ];
                for (kk, hh, is_x) in parts {
                    let first = me.slack(l, k, is_x);
                    for sign in [1.0, -1.0] {
                        // Ŷ − sign·G ⪰ εκI.
                        let mut t = me.sym_terms(first, 1.0);
                        t.extend(me.he_terms(l, &(&kk * -sign), &(&hh * -sign)));
                        out.psd(&(-id(nx) * eps_rate), &t);
                    }
                    main.extend(me.sym_terms(first, 1.0));
                }
            }
            // −(F0 + ΣŶ + ΣX̂) ⪰ εκI.
            let neg: Vec<(usize, DMatrix<f64>)> = main.into_iter().map(|(v, m)| (v, -m)).collect();
            out.psd(&(&zero - id(nx) * eps_rate), &neg);
        }
        let n = me.n_vars();
        let m = out.b.len();
        let a = CscMatrix::new_from_triplets(m, n, out.i, out.j, out.v);
        let gains: Vec<usize> = (tri(nx)..tri(nx) + nv * nx * ny).collect();
        let p =
            CscMatrix::new_from_triplets(n, n, gains.clone(), gains.clone(), vec![w; gains.len()]);
        let sdp = Sdp {
            p,
            q: vec![0.0; n],
            a,
            b: out.b,
            cones: out.cones,
        };
        (me, sdp)
    }

    /// The solution vector in model units.
    pub fn unpack(&self, x: &[f64]) -> Point {
        let (nx, ny, s) = (self.nx, self.ny, self.s);
        let sym =
            |first: usize| DMatrix::from_fn(nx, nx, |r, c| s * x[first + idx(r.min(c), r.max(c))]);
        let per = |is_x: bool| -> Vec<Vec<DMatrix<f64>>> {
            (0..self.nv)
                .map(|l| (0..self.r).map(|k| sym(self.slack(l, k, is_x))).collect())
                .collect()
        };
        let p = sym(0);
        let gammas: Vec<DMatrix<f64>> = (0..self.nv)
            .map(|l| DMatrix::from_fn(nx, ny, |r, c| s * x[self.gvar(l, r, c)]))
            .collect();
        let d = (0..self.r).map(|k| x[self.dvar(k)]).collect();
        if self.per == 2 {
            return Point {
                p,
                gammas,
                y: per(false),
                x: per(true),
                d,
            };
        }
        // Lean: Y = W/3 + aI, X = 2W/3 − aI, a = m/6.
        let lmin = |m: &DMatrix<f64>| ((m + m.transpose()) * 0.5).symmetric_eigenvalues().min();
        let (mut y, mut xs) = (Vec::new(), Vec::new());
        for (l, ws) in per(false).into_iter().enumerate() {
            let (mut yl, mut xl) = (Vec::new(), Vec::new());
            for (k, w) in ws.into_iter().enumerate() {
                let (kk, hh) = &self.g_parts[l][k];
                let g = &p * kk - &gammas[l] * hh;
                let g3 = (&g + g.transpose()) * 3.0;
                let a = lmin(&(&w - &g3)).min(lmin(&(&w + &g3))) / 6.0;
                let shift = DMatrix::identity(nx, nx) * a;
                yl.push(&w / 3.0 + &shift);
                xl.push(&w * (2.0 / 3.0) - shift);
            }
            y.push(yl);
            xs.push(xl);
        }
        Point {
            p,
            gammas,
            y,
            x: xs,
            d,
        }
    }
}
