//! Pole regions (`poles = ...`) as data: the LMI-region blocks of Chilali &
//! Gahinet on the frozen error dynamics, written on the rate family's own
//! matrices (docs/method.md §18, "Pole regions").
//!
//! For a rate combination with weights w_t and a region-vertex pair (i, j),
//! let X = Σ_t w_t (γ(P A_l − Γ_l C_m) + σ P R_{l,i,j} − Γ_l S_{m,i,j}), the
//! rate block's γ·PF without its α term (F the error-dynamics matrix at
//! θ-vertex l, e = x_(i)/γ, x = x_(j)/γ), and g = γ Σ_t w_t (so that the
//! constant terms carry the combination's weight like γαP in (S5)). Every
//! block below is linear in (X, P), hence in (P, Γ_l), and required ≺ 0:
//!
//! ```text
//!     disk |λ − c| < r:   [ −r g P        X − c g P ]
//!                          [ (X − c g P)ᵀ  −r g P    ]
//!     sector, half-angle β (degrees → radians):
//!                          [ sinβ He(X)       cosβ (X − Xᵀ) ]
//!                          [ cosβ (Xᵀ − X)    sinβ He(X)    ]
//!     strip lo < Re λ < hi:  He(X) − 2 hi g P,   2 lo g P − He(X)
//! ```
//!
//! With γ = 1 and one term these are the regions' conditions on P F
//! (F = A_l − L_l C); γ > 0 and the weights scale them without changing a
//! sign. The blocks are affine in the vertex terms, so (as for (S5)) the
//! vertex combinations imply every θ in Θ, e ∈ E and x ∈ F.

use nalgebra::DMatrix;
use qpv_dsl::PoleRegion;

/// The blocks of `region` (each required ≺ 0) for the matrices X and P of
/// the module documentation and g = γ Σ_t w_t; linear in (X, P).
pub fn blocks(
    region: &PoleRegion,
    x: &DMatrix<f64>,
    p: &DMatrix<f64>,
    g: f64,
) -> Vec<DMatrix<f64>> {
    let n = p.nrows();
    let he = x + x.transpose();
    match *region {
        PoleRegion::Disk { centre, radius } => {
            let off = x - p * (centre * g);
            let diag = p * (-radius * g);
            vec![two_by_two(&diag, &off, &diag)]
        }
        PoleRegion::Sector { angle } => {
            let b = angle.to_radians();
            let d = &he * b.sin();
            let off = (x - x.transpose()) * b.cos();
            vec![two_by_two(&d, &off, &d)]
        }
        PoleRegion::Strip { lo, hi } => {
            debug_assert_eq!(he.nrows(), n);
            vec![&he - p * (2.0 * hi * g), p * (2.0 * lo * g) - &he]
        }
    }
}

/// [a b; bᵀ d] for square n × n blocks.
fn two_by_two(a: &DMatrix<f64>, b: &DMatrix<f64>, d: &DMatrix<f64>) -> DMatrix<f64> {
    let n = a.nrows();
    let mut m = DMatrix::zeros(2 * n, 2 * n);
    m.view_mut((0, 0), (n, n)).copy_from(a);
    m.view_mut((0, n), (n, n)).copy_from(b);
    m.view_mut((n, 0), (n, n)).copy_from(&b.transpose());
    m.view_mut((n, n), (n, n)).copy_from(d);
    m
}

/// The size of a region's constants (|c| + r, 1, |lo| + |hi|): what the
/// margin of its blocks scales with, beside the data of X.
pub(crate) fn data_size(region: &PoleRegion) -> f64 {
    match *region {
        PoleRegion::Disk { centre, radius } => centre.abs() + radius,
        PoleRegion::Sector { .. } => 1.0,
        PoleRegion::Strip { lo, hi } => lo.abs() + hi.abs(),
    }
}
