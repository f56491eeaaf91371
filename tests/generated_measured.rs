//! Observers of plants scheduled on a measured output, as `qpv!` generates
//! them: Van der Pol and Duffing written as a textbook writes them (their
//! degree-3 terms scheduled on y1 = x1 by the compiler). The observer's
//! steppers take y and no parameter (`NTHETA_IN = 0`; `theta_of` computes
//! θ from y); the plant as written (not the generated one) is integrated
//! beside it from initial errors across a box, and V = eᵀPe must stay under
//! the certified envelope V(0)·e^(−αt) while x stays in the state bound F
//! and y1 in its interval.

qpv::qpv!(include "examples/van_der_pol.qpv");
qpv::qpv!(include "examples/duffing.qpv");

type Rhs = fn(f64, &[f64; 2]) -> [f64; 2];

/// Van der Pol as written, μ = 1.
fn vdp(_t: f64, x: &[f64; 2]) -> [f64; 2] {
    let mu = 1.0;
    [x[1], mu * x[1] - mu * x[0] * x[0] * x[1] - x[0]]
}

/// The Duffing force of the runs below.
fn duffing_u(t: f64) -> f64 {
    (1.2 * t).sin()
}

/// Duffing as written, δ = 0.3, α = 1, β = 0.5, u = sin(1.2 t).
fn duffing_plant(t: f64, x: &[f64; 2]) -> [f64; 2] {
    [
        x[1],
        -0.3 * x[1] - x[0] - 0.5 * x[0] * x[0] * x[0] + duffing_u(t),
    ]
}

/// eᵀPe.
fn v(p: &[[f64; 2]; 2], e: &[f64; 2]) -> f64 {
    let pe = [
        p[0][0] * e[0] + p[0][1] * e[1],
        p[1][0] * e[0] + p[1][1] * e[1],
    ];
    e[0] * pe[0] + e[1] * pe[1]
}

/// What one run measured: the worst ratio V(t)/(V(0)e^(−αt)) (floored at
/// 1e-12·V(0): the RK4 error of the run), the largest xᵀQ⁻¹x, the largest
/// |y1|.
struct Run {
    envelope: f64,
    in_f: f64,
    y_max: f64,
}

/// The observer's right-hand side at time t, plant state x (y = x1 is
/// measured from it) and estimate x̂.
type ObsRhs<'a> = &'a dyn Fn(f64, &[f64; 2], &[f64; 2]) -> [f64; 2];

