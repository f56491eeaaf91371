//! The coordinates a certificate evaluates in: the balancing congruence
//! x = D z applied to the model, P, L_l, Γ_l and cube slacks (exact in
//! floating point), and Γ_l = P L_l as the certificate sees them.

use crate::conditions::cube::CubeSlacks;
use crate::model::{ObserverKind, StateScaling};
use nalgebra::DMatrix;
use qpv_dsl::{Mode, PolytopicModel};
use std::borrow::Cow;

/// Γ_l = P L_l as the certificate sees them (empty where the sizes do not
/// fit, which the certificate then reports), and ‖L_l‖_F.
pub(super) fn gammas_of(p: &DMatrix<f64>, l: &[DMatrix<f64>]) -> (Vec<DMatrix<f64>>, Vec<f64>) {
    let gammas = l
        .iter()
        .map(|li| {
            if p.ncols() == li.nrows() {
                p * li
            } else {
                DMatrix::zeros(0, 0)
            }
        })
        .collect();
    (gammas, l.iter().map(|li| li.norm()).collect())
}

/// Whether the certificate checks the global observer: decided here, once
/// for the whole certificate, from the model as it is now and the caller's
/// mode ([`ObserverKind::of`]), never from a report's claim.
pub(super) fn is_global(model: &PolytopicModel, mode: Mode) -> bool {
    ObserverKind::of(model, mode).is_global()
}

/// The model and γ the blocks use, and whether the observer is global: for
/// the global observer its region-free model ([`crate::model::global_model`]:
/// the region the point {0}, whose one pair has no nonlinear terms, and no
/// state bound) and γ = 1; else the model and γ as given.
pub(super) fn block_model(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
) -> (Cow<'_, PolytopicModel>, f64, bool) {
    if is_global(model, mode) {
        (crate::model::global_model(model), 1.0, true)
    } else {
        (Cow::Borrowed(model), gamma, false)
    }
}

/// The model in balanced coordinates x = D z ([`StateScaling`]: sound mode,
/// a badly scaled region, every entry transformed exactly), with D. The
/// certificate evaluates every condition on the user's P and L_l after this
/// congruence (P_z = DPD, L_z = D⁻¹L, exact in floating point): the same
/// inequalities, with the eigenvalues of well-balanced matrices; its
/// margins are those of the balanced matrices.
pub(super) fn balanced(
    model: &PolytopicModel,
    mode: Mode,
) -> Option<(PolytopicModel, StateScaling)> {
    let s = StateScaling::of(model, mode)?;
    Some((s.model(model)?, s))
}

/// [`balanced`], or for the global observer (which has no region to fix
/// the units) the congruence that balances the P being checked
/// ([`StateScaling::of_p`]: powers of two, exact like every other).
pub(super) fn balanced_for(
    model: &PolytopicModel,
    mode: Mode,
    p: &DMatrix<f64>,
) -> Option<(PolytopicModel, StateScaling)> {
    if let Some(b) = balanced(model, mode) {
        return Some(b);
    }
    if !is_global(model, mode) || p.shape() != (model.nx(), model.nx()) {
        return None;
    }
    let s = StateScaling::of_p(p)?;
    Some((s.model(model)?, s))
}

pub(super) fn l_to_z(s: &StateScaling, l: &[DMatrix<f64>]) -> Option<Vec<DMatrix<f64>>> {
    l.iter().map(|x| s.l_to_z(x)).collect()
}

pub(super) fn gammas_to_z(s: &StateScaling, g: &[DMatrix<f64>]) -> Option<Vec<DMatrix<f64>>> {
    g.iter().map(|x| s.gamma_to_z(x)).collect()
}

/// Cube slacks in balanced coordinates: Y_z = DYD, X_z = DXD (D of the
/// generators unchanged: G_zᵀP_zG_z = GᵀPG).
pub(super) fn cube_to_z(s: &StateScaling, c: &CubeSlacks) -> Option<CubeSlacks> {
    let per = |v: &Vec<Vec<DMatrix<f64>>>| -> Option<Vec<Vec<DMatrix<f64>>>> {
        v.iter()
            .map(|row| row.iter().map(|m| s.p_to_z(m)).collect())
            .collect()
    };
    Some(CubeSlacks {
        y: per(&c.y)?,
        x: per(&c.x)?,
        d: c.d.clone(),
    })
}
