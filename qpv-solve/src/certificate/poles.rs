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

use super::margins::{block_guard, lambda_max, Acc, FamilyMargin};
use super::rate::Terms;
use super::units::{balanced_for, block_model, gammas_of, l_to_z};
use super::{Certificate, Gains};
use crate::conditions::poles::{blocks, data_size};
use crate::conditions::{rate_combos, ConditionSet};
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
fn check_poles(
    model: &PolytopicModel,
    mode: qpv_dsl::Mode,
    at: &Candidate,
    gains: &Gains,
    poles: &[PoleRegion],
) -> FamilyMargin {
    let (model, gamma, _) = block_model(model, mode, at.gamma);
    if let Some((zm, s)) = balanced_for(&model, mode, gains.p) {
        if let (Some(pz), Some(lz)) = (s.p_to_z(gains.p), l_to_z(&s, gains.l)) {
            return check_in(&zm, mode, gamma, &pz, &lz, poles);
        }
    }
    check_in(&model, mode, gamma, gains.p, gains.l, poles)
}

/// Family "D" in the model's coordinates as given: the blocks of
/// [`crate::conditions::poles::blocks`] at X = Σ_t w_t γ·PF of every
/// combination and pair, each required ≺ 0.
fn check_in(
    model: &PolytopicModel,
    mode: qpv_dsl::Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
    poles: &[PoleRegion],
) -> FamilyMargin {
    let mut acc = Acc::new(Family::D);
    let ps = (p + p.transpose()) * 0.5;
    let (gammas, lnorm) = gammas_of(&ps, l);
    let xs = &model.region.vertices;
    let terms = Terms::new(model, xs, &ps, &gammas, &lnorm, gamma);
    let sg = ConditionSet::from_mode(mode).nonlinear_sign();
    let double = is_double_sum(model);
    let pn = ps.norm();
    for combo in rate_combos(model) {
        let g = gamma * combo.weight();
        for (i, j) in combo.pairs(model) {
            let (x, size) = terms.weighted(&combo, sg, (i, j), |x| x);
            for region in poles {
                for (k, m) in blocks(region, &x, &ps, g).iter().enumerate() {
                    let size = 2.0 * (size + g * pn * data_size(region));
                    acc.add(-lambda_max(m), block_guard(m.nrows(), size, m), || {
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
