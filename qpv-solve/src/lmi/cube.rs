//! The assembly of `conditions = cube` ([`crate::conditions::cube`]).
//!
//! Variables after Γ̂: per rate combination c and generator k the lower
//! slacks Ŝ_{c,k} = Ŷ_{c,k} − G_c(g_k), Ŝ'_{c,k} = X̂_{c,k} − H_c(g_k)
//! (upper triangles like P̂, model units over s), then the r diagonal
//! entries of D (dimensionless). Ŷ, X̂ themselves are not variables: the
//! report's Y, X are recomputed from Ŝ, P and Γ_l ([`Problem::unpack_cube`]).
//! Rows:
//!
//! ```text
//!   region, in place of the vertex rows:
//!     sound (S2):  D − ĜᵀP̂Ĝ − εI ⪰ 0           PSD(r)       (Ĝ = G/ρ)
//!     paper (13):  [D Ĝᵀ; Ĝ P̂] − εI ⪰ 0         PSD(r + nx)
//!                  1 − ε − Σ_k D_kk ≥ 0          Nonnegative(1)
//!   facets (S3)/(14): one block per pair of opposite facets (a and −a
//!     give the same block up to the congruence diag(−1, I))
//!   rate, per combination c and generator k (Ŷ − G = Ŝ, Ŷ + G = Ŝ + 2G):
//!     Ŝ_{c,k} − εκ I ⪰ 0,  Ŝ_{c,k} + 2G_c(g_k) − εκ I ⪰ 0             2r × PSD(nx)
//!     Ŝ'_{c,k} − εκ I ⪰ 0, Ŝ'_{c,k} + 2H_c(g_k) − εκ I ⪰ 0            2r × PSD(nx)
//!   and per combination
//!     −(F0_c + Σ_k (Ŝ_{c,k} + G_c(g_k)) + Σ_k (Ŝ'_{c,k} + H_c(g_k))) − ε_rate I ⪰ 0   PSD(nx)
//! ```
//!
//! with F0_c, G_c, H_c the parts of the rate matrix He{P̂K − Γ̂H} of
//! [`crate::lmi`]: F0 = He{P̂(γA_l + (γα/2)I) − γΓ̂_l C_m}, G(g) =
//! He{−σP̂ rows(N_l, g) + Γ̂_l rows(M_m, g)}, H(g) = He{σP̂ rowsHe(N_l, g) −
//! Γ̂_l rowsHe(M_m, g)}, each weighted by the combination's terms. The slack
//! inequalities keep their margin εκ under every objective (the max-margin
//! column sits on the last block only), so that the returned slacks satisfy
//! them strictly, as the certificate requires.
//!
//! These are exactly Ŷ ∓ G ⪰ εκI, X̂ ∓ H ⪰ εκI and −(F0 + ΣŶ + ΣX̂) ⪰ ε_rate I
//! (a change of variables); the lower slack makes the first block of every
//! pair a block on its own variable only, which the solver's sparse LDL
//! factorisation of the KKT system eliminates cheaply (about a quarter fewer
//! operations per iteration at nx = 10..12 than with Ŷ, X̂ as variables).
//!
//! One slack per generator ([`Problem::cube_one_slack`]): when every N_l
//! and M_m is symmetric (the symmetric split of sound mode), rowsHe(T, g) =
//! 2 rows(T, g) exactly, so H_c(g) = −2G_c(g) and the pair (Y, X) enters
//! only through W = Y + X. Then
//!
//! ```text
//!     Y ⪰ ±G, X ⪰ ±H, F0 + ΣY + ΣX ≺ 0   ⟺   W ⪰ ±3G, F0 + ΣW ≺ 0
//! ```
//!
//! (⇒: W ∓ 3G = (Y ∓ G) + (X ± H); ⇐: Y = W/3 + aI, X = 2W/3 − aI), with
//! the margins: Y ∓ G ⪰ εκI and X ∓ H ⪰ εκI give W ∓ 3G ⪰ 2εκI, and from
//! W ∓ 3G ⪰ mI (m ≥ 2εκ) the split a = m/6 gives Y ∓ G ⪰ (m/2)I and
//! X ∓ H ⪰ (m/2)I. So the rows per combination and generator are
//!
//! ```text
//!     Ŝ_{c,k} − 2εκ I ⪰ 0,  Ŝ_{c,k} + 6G_c(g_k) − 2εκ I ⪰ 0      (Ŝ = Ŵ − 3G)
//! ```
//!
//! and the last block −(F0_c + Σ_k (Ŝ_{c,k} + 3G_c(g_k))) − ε_rate I ⪰ 0:
//! the same relaxation with half the slack variables and blocks
//! (c(2r + 1) instead of c(4r + 1)). The report still carries Y and X
//! (recomputed by that split), and the certificate checks all 4r + 1
//! inequalities per combination.

