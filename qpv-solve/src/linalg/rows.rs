//! rows(T, v) and rowsHe(T, v): the two products of a vector with a list of
//! matrices that every condition family is written with.

use nalgebra::{DMatrix, DVector};

/// rows(T, v): the matrix whose row k is vᵀ T_k (one row per T_k).
pub fn rows(t: &[DMatrix<f64>], v: &DVector<f64>) -> DMatrix<f64> {
    let n = v.len();
    let mut out = DMatrix::zeros(t.len(), n);
    for (k, tk) in t.iter().enumerate() {
        for c in 0..n {
            let mut acc = 0.0;
            for r in 0..n {
                acc += v[r] * tk[(r, c)];
            }
            out[(k, c)] = acc;
        }
    }
    out
}

/// rowsHe(T, v): the matrix whose row k is vᵀ (T_k + T_kᵀ).
pub fn rows_he(t: &[DMatrix<f64>], v: &DVector<f64>) -> DMatrix<f64> {
    let n = v.len();
    let mut out = DMatrix::zeros(t.len(), n);
    for (k, tk) in t.iter().enumerate() {
        for c in 0..n {
            let mut acc = 0.0;
            for r in 0..n {
                acc += v[r] * (tk[(r, c)] + tk[(c, r)]);
            }
            out[(k, c)] = acc;
        }
    }
    out
}
