//! A `sample = h` design (docs/method.md §16) baked by `qpv!`. The generated
//! `step` is exactly the certified Euler step at `SAMPLE_PERIOD`, the
//! certificate says at which rate it holds, and against the plant stepped by
//! the same Euler step V(e_k) ≤ (1 − hα)^k V(e_0) on the paper example.
//!
//! A module of the `generated` test binary.

use super::{paper_theta, quad_form, Rng};

// The paper's example certified at 1 kHz.
qpv::qpv!(include "tests/fixtures/paper_sampled.qpv");

use paper_sampled as m;

/// One explicit Euler step of the plant at `SAMPLE_PERIOD`.
fn plant_step(x: &[f64; 3], th: &[f64; 2]) -> [f64; 3] {
    let f = m::plant::derivative(x, &[], th);
    core::array::from_fn(|i| x[i] + m::SAMPLE_PERIOD * f[i])
}

/// Runs the Euler plant from `x0` against the observer from 0 for `steps`
/// samples with θ_k from `theta`; returns the largest
/// V(e_k) / ((1 − hα)^k V(e_0)).
fn worst_ratio(x0: [f64; 3], steps: usize, mut theta: impl FnMut(usize) -> [f64; 2]) -> f64 {
    let v = |e: &[f64; 3]| quad_form(&m::P, e);
    let decrease = 1.0 - m::SAMPLE_PERIOD * m::ALPHA;
    let mut x = x0;
    let mut obs = m::Observer::new();
    let v0 = v(&x0);
    let mut bound = v0;
    let mut worst: f64 = 0.0;
    for k in 0..steps {
        let th = theta(k);
        let y = m::plant::output(&x, &th);
        obs.step(&y, &[], &th);
        x = plant_step(&x, &th);
        bound *= decrease;
        let xh = obs.estimate();
        let e: [f64; 3] = core::array::from_fn(|i| x[i] - xh[i]);
        worst = worst.max(v(&e) / bound);
    }
    assert_eq!(obs.clamped(), 0);
    worst
}

#[test]
fn the_sampled_design_is_baked_with_its_period_and_certificate() {
    assert_eq!(m::SAMPLE_PERIOD, 1e-3);
    assert_eq!(m::design1::SAMPLE_PERIOD, 1e-3);
    let s = m::CERTIFICATE.sample.expect("a sampled certificate");
    assert_eq!(s.period, 1e-3);
    assert_eq!(s.decrease, 1.0 - 1e-3 * m::ALPHA);
    assert_eq!(s.text, "h = 1e-3 s (1 kHz)");
    let text = m::CERTIFICATE.to_string();
    assert!(text.contains("certified at h = 1e-3 s (1 kHz)"), "{text}");
    // The macro re-checked the discrete family, not the continuous one.
    let families: Vec<&str> = m::CERTIFICATE.margins.iter().map(|f| f.family).collect();
    assert!(families.contains(&"S5d"), "{families:?}");
    assert!(!families.contains(&"S5"), "{families:?}");
    assert!(m::CERTIFICATE.margins.iter().all(|f| f.margin > 0.0));
    assert!(m::CERTIFICATE.request.ends_with("sample = 0.001"));
    // §16: the continuous figures are not computed for a sampled design.
    assert_eq!(m::MAX_STEP_EULER, 0.0);
    assert!(m::NOISE_SIGMA.is_infinite());
}

#[test]
fn step_is_the_euler_step_at_the_sample_period() {
    let mut rng = Rng(5);
    for _ in 0..200 {
        let x0: [f64; 3] = core::array::from_fn(|_| rng.uniform(-0.02, 0.02));
        let y: [f64; 2] = core::array::from_fn(|_| rng.uniform(-0.02, 0.02));
        let th: [f64; 2] = core::array::from_fn(|_| rng.uniform(0.0, 1.0));
        let mut a = m::Observer::with_state(&x0);
        let mut b = a;
        a.step(&y, &[], &th);
        b.step_euler(m::SAMPLE_PERIOD, &y, &[], &th);
        assert_eq!(a, b, "bit for bit");
    }
}

