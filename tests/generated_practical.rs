//! The practical `alpha = max` (docs/method.md §11a), as a user meets it: a crate bakes the default
//! `alpha = max` design of the Lorenz plant (ρ scheduled, y = x; written
//! from its equations, not tuned for the observer) and steps it at 1 ms.
//! Before the practical α = max, its gains were 1.7·10⁶ with a certified
//! Euler step of microseconds, and `step_rk4(1e-3, ..)` gave NaN after 3 ms.
//!
//! A module of the `generated` test binary.

qpv::qpv!(include "examples/lorenz.qpv");

/// ρ(t) inside its box [0.5, 0.9].
fn rho(t: f64) -> [f64; 1] {
    [0.7 + 0.2 * (1.3 * t).sin()]
}

/// Runs plant and observer for `t_end` with step `h` (`rk4`: both by RK4,
/// else both by Euler); returns ‖e(t_end)‖ / ‖e(0)‖ and the largest ratio.
fn run(h: f64, t_end: f64, rk4: bool) -> (f64, f64) {
    let mut x = [0.6, -0.4, 0.5];
    let mut obs = lorenz::Observer::new();
    let norm = |e: &[f64; 3]| e.iter().map(|v| v * v).sum::<f64>().sqrt();
    let e0 = norm(&x);
    let mut worst: f64 = 1.0;
    let steps = (t_end / h).round() as usize;
    for n in 0..steps {
        let t = n as f64 * h;
        let th = rho(t);
        let y = lorenz::plant::output(&x, &th);
        if rk4 {
            obs.step_rk4(h, &y, &[], &th);
            let f = |x: &[f64; 3]| lorenz::plant::derivative(x, &[], &th);
            let k1 = f(&x);
            let k2 = f(&core::array::from_fn(|i| x[i] + 0.5 * h * k1[i]));
            let k3 = f(&core::array::from_fn(|i| x[i] + 0.5 * h * k2[i]));
            let k4 = f(&core::array::from_fn(|i| x[i] + h * k3[i]));
            x = core::array::from_fn(|i| {
                x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            });
        } else {
            obs.step_euler(h, &y, &[], &th);
            let dx = lorenz::plant::derivative(&x, &[], &th);
            x = core::array::from_fn(|i| x[i] + h * dx[i]);
        }
        let xh = obs.estimate();
        let e: [f64; 3] = core::array::from_fn(|i| x[i] - xh[i]);
        let r = norm(&e) / e0;
        assert!(r.is_finite(), "the error is not finite at t = {}", t + h);
        worst = worst.max(r);
    }
    let xh = obs.estimate();
    let e: [f64; 3] = core::array::from_fn(|i| x[i] - xh[i]);
    (norm(&e) / e0, worst)
}

#[test]
fn the_default_alpha_max_design_runs_at_one_millisecond() {
    const { assert!(lorenz::CERTIFIES) };
    // ALPHA_SUP: the search's supremum estimate; the design certifies
    // ALPHA, at most that (1 % below it unless the gains force the knee).
    const { assert!(lorenz::ALPHA > 0.0 && lorenz::ALPHA <= lorenz::ALPHA_SUP) };
    // The certified Euler step covers 1 ms (the debug assertion of
    // step_euler would refuse it otherwise).
    const { assert!(lorenz::MAX_STEP_EULER >= 1e-3) };
    // At α ≈ 5.3 the error falls by e^(−α t/2) in V's norm: over 4 s by
    // more than 10⁴ (the bound's constant √cond(P) < 10 here).
    for rk4 in [false, true] {
        let (end, worst) = run(1e-3, 4.0, rk4);
        assert!(end < 1e-4, "rk4 = {rk4}: ‖e(4)‖/‖e(0)‖ = {end}");
        assert!(worst < 10.0, "rk4 = {rk4}: the error grew {worst}×");
    }
}
