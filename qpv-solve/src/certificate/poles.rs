//! The independent check of `poles = ...` (family "D"): every pole-region
//! block recomputed from P and the gains L_l (Γ_l = P L_l) with dense
//! eigenvalues, at every rate combination and region-vertex pair, in the
//! coordinates the rest of the certificate uses (docs/method.md §18).
//!
//! With X = Σ_t w_t (γ(P A_l − Γ_l C_m) + σ P R_{l,i,j} − Γ_l S_{m,i,j})
//! (γ·PF at the vertices, without α) and g = γ Σ_t w_t, the blocks required
//! ≺ 0 are, for a disk |λ − c| < r, [−rgP, X − cgP; (X − cgP)ᵀ, −rgP]; for a
//! sector of half-angle β, [sinβ(X + Xᵀ), cosβ(X − Xᵀ); cosβ(Xᵀ − X),
//! sinβ(X + Xᵀ)]; for a strip lo < Re λ < hi, X + Xᵀ − 2hi·gP and
//! 2lo·gP − X − Xᵀ. The margin of the family is the smallest −λ_max.
//!
//! What a passed family D implies (docs/method.md §18): every eigenvalue
//! of the error dynamics frozen at any θ ∈ Θ (and, for a QPV plant, any
//! e ∈ E and x ∈ F) lies in every region; with a disk, ‖F − cI‖₂ ≤ r√κ(P),
//! whence the gain bound of [`disk_gain_bound`].

use super::rate::sigma;
use super::{balanced_for, gammas_of, lambda_max, Acc, Terms, GUARD_C};
use super::{Certificate, Gains};
use crate::conditions::{rate_combos, Combo, ConditionSet};
use crate::model::is_double_sum;
use crate::vocab::{Candidate, Family};
use nalgebra::DMatrix;
use qpv_dsl::{PoleRegion, PolytopicModel};

impl Certificate {
    /// The certificate with family "D" of the pole regions `poles` (their
    /// intersection) checked on `gains` at `at`; unchanged when `poles` is
    /// empty or the inputs were already refused. A failed family D fails
    /// the certificate.
    pub fn with_poles(
        mut self,
        model: &PolytopicModel,
        gains: &Gains,
        at: &Candidate,
        poles: &[PoleRegion],
    ) -> Certificate {
        if poles.is_empty() || !self.input_errors.is_empty() {
            return self;
        }
        let fam = check_poles(model, self.mode, at, gains, poles);
        self.passed &= fam.passed;
        self.families.push(fam);
        self
    }
}

/// Family "D": the worst margin of every region's blocks (see the module
/// documentation), in balanced coordinates where the rest of the
/// certificate uses them.
pub fn check_poles(
    model: &PolytopicModel,
    mode: qpv_dsl::Mode,
    at: &Candidate,
    gains: &Gains,
    poles: &[PoleRegion],
) -> super::FamilyMargin {
    let global = crate::model::is_global(model, mode);
    let gm = crate::model::global_model(model);
    let (model, gamma) = if global {
        (&*gm, 1.0)
    } else {
        (model, at.gamma)
    };
    if let Some((zm, s)) = balanced_for(model, mode, gains.p) {
        let lz: Option<Vec<DMatrix<f64>>> = gains.l.iter().map(|x| s.l_to_z(x)).collect();
        if let (Some(pz), Some(lz)) = (s.p_to_z(gains.p), lz) {
            return check_in(&zm, mode, gamma, &pz, &lz, poles);
        }
    }
    check_in(model, mode, gamma, gains.p, gains.l, poles)
}

/// Family "D" in the model's coordinates as given.
fn check_in(
    model: &PolytopicModel,
    mode: qpv_dsl::Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
    poles: &[PoleRegion],
) -> super::FamilyMargin {
    let mut acc = Acc::new(Family::D);
    let ps = (p + p.transpose()) * 0.5;
    let (gammas, lnorm) = gammas_of(&ps, l);
    let xs = &model.region.vertices;
    let terms = Terms::new(model, xs, &ps, &gammas, &lnorm, gamma);
    let sg = sigma(ConditionSet::from_mode(mode));
    let double = is_double_sum(model);
    let pn = ps.norm();
    for combo in rate_combos(model) {
        let g = gamma * combo.weight();
        let pairs: Vec<(usize, usize)> = if xs.len() <= 1 || super::combo_is_linear(model, &combo) {
            vec![(0, 0)]
        } else {
            (0..xs.len())
                .flat_map(|i| (0..xs.len()).map(move |j| (i, j)))
                .collect()
        };
        for (i, j) in pairs {
            let (x, size) = combo_x(&terms, &combo, sg, gamma, i, j);
            for region in poles {
                for (k, m) in region_matrices(region, &x, &ps, g).iter().enumerate() {
                    let size = 2.0 * (size + g * pn * region_size(region));
                    let guard = GUARD_C * (m.nrows() as f64 + 1.0) * 2.0 * (size + m.norm());
                    acc.add(-lambda_max(m), guard, || {
                        let side = match (region, k) {
                            (PoleRegion::Strip { .. }, 0) => " Re < hi",
                            (PoleRegion::Strip { .. }, _) => " Re > lo",
                            _ => "",
                        };
                        let pair = if xs.len() <= 1 {
                            String::new()
                        } else {
                            format!(" i={} j={}", i + 1, j + 1)
                        };
                        format!("{}{side} {}{pair}", region.name(), combo.label(double))
                    });
                }
            }
        }
    }
    acc.finish()
}