#[test]
fn the_euler_plant_keeps_the_certified_decrease_per_step() {
    // The paper's scenario sampled at 1 kHz, e(0) = x(0) = −0.02 (a vertex
    // of the region): 2 s.
    let w = worst_ratio([-0.02; 3], 2000, |k| {
        paper_theta(k as f64 * m::SAMPLE_PERIOD)
    });
    assert!(w <= 1.0, "V(e_k) / ((1 − hα)^k V(e_0)) reached {w}");
    // θ_k jumping anywhere in Θ at every sample and e(0) anywhere in the
    // region: the discrete certificate allows both.
    let mut rng = Rng(17);
    for _ in 0..20 {
        let x0: [f64; 3] = core::array::from_fn(|_| rng.uniform(-0.02, 0.02));
        let mut r = Rng(rng.0 ^ 0x9e37_79b9);
        let w = worst_ratio(x0, 500, |_| [r.uniform(0.0, 1.0), r.uniform(0.0, 1.0)]);
        assert!(w <= 1.0, "from {x0:?}: ratio {w}");
    }
}

/// The continuous plant (RK4 at h/20) against the observer stepped at h
/// with sampled y and θ: √V(e_k) stays below the bound of docs/method.md
/// §16, ρ^k √V(e_0) + δ(1 − ρ^k)/(1 − ρ), ρ = √(1 − hα), with δ recomputed
/// here from the model and the baked P. `rates`: the model declares
/// θ's rates and θ(t) moves continuously; without, θ is held over each step
/// (the stated assumption).
fn continuous_plant_stays_in_the_bound(rates: bool) -> f64 {
    let mut text = include_str!("fixtures/paper_sampled.qpv").to_string();
    if rates {
        // |θ1'| ≤ 0.5·4π, |θ2'| ≤ 0.5·π/5 for the paper's θ(t)
        text = text
            .replace("th1 in [0, 1];", "th1 in [0, 1] rate 6.3;")
            .replace("th2 in [0, 1];", "th2 in [0, 1] rate 0.32;");
    }
    let model = super::polytopic(&text);
    assert_eq!(model.params[0].rate, rates.then_some(6.3));
    let p = nalgebra::DMatrix::from_fn(3, 3, |i, j| m::P[i][j]);
    let h = m::SAMPLE_PERIOD;
    let b = qpv::solve::report::continuous::continuous_bound(&model, m::ALPHA, h, &p)
        .expect("the bound is computed");
    assert_eq!(b.rates_declared, rates);
    assert!(b.invariant && b.truncation > 0.0);
    let rho = (1.0 - h * m::ALPHA).sqrt();
    let v = |e: &[f64; 3]| quad_form(&m::P, e).sqrt();
    let mut x = [-0.02, 0.02, -0.02];
    let mut obs = m::Observer::new();
    let s0 = v(&x);
    assert!(s0 <= 1.0, "e(0) in the certified set");
    let (mut bound, mut worst, mut last) = (s0, 0.0f64, 0.0);
    let fine = 20;
    let dt = h / fine as f64;
    for k in 0..3000 {
        let t = k as f64 * h;
        let th_k = paper_theta(t);
        let y = m::plant::output(&x, &th_k);
        obs.step(&y, &[], &th_k);
        for n in 0..fine {
            let tn = t + n as f64 * dt;
            let th = |s: f64| if rates { paper_theta(s) } else { th_k };
            x = super::rk4_step(|x, s| m::plant::derivative(x, &[], &th(s)), &x, tn, dt);
        }
        bound = rho * bound + b.delta;
        let xh = obs.estimate();
        let e: [f64; 3] = core::array::from_fn(|i| x[i] - xh[i]);
        worst = worst.max(v(&e) / bound);
        last = e.iter().map(|v| v * v).sum::<f64>().sqrt();
    }
    assert!(worst <= 1.0, "√V(e_k) / bound reached {worst}");
    assert!(last <= b.ultimate_error, "{last} > {}", b.ultimate_error);
    worst
}

