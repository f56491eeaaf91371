//! Clarabel PSD-cone problems with known answers, solved through the
//! pure-Rust BLAS/LAPACK symbols of `qpv_solve::lapack` (cones ≥ 4×4, since
//! Clarabel handles sizes ≤ 3 in closed form without LAPACK).
#![allow(clippy::needless_range_loop)]

use nalgebra::DMatrix;
use qpv_clarabel::clarabel::algebra::*;
use qpv_clarabel::clarabel::solver::*;
use qpv_clarabel::Solved;
use qpv_solve::svec::{smat, svec, svec_index, svec_len, SQRT2};
use std::time::Instant;

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
    let mut b = vec![0.0; 1 + d];
    b[0] = 1.0;
    let cones = [ZeroConeT(1), PSDTriangleConeT(n)];
    let solver = solve(&format!("min-eig {n}x{n}"), &q, &rows, &b, &cones);
    let sol = &solver.solution;
    (sol.status, sol.obj_val, sol.x.clone())
}

/// Runs Clarabel on `min ½xᵀPx + qᵀx, A x + s = b, s ∈ cones` (P = 0),
/// printing the solve time; returns the solution for inspection.
fn solve(
    name: &str,
    q: &[f64],
    rows: &[Vec<f64>],
    b: &[f64],
    cones: &[SupportedConeT<f64>],
) -> Solved {
    #[cfg(feature = "pure-lapack")]
    qpv_solve::lapack::ensure_linked();
    let n = q.len();
    let a = CscMatrix::from(rows);
    let p = CscMatrix::<f64>::zeros((n, n));
    let t0 = Instant::now();
    let sdp = qpv_clarabel::Sdp {
        p,
        q: q.to_vec(),
        a,
        b: b.to_vec(),
        cones: cones.to_vec(),
    };
    let solver = qpv_clarabel::solve(sdp, settings()).unwrap();
    let wall = t0.elapsed();
    eprintln!(
        "{name}: status {:?}, {} iterations, Clarabel solve_time {:.3} ms, setup+solve wall {:.3} ms",
        solver.solution.status,
        solver.solution.iterations,
        solver.solution.solve_time * 1e3,
        wall.as_secs_f64() * 1e3
    );
    solver
}

fn min_eig(m: &DMatrix<f64>) -> f64 {
    m.clone().symmetric_eigenvalues().min()
}

fn assert_psd(m: &DMatrix<f64>, tol: f64, what: &str) {
    let l = min_eig(m);
    assert!(l >= -tol, "{what}: λmin {l}");
}

/// Checks the λmin SDP for a random n × n matrix: optimum and X* = v vᵀ.
fn check_min_eig(n: usize, seed: u64) {
    let c = test_matrix(n, seed);
    let lmin = min_eig(&c);
    let (status, obj, x) = min_eig_sdp(&c);
    assert_eq!(status, SolverStatus::Solved);
    assert!((obj - lmin).abs() < 1e-6, "obj {obj} vs λmin {lmin}");
    // X* = v vᵀ for the eigenvector v of λmin (distinct eigenvalues).
    let e = c.clone().symmetric_eigen();
    let v = e.eigenvectors.column(e.eigenvalues.imin());
    let xs = smat(&x);
    assert!((&xs - v * v.transpose()).amax() < 1e-5, "X* = v vᵀ");
    assert!((xs.trace() - 1.0).abs() < 1e-8);
}

#[test]
fn min_eigenvalue_4x4() {
    check_min_eig(4, 1);
}

#[test]
fn min_eigenvalue_6x6() {
    check_min_eig(6, 2);
}

#[test]
fn min_eigenvalue_larger_cones() {
    for n in [5, 8, 12] {
        check_min_eig(n, n as u64);
    }
}

/// Packing convention: maximise X₀₁ s.t. diag(X) = 1, X ⪰ 0 (4×4) → X₀₁ = 1.
/// With the wrong off-diagonal scaling the optimum would come out as √2 or
/// 1/√2.
#[test]
fn packing_convention_matches_clarabel() {
    let n = 4;
    let d = svec_len(n);
    let mut q = vec![0.0; d];
    q[svec_index(0, 1)] = -1.0 / SQRT2; // X₀₁ = x[k] / √2
    let mut rows = vec![vec![0.0; d]; n + d];
    let mut b = vec![0.0; n + d];
    for i in 0..n {
        rows[i][svec_index(i, i)] = 1.0;
        b[i] = 1.0;
    }
    for k in 0..d {
        rows[n + k][k] = -1.0;
    }
    let solver = solve(
        "max X01 4x4",
        &q,
        &rows,
        &b,
        &[ZeroConeT(n), PSDTriangleConeT(n)],
    );
    assert_eq!(solver.solution.status, SolverStatus::Solved);
    assert!((solver.solution.obj_val + 1.0).abs() < 1e-6);
    let x = smat(&solver.solution.x);
    assert!((x[(0, 1)] - 1.0).abs() < 1e-6 && (x[(1, 0)] - 1.0).abs() < 1e-6);
    // Clarabel's slack for the PSD block is svec of a PSD matrix.
    assert_psd(&smat(&solver.solution.s[n..]), 1e-8, "slack");
}

