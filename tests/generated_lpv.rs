//! An LPV plant baked by `qpv!`: the three-tank model of Sename et al.
//! (examples/three_tank.qpv) with no region or state bound, designed as the
//! global observer (docs/method.md §17) with a pole region (§18). The baked
//! certificate names the global family G5 and the pole family D; the
//! observer, stepped against the plant under a fast-varying θ, converges
//! from an arbitrary (large) initial error at the certified rate.
//!
//! A module of the `generated` test binary.

use super::{quad_form, Rng};

qpv::qpv! {
    model tank_lpv {
        state  x1, x2, x3;
        input  q;
        output y;
        param  r1 in [0.05, 0.7];
        param  r2 in [0.03, 1.5];
        param  r3 in [0.03, 1.1];
        param  r4 in [0.03, 1.4];
        param  r5 in [0.03, 1.8];
        der x1 = -r1*x1 + q;
        der x2 = r2*x1 - r3*x2;
        der x3 = r4*x2 - r5*x3;
        out y = x3;
        design { alpha = 0.09; poles = disk(centre = -3, radius = 3); }
    }
}

use tank_lpv as m;

/// One RK4 step of the plant with q and θ held.
fn plant_rk4(x: &[f64; 3], q: f64, th: &[f64; 5], dt: f64) -> [f64; 3] {
    let f = |x: &[f64; 3]| m::plant::derivative(x, &[q], th);
    let add = |x: &[f64; 3], k: &[f64; 3], s: f64| -> [f64; 3] {
        core::array::from_fn(|i| x[i] + s * k[i])
    };
    let k1 = f(x);
    let k2 = f(&add(x, &k1, dt / 2.0));
    let k3 = f(&add(x, &k2, dt / 2.0));
    let k4 = f(&add(x, &k3, dt));
    core::array::from_fn(|i| x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

#[test]
fn the_global_design_is_baked_with_its_families() {
    let families: Vec<&str> = m::CERTIFICATE.margins.iter().map(|f| f.family).collect();
    assert!(families.contains(&"G5"), "{families:?}");
    assert!(families.contains(&"D"), "{families:?}");
    assert!(
        !families.contains(&"S2") && !families.contains(&"S5"),
        "{families:?}"
    );
    assert!(m::CERTIFICATE.margins.iter().all(|f| f.margin > 0.0));
    assert_eq!(m::ALPHA, 0.09);
    assert!(
        m::CERTIFICATE
            .request
            .contains("poles = disk(centre = -3, radius = 3)"),
        "{}",
        m::CERTIFICATE.request
    );
}

#[test]
fn converges_from_an_arbitrary_initial_error_under_fast_varying_theta() {
    let mut rng = Rng(28);
    let (dt, steps) = (0.01, 6000);
    for x0 in [[50.0, -30.0, 20.0], [-1e3, 2e3, 5e2], [0.0, 0.0, 1e-3]] {
        let mut x = x0;
        let mut obs = m::Observer::new();
        let e0 = x0;
        let v0 = quad_form(&m::P, &e0);
        let mut worst: f64 = 0.0;
        for k in 0..steps {
            // θ jumps to a new point of the box every step; the inflow varies.
            let th: [f64; 5] = [
                rng.uniform(0.05, 0.7),
                rng.uniform(0.03, 1.5),
                rng.uniform(0.03, 1.1),
                rng.uniform(0.03, 1.4),
                rng.uniform(0.03, 1.8),
            ];
            // No inflow: the observer holds y over each step, an error of
            // order dt·‖x‖ that a driven x would let dominate a small e.
            let q = 0.0;
            let y = m::plant::output(&x, &th);
            obs.step_rk4(dt, &y, &[q], &th);
            x = plant_rk4(&x, q, &th, dt);
            let xh = obs.estimate();
            let e: [f64; 3] = core::array::from_fn(|i| x[i] - xh[i]);
            let t = dt * (k + 1) as f64;
            // V(e(t)) ≤ V(e(0)) e^{−αt}, with room for the discretisation
            // (the output held over a step of 0.01 s).
            let ratio = quad_form(&m::P, &e) / (v0 * (-m::ALPHA * t).exp());
            worst = worst.max(ratio);
        }
        assert!(
            worst <= 1.0 + 1e-3,
            "x0 = {x0:?}: V / bound reached {worst}"
        );
        assert_eq!(obs.clamped(), 0);
        // After 60 s the error has decayed at least as e^{−αt/2} in norm.
        let xh = obs.estimate();
        let e: f64 = (0..3).map(|i| (x[i] - xh[i]).powi(2)).sum::<f64>().sqrt();
        let e0n: f64 = e0.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(e < e0n, "{e} vs {e0n}");
    }
}

qpv::qpv! {
    model tank_lpv_noise {
        state  x1, x2, x3;
        input  q;
        output y;
        param  r1 in [0.05, 0.7];
        param  r2 in [0.03, 1.5];
        param  r3 in [0.03, 1.1];
        param  r4 in [0.03, 1.4];
        param  r5 in [0.03, 1.8];
        der x1 = -r1*x1 + q;
        der x2 = r2*x1 - r3*x2;
        der x3 = r4*x2 - r5*x3;
        out y = x3;
        design { alpha = 0.1; noise = min; }
    }
}

/// The global noise-optimal design bakes a finite σ and error bound and
/// an unlimited amplitude (its claim holds for every e, docs/method.md §17).
#[test]
fn the_global_noise_design_bakes_an_unlimited_amplitude() {
    use tank_lpv_noise as n;
    assert!(n::NOISE_SIGMA.is_finite() && n::NOISE_SIGMA > 0.0);
    assert!(n::ERROR_BOUND_PER_NOISE.is_finite() && n::ERROR_BOUND_PER_NOISE > 0.0);
    assert_eq!(n::MAX_NOISE_AMPLITUDE, f64::INFINITY);
    let families: Vec<&str> = n::CERTIFICATE.margins.iter().map(|f| f.family).collect();
    assert!(families.contains(&"G5"), "{families:?}");
}
