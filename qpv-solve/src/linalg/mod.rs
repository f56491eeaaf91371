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