/// An LMI coupling two cones through one scalar: maximise t s.t.
/// A₁ − t I ⪰ 0 (4×4) and A₂ − t I ⪰ 0 (6×6) → t* = min(λmin A₁, λmin A₂).
/// In Clarabel's form `A x + s = b`: b = svec(Fᵢ₀), column = −svec(Fᵢₖ).
#[test]
fn lmi_two_coupled_cones() {
    for (seed, shift) in [(3u64, 0.0), (4, 0.7), (5, -0.7)] {
        let a1 = test_matrix(4, seed);
        let a2 = test_matrix(6, seed + 100) + DMatrix::identity(6, 6) * shift;
        let want = min_eig(&a1).min(min_eig(&a2));
        let (d1, d2) = (svec_len(4), svec_len(6));
        let eye = |n| svec(&DMatrix::identity(n, n));
        let mut rows = Vec::new();
        for v in eye(4).into_iter().chain(eye(6)) {
            rows.push(vec![v]); // F(t) = A − t I: column = −svec(−I) = svec(I)
        }
        let b: Vec<f64> = svec(&a1).into_iter().chain(svec(&a2)).collect();
        let solver = solve(
            &format!("LMI 4x4+6x6 (seed {seed})"),
            &[-1.0],
            &rows,
            &b,
            &[PSDTriangleConeT(4), PSDTriangleConeT(6)],
        );
        let sol = &solver.solution;
        assert_eq!(sol.status, SolverStatus::Solved);
        assert!((sol.x[0] - want).abs() < 1e-6, "t* {} vs {want}", sol.x[0]);
        // Dual: Z₁, Z₂ ⪰ 0 with trace Z₁ + trace Z₂ = 1 (stationarity in t),
        // complementary to the slacks.
        let (z1, z2) = (smat(&sol.z[..d1]), smat(&sol.z[d1..d1 + d2]));
        assert_psd(&z1, 1e-8, "Z1");
        assert_psd(&z2, 1e-8, "Z2");
        assert!((z1.trace() + z2.trace() - 1.0).abs() < 1e-6);
        let (s1, s2) = (smat(&sol.s[..d1]), smat(&sol.s[d1..]));
        assert!((&s1 * &z1).trace().abs() < 1e-6 && (&s2 * &z2).trace().abs() < 1e-6);
    }
}

/// A matrix variable in two cones: minimise trace(P) s.t. P ⪰ 0 and
/// −(AᵀP + PA + Q) ⪰ 0 (4×4 each), A Hurwitz → the Lyapunov solution
/// AᵀP + PA + Q = 0 (every feasible P dominates it).
#[test]
fn lyapunov_4x4_min_trace() {
    let n = 4;
    let a = DMatrix::from_row_slice(
        n,
        n,
        &[
            -2.0, 1.0, 0.0, 0.3, 0.0, -1.5, 0.5, 0.0, 0.2, 0.0, -3.0, 1.0, 0.0, -0.4, 0.0, -1.0,
        ],
    );
    let qm = DMatrix::from_fn(n, n, |i, j| if i == j { 1.0 + i as f64 } else { 0.1 });
    // Reference: solve (I ⊗ Aᵀ + Aᵀ ⊗ I) vec(P) = −vec(Q).
    let at = a.transpose();
    let eye = DMatrix::<f64>::identity(n, n);
    let k = eye.kronecker(&at) + at.kronecker(&eye);
    let rhs = -DMatrix::from_column_slice(n * n, 1, qm.as_slice());
    let vecp = k.lu().solve(&rhs).unwrap();
    let p_ref = DMatrix::from_column_slice(n, n, vecp.as_slice());
    let p_ref = (&p_ref + p_ref.transpose()) * 0.5;

    // Variables x = svec(P); basis matrices E_k with svec(E_k) = e_k.
    let d = svec_len(n);
    let basis: Vec<DMatrix<f64>> = (0..d)
        .map(|k| {
            let mut e = vec![0.0; d];
            e[k] = 1.0;
            smat(&e)
        })
        .collect();
    let q: Vec<f64> = basis.iter().map(|e| e.trace()).collect();
    let mut rows = vec![vec![0.0; d]; 2 * d];
    // Cone 1: s = svec(P) = x  →  −x + s = 0.
    for k in 0..d {
        rows[k][k] = -1.0;
    }
    // Cone 2: s = svec(−Q − AᵀP − PA) = b − A x with b = −svec(Q),
    // column k = svec(Aᵀ E_k + E_k A).
    for (k, e) in basis.iter().enumerate() {
        let col = svec(&(&at * e + e * &a));
        for (r, v) in col.into_iter().enumerate() {
            rows[d + r][k] = v;
        }
    }
    let b: Vec<f64> = vec![0.0; d].into_iter().chain(svec(&(-&qm))).collect();
    let solver = solve(
        "Lyapunov 4x4 (two 4x4 cones)",
        &q,
        &rows,
        &b,
        &[PSDTriangleConeT(n), PSDTriangleConeT(n)],
    );
    assert_eq!(solver.solution.status, SolverStatus::Solved);
    let p = smat(&solver.solution.x);
    assert!(
        (solver.solution.obj_val - p_ref.trace()).abs() < 1e-6,
        "trace {} vs {}",
        solver.solution.obj_val,
        p_ref.trace()
    );
    assert!(
        (&p - &p_ref).amax() < 1e-5,
        "P vs Lyapunov solution: {}",
        (&p - &p_ref).amax()
    );
}
