//! α-capacity: the largest α at which the same (P, Γ_l) (and cube slacks)
//! satisfy every rate condition at this γ, solved exactly by eigenvalues.

use super::cube::CubeTerms;
use super::margins::lambda_max;
use super::rate::{combo_is_linear, sigma, Terms};
use super::units::{balanced, balanced_for, cube_to_z, gammas_to_z};
use crate::conditions::cube::CubeSlacks;
use crate::conditions::{rate_combos, ConditionSet};
use crate::vocab::Candidate;
use nalgebra::DMatrix;
use qpv_dsl::{Mode, PolytopicModel};

/// The largest α at which the *same* (P, Γ_l) satisfy every rate LMI at
/// this γ (exactly: −λ_max(L⁻¹ M₀ L⁻ᵀ)/γ minimised over the blocks, with
/// P = LLᵀ and M₀ the rate LMI without its γαP term). Returns 0 if P is not
/// positive definite or not even α → 0⁺ works. The region conditions do not
/// depend on α.
pub fn alpha_capacity(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> f64 {
    if let Some((zm, s)) = balanced_for(model, mode, p) {
        if let (Some(pz), Some(gz)) = (s.p_to_z(p), gammas_to_z(&s, gammas)) {
            return capacity_inner(&zm, mode, gamma, &pz, &gz);
        }
    }
    capacity_inner(model, mode, gamma, p, gammas)
}

pub(super) fn capacity_inner(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> f64 {
    let set = ConditionSet::from_mode(mode);
    let global_model = crate::model::global_model(model);
    let (model, gamma) = if crate::model::is_global(model, mode) {
        (&*global_model, 1.0)
    } else {
        (model, gamma)
    };
    let ps = (p + p.transpose()) * 0.5;
    let Some(ch) = ps.clone().cholesky() else {
        return 0.0;
    };
    let linv = match ch.l().try_inverse() {
        Some(li) => li,
        None => return 0.0,
    };
    let xs = &model.region.vertices;
    let lnorm = vec![0.0; gammas.len()];
    let terms = Terms::new(model, xs, &ps, gammas, &lnorm, gamma);
    let mut worst = f64::INFINITY;
    for combo in rate_combos(model) {
        let n = if combo_is_linear(model, &combo) {
            xs.len().min(1)
        } else {
            xs.len()
        };
        for i in 0..n {
            for j in 0..n {
                let (m0, _) = terms.combo0(&combo, sigma(set), gamma, i, j);
                let w = &linv * m0 * linv.transpose();
                let a = -lambda_max(&w) / (gamma * combo.weight());
                if a.is_nan() {
                    return 0.0;
                }
                worst = worst.min(a);
            }
        }
    }
    worst.max(0.0)
}

/// [`alpha_capacity`] for a design of `conditions = cube`: the largest α
/// at which F0_c(α) + Σ_k Y_{c,k} + Σ_k X_{c,k} ≺ 0 for the same (P, Γ_l) and
/// slacks (the slack inequalities and the region conditions do not depend
/// on α; [`check_cube`] checks them). 0 if P is not positive definite.
pub(crate) fn alpha_capacity_cube(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    slacks: &CubeSlacks,
) -> f64 {
    if let Some((zm, s)) = balanced(model, mode) {
        if let (Some(pz), Some(gz), Some(cz)) =
            (s.p_to_z(p), gammas_to_z(&s, gammas), cube_to_z(&s, slacks))
        {
            return capacity_cube_inner(&zm, mode, gamma, &pz, &gz, &cz);
        }
    }
    capacity_cube_inner(model, mode, gamma, p, gammas, slacks)
}

pub(super) fn capacity_cube_inner(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    slacks: &CubeSlacks,
) -> f64 {
    let set = ConditionSet::from_mode(mode);
    let ps = (p + p.transpose()) * 0.5;
    let Some(ch) = ps.clone().cholesky() else {
        return 0.0;
    };
    let Some(linv) = ch.l().try_inverse() else {
        return 0.0;
    };
    let combos = rate_combos(model);
    if slacks.y.len() != combos.len() || slacks.x.len() != combos.len() {
        return 0.0;
    }
    let lnorm = vec![0.0; gammas.len()];
    let ct = CubeTerms::new(model, &ps, gammas, &lnorm, set, Candidate::new(0.0, gamma));
    let mut worst = f64::INFINITY;
    for (ci, combo) in combos.iter().enumerate() {
        let a = ct.capacity(combo, ci, &linv, slacks);
        if a.is_nan() {
            return 0.0;
        }
        worst = worst.min(a);
    }
    worst.max(0.0)
}
