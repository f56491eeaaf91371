//! The noise-optimal design baked by `qpv!` (`noise = min`) and the noise
//! and sampling constants of the generated module: σ against the reference
//! value of the paper example, and the certified Euler step shown both
//! sufficient (the observer converges at 0.8 of it) and not vacuous (the
//! Euler contraction check fails a little above it).
//!
//! A module of the `generated` test binary: `inline_model!`, the scenario
//! and the helpers come from tests/generated.rs.

use super::{gains, paper_theta, polytopic, quad_form};
use nalgebra::DMatrix;
use qpv::solve::certificate::sampling;
use qpv::solve::model::{ObserverModel, ObserverOptions, StateBoundClaim};

// The paper's example, σ minimised at α = 5, γ = 0.18898 (sound mode,
// symmetric split: the defaults), noise on both outputs.
inline_model! {
    PAPER_NOISE_TEXT,
    model paper_noise {
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
        design { alpha = 5; gamma = 0.18898; noise = min; }
    }
}

/// The reference σ_min of the paper example at α = 5, γ = 0.18898 (noise on
/// both outputs), from an independent solve (docs/method.md).
const SIGMA_REFERENCE: f64 = 590.0;

#[test]
fn noise_min_design_bakes_sigma_near_the_reference() {
    const { assert!(paper_noise::CERTIFIES) };
    assert!(PAPER_NOISE_TEXT.contains("noise = min"));
    let sigma = paper_noise::NOISE_SIGMA;
    assert!(
        (0.99 * SIGMA_REFERENCE..=1.05 * SIGMA_REFERENCE).contains(&sigma),
        "NOISE_SIGMA = {sigma}, reference {SIGMA_REFERENCE}"
    );
    // ν_max = √(α/σ), and the error bound per unit noise is finite.
    let amp = (paper_noise::ALPHA / sigma).sqrt();
    assert!((paper_noise::MAX_NOISE_AMPLITUDE - amp).abs() <= 1e-9 * amp);
    assert!(paper_noise::ERROR_BOUND_PER_NOISE.is_finite());
    const _: () = assert!(paper_noise::ERROR_BOUND_PER_NOISE > 0.0);
    const _: () = assert!(paper_noise::MAX_STEP_EULER > 0.0);
    const _: () = assert!(paper_noise::STEP_ESTIMATE_RK4 > 0.0);
    assert_eq!(paper_noise::EULER_BETA, paper_noise::ALPHA / 2.0);
}

/// V(e) = eᵀ P e with the baked P.
fn lyapunov(e: &[f64; 3]) -> f64 {
    quad_form(&paper_noise::P, e)
}

#[test]
fn euler_observer_converges_at_0_8_of_the_certified_step() {
    // The paper's scenario: θ1 = 0.5 + 0.5 sin(4πt), θ2 = 0.5 + 0.5 cos(πt/5 + π/6),
    // x(0) = −0.02 (a vertex of the region), x̂(0) = 0. Plant and observer
    // are discretised by the same Euler step, the setting MAX_STEP_EULER
    // covers: V_k ≤ (1 − h β)^k V_0.
    let theta = paper_theta;
    let h = 0.8 * paper_noise::MAX_STEP_EULER;
    let steps = (5.0 / h).ceil() as usize;
    let mut x = [-0.02; 3];
    let mut obs = paper_noise::Observer::new();
    let v0 = lyapunov(&x);
    let e0 = x.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut worst_ratio: f64 = 0.0;
    let mut below_at = None;
    for n in 0..steps {
        let t = n as f64 * h;
        let th = theta(t);
        let y = paper_noise::plant::output(&x, &th);
        obs.step_euler(h, &y, &[], &th);
        let dx = paper_noise::plant::derivative(&x, &[], &th);
        x = core::array::from_fn(|i| x[i] + h * dx[i]);
        let xh = obs.estimate();
        let e: [f64; 3] = core::array::from_fn(|i| x[i] - xh[i]);
        let bound = v0 * (1.0 - h * paper_noise::EULER_BETA).powi(n as i32 + 1);
        worst_ratio = worst_ratio.max(lyapunov(&e) / bound);
        let norm = e.iter().map(|v| v * v).sum::<f64>().sqrt();
        if below_at.is_none() && norm < 1e-3 * e0 {
            below_at = Some(t + h);
        }
    }
    assert!(
        worst_ratio <= 1.0 + 1e-9,
        "V_k / (V_0 (1 − hβ)^k) reached {worst_ratio}"
    );
    let t = below_at.expect("the error never fell below 1e-3 of its start within 5 s");
    assert!(t <= 5.0);
    assert_eq!(obs.clamped(), 0);
}

