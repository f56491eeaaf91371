//! The discrete decrease family "S5d" of a `sample = h` design, recomputed
//! from P and the gains L_l (Γ_l = P L_l) in model units.
//!
//! The observer and the plant stepped by the same explicit Euler step h
//! give the error map e⁺ = (I + hF)e, F the error-dynamics matrix of
//! docs/method.md §2. V(e⁺) ≤ (1 − hα)V(e) for every e ⇔
//! (I + hF)ᵀP(I + hF) ⪯ (1 − hα)P ⇔ (Schur complement, P ≻ 0)
//!
//! ```text
//!     [ (1 − hα)P      (P + hPF)ᵀ ]
//!     [ P + hPF         P         ]  ⪰ 0,
//! ```
//!
//! affine in F. At the vertex (θ-vertex l, output vertex m, e = x_(i)/γ,
//! x = x_(j)/γ), PF = Φ = PA_l − Γ_l C_m + (P R_{l,i,j} − Γ_l S_{m,i,j})/γ.
//! A rate combination (weights w_t, W = Σ_t w_t; see
//! [`crate::conditions::Combo`]) sums the vertex blocks with its weights:
//! [W(1 − hα)P, Mᵀ; M, WP], M = WP + h Σ_t w_t Φ_t. The family's margin
//! is λ_min of that block (positive = satisfied).

use super::capacity::{least, sym_and_linv};
use super::margins::block_guard;
use super::margins::{lambda_min, Acc};
use super::rate::{Pair, Terms};
use crate::conditions::{pair_suffix, rate_combos, Combo, ConditionSet};
use crate::model::is_double_sum;
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// The input errors of a sampled check: sound mode only, h positive finite.
pub(super) fn input_errors(set: ConditionSet, alpha: f64, h: f64) -> Vec<String> {
    let mut errs = Vec::new();
    if set != ConditionSet::Sound {
        errs.push("the sampled decrease (S5d) is a sound-mode condition".into());
    }
    if !(h.is_finite() && h > 0.0) {
        errs.push(format!(
            "sample period h = {h} is not a positive finite number"
        ));
    } else if alpha.is_finite() && h * alpha >= 1.0 {
        errs.push(format!(
            "hα = {:.6} ≥ 1: no Lyapunov function decreases by a factor 1 − hα ≤ 0 per step",
            h * alpha
        ));
    }
    errs
}

/// The combination's block W(1 − hα)P, M, WP as one 2nx matrix, and the
/// size of its terms (for the guard).
pub(super) fn block(
    terms: &Terms<'_>,
    combo: &Combo,
    alpha: f64,
    h: f64,
    pair: Pair,
) -> (DMatrix<f64>, f64) {
    let (p, gamma) = (terms.p, terms.gamma);
    let nx = p.nrows();
    let w = combo.weight();
    let pn = p.norm();
    let mut m = p * w;
    let mut size = w.abs() * pn;
    for &(l, mm, wt) in &combo.terms {
        // phi = γΦ (σ = +1: the sound error dynamics).
        let (phi, sz) = terms.phi(1.0, (l, mm), pair);
        m += phi * (h * wt / gamma);
        size += h * wt.abs() * sz / gamma;
    }
    let mut b = DMatrix::zeros(2 * nx, 2 * nx);
    b.view_mut((0, 0), (nx, nx))
        .copy_from(&(p * (w * (1.0 - h * alpha))));
    b.view_mut((nx, 0), (nx, nx)).copy_from(&m);
    b.view_mut((0, nx), (nx, nx)).copy_from(&m.transpose());
    b.view_mut((nx, nx), (nx, nx)).copy_from(&(p * w));
    let size = 2.0 * size + w.abs() * pn * (1.0 + (1.0 - h * alpha).abs());
    (b, size)
}

/// Every region-vertex pair (i, j) of the model (0-based): the discrete
/// family has no shortcut for linear combinations.
fn all_pairs(model: &PolytopicModel) -> impl Iterator<Item = Pair> + Clone {
    let np = model.region.vertices.len();
    (0..np).flat_map(move |i| (0..np).map(move |j| (i, j)))
}

/// Adds every discrete block (combination, i, j) to `acc` (λ_min ⪰ 0).
pub(super) fn check_family(acc: &mut Acc, terms: &Terms<'_>, alpha: f64, h: f64) {
    let model = terms.model;
    let double = is_double_sum(model);
    let nx = model.nx();
    for combo in rate_combos(model) {
        for (i, j) in all_pairs(model) {
            let (b, size) = block(terms, &combo, alpha, h, (i, j));
            acc.add(lambda_min(&b), block_guard(2 * nx, size, &b), || {
                format!("{}{}", combo.label(double), pair_suffix(model, i, j))
            });
        }
    }
}

/// The largest α at which the *same* (P, Γ_l) satisfy every discrete block
/// at (γ, h): W(1 − hα)P ⪰ Mᵀ(WP)⁻¹M ⇔ 1 − hα ≥ σ_max(L⁻¹ M L⁻ᵀ)²/W²
/// (P = LLᵀ), so α_c = min over the blocks of (1 − σ_max²/W²)/h — the
/// generalised eigenvalue problem of the discrete family, solved exactly.
/// 0 if P is not positive definite or not even α → 0⁺ works.
pub fn alpha_capacity_sampled(
    model: &PolytopicModel,
    gamma: f64,
    h: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> f64 {
    if !(h.is_finite() && h > 0.0) {
        return 0.0;
    }
    let Some((ps, linv)) = sym_and_linv(p) else {
        return 0.0;
    };
    let nx = ps.nrows();
    let terms = Terms::new(model, &model.region.vertices, &ps, gammas, &[], gamma);
    least(rate_combos(model).iter().flat_map(|combo| {
        let (terms, linv) = (&terms, &linv);
        all_pairs(model).map(move |pair| {
            // α = 0 gives top-left WP; M is the lower-left block.
            let (b, _) = block(terms, combo, 0.0, h, pair);
            let m = b.view((nx, 0), (nx, nx)).into_owned();
            let n = linv * m * linv.transpose();
            let smax = crate::linalg::norm2(&n);
            (1.0 - (smax / combo.weight()).powi(2)) / h
        })
    }))
}
