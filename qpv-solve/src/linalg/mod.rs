//! Small linear-algebra helpers shared by every layer: the svec packing of
//! symmetric matrices, rows / rowsHe, and matrices as lists of rows.

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
