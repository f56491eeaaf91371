//! The linear-algebra helpers under the SDPs: the svec packing of
//! symmetric matrices (index order, isometry, inverse), the CSC column
//! builder (packed PSD blocks, no stored zeros), and rows / rowsHe against
//! the quadratic forms they stand for.

use nalgebra::{DMatrix, DVector};
use qpv_solve::linalg::csc::Columns;
use qpv_solve::linalg::rows::{rows, rows_he};
use qpv_solve::linalg::svec::{
    smat, svec, svec_entry, svec_index, svec_len, svec_scale, svec_side,
};

#[test]
fn index_order_is_upper_triangle_by_columns() {
    let expected = [(0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2), (0, 3)];
    for (k, &(i, j)) in expected.iter().enumerate() {
        assert_eq!(svec_index(i, j), k);
        assert_eq!(svec_index(j, i), k);
        assert_eq!(svec_entry(k), (i, j));
    }
    for k in 0..svec_len(60) {
        let (i, j) = svec_entry(k);
        assert!(i <= j);
        assert_eq!(svec_index(i, j), k);
    }
    for n in 0..60 {
        assert_eq!(svec_side(svec_len(n)), Some(n));
    }
    assert_eq!(svec_side(4), None);
}

#[test]
fn svec_is_an_isometry_and_smat_inverts_it() {
    let n = 5;
    let a = DMatrix::from_fn(n, n, |i, j| (i * 7 + j * 3) as f64 % 5.0 - 2.0);
    let a = &a + a.transpose();
    let b = DMatrix::from_fn(n, n, |i, j| ((i + 1) * (j + 2)) as f64 % 3.0 - 1.0);
    let b = &b + b.transpose();
    let (va, vb) = (svec(&a), svec(&b));
    let dot: f64 = va.iter().zip(&vb).map(|(p, q)| p * q).sum();
    assert!((dot - (&a * &b).trace()).abs() < 1e-12);
    assert!((smat(&va) - &a).amax() < 1e-12);
    for i in 0..n {
        for j in 0..n {
            let k = svec_index(i, j);
            assert!((va[k] - svec_scale(i, j) * a[(i, j)]).abs() < 1e-12);
        }
    }
}

#[test]
fn svec_block_is_packed_upper_triangle_with_sqrt2() {
    let m = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 3.0]);
    let mut cols = Columns::new(2);
    cols.push_svec(0, 1, &m, -1.0);
    let a = cols.into_csc(3);
    assert_eq!(a.colptr, vec![0, 0, 3]);
    assert_eq!(a.rowval, vec![0, 1, 2]);
    let s2 = std::f64::consts::SQRT_2;
    assert_eq!(a.nzval, vec![-1.0, -2.0 * s2, -3.0]);
}

#[test]
fn zeros_are_not_stored() {
    let mut cols = Columns::new(1);
    cols.push(0, 0, 0.0);
    cols.push(1, 0, 4.0);
    let a = cols.into_csc(2);
    assert_eq!((a.rowval, a.nzval), (vec![1], vec![4.0]));
}

#[test]
#[allow(clippy::needless_range_loop)]
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
