//! The Jacobian box of a model's nonlinear terms, recomputed for a
//! certificate from the terms themselves (not from the vertices or a
//! report), and the check that the gains do not depend on it.

use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// The model with its vertices expanded by the Jacobian box recomputed
/// from its nonlinear terms (the global bound, or the bound on the set S
/// at `gamma`); `None` for a model without nonlinear terms.
pub(super) fn recompute(
    model: &PolytopicModel,
    gamma: f64,
) -> Result<Option<PolytopicModel>, String> {
    if model.jacobian.is_none() {
        return Ok(None);
    }
    let g = model.jacobian_needs_set().then_some(gamma);
    model
        .with_jacobian(g)
        .map(Some)
        .map_err(|e| format!("the Jacobian bound of the nonlinear terms: {e}"))
}

/// Whether the gains of the 2^q Jacobian corners of every θ-vertex are the
/// same matrix (the gain may depend on θ only: H is not measured).
pub(super) fn tied(model: &PolytopicModel, l: &[DMatrix<f64>]) -> Result<(), String> {
    let q = model.gain_shift();
    if q == 0 {
        return Ok(());
    }
    for (k, g) in l.iter().enumerate() {
        if l.get(k >> q << q) != Some(g) {
            return Err(format!(
                "the gain at vertex {} differs from the one of its θ-vertex: a gain may not depend \
                 on the unmeasured Jacobian corner",
                k + 1
            ));
        }
    }
    Ok(())
}