/// Plant `f` from x0 and the observer `g` from x̂0 = x0 − e0 integrated as
/// one system by RK4 (the observer reads y at every stage, as the
/// continuous claim has it) for 4 s at h = 1 ms.
fn run(
    f: Rhs,
    g: ObsRhs<'_>,
    x0: [f64; 2],
    e0: [f64; 2],
    q_diag: [f64; 2],
    p: &[[f64; 2]; 2],
    alpha: f64,
) -> Run {
    let h = 1e-3;
    let both = |t: f64, z: &[f64; 4]| -> [f64; 4] {
        let (x, xh) = ([z[0], z[1]], [z[2], z[3]]);
        let (a, b) = (f(t, &x), g(t, &x, &xh));
        [a[0], a[1], b[0], b[1]]
    };
    let mut z = [x0[0], x0[1], x0[0] - e0[0], x0[1] - e0[1]];
    let v0 = v(p, &e0);
    let mut out = Run {
        envelope: 0.0,
        in_f: 0.0,
        y_max: 0.0,
    };
    let mut t = 0.0;
    while t < 4.0 {
        let add = |a: &[f64; 4], k: &[f64; 4], s: f64| {
            [
                a[0] + s * k[0],
                a[1] + s * k[1],
                a[2] + s * k[2],
                a[3] + s * k[3],
            ]
        };
        let k1 = both(t, &z);
        let k2 = both(t + 0.5 * h, &add(&z, &k1, 0.5 * h));
        let k3 = both(t + 0.5 * h, &add(&z, &k2, 0.5 * h));
        let k4 = both(t + h, &add(&z, &k3, h));
        for i in 0..4 {
            z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        t += h;
        let e = [z[0] - z[2], z[1] - z[3]];
        let bound = (v0 * (-alpha * t).exp()).max(1e-12 * v0);
        out.envelope = out.envelope.max(v(p, &e) / bound);
        out.in_f = out
            .in_f
            .max(z[0] * z[0] / q_diag[0] + z[1] * z[1] / q_diag[1]);
        out.y_max = out.y_max.max(z[0].abs());
    }
    out
}

/// Initial errors across the box |e_i| ≤ r (corners and edge midpoints).
fn errors(r: f64) -> Vec<[f64; 2]> {
    let mut v = Vec::new();
    for a in [-1.0, 0.0, 1.0] {
        for b in [-1.0, 0.0, 1.0] {
            if a != 0.0 || b != 0.0 {
                v.push([a * r, b * r]);
            }
        }
    }
    v
}

#[test]
fn van_der_pol_as_written_stays_in_its_envelope() {
    use van_der_pol::*;
    assert_eq!(NTHETA, 1);
    assert_eq!(NTHETA_IN, 0, "y1 is computed from y, not given");
    assert_eq!(theta_of(&[1.25], &[]), [1.25]);
    const { assert!(CERTIFIES && ALPHA > 0.0) };
    // the generated plant with θ = x1 is the plant as written
    let x = [0.7, -1.3];
    let d = plant::derivative(&x, &[], &[x[0]]);
    let w = vdp(0.0, &x);
    assert!(
        (d[0] - w[0]).abs() < 1e-12 && (d[1] - w[1]).abs() < 1e-12,
        "{d:?} {w:?}"
    );
    let g = |_t: f64, x: &[f64; 2], xh: &[f64; 2]| -> [f64; 2] {
        Observer::with_state(xh).derivative(&[x[0]], &[], &[])
    };
    for x0 in [[2.0, 0.0], [-1.0, 1.5], [0.5, -2.0]] {
        for e0 in errors(1.0) {
            let r = run(vdp, &g, x0, e0, [6.25, 12.25], &P, ALPHA);
            assert!(r.in_f <= 1.0, "x left F from {x0:?}: {}", r.in_f);
            assert!(r.y_max <= THETA_MAX[0], "y1 left its interval: {}", r.y_max);
            assert!(
                r.envelope <= 1.0 + 1e-6,
                "x0 {x0:?}, e0 {e0:?}: V/(V0 e^(-αt)) reached {}",
                r.envelope
            );
        }
    }
    // the stepper: y held over each 1 ms step, no θ given
    let mut obs = Observer::new();
    let mut x = [2.0, 0.0];
    for k in 0..4000 {
        obs.step_rk4(1e-3, &[x[0]], &[], &[]);
        x = euler_substeps(vdp, k as f64 * 1e-3, x);
    }
    let xh = obs.estimate();
    assert!((x[0] - xh[0]).hypot(x[1] - xh[1]) < 1e-2, "{x:?} {xh:?}");
    assert_eq!(obs.clamped(), 0);
}

#[test]
fn duffing_as_written_stays_in_its_envelope() {
    use duffing::*;
    assert_eq!((NTHETA, NTHETA_IN), (1, 0));
    assert_eq!(theta_of(&[-0.5], &[]), [-0.5]);
    const { assert!(CERTIFIES && ALPHA > 0.0) };
    let x = [1.1, 0.4];
    let d = plant::derivative(&x, &[0.3], &[x[0]]);
    let w = [x[1], -0.3 * x[1] - x[0] - 0.5 * x[0].powi(3) + 0.3];
    assert!(
        (d[0] - w[0]).abs() < 1e-12 && (d[1] - w[1]).abs() < 1e-12,
        "{d:?} {w:?}"
    );
    let g = |t: f64, x: &[f64; 2], xh: &[f64; 2]| -> [f64; 2] {
        Observer::with_state(xh).derivative(&[x[0]], &[duffing_u(t)], &[])
    };
    for x0 in [[1.5, 0.0], [-1.0, 1.0], [0.0, -1.5]] {
        for e0 in errors(1.0) {
            let r = run(duffing_plant, &g, x0, e0, [4.0, 4.0], &P, ALPHA);
            assert!(r.in_f <= 1.0, "x left F from {x0:?}: {}", r.in_f);
            assert!(r.y_max <= THETA_MAX[0], "y1 left its interval: {}", r.y_max);
            assert!(
                r.envelope <= 1.0 + 1e-6,
                "x0 {x0:?}, e0 {e0:?}: V/(V0 e^(-αt)) reached {}",
                r.envelope
            );
        }
    }
}

/// The plant over 1 ms from time t by 100 explicit Euler substeps.
fn euler_substeps(f: Rhs, t: f64, mut x: [f64; 2]) -> [f64; 2] {
    for i in 0..100 {
        let d = f(t + i as f64 * 1e-5, &x);
        x = [x[0] + 1e-5 * d[0], x[1] + 1e-5 * d[1]];
    }
    x
}

// An f32 design beside the f64 one: its steppers take y and no θ either.
qpv::qpv! {
    model duffing_f32 {
        state x1, x2;
        input u in [-1, 1];
        output y1;
        der x1 = x2;
        der x2 = -0.3*x2 - x1 - 0.5*x1^3 + u;
        out y1 = x1;
        state_bound Q = [4, 0; 0, 4];
        design { alpha = max; max_gain = 100; }
        design { alpha = 5; max_gain = 100; float = f32; }
    }
}

#[test]
fn an_f32_design_computes_theta_from_y_too() {
    use duffing_f32::design2;
    assert_eq!(design2::NTHETA_IN, 0);
    let _: [f32; 1] = design2::theta_of(&[0.5f32], &[]);
    let mut o = design2::Observer::new();
    let mut x = [1.5f64, 0.0];
    for k in 0..4000 {
        let u = duffing_u(k as f64 * 1e-3);
        o.step_rk4(1e-3f32, &[x[0] as f32], &[u as f32], &[]);
        for i in 0..100 {
            let d = duffing_plant(k as f64 * 1e-3 + i as f64 * 1e-5, &x);
            x = [x[0] + 1e-5 * d[0], x[1] + 1e-5 * d[1]];
        }
    }
    let xh = o.estimate();
    let err = (x[0] - f64::from(xh[0])).hypot(x[1] - f64::from(xh[1]));
    assert!(err < 1e-2, "{x:?} {xh:?}");
    assert_eq!(o.clamped(), 0);
}