#[test]
fn the_continuous_plant_with_held_theta_stays_in_the_reported_bound() {
    continuous_plant_stays_in_the_bound(false);
}

#[test]
fn the_continuous_plant_with_rate_bounded_theta_stays_in_the_reported_bound() {
    continuous_plant_stays_in_the_bound(true);
}

/// The same design baked in f32 (`float = f32`): the Rust module carries
/// the certified floor of its `step` (as the C export does), and the f32
/// `step` started at x̂(0) = x(0) (`with_state`) against the f64 Euler plant
/// stays at or below it at every step (the recursion behind the floor
/// keeps ρ_k ≤ ρ* from ρ_0 = 0; docs/embedded.md).
mod f32_step_floor {
    qpv::qpv! {
        model paper_sampled_f32 {
            state  x1, x2, x3;
            output y1, y2;
            param  th1 in [0, 1];
            param  th2 in [0, 1];
            A  = [ -4 - th1,  10,        2 + 2*th2 ;
                   -1,        -1 - th2,  1.5 + 2*th1 ;
                    1,         1,        -4 - 3*th1 ];
            N1 = [ 0.5, 1 + th1, 0 ;  0, 0, -th2 ;  0, 1 + th2, 0 ];
            N2 = [ -0.4, 0, 1 - th1 ;  1.5, 0, 1 + th2 ;  2 + th2, 0, 0 ];
            N3 = [ 1.5, -0.5 - th1, 0 ;  3 + th1, 0, 0 ;  0, 2 - th2, 0 ];
            C  = [ 1, 0, 0 ; 0, 1, 0 ];
            M1 = [ 0, 0, 0 ; 0, 0, 1 ; 0, 0, 0 ];
            M2 = [ 0, 0, 1 ; 0, 0, 0 ; 0, 0, 0 ];
            region box(0.02);
            state_bound Q = [ 0.0112, 0.0017, 0.0006 ; 0.0017, 0.0025, -0.0022 ; 0.0006, -0.0022, 0.0061 ];
            design { alpha = 10; gamma = 0.1889; sample = 1e-3; float = f32; }
        }
    }

    use paper_sampled_f32::design1 as d;

    #[test]
    fn the_f32_step_stays_below_its_certified_floor() {
        const {
            assert!(d::FLOAT_BITS == 32);
            assert!(d::F32_STEP_FLOOR < f32::INFINITY && d::F32_STEP_FLOOR > 0.0);
            assert!(d::F32_RATE > 0.0 && d::F32_RATE <= d::ALPHA);
        }
        let floor = f64::from(d::F32_STEP_FLOOR);
        let h = f64::from(d::SAMPLE_PERIOD);
        let mut x: [f64; 3] = [0.01f32, -0.005, 0.004].map(f64::from);
        let mut obs = d::Observer::with_state(&x.map(|v| v as f32));
        let mut worst = 0.0f64;
        for k in 0..3000 {
            let th = super::paper_theta(k as f64 * h);
            let y = paper_sampled_f32::plant::output(&x, &th);
            obs.step(&y.map(|v| v as f32), &[], &th.map(|v| v as f32));
            let f = paper_sampled_f32::plant::derivative(&x, &[], &th);
            x = core::array::from_fn(|i| x[i] + h * f[i]);
            let xh = obs.estimate();
            let e2: f64 = (0..3).map(|i| (x[i] - f64::from(xh[i])).powi(2)).sum();
            worst = worst.max(e2.sqrt());
        }
        assert!(
            worst > 0.0 && worst <= floor,
            "|e| = {worst:e}, floor {floor:e}"
        );
    }
}
