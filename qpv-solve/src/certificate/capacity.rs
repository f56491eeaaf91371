//! α-capacity: the largest α at which the same (P, Γ_l) (and cube slacks)
//! satisfy every rate condition at this γ, solved exactly by eigenvalues.

use super::cube::CubeTerms;
use super::margins::lambda_max;
use super::rate::Terms;
use super::units::{balanced, balanced_for, block_model, cube_to_z, gammas_to_z};
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

fn capacity_inner(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> f64 {
    let sigma = ConditionSet::from_mode(mode).nonlinear_sign();
    let (model, gamma, _) = block_model(model, mode, gamma);
    let Some((ps, linv)) = sym_and_linv(p) else {
        return 0.0;
    };
    let terms = Terms::new(&model, &model.region.vertices, &ps, gammas, &[], gamma);
    least(rate_combos(&model).iter().flat_map(|combo| {
        let (terms, linv) = (&terms, &linv);
        combo.pairs(&model).into_iter().map(move |(i, j)| {
            let (m0, _) = terms.combo0(combo, sigma, (i, j));
            let w = linv * m0 * linv.transpose();
            -lambda_max(&w) / (gamma * combo.weight())
        })
    }))
}

/// The symmetric part of P and L⁻¹ (P = LLᵀ), if P is positive definite.
pub(super) fn sym_and_linv(p: &DMatrix<f64>) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let ps = (p + p.transpose()) * 0.5;
    let linv = ps.clone().cholesky()?.l().try_inverse()?;
    Some((ps, linv))
}

/// The smallest of the blocks' capacities, at least 0; 0 as soon as one is
/// NaN (not even α → 0⁺ is shown to work).
pub(super) fn least(caps: impl IntoIterator<Item = f64>) -> f64 {
    let mut worst = f64::INFINITY;
    for a in caps {
        if a.is_nan() {
            return 0.0;
        }
        worst = worst.min(a);
    }
    worst.max(0.0)
}

/// [`alpha_capacity`] for a design of `conditions = cube`: the largest α
/// at which F0_c(α) + Σ_k Y_{c,k} + Σ_k X_{c,k} ≺ 0 for the same (P, Γ_l) and
/// slacks (the slack inequalities and the region conditions do not depend
/// on α; the certificate checks them). 0 if P is not positive definite.
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

fn capacity_cube_inner(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    slacks: &CubeSlacks,
) -> f64 {
    let set = ConditionSet::from_mode(mode);
    let Some((ps, linv)) = sym_and_linv(p) else {
        return 0.0;
    };
    let combos = rate_combos(model);
    if slacks.y.len() != combos.len() || slacks.x.len() != combos.len() {
        return 0.0;
    }
    let ct = CubeTerms::new(model, &ps, gammas, &[], set, Candidate::new(0.0, gamma));
    least(
        combos
            .iter()
            .enumerate()
            .map(|(ci, combo)| ct.capacity(combo, ci, &linv, slacks)),
    )
}
