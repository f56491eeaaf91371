//! Clarabel PSD-cone problems with known answers, solved through the
//! pure-Rust BLAS/LAPACK symbols of `qpv_solve::lapack` (cones ≥ 4×4, since
//! Clarabel handles sizes ≤ 3 in closed form without LAPACK).

use clarabel::algebra::*;
use clarabel::solver::*;
use nalgebra::DMatrix;
use qpv_solve::svec::{svec, svec_index, svec_len};

fn settings() -> DefaultSettings<f64> {
    DefaultSettingsBuilder::default()
        .verbose(false)
        .build()
        .unwrap()
}

/// A deterministic symmetric test matrix with distinct eigenvalues.
fn test_matrix(n: usize, seed: u64) -> DMatrix<f64> {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    let m = DMatrix::from_fn(n, n, |_, _| next());
    (&m + m.transpose()) * 0.5
}

/// min trace(C X) s.t. trace(X) = 1, X ⪰ 0  →  λ_min(C).
fn min_eig_sdp(c: &DMatrix<f64>) -> (SolverStatus, f64, Vec<f64>) {
    qpv_solve::lapack::ensure_linked();
    let n = c.nrows();
    let d = svec_len(n);
    let q = svec(c);
    // Row 0: trace(X) = 1 (zero cone). Rows 1..: -x + s = 0, s ∈ PSD.
    let mut rows = vec![vec![0.0; d]; 1 + d];
    for j in 0..n {
        rows[0][svec_index(j, j)] = 1.0;
    }
    for k in 0..d {
        rows[1 + k][k] = -1.0;
    }
    let a = CscMatrix::from(&rows);
    let mut b = vec![0.0; 1 + d];
    b[0] = 1.0;
    let p = CscMatrix::<f64>::zeros((d, d));
    let cones = [ZeroConeT(1), PSDTriangleConeT(n)];
    let mut solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings()).unwrap();
    solver.solve();
    let sol = &solver.solution;
    (sol.status, sol.obj_val, sol.x.clone())
}

#[test]
fn min_eigenvalue_4x4() {
    let c = test_matrix(4, 1);
    let lmin = c.clone().symmetric_eigenvalues().min();
    let (status, obj, _) = min_eig_sdp(&c);
    assert_eq!(status, SolverStatus::Solved);
    assert!((obj - lmin).abs() < 1e-6, "obj {obj} vs λmin {lmin}");
}

#[test]
fn min_eigenvalue_6x6() {
    let c = test_matrix(6, 2);
    let lmin = c.clone().symmetric_eigenvalues().min();
    let (status, obj, _) = min_eig_sdp(&c);
    assert_eq!(status, SolverStatus::Solved);
    assert!((obj - lmin).abs() < 1e-6, "obj {obj} vs λmin {lmin}");
}