#[test]
fn the_certified_euler_step_is_not_vacuous() {
    // The model the design was certified on (sound mode's symmetric split),
    // the baked gains: the Euler contraction check holds at the step and
    // fails at 1.05 times it.
    let plant = polytopic(PAPER_NOISE_TEXT);
    let req = &plant.designs[0];
    let observer = ObserverModel::prepare(
        &plant,
        &ObserverOptions::for_request(req),
        StateBoundClaim::Compute(&Default::default()),
    )
    .expect("the observer model builds");
    let p = DMatrix::from_fn(3, 3, |i, j| paper_noise::P[i][j]);
    let l = gains(&paper_noise::L);
    let fs = sampling::vertex_dynamics(&observer.model, paper_noise::GAMMA, &l);
    let beta = paper_noise::EULER_BETA;
    let h = paper_noise::MAX_STEP_EULER;
    let (_, ok_at, _) = sampling::euler_margin(&p, &fs, beta, h);
    assert!(ok_at, "the check must hold at MAX_STEP_EULER");
    let (margin, ok_above, at) = sampling::euler_margin(&p, &fs, beta, 1.05 * h);
    assert!(
        !ok_above,
        "the check still holds at 1.05 × MAX_STEP_EULER (margin {margin} at {at})"
    );
}

#[test]
#[cfg(debug_assertions)]
#[should_panic(expected = "exceeds MAX_STEP_EULER")]
fn a_step_above_the_certified_euler_step_is_a_debug_assertion() {
    // Debug builds refuse an Euler step the design does not
    // certify; the message names the constant. (Release builds do not check.)
    let mut obs = paper_noise::Observer::new();
    let th = paper_theta(0.0);
    obs.step_euler(
        1.5 * paper_noise::MAX_STEP_EULER,
        &[0.0; paper_noise::NY],
        &[],
        &th,
    );
}

// The paper's example, the RMS-optimal design for white output noise of
// std 4e-4 sampled every 1 ms, at γ = 0.18898 and any certified rate.
inline_model! {
    PAPER_RMS_TEXT,
    model paper_rms {
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
        design { gamma = 0.18898; noise = rms; output_std = 4e-4; noise_period = 1e-3; }
    }
}

#[test]
fn qpv_bakes_the_rms_bound_it_recomputes() {
    const { assert!(paper_rms::CERTIFIES) };
    let per = paper_rms::RMS_BOUND_PER_STATE;
    const _: () = assert!(paper_rms::RMS_BOUND > 0.0 && paper_rms::RMS_BOUND < 4e-4);
    assert!(per
        .iter()
        .all(|&v| v > 0.0 && v <= paper_rms::RMS_BOUND * (1.0 + 1e-12)));
    // The baked bound is the certificate's recomputation on the baked P, L.
    let model = polytopic(PAPER_RMS_TEXT);
    let d = qpv::solve::design(
        &model,
        &qpv::dsl::parse(PAPER_RMS_TEXT).unwrap()[0].designs[0],
        &qpv::solve::Settings::default(),
    )
    .unwrap();
    let obs = d.observer_model(&model).unwrap();
    let p = DMatrix::from_fn(3, 3, |i, j| paper_rms::P[i][j]);
    let b = qpv::solve::certificate::rms::rms_bound(
        &obs,
        &d.rms.as_ref().unwrap().noise,
        paper_rms::GAMMA,
        &p,
        &gains(&paper_rms::L),
    )
    .unwrap();
    assert!((b.total - paper_rms::RMS_BOUND).abs() <= 1e-9 * b.total);
}
