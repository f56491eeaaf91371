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

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    #[test]
    fn rows_and_rows_he_match_quadratic_forms() {
        // row k of rows(T, v) v = vᵀ T_k v; rowsHe(T, x) e = eᵀ He{T_k} x.
        let t = vec![
            DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 3.0, 4.0]),
            DMatrix::from_row_slice(2, 2, &[0.0, -1.0, 5.0, 0.5]),
        ];
        let v = DVector::from_vec(vec![0.3, -0.7]);
        let e = DVector::from_vec(vec![1.1, 0.2]);
        let r = rows(&t, &v);
        let rh = rows_he(&t, &v);
        for k in 0..2 {
            let q = v.dot(&(&t[k] * &v));
            assert!(((&r * &v)[k] - q).abs() < 1e-14);
            let he = &t[k] + t[k].transpose();
            let q2 = e.dot(&(&he * &v));
            assert!(((&rh * &e)[k] - q2).abs() < 1e-14);
        }
    }
}
