//! The paper's example, designed and certified at build time by `qpv!`, then
//! simulated with the generated observer and plant (spec §7 scenario).
//!
//!     cargo run --release --example paper
//!
//! `examples/paper.qpv` holds two designs: the published point in paper mode
//! (a reproduction: the generated `design1` only records that the printed
//! conditions hold; they certify nothing, so it has no observer) and a sound
//! α = max / γ = search design (`design2`, re-exported as
//! `paper_example::Observer`, `paper_example::CERTIFICATE`, ...).

use std::f64::consts::PI;

qpv::qpv!(include "examples/paper.qpv");

use paper_example as model;

/// θ(t) of the paper's scenario.
fn theta(t: f64) -> [f64; model::NTHETA] {
    [
        0.5 + 0.5 * (4.0 * PI * t).sin(),
        0.5 + 0.5 * (PI * t / 5.0 + PI / 6.0).cos(),
    ]
}

/// One RK4 step of the plant with θ(t) evaluated at the stages.
fn plant_step(x: &[f64; model::NX], t: f64, dt: f64) -> [f64; model::NX] {
    let f = |x: &[f64; model::NX], t: f64| model::plant::derivative(x, &[], &theta(t));
    let k1 = f(x, t);
    let k2 = f(
        &std::array::from_fn(|i| x[i] + 0.5 * dt * k1[i]),
        t + 0.5 * dt,
    );
    let k3 = f(
        &std::array::from_fn(|i| x[i] + 0.5 * dt * k2[i]),
        t + 0.5 * dt,
    );
    let k4 = f(&std::array::from_fn(|i| x[i] + dt * k3[i]), t + dt);
    std::array::from_fn(|i| x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

fn main() {
    println!("{}", model::design1::CERTIFICATE);
    println!();
    println!("{}", model::CERTIFICATE);
    println!();
    println!(
        "generated observer: NX = {}, NY = {}, NV = {} vertices, alpha = {}, gamma = {}",
        model::NX,
        model::NY,
        model::NV,
        model::ALPHA,
        model::GAMMA
    );

    let dt = 1e-4;
    let report_at = [0.0, 0.25, 0.5, 1.0, 2.0];
    let steps = (2.0 / dt) as usize;
    let mut x = [-0.02; model::NX];
    let mut obs = model::Observer::new();
    let mut next = 0;
    println!();
    println!(
        "{:>6}  {:>12}  {:>12}  {:>12}  {:>12}",
        "t", "|e|_inf", "e1", "e2", "e3"
    );
    for n in 0..=steps {
        let t = n as f64 * dt;
        if next < report_at.len() && (t - report_at[next]).abs() < 0.5 * dt {
            let xh = obs.estimate();
            let e: [f64; model::NX] = std::array::from_fn(|i| x[i] - xh[i]);
            let norm = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            println!(
                "{t:>6.2}  {norm:>12.3e}  {:>12.3e}  {:>12.3e}  {:>12.3e}",
                e[0], e[1], e[2]
            );
            next += 1;
        }
        if n == steps {
            break;
        }
        let th = theta(t);
        let y = model::plant::output(&x, &th);
        obs.step_rk4(dt, &y, &[], &th);
        x = plant_step(&x, t, dt);
    }
    println!();
    println!("steps with θ clamped into Θ: {}", obs.clamped());
}
