//! The cube's slack inequalities (`conditions = cube`), checked on the
//! slacks a design carries: its region condition through D and its rate
//! family through Y and X per generator.

use super::margins::{block_guard, lambda_max, lambda_min, Acc, GUARD_C};
use super::rate::gain_sizes;
use crate::conditions::cube::CubeSlacks;
use crate::conditions::{Combo, ConditionSet};
use crate::linalg::rows::{rows, rows_he};
use crate::vocab::Candidate;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::PolytopicModel;

/// The cube's vertex condition: D ⪰ GᵀPG (sound) or [D Gᵀ; G P] ⪰ 0
/// (paper), and Σ D_kk ≤ 1.
pub(super) fn cube_region(
    acc: &mut Acc,
    set: ConditionSet,
    ps: &DMatrix<f64>,
    gens: &[DVector<f64>],
    d: &[f64],
) {
    let (nx, r) = (ps.nrows(), gens.len());
    let g = DMatrix::from_columns(gens);
    let dm = DMatrix::from_diagonal(&DVector::from_column_slice(d));
    let pn = ps.norm();
    match set {
        ConditionSet::Sound => {
            let gpg = g.transpose() * ps * &g;
            let m = &dm - &gpg;
            let guard =
                GUARD_C * (r as f64 + nx as f64 + 1.0) * 2.0 * (dm.norm() + pn * g.norm_squared());
            acc.add(lambda_min(&m), guard, || "D ⪰ GᵀPG".into());
        }
        ConditionSet::Paper => {
            let mut m = DMatrix::zeros(r + nx, r + nx);
            m.view_mut((0, 0), (r, r)).copy_from(&dm);
            m.view_mut((r, 0), (nx, r)).copy_from(&g);
            m.view_mut((0, r), (r, nx)).copy_from(&g.transpose());
            m.view_mut((r, r), (nx, nx)).copy_from(ps);
            let guard = GUARD_C * (r as f64 + nx as f64 + 2.0) * m.norm();
            acc.add(lambda_min(&m), guard, || "[D Gᵀ; G P] ⪰ 0".into());
        }
    }
    let tr: f64 = d.iter().sum();
    let guard = GUARD_C * (r as f64 + 1.0) * (1.0 + d.iter().map(|v| v.abs()).sum::<f64>());
    acc.add(1.0 - tr, guard, || "trace D ≤ 1".into());
}

/// The pieces of the cube's rate inequalities, in model units.
pub(super) struct CubeTerms<'a> {
    pub(super) model: &'a PolytopicModel,
    pub(super) p: &'a DMatrix<f64>,
    pub(super) gammas: &'a [DMatrix<f64>],
    /// ‖L_l‖‖P‖ + ‖Γ_l‖ (error size of Γ_l).
    pub(super) gn: Vec<f64>,
    pub(super) sigma: f64,
    pub(super) gamma: f64,
    /// The α the slack inequalities are checked at.
    pub(super) alpha: f64,
}

impl<'a> CubeTerms<'a> {
    /// The pieces at the candidate `at` (its α is used by
    /// [`CubeTerms::check`] only).
    pub(super) fn new(
        model: &'a PolytopicModel,
        p: &'a DMatrix<f64>,
        gammas: &'a [DMatrix<f64>],
        lnorm: &[f64],
        set: ConditionSet,
        at: Candidate,
    ) -> Self {
        CubeTerms {
            model,
            p,
            gammas,
            gn: gain_sizes(p, gammas, lnorm),
            sigma: set.nonlinear_sign(),
            gamma: at.gamma,
            alpha: at.alpha,
        }
    }

