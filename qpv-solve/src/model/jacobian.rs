//! Nonlinear terms of unmeasured states in the observer's model
//! (docs/method.md, "Nonlinear terms of unmeasured states"): the routes
//! and options that cannot carry them refused, and the vertices expanded by
//! the Jacobian box on the set S at the γ the design uses.

use crate::error::SolveError;
use qpv_dsl::{OutputRoute, PolytopicModel, StateBound};

/// The γ the Jacobian box on S is computed for when the design searches γ:
/// the top of the γ range, min(1, γ_max)(1 − 10⁻⁶) (S4), where S is
/// smallest. `None` without a given state bound.
pub fn gamma_for_set(model: &PolytopicModel) -> Option<f64> {
    let g = crate::model::gamma_max(model)?;
    (g.is_finite() && g > 0.0).then(|| g.min(1.0) * (1.0 - 1e-6))
}

/// Refuses what the nonlinear terms do not support: `state_bound auto`
/// (its invariance LMI does not see them), the output post-filter and the
/// skew slack. `plant` is the model before its state bound is resolved.
pub(crate) fn refuse_unsupported(
    plant: &PolytopicModel,
    route: &OutputRoute,
    skew: bool,
) -> Result<(), SolveError> {
    if plant.jacobian.is_none() {
        return Ok(());
    }
    let what = if matches!(plant.state_bound, StateBound::Auto { .. }) {
        "`state_bound auto` (its invariance conditions do not include the nonlinear terms: give `state_bound Q = [...]`)"
    } else if matches!(route, OutputRoute::Filter(_)) {
        "the output post-filter (`output_route = filter`)"
    } else if skew {
        "the skew slack (`split = skew_slack`)"
    } else {
        return Ok(());
    };
    Err(SolveError::Unsupported(format!(
        "model `{}` has nonlinear terms of unmeasured states; {what} is not supported with them",
        plant.name
    )))
}

/// The model with its vertices expanded by the Jacobian box: unchanged
/// when the box is global (already expanded by the model compiler) or
/// there are no nonlinear terms; else the box on S at `gamma`
/// ([`gamma_for_set`] when `None`).
pub fn expand(model: PolytopicModel, gamma: Option<f64>) -> Result<PolytopicModel, SolveError> {
    if !model.jacobian_needs_set() {
        return Ok(model);
    }
    let g = gamma.or_else(|| gamma_for_set(&model));
    model
        .with_jacobian(g)
        .map_err(|e| SolveError::Unsupported(format!("model `{}`: {e}", model.name)))
}
