//! Parameters computed from a measured output: `param p = y1 [in [lo,
//! hi]]`, the interval derived from the state bound, and terms of degree 3
//! scheduled on measured factors (the matrices they give, exact along the
//! plant's trajectories).

use nalgebra::DVector;
use qpv_dsl::{parse, MeasuredOrigin, Model};

fn model(src: &str) -> Model {
    parse(src).unwrap_or_else(|e| panic!("{e}")).remove(0)
}

/// The plant as the model reads it, at x with θ = the measured outputs
/// (every parameter here is computed from y1 = x1).
fn rhs_on_trajectory(m: &Model, x: &[f64]) -> Vec<f64> {
    let theta: Vec<f64> = m.params.iter().map(|_| x[0]).collect();
    let xv = DVector::from_column_slice(x);
    let u = DVector::zeros(m.nu());
    m.rhs(&xv, &u, &theta).iter().copied().collect()
}

#[test]
fn van_der_pol_as_written_is_scheduled_on_y1_and_exact() {
    let m = model(
        "model v { state x1, x2; output y1; const mu = 1.5;
         der x1 = x2; der x2 = mu*x2 - mu*x1^2*x2 - x1; out y1 = x1;
         state_bound Q = [4, 0; 0, 9]; }",
    );
    assert_eq!(m.params.len(), 1, "one parameter added");
    let p = &m.params[0];
    assert_eq!(p.name, "y1");
    let meas = p.measured.as_ref().expect("measured");
    assert_eq!(meas.origin, MeasuredOrigin::Automatic);
    assert_eq!(meas.row, vec![1.0, 0.0]);
    // √(cᵀQc) = 2, rounded outward to six significant digits
    assert!(p.hi >= 2.0 && p.hi <= 2.00001 && p.lo == -p.hi, "{p:?}");
    assert_eq!(meas.rewrites.len(), 1, "{:?}", meas.rewrites);
    assert!(
        meas.rewrites[0].contains("`x1^2*x2`"),
        "{:?}",
        meas.rewrites
    );
    assert!(m.is_lpv(), "every quadratic term went into y1²");
    assert_eq!(m.derived.len(), 1, "y1² is one derived variable");
    assert!(m
        .warnings
        .iter()
        .any(|w| w.message.contains("is scheduled on the measured output y1")));
    for x in [[0.3, -1.2], [-1.7, 0.4], [1.9, 2.5]] {
        let got = rhs_on_trajectory(&m, &x);
        let want = [x[1], 1.5 * x[1] - 1.5 * x[0] * x[0] * x[1] - x[0]];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-12, "{x:?}: {got:?} vs {want:?}");
        }
    }
}

#[test]
fn a_declared_measured_parameter_is_used_and_a_scaled_output_divides() {
    // y1 = 2·x1: x1 = p/2, so x1³ = p²·x1/4
    let m = model(
        "model d { state x1, x2; input u; output y1; param p = y1 in [-5, 5];
         der x1 = x2; der x2 = -x2 - x1 - x1^3 + u; out y1 = 2*x1;
         state_bound Q = [4, 0; 0, 4]; }",
    );
    assert_eq!(m.params.len(), 1, "the declared p, no other");
    assert_eq!(
        m.params[0].measured.as_ref().map(|m| m.origin),
        Some(MeasuredOrigin::Declared)
    );
    assert_eq!((m.params[0].lo, m.params[0].hi), (-5.0, 5.0));
    for x in [[0.3, -1.2], [-1.7, 0.4]] {
        let theta = [2.0 * x[0]];
        let xv = DVector::from_column_slice(&x);
        let got = m.rhs(&xv, &DVector::from_element(1, 0.5), &theta);
        let want = [x[1], -x[1] - x[0] - x[0].powi(3) + 0.5];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-12, "{x:?}: {got:?} vs {want:?}");
        }
    }
}

#[test]
fn the_interval_is_derived_from_the_state_bound_and_quadratic_models_are_untouched() {
    let m = model(
        "model q { state x1, x2; output y1; param p = y1;
         der x1 = -x1 + p*x1*x2; der x2 = -x2 + x1*x1; out y1 = x1 + x2;
         region box(0.1); state_bound Q = [1, 0.5; 0.5, 2]; }",
    );
    let p = &m.params[0];
    let r = (1.0f64 + 0.5 + 0.5 + 2.0).sqrt();
    assert!(p.hi >= r && p.hi <= r * (1.0 + 1e-5), "{} vs {r}", p.hi);
    let meas = p.measured.as_ref().expect("measured");
    assert_eq!(meas.origin, MeasuredOrigin::Derived);
    assert!(
        meas.rewrites.is_empty(),
        "degree-2 terms are never rewritten"
    );
    assert!(!m.is_lpv(), "x1*x1 stays a quadratic term");
    assert!((meas.reach(&[1.0, 0.5, 0.5, 2.0]) - r).abs() < 1e-12);
}
