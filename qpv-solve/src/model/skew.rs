//! The skew-symmetric slack K_k added to N_k: N_k + K_k with K_k = −K_kᵀ is
//! the same plant (xᵀK_kx = 0), a different representation in the LMIs.

use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// The model with K_{k,l} added to N_{k,l} (K must be skew-symmetric).
pub fn with_skew(model: &PolytopicModel, k: &[Vec<DMatrix<f64>>]) -> PolytopicModel {
    let mut out = model.clone();
    for (v, kl) in out.vertices.iter_mut().zip(k) {
        for (n, kk) in v.n.iter_mut().zip(kl) {
            // The skew part only (exact for a skew-symmetric K): a
            // symmetric remainder would change the plant.
            *n += (kk - kk.transpose()) * 0.5;
        }
    }
    out
}
