//! `float = f32` designs (docs/embedded.md): an f64 and an f32 design of the paper
//! example side by side in one model; the f32 observer against the f64 one
//! within the certified f32 error floor; the f32 constants are what the
//! certificate checked (and a tampered one fails).
//!
//! A module of the `generated` test binary.

use super::{gains, paper_theta, polytopic};
use nalgebra::DMatrix;
use qpv::dsl::Mode;
use qpv::solve::certificate::Gains;
use qpv::solve::model::{ObserverModel, ObserverOptions, StateBoundClaim};
use qpv::solve::vocab::Candidate;

inline_model! {
    PAPER_F32_TEXT,
    model paper_f32 {
        state x1, x2, x3;
        output y1, y2;
        param th1 in [0, 1];
        param th2 in [0, 1];
        A = [-4 - th1, 10, 2 + 2*th2; -1, -1 - th2, 1.5 + 2*th1; 1, 1, -4 - 3*th1];
        N1 = [0.5, 1 + th1, 0; 0, 0, -th2; 0, 1 + th2, 0];
        N2 = [-0.4, 0, 1 - th1; 1.5, 0, 1 + th2; 2 + th2, 0, 0];
        N3 = [1.5, -0.5 - th1, 0; 3 + th1, 0, 0; 0, 2 - th2, 0];
        C = [1, 0, 0; 0, 1, 0];
        M1 = [0, 0, 0; 0, 0, 1; 0, 0, 0];
        M2 = [0, 0, 1; 0, 0, 0; 0, 0, 0];
        region box(0.02);
        state_bound Q = [0.0112, 0.0017, 0.0006; 0.0017, 0.0025, -0.0022; 0.0006, -0.0022, 0.0061];
        design { alpha = 5; gamma = 0.18898; }
        design { alpha = 5; gamma = 0.18898; float = f32; }
    }
}

#[test]
fn f64_and_f32_designs_side_by_side() {
    // The types are the contract: design1 is f64, design2 f32 throughout.
    let _: f64 = paper_f32::design1::ALPHA;
    let _: f32 = paper_f32::design2::ALPHA;
    let _: [[f32; 3]; 3] = paper_f32::design2::P;
    let _: [[[f32; 2]; 3]; 4] = paper_f32::design2::L;
    let _: [f32; 4] = paper_f32::design2::mu(&[0.5f32, 0.25]);
    let _: [[f32; 2]; 3] = paper_f32::design2::gain(&[0.5f32, 0.25]);
    let _: [f32; 3] = paper_f32::design2::plant::derivative(&[0.01f32; 3], &[], &[0.5, 0.5]);
    let mut o = paper_f32::design2::Observer::new();
    o.step_euler(1e-3f32, &[0.01f32, 0.0], &[], &[0.5f32, 0.5]);
    o.step_rk4(1e-3f32, &[0.01f32, 0.0], &[], &[0.5f32, 0.5]);
    let _: [f32; 3] = o.derivative(&[0.0f32; 2], &[], &[0.5, 0.5]);
    assert_eq!(paper_f32::design2::CERTIFICATE.float, "f32");
    assert_eq!(paper_f32::design1::CERTIFICATE.float, "f64");
    assert_eq!(paper_f32::design1::CERTIFICATE.f32_error_floor, None);
    let floor = paper_f32::design2::F32_ERROR_FLOOR;
    assert!(
        floor.is_finite() && floor > 0.0,
        "F32_ERROR_FLOOR = {floor}"
    );
    // the constant is the record's f64 value rounded up to f32
    let record = paper_f32::design2::CERTIFICATE
        .f32_error_floor
        .expect("the floor is in the certificate");
    assert!(f64::from(floor) >= record && f64::from(floor) <= record * (1.0 + 1e-6));
    eprintln!("paper example: F32_ERROR_FLOOR = {floor:e}");
}

/// The observer's model of design `index` (0-based) as the certificate checks it.
fn checked_model(index: usize) -> qpv::dsl::PolytopicModel {
    let plant = polytopic(PAPER_F32_TEXT);
    let req = &plant.designs[index];
    ObserverModel::prepare(
        &plant,
        &ObserverOptions::for_request(req),
        StateBoundClaim::Compute(&Default::default()),
    )
    .expect("the observer model builds")
    .model
}

