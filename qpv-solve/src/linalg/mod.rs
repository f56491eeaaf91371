//! Small linear-algebra helpers shared by every layer: the svec packing of
//! symmetric matrices, rows / rowsHe, matrices as lists of rows, and the
//! symmetric square root.

pub mod csc;
pub mod rows;
pub mod svec;

use nalgebra::DMatrix;

/// A matrix as a list of rows.
pub fn matrix_to_rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

/// A list of rows as a matrix (rows must have equal length; 0 × 0 if empty).
pub fn rows_to_matrix(rows: &[Vec<f64>]) -> DMatrix<f64> {
    let r = rows.len();
    let c = rows.first().map_or(0, |x| x.len());
    DMatrix::from_fn(r, c, |i, j| rows[i].get(j).copied().unwrap_or(f64::NAN))
}

/// The symmetric square root Q^{1/2} of a positive semidefinite `q` (its
/// symmetric part; eigenvalues below 0, from rounding, count as 0). It maps
/// the unit ball onto the ellipsoid {x : xᵀQ⁻¹x ≤ 1} of a state bound Q.
pub fn sqrtm(q: &DMatrix<f64>) -> DMatrix<f64> {
    let e = ((q + q.transpose()) * 0.5).symmetric_eigen();
    let d = DMatrix::from_diagonal(&e.eigenvalues.map(|v| v.max(0.0).sqrt()));
    &e.eigenvectors * d * e.eigenvectors.transpose()
}

/// The observer gains L_l = P⁻¹Γ_l of a Lyapunov matrix P and its
/// Γ_l = P L_l: the one place they are computed (a Cholesky factor of P's
/// symmetric part, else its LU). None if P is singular.
pub fn gains(p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> Option<Vec<DMatrix<f64>>> {
    let ps = (p + p.transpose()) * 0.5;
    if let Some(ch) = ps.clone().cholesky() {
        return Some(gammas.iter().map(|g| ch.solve(g)).collect());
    }
    let lu = ps.lu();
    gammas.iter().map(|g| lu.solve(g)).collect()
}

/// The singular values of `m`, or `None` when an entry is not finite or
/// the iteration does not converge: nalgebra's SVD never returns on
/// non-finite input (a sample period of 1e305 makes the discrete blocks
/// infinite), so every SVD of numbers that come from input goes through
/// here, bounded before it starts.
pub fn singular_values(m: &DMatrix<f64>) -> Option<nalgebra::DVector<f64>> {
    if m.iter().any(|v| !v.is_finite()) {
        return None;
    }
    if m.is_empty() {
        return Some(nalgebra::DVector::zeros(0));
    }
    m.clone()
        .try_svd(false, false, f64::EPSILON, 10_000)
        .map(|s| s.singular_values)
}

/// The spectral norm ‖m‖₂ (largest singular value): `f64::INFINITY` when
/// an entry is infinite, NaN when one is NaN or the SVD does not converge
/// ([`singular_values`]), so that a comparison with a bound fails.
pub fn norm2(m: &DMatrix<f64>) -> f64 {
    if m.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    if m.iter().any(|v| v.is_infinite()) {
        return f64::INFINITY;
    }
    singular_values(m).map_or(f64::NAN, |s| s.max())
}

/// The smallest singular value of `m` (NaN when [`singular_values`] gives
/// none).
pub fn min_singular(m: &DMatrix<f64>) -> f64 {
    singular_values(m).map_or(f64::NAN, |s| s.min())
}