    /// F0_c = Σ_t w_t (He{γ(PA_l − Γ_l C_m)} + γαP), G_c(g) = Σ_t w_t
    /// He{−σP rows(N_l, g) + Γ_l rows(M_m, g)} and H_c(g) = Σ_t w_t
    /// He{σP rowsHe(N_l, g) − Γ_l rowsHe(M_m, g)}: which = 0, 1, 2; with the
    /// size of their terms (for the guard).
    pub(super) fn part(
        &self,
        c: &Combo,
        alpha: f64,
        which: u8,
        g: &DVector<f64>,
    ) -> (DMatrix<f64>, f64) {
        let nx = self.p.nrows();
        let pn = self.p.norm();
        let mut out = DMatrix::zeros(nx, nx);
        let mut size = 0.0;
        for &(l, m, w) in &c.terms {
            let (vl, vm, gl) = (
                &self.model.vertices[l],
                &self.model.vertices[m],
                &self.gammas[l],
            );
            let (x, sz) = match which {
                0 => {
                    let x = (self.p * &vl.a - gl * &vm.c) * self.gamma
                        + self.p * (0.5 * self.gamma * alpha);
                    let sz =
                        self.gamma * (pn * vl.a.norm() + self.gn[l] * vm.c.norm() + alpha * pn);
                    (x, sz)
                }
                1 => {
                    let (rn, rm) = (rows(&vl.n, g), rows(&vm.m, g));
                    let x = self.p * &rn * (-self.sigma) + gl * &rm;
                    (x, pn * rn.norm() + self.gn[l] * rm.norm())
                }
                _ => {
                    let (rn, rm) = (rows_he(&vl.n, g), rows_he(&vm.m, g));
                    let x = self.p * &rn * self.sigma - gl * &rm;
                    (x, pn * rn.norm() + self.gn[l] * rm.norm())
                }
            };
            out += (&x + x.transpose()) * w;
            size += 2.0 * sz * w.abs();
        }
        (out, size)
    }

    /// Adds every slack inequality of combination `c` (index `ci`; labelled
    /// for a double sum if `double`) to `acc`.
    pub(super) fn check(
        &self,
        acc: &mut Acc,
        (c, ci, double): (&Combo, usize, bool),
        gens: &[DVector<f64>],
        slacks: &CubeSlacks,
    ) {
        let alpha = self.alpha;
        let nx = self.p.nrows();
        let g0 = DVector::zeros(nx);
        let guard = |size: f64, m: &DMatrix<f64>| block_guard(nx, size, m);
        let sym = |m: &DMatrix<f64>| (m + m.transpose()) * 0.5;
        let (mut sum, mut size) = self.part(c, alpha, 0, &g0);
        for (k, g) in gens.iter().enumerate() {
            for (which, name, s) in [(1u8, "Y", &slacks.y[ci][k]), (2u8, "X", &slacks.x[ci][k])] {
                let s = sym(s);
                let (part, psize) = self.part(c, alpha, which, g);
                for sign in [1.0, -1.0] {
                    let m = &s - &part * sign;
                    let sz = psize + s.norm();
                    acc.add(lambda_min(&m), guard(sz, &m), || {
                        format!(
                            "{} {name} k={} {}",
                            c.label(double),
                            k + 1,
                            if sign > 0.0 { "⪰ +" } else { "⪰ −" }
                        )
                    });
                }
                sum += &s;
                size += s.norm();
            }
        }
        acc.add(-lambda_max(&sum), guard(size, &sum), || {
            format!("{} F0 + ΣY + ΣX", c.label(double))
        });
    }

    /// The largest α with F0_c(α) + ΣY + ΣX ≺ 0 for these (P, Γ_l) and slacks.
    pub(super) fn capacity(
        &self,
        c: &Combo,
        ci: usize,
        linv: &DMatrix<f64>,
        slacks: &CubeSlacks,
    ) -> f64 {
        let nx = self.p.nrows();
        let (mut m0, _) = self.part(c, 0.0, 0, &DVector::zeros(nx));
        for k in 0..slacks.y[ci].len() {
            m0 += (&slacks.y[ci][k] + slacks.y[ci][k].transpose()) * 0.5;
            m0 += (&slacks.x[ci][k] + slacks.x[ci][k].transpose()) * 0.5;
        }
        let w = linv * m0 * linv.transpose();
        -lambda_max(&w) / (self.gamma * c.weight())
    }
}