#[test]
fn the_f32_constants_are_certified_and_a_tampered_one_fails() {
    let model = checked_model(1);
    let p = DMatrix::from_fn(3, 3, |i, j| f64::from(paper_f32::design2::P[i][j]));
    let l32 = paper_f32::design2::L;
    let l64: Vec<[[f64; 2]; 3]> = l32
        .iter()
        .map(|m| core::array::from_fn(|i| core::array::from_fn(|j| f64::from(m[i][j]))))
        .collect();
    let ls = gains(&l64);
    // α, γ of the record (f64, as certified); the baked f32 P and L_l
    let (alpha, gamma) = (
        paper_f32::design2::CERTIFICATE.alpha,
        paper_f32::design2::CERTIFICATE.gamma,
    );
    let cert = qpv::solve::certificate::check(
        &model,
        &Gains::new(&p, &ls).with_cube(None),
        &Candidate::new(alpha, gamma),
        Mode::Sound,
    );
    assert!(cert.passed, "the baked f32 numbers must pass");
    // one gain entry off by a factor 50: fails
    let mut bad = ls.clone();
    bad[0][(0, 0)] *= 50.0;
    let cert = qpv::solve::certificate::check(
        &model,
        &Gains::new(&p, &bad).with_cube(None),
        &Candidate::new(alpha, gamma),
        Mode::Sound,
    );
    assert!(!cert.passed, "a tampered L_1 passed the certificate");
    // P with a negated entry: fails
    let mut bad_p = p.clone();
    bad_p[(0, 1)] = -bad_p[(0, 1)] * 20.0;
    bad_p[(1, 0)] = bad_p[(0, 1)];
    let cert = qpv::solve::certificate::check(
        &model,
        &Gains::new(&bad_p, &ls).with_cube(None),
        &Candidate::new(alpha, gamma),
        Mode::Sound,
    );
    assert!(!cert.passed, "a tampered P passed the certificate");
}

#[test]
fn f32_observer_agrees_with_the_f64_one_within_the_certified_floor() {
    // The paper's scenario for 2 s, RK4 at h = 1e-3, both observers started
    // at the true state (x̂(0) = x(0)), so the f64 observer tracks the plant
    // to its own rounding and the f32 one's distance from it is what f32
    // arithmetic leaves: at most F32_ERROR_FLOOR plus the rounding of the
    // state itself (u·‖x‖ per step, not in the floor; see docs/embedded.md).
    let h = 1e-3;
    let mut x = [-0.01, 0.015, -0.02];
    let mut o64 = paper_f32::design1::Observer::with_state(&x);
    let mut o32 = paper_f32::design2::Observer::with_state(&x.map(|v| v as f32));
    let floor = f64::from(paper_f32::design2::F32_ERROR_FLOOR);
    let mut worst: f64 = 0.0;
    let mut xmax: f64 = 0.0;
    for n in 0..2000 {
        let t = n as f64 * h;
        let th = paper_theta(t);
        let y = paper_f32::plant::output(&x, &th);
        o64.step_rk4(h, &y, &[], &th);
        o32.step_rk4(h as f32, &y.map(|v| v as f32), &[], &th.map(|v| v as f32));
        x = super::rk4_step(|s, _| paper_f32::plant::derivative(s, &[], &th), &x, t, h);
        let (a, b) = (o64.estimate(), o32.estimate());
        let d = (0..3)
            .map(|i| (a[i] - f64::from(b[i])).powi(2))
            .sum::<f64>()
            .sqrt();
        worst = worst.max(d);
        xmax = xmax.max(x.iter().map(|v| v * v).sum::<f64>().sqrt());
    }
    let rounding = 2.0 * f64::from(f32::EPSILON) * xmax;
    eprintln!("paper f32 vs f64: max ‖x̂32 − x̂64‖ = {worst:e}, floor {floor:e}, estimate rounding {rounding:e}");
    assert!(
        worst <= floor + rounding,
        "‖x̂32 − x̂64‖ reached {worst:e} > floor {floor:e} + {rounding:e}"
    );
}

#[test]
fn f32_euler_observer_stays_within_the_certified_euler_floor() {
    // The premise of F32_EULER_FLOOR (docs/method.md §15, "The f32 error
    // floor"): the Euler-discretised plant and the f32 observer's
    // step_euler at the same h, F32_EULER_MIN_STEP < h ≤ MAX_STEP_EULER.
    // Started at the true state (e = 0, inside the floor's invariant
    // sublevel set), the f32 estimate stays within the floor of the plant
    // at every step, the rounding of the state update included.
    use paper_f32::design2 as d;
    let h = 1e-3f32;
    assert!(d::F32_EULER_MIN_STEP < h && h <= d::MAX_STEP_EULER);
    let floor = f64::from(d::F32_EULER_FLOOR) + f64::from(d::F32_EULER_UPDATE_ROUNDING / h);
    assert!(floor.is_finite() && floor > 0.0);
    let hd = f64::from(h);
    let mut x = [-0.01, 0.015, -0.02].map(|v: f32| f64::from(v));
    let mut o = d::Observer::with_state(&x.map(|v| v as f32));
    let mut worst: f64 = 0.0;
    for n in 0..2000 {
        let th = paper_theta(f64::from(n) * hd);
        let y = paper_f32::plant::output(&x, &th);
        o.step_euler(h, &y.map(|v| v as f32), &[], &th.map(|v| v as f32));
        let dx = paper_f32::plant::derivative(&x, &[], &th);
        x = [0, 1, 2].map(|i| x[i] + hd * dx[i]);
        let e = (0..3)
            .map(|i| (x[i] - f64::from(o.estimate()[i])).powi(2))
            .sum::<f64>()
            .sqrt();
        worst = worst.max(e);
    }
    eprintln!(
        "paper f32 step_euler at h = {h}: max ‖x − x̂32‖ = {worst:e}, certified floor {floor:e}"
    );
    assert!(
        worst <= floor,
        "‖e‖ reached {worst:e} > the Euler floor {floor:e}"
    );
}
