//! The EKF baseline of benches/ekf.rs (benches/ekf/filter.rs), validated:
//! its model and exact Jacobians against the library's reference
//! right-hand side and central differences, its gain against the scalar
//! discrete Riccati solution, and its first step against a hand computation.

#[allow(dead_code)]
#[path = "../benches/ekf/filter.rs"]
mod filter;

use filter::{Ekf, Frozen, Mat, Qpv, Vector};
use qpv::dsl::PolytopicModel;
fn paper() -> PolytopicModel {
    let src = include_str!("../examples/paper.qpv");
    qpv::dsl::parse(src).expect("parses").remove(0).polytopic()
}

/// f, h against the library's reference right-hand side, and the
/// Jacobians against central differences, on the paper example.
#[test]
fn model_and_jacobians_match_the_reference() {
    let model = paper();
    let qpv = Qpv::<3, 2>::new(&model, &[]);
    for i in 0..20 {
        let s = f64::from(i);
        let theta = [0.5 + 0.5 * (0.7 * s).sin(), 0.5 + 0.5 * (1.3 * s).cos()];
        let x = Vector::<3>::new(
            0.02 * (1.1 * s).sin(),
            -0.03 * (0.4 * s).cos(),
            0.01 * (2.1 * s).sin(),
        );
        let m = qpv.at(&model.mu(&theta));
        let sl = x.as_slice();
        let f_ref = qpv::solve::simulate::plant_derivative(&model, sl, &[], &theta).unwrap();
        let h_ref = qpv::solve::simulate::plant_output(&model, sl, &theta).unwrap();
        let (f, jf) = m.f_jac(&x);
        let (h, jh) = m.h_jac(&x);
        for k in 0..3 {
            assert!((f[k] - f_ref[k]).abs() <= 1e-14, "{f} vs {f_ref:?}");
        }
        for k in 0..2 {
            assert!((h[k] - h_ref[k]).abs() <= 1e-14, "{h} vs {h_ref:?}");
        }
        let d = 1e-6;
        for j in 0..3 {
            let mut xp = x;
            let mut xm = x;
            xp[j] += d;
            xm[j] -= d;
            let df = (m.f(&xp) - m.f(&xm)) / (2.0 * d);
            let dh = (m.h(&xp) - m.h(&xm)) / (2.0 * d);
            for k in 0..3 {
                assert!((df[k] - jf[(k, j)]).abs() <= 1e-8, "∂f{k}/∂x{j}");
            }
            for k in 0..2 {
                assert!((dh[k] - jh[(k, j)]).abs() <= 1e-8, "∂h{k}/∂x{j}");
            }
        }
    }
}

/// A scalar linear plant x' = a x, y = c x: the filter's gain converges
/// to the steady-state Kalman gain of (Φ = 1 + a dt, c, Q_d, R), the
/// positive root of the scalar discrete Riccati equation.
#[test]
fn scalar_gain_converges_to_the_riccati_solution() {
    let (a, c, dt, qd, r) = (-2.0, 1.5, 1e-2, 3e-4, 0.04);
    let m = Frozen::<1, 1> {
        a: Mat::<1, 1>::new(a),
        sn: [Mat::zeros()],
        c: Mat::<1, 1>::new(c),
        sm: [Mat::zeros()],
        l: Mat::zeros(),
    };
    let mut ekf = Ekf {
        x: Vector::<1>::new(0.0),
        p: Mat::<1, 1>::new(1.0),
        q: Mat::<1, 1>::new(qd),
        r: Mat::<1, 1>::new(r),
    };
    let mut k = 0.0;
    for _ in 0..5000 {
        k = ekf.update(&m, &Vector::<1>::new(0.0)).unwrap()[0];
        ekf.predict([&m; 3], dt);
    }
    // prior P: c²P² + (R(1 − Φ²) − Q_d c²) P − Q_d R = 0
    let phi = 1.0 + a * dt;
    let b = r * (1.0 - phi * phi) - qd * c * c;
    let p = (-b + (b * b + 4.0 * c * c * qd * r).sqrt()) / (2.0 * c * c);
    let k_ref = p * c / (c * c * p + r);
    assert!((k - k_ref).abs() <= 1e-12 * k_ref, "{k} vs {k_ref}");
}

/// The first update and prediction on a two-state linear plant, against
/// numbers computed by hand.
#[test]
fn first_step_by_hand() {
    // x' = [[-1, 1], [0, -2]] x, y = x1; P0 = diag(4, 1), R = 1.
    let m = Frozen::<2, 1> {
        a: Mat::<2, 2>::new(-1.0, 1.0, 0.0, -2.0),
        sn: [Mat::zeros(); 2],
        c: Mat::<1, 2>::from_row_slice(&[1.0, 0.0]),
        sm: [Mat::zeros()],
        l: Mat::zeros(),
    };
    let mut ekf = Ekf {
        x: Vector::<2>::new(0.0, 0.0),
        p: Mat::<2, 2>::new(4.0, 0.0, 0.0, 1.0),
        q: Mat::<2, 2>::new(0.1, 0.0, 0.0, 0.1),
        r: Mat::<1, 1>::new(1.0),
    };
    // S = 4 + 1 = 5, K = (4/5, 0), x̂ = K · 1 = (0.8, 0),
    // P = diag(4 − 16/5, 1) = diag(0.8, 1) (Joseph: (1/5)²·4 + (4/5)²·1 = 0.8).
    let k = ekf.update(&m, &Vector::<1>::new(1.0)).unwrap();
    assert!((k[0] - 0.8).abs() < 1e-15 && k[1] == 0.0);
    assert!((ekf.x[0] - 0.8).abs() < 1e-15 && ekf.x[1] == 0.0);
    assert!((ekf.p[(0, 0)] - 0.8).abs() < 1e-15 && (ekf.p[(1, 1)] - 1.0).abs() < 1e-15);
    // dt = 0.1: Φ = [[0.9, 0.1], [0, 0.8]];
    // Φ P Φᵀ = [[0.81·0.8 + 0.01, 0.08], [0.08, 0.64]] = [[0.658, 0.08], [0.08, 0.64]],
    // plus Q_d. Mean: RK4 of x' = -x1 from 0.8 with x2 = 0:
    // 0.8 · (1 − h + h²/2 − h³/6 + h⁴/24), h = 0.1.
    ekf.predict([&m; 3], 0.1);
    let p = [[0.758, 0.08], [0.08, 0.74]];
    for (i, row) in p.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            assert!((ekf.p[(i, j)] - v).abs() < 1e-15, "P[{i}][{j}]");
        }
    }
    let h: f64 = 0.1;
    let x1 = 0.8 * (1.0 - h + h * h / 2.0 - h.powi(3) / 6.0 + h.powi(4) / 24.0);
    assert!((ekf.x[0] - x1).abs() < 1e-15 && ekf.x[1] == 0.0);
}