use super::blocks::RateMargins;
use super::blocks::{add_term, At, Kh};
use super::Problem;
use crate::backend::builder::SdpBuilder;
use crate::conditions::cube::CubeSlacks;
use crate::linalg::svec::svec_index;
use nalgebra::{DMatrix, DVector};

/// Which part of the rate matrix of a combination.
#[derive(Clone, Copy)]
enum Part<'a> {
    /// F0: the terms without region vectors (with γαP).
    Constant,
    /// G(g): the e-vertex terms, linear in g.
    E(&'a DVector<f64>),
    /// H(g): the x-vertex terms, linear in g.
    X(&'a DVector<f64>),
}

impl Problem<'_> {
    /// Number of generators r (cube conditions; 0 otherwise).
    pub fn n_generators(&self) -> usize {
        self.gens.len()
    }

    /// Whether the cube slacks of a combination and generator are one
    /// (W = Y + X, see the module doc): every N_l and M_m is symmetric, so
    /// that H_c(g) = −2G_c(g) exactly. Otherwise a pair Y, X.
    pub fn cube_one_slack(&self) -> bool {
        self.cube_one_slack
    }

    /// Whether every N_l and M_m of the model is symmetric (entry for
    /// entry), which makes H_c(g) = −2G_c(g) in floating point too.
    pub(super) fn cube_pairs_fold(&self) -> bool {
        let sym = |ms: &[DMatrix<f64>]| ms.iter().all(|m| m == &m.transpose());
        self.model.vertices.iter().all(|v| sym(&v.n) && sym(&v.m))
    }

    /// Number of symmetric slack variables per combination and generator.
    pub(super) fn cube_slacks_per_generator(&self) -> usize {
        if self.cube_one_slack {
            1
        } else {
            2
        }
    }

    /// Number of cube slack variables (the slacks' upper triangles and D).
    pub(super) fn cube_slack_vars(&self) -> usize {
        let r = self.gens.len();
        self.combos.len() * r * self.cube_slacks_per_generator() * self.np + r
    }

    /// First variable of Ŝ_{c,k} (Ŝ'_{c,k} follows it, unless the
    /// slacks are one).
    fn yvar(&self, c: usize, k: usize) -> usize {
        let per = self.cube_slacks_per_generator() * self.np;
        self.gains_end() + (c * self.gens.len() + k) * per
    }

    /// Variable of D_kk.
    fn dvar(&self, k: usize) -> usize {
        self.gains_end() + self.cube_slack_vars() - self.gens.len() + k
    }

    /// K and the gain terms of one part of combination c's rate matrix, so
    /// that the part is He{P̂K − Σ_l Γ̂_l H_l}, times `sign`.
    fn cube_kh(&self, alpha: f64, gamma: f64, c: usize, part: Part, sign: f64) -> Kh {
        let ab = (alpha, gamma);
        match part {
            Part::Constant => self.combo_kh(ab, c, (true, sign), None, None),
            Part::E(g) => self.combo_kh(ab, c, (false, sign), Some(At::Vector(g)), None),
            Part::X(g) => self.combo_kh(ab, c, (false, sign), None, Some(At::Vector(g))),
        }
    }

    /// The region's vertex condition through D (see the module doc).
    pub(super) fn push_cube_region(&self, out: &mut SdpBuilder, eps: f64) {
        let (nx, r) = (self.nx, self.gens.len());
        let gh: Vec<DVector<f64>> = self.gens.iter().map(|g| g / self.rho).collect();
        let sound = self.set.nonlinear_sign() > 0.0;
        if sound {
            // D − ĜᵀP̂Ĝ − εI ⪰ 0: A[P̂_ij] = +sc ∂(ĝ_aᵀP̂ĝ_b)/∂P̂_ij, A[D_k] = −1.
            let blk = out.psd(r, eps);
            for j in 0..nx {
                for i in 0..=j {
                    let v = svec_index(i, j);
                    for bb in 0..r {
                        for a in 0..=bb {
                            let d = if i == j {
                                gh[a][i] * gh[bb][i]
                            } else {
                                gh[a][i] * gh[bb][j] + gh[a][j] * gh[bb][i]
                            };
                            out.entry(&blk, a, bb, v, d);
                        }
                    }
                }
            }
            for k in 0..r {
                out.entry(&blk, k, k, self.dvar(k), -1.0);
            }
        } else {
            // [D Ĝᵀ; Ĝ P̂] − εI ⪰ 0 (indices 0..r: D, r..: P̂).
            let blk = out.psd(r + nx, eps);
            for (a, g) in gh.iter().enumerate() {
                for i in 0..nx {
                    out.rhs(&blk, a, r + i, g[i]);
                }
            }
            for j in 0..nx {
                for i in 0..=j {
                    out.entry(&blk, r + i, r + j, svec_index(i, j), -1.0);
                }
            }
            for k in 0..r {
                out.entry(&blk, k, k, self.dvar(k), -1.0);
            }
        }
        // 1 − ε − Σ D_kk ≥ 0.
        let row = out.nonneg(1);
        out.set_b(row, 1.0 - eps);
        for k in 0..r {
            out.a(row, self.dvar(k), 1.0);
        }
    }

    /// The cube rate family (see the module doc). The variables are the
    /// lower slacks Ŝ = Ŷ − G(g_k) (and Ŝ' = X̂ − H(g_k)), so that the
    /// first block of each pair, Ŝ ⪰ εκI, involves no other variable; the
    /// second is Ŝ + 2G ⪰ εκI and the last −(F0 + Σ_k (Ŝ_k + G_k) + Σ_k
    /// (Ŝ'_k + H_k)) ⪰ εI. The same inequalities in Ŷ, X̂ (an exact change
    /// of variables), with about a quarter less work in the solver's KKT
    /// factorisation: half of the slack blocks no longer couple to P̂ and Γ̂.
    pub(super) fn push_rate_cube(
        &self,
        out: &mut SdpBuilder,
        alpha: f64,
        gamma: f64,
        rate: &RateMargins,
    ) {
        let nx = self.nx;
        let mut df = vec![0.0; nx * nx];
        let mut block = |out: &mut SdpBuilder, kh: &Kh, eps: f64, vars: &[(usize, f64)]| {
            let blk = out.psd(nx, eps);
            self.push_he_block(out, &blk, kh, &mut df);
            for &(first, sign) in vars {
                self.push_sym_var(out, &blk, first, sign);
            }
            blk
        };
        for c in 0..self.combos.len() {
            let mut sum: Vec<(usize, f64)> = Vec::with_capacity(2 * self.gens.len());
            let mut main = self.cube_kh(alpha, gamma, c, Part::Constant, 1.0);
            if self.cube_one_slack {
                for (k, g) in self.gens.iter().enumerate() {
                    let var = self.yvar(c, k);
                    // Ŵ − 3G = Ŝ ⪰ 2εκI: the variable alone.
                    let blk = out.psd(nx, 2.0 * rate.slack_eps);
                    self.push_sym_var(out, &blk, var, -1.0);
                    // Ŵ + 3G = Ŝ + 6G ⪰ 2εκI is −(−6G − Ŝ) ⪰ 2εκI.
                    let kh = self.cube_kh(alpha, gamma, c, Part::E(g), -6.0);
                    block(out, &kh, 2.0 * rate.slack_eps, &[(var, -1.0)]);
                    // Ŵ = Ŝ + 3G in the main block.
                    add_kh(&mut main, &self.cube_kh(alpha, gamma, c, Part::E(g), 3.0));
                    sum.push((var, 1.0));
                }
                let blk = block(out, &main, rate.eps, &sum);
                rate.push_column(out, &blk);
                continue;
            }
            for (k, g) in self.gens.iter().enumerate() {
                let (y, x) = (self.yvar(c, k), self.yvar(c, k) + self.np);
                for (part, var) in [(Part::E(g), y), (Part::X(g), x)] {
                    // Ŷ − G = Ŝ ⪰ εκI: the variable alone.
                    let blk = out.psd(nx, rate.slack_eps);
                    self.push_sym_var(out, &blk, var, -1.0);
                    // Ŷ + G = Ŝ + 2G ⪰ εκI is −(−2G − Ŝ) ⪰ εκI.
                    let kh = self.cube_kh(alpha, gamma, c, part, -2.0);
                    block(out, &kh, rate.slack_eps, &[(var, -1.0)]);
                    // Ŷ = Ŝ + G in the main block.
                    add_kh(&mut main, &self.cube_kh(alpha, gamma, c, part, 1.0));
                    sum.push((var, 1.0));
                }
            }
            let blk = block(out, &main, rate.eps, &sum);
            rate.push_column(out, &blk);
        }
    }

    /// He{P K − Σ_l Γ_l H_l} for (P, Γ_l) in model units.
    fn eval_kh(kh: &Kh, p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> DMatrix<f64> {
        let mut m = p * &kh.0;
        for (l, h) in &kh.1 {
            m -= &gammas[*l] * h;
        }
        &m + m.transpose()
    }

    /// G_c(g_k) (`e`) or H_c(g_k) (`!e`) at (P, Γ_l) in model units.
    fn cube_part(
        &self,
        c: usize,
        k: usize,
        e: bool,
        p: &DMatrix<f64>,
        gs: &[DMatrix<f64>],
    ) -> DMatrix<f64> {
        let g = &self.gens[k];
        let part = if e { Part::E(g) } else { Part::X(g) };
        Self::eval_kh(&self.cube_kh(0.0, 0.0, c, part, 1.0), p, gs)
    }

    /// The cube slacks of a solution vector, in model units (None unless
    /// the conditions are cube): Y = sŜ + G(g_k), X = sŜ' + H(g_k) at the
    /// solution's (P, Γ_l); with one slack, W = sŜ + 3G(g_k) split as
    /// Y = W/3 + aI, X = 2W/3 − aI with a = m/6, m the smaller of
    /// λ_min(W ∓ 3G(g_k)) (so that every Y ∓ G and X ∓ H keeps half of W's
    /// margin, see the module doc).
    pub fn unpack_cube(&self, x: &[f64]) -> Option<CubeSlacks> {
        if self.gens.is_empty() {
            return None;
        }
        let (p, gs) = self.unpack(x);
        let sym = |first: usize| self.sym_at(x, first);
        let d = (0..self.gens.len()).map(|k| x[self.dvar(k)]).collect();
        if self.cube_one_slack {
            let (mut ys, mut xs) = (Vec::new(), Vec::new());
            for c in 0..self.combos.len() {
                let (mut yc, mut xc) = (Vec::new(), Vec::new());
                for k in 0..self.gens.len() {
                    let g3 = self.cube_part(c, k, true, &p, &gs) * 3.0;
                    let w = sym(self.yvar(c, k)) + &g3;
                    let m = lambda_min(&(&w - &g3)).min(lambda_min(&(&w + &g3)));
                    let shift = DMatrix::identity(self.nx, self.nx) * (m / 6.0);
                    yc.push(&w / 3.0 + &shift);
                    xc.push(&w * (2.0 / 3.0) - shift);
                }
                ys.push(yc);
                xs.push(xc);
            }
            return Some(CubeSlacks { y: ys, x: xs, d });
        }
        let per = |off: usize| -> Vec<Vec<DMatrix<f64>>> {
            (0..self.combos.len())
                .map(|c| {
                    (0..self.gens.len())
                        .map(|k| {
                            sym(self.yvar(c, k) + off) + self.cube_part(c, k, off == 0, &p, &gs)
                        })
                        .collect()
                })
                .collect()
        };
        Some(CubeSlacks {
            y: per(0),
            x: per(self.np),
            d,
        })
    }

    /// Writes cube slacks (model units; upper triangles used) into a
    /// variable vector from [`Problem::pack`], which must hold P and Γ_l
    /// already (the variables are Ŝ = (Y − G)/s, or with one slack
    /// Ŝ = (Y + X − 3G)/s; cube conditions only; tests).
    pub fn pack_cube(&self, x: &mut [f64], slacks: &CubeSlacks) {
        assert!(
            !self.gens.is_empty(),
            "only cube problems have these slacks"
        );
        let (p, gs) = self.unpack(x);
        let mut put = |first: usize, m: &DMatrix<f64>| self.put_sym(x, first, m);
        for c in 0..self.combos.len() {
            for k in 0..self.gens.len() {
                if self.cube_one_slack {
                    let g3 = self.cube_part(c, k, true, &p, &gs) * 3.0;
                    put(self.yvar(c, k), &(&slacks.y[c][k] + &slacks.x[c][k] - g3));
                    continue;
                }
                put(
                    self.yvar(c, k),
                    &(&slacks.y[c][k] - self.cube_part(c, k, true, &p, &gs)),
                );
                put(
                    self.yvar(c, k) + self.np,
                    &(&slacks.x[c][k] - self.cube_part(c, k, false, &p, &gs)),
                );
            }
        }
        for (k, d) in slacks.d.iter().enumerate() {
            x[self.dvar(k)] = *d;
        }
    }
}

/// `acc += kh` (K and the gain terms, merged by vertex).
fn add_kh(acc: &mut Kh, kh: &Kh) {
    acc.0 += &kh.0;
    for (l, h) in &kh.1 {
        add_term(&mut acc.1, *l, h.clone());
    }
    acc.1.sort_by_key(|(g, _)| *g);
}

/// λ_min of the symmetric part of `m`.
fn lambda_min(m: &DMatrix<f64>) -> f64 {
    ((m + m.transpose()) * 0.5).symmetric_eigenvalues().min()
}

/// The facet normals with one of each pair of opposite facets (a_j = −a_i
/// entry for entry) left out: the (S3)/(14) blocks of a and −a are the same
/// up to the congruence diag(−1, I), so the second of a pair adds nothing.
/// A zonotope's facets come in such pairs, so its blocks halve.
pub(super) fn one_of_each_opposite_pair(facets: &[DVector<f64>]) -> Vec<DVector<f64>> {
    let mut kept: Vec<DVector<f64>> = Vec::with_capacity(facets.len());
    for a in facets {
        let opposite = |b: &DVector<f64>| b.iter().zip(a.iter()).all(|(x, y)| *x == -*y);
        if !kept.iter().any(opposite) {
            kept.push(a.clone());
        }
    }
    kept
}
