//! The convergence region P: a polytope containing the origin in its
//! interior, held both as vertices and as facets a_kᵀ x ≤ 1.

use nalgebra::DVector;
use serde::Serialize;

/// A bounded polytope P = Co{x_(1..p)} = {x : a_kᵀ x ≤ 1, k = 1..q}.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Region {
    /// The vertices x_(i).
    pub vertices: Vec<DVector<f64>>,
    /// The facet normals a_k, each facet being a_kᵀ x ≤ 1.
    pub facets: Vec<DVector<f64>>,
}
