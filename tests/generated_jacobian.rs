//! The flexible-joint arm (examples/flexible_joint.qpv: sin of the
//! unmeasured link angle) baked by `qpv!`: one gain for both Jacobian
//! corners, the plant and the observer evaluating sin(q̂1) as written
//! against the reference implementation, and the sampled observer stepped
//! against the plant converging inside its certified decay.
//!
//! A module of the `generated` test binary.

use super::{quad_form, rel_err, Rng};
use nalgebra::DMatrix;
use qpv::solve::simulate;

qpv::qpv!(include "examples/flexible_joint.qpv");

use flexible_joint as m;

fn model() -> qpv::dsl::Model {
    qpv::dsl::parse(include_str!("../examples/flexible_joint.qpv"))
        .expect("parses")
        .remove(0)
}

#[test]
fn the_baked_observer_has_one_gain_per_theta_vertex_and_is_certified() {
    const { assert!(m::CERTIFIES) };
    assert_eq!(m::NV, 1, "the Jacobian corners share the θ-vertex's gain");
    const { assert!(m::ALPHA > 0.0) };
    let norm = DMatrix::from_fn(4, 2, |i, j| m::L[0][i][j]).norm();
    assert!(norm.is_finite() && norm > 0.0);
}

#[test]
fn the_plant_and_the_observer_evaluate_sin_q1_as_written() {
    let model = model();
    let poly = model.polytopic();
    // the reference takes one gain per vertex of the expanded model
    let l = DMatrix::from_fn(4, 2, |i, j| m::L[0][i][j]);
    let gains = vec![l; poly.nv()];
    let mut rng = Rng(38);
    for _ in 0..200 {
        let x: [f64; 4] = core::array::from_fn(|_| rng.uniform(-4.0, 4.0));
        let u = [rng.uniform(-1.0, 1.0)];
        let got = m::plant::derivative(&x, &u, &[]);
        let xv = nalgebra::DVector::from_column_slice(&x);
        let want = model.rhs(&xv, &nalgebra::DVector::from_column_slice(&u), &[]);
        assert!(rel_err(&got, want.as_slice()) <= 1e-12, "{got:?} vs {want}");
        let y = [rng.uniform(-4.0, 4.0), rng.uniform(-4.0, 4.0)];
        let want = simulate::observer_derivative(&poly, &gains, &x, &y, &u, &[]).expect("ok");
        let got = m::Observer::with_state(&x).derivative(&y, &u, &[]);
        assert!(rel_err(&got, &want) <= 1e-12, "{got:?} vs {want:?}");
    }
}

#[test]
fn the_sampled_observer_keeps_its_certified_decrease_on_the_euler_stepped_plant() {
    // The certificate (S5d) is for the plant stepped like the observer, one
    // explicit Euler step of h with the input held: then V(e_k+1) ≤
    // (1 − hα) V(e_k) for every corner of sin(q1)'s Jacobian box, so along
    // the nonlinear plant as written.
    let h = m::SAMPLE_PERIOD;
    let rate = 1.0 - h * m::ALPHA;
    for x0 in [
        [1.5, 0.0, 0.0, 0.0],
        [-3.0, 2.0, 0.5, -1.0],
        [3.1, -4.0, 0.0, 0.0],
    ] {
        let mut x = x0;
        let mut obs = m::Observer::new();
        let v0 = quad_form(&m::P, &x0);
        let mut bound = v0;
        for k in 0..300 {
            let u = 0.8 * (5.0 * h * k as f64).sin();
            let y = m::plant::output(&x, &[]);
            obs.step(&y, &[u], &[]);
            let f = m::plant::derivative(&x, &[u], &[]);
            x = core::array::from_fn(|i| x[i] + h * f[i]);
            bound *= rate;
            let xh = obs.estimate();
            let e: [f64; 4] = core::array::from_fn(|i| x[i] - xh[i]);
            let v = quad_form(&m::P, &e);
            assert!(
                v <= bound * (1.0 + 1e-9) + 1e-24 * v0,
                "x0 = {x0:?}, step {k}: V = {v:e} > {bound:e}"
            );
        }
    }
}