/// X of one combination at the pair (i, j): Σ_t w_t γ·PF, and its size.
fn combo_x(
    terms: &Terms,
    combo: &Combo,
    sg: f64,
    gamma: f64,
    i: usize,
    j: usize,
) -> (DMatrix<f64>, f64) {
    let n = terms.p.nrows();
    let mut x = DMatrix::zeros(n, n);
    let mut size = 0.0;
    for &(l, m, w) in &combo.terms {
        let (xi, s) = terms.phi(sg, gamma, l, m, i, j);
        x += xi * w;
        size += s * w.abs();
    }
    (x, size)
}

/// |c| + r, 1, |lo| + |hi|: the region's constants, for the guard.
fn region_size(region: &PoleRegion) -> f64 {
    match *region {
        PoleRegion::Disk { centre, radius } => centre.abs() + radius,
        PoleRegion::Sector { .. } => 1.0,
        PoleRegion::Strip { lo, hi } => lo.abs() + hi.abs(),
    }
}

/// The matrices required ≺ 0 for one region (module documentation).
fn region_matrices(
    region: &PoleRegion,
    x: &DMatrix<f64>,
    p: &DMatrix<f64>,
    g: f64,
) -> Vec<DMatrix<f64>> {
    let n = p.nrows();
    let sym = x + x.transpose();
    let stack = |a: &DMatrix<f64>, b: &DMatrix<f64>, d: &DMatrix<f64>| {
        let mut m = DMatrix::zeros(2 * n, 2 * n);
        for r in 0..n {
            for c in 0..n {
                m[(r, c)] = a[(r, c)];
                m[(r, n + c)] = b[(r, c)];
                m[(n + c, r)] = b[(r, c)];
                m[(n + r, n + c)] = d[(r, c)];
            }
        }
        m
    };
    match *region {
        PoleRegion::Disk { centre, radius } => {
            let d = p * (-radius * g);
            let b = x - p * (centre * g);
            vec![stack(&d, &b, &d)]
        }
        PoleRegion::Sector { angle } => {
            let (s, c) = angle.to_radians().sin_cos();
            let d = &sym * s;
            let b = (x - x.transpose()) * c;
            vec![stack(&d, &b, &d)]
        }
        PoleRegion::Strip { lo, hi } => vec![&sym - p * (2.0 * hi * g), p * (2.0 * lo * g) - &sym],
    }
}

/// The bound on every ‖L_l‖₂ that a passed disk |λ − c| < r implies for the
/// global observer (an LPV plant): the disk block at the diagonal
/// combination l is (F_l − cI)ᵀP(F_l − cI) ≺ r²P with F_l = A_l − L_l C_l,
/// so ‖F_l − cI‖₂ < r√κ(P), ‖L_l C_l‖₂ ≤ ‖A_l − cI‖₂ + r√κ(P), and, where
/// C_l has full row rank, ‖L_l‖₂ ≤ (‖A_l − cI‖₂ + r√κ(P)) / σ_min(C_l).
/// The largest over l; None for a QPV plant, without a disk, for a P that
/// is not positive definite or a C_l without full row rank.
pub fn disk_gain_bound(
    model: &PolytopicModel,
    p: &DMatrix<f64>,
    poles: &[PoleRegion],
) -> Option<f64> {
    if !model.is_lpv() {
        return None;
    }
    let ps = (p + p.transpose()) * 0.5;
    let eig = ps.symmetric_eigenvalues();
    let (lmin, lmax) = (eig.min(), eig.max());
    if !(lmin > 0.0 && lmax.is_finite()) {
        return None;
    }
    let kappa = lmax / lmin;
    let mut best: Option<f64> = None;
    for region in poles {
        let PoleRegion::Disk { centre, radius } = *region else {
            continue;
        };
        let mut worst: f64 = 0.0;
        for v in &model.vertices {
            let n = v.a.nrows();
            let shifted = &v.a - DMatrix::identity(n, n) * centre;
            let a_norm = crate::linalg::norm2(&shifted);
            let smin = crate::linalg::min_singular(&v.c);
            if v.c.nrows() > v.c.ncols() || smin.is_nan() || smin <= 0.0 {
                return None;
            }
            worst = worst.max((a_norm + radius * kappa.sqrt()) / smin);
        }
        best = Some(best.map_or(worst, |b| b.min(worst)));
    }
    best
}
