//! Nonlinear terms of unmeasured states in `der` equations: the split into
//! the polynomial part (A, N_k, B exactly as before) and the terms kept as
//! written, their global Jacobian bound and the vertex expansion, and the
//! bound on the set S of a term without a global bound.

use qpv_dsl::{parse, Model};

fn one(src: &str) -> Model {
    let mut m = parse(src).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.len(), 1);
    m.remove(0)
}

const ARM: &str = include_str!("../../examples/flexible_joint.qpv");

#[test]
fn the_arm_keeps_its_affine_part_in_a_and_sin_q1_as_a_term() {
    let m = one(ARM);
    // der w1 = -(mgl/Jl)*sin(q1) - (k/Jl)*(q1 - q2): A[1] = [-100, 0, 100, 0]
    let a = m.eval_a(&[]);
    assert_eq!(a[(1, 0)], -100.0);
    assert_eq!(a[(1, 2)], 100.0);
    assert_eq!(a[(3, 3)], -5.0);
    assert!(m.n.iter().all(|n| n.is_zero()));
    assert_eq!(m.nonlinear.len(), 1);
    let t = &m.nonlinear[0];
    assert_eq!(t.row, 1);
    assert_eq!(t.text, "-(mgl/Jl)*sin(q1)");
    // the right-hand side evaluates the term as written
    let x = nalgebra::DVector::from_vec(vec![0.7, 0.0, 0.2, 0.0]);
    let f = m.rhs(&x, &nalgebra::DVector::zeros(1), &[]);
    let want = -20.0 * 0.7f64.sin() - 100.0 * (0.7 - 0.2);
    assert!((f[1] - want).abs() < 1e-12, "{} vs {want}", f[1]);
    assert!(m.is_lpv(), "a global bound keeps the global observer");
}

#[test]
fn a_global_bound_expands_every_vertex_to_the_corners_of_the_jacobian_box() {
    let p = one(ARM).polytopic();
    assert_eq!(p.nv(), 2);
    assert_eq!(p.gain_shift(), 1);
    let b = p
        .jacobian
        .as_ref()
        .and_then(|j| j.bound.as_ref())
        .expect("bound");
    assert!(b.state_box.is_none(), "global");
    assert_eq!(b.entries.len(), 1);
    let e = &b.entries[0];
    assert_eq!((e.row, e.col), (1, 0));
    // -(mgl/Jl) cos(q1) ∈ [-20, 20], rounded outward by a few ulps
    assert!(e.lo <= -20.0 && e.lo > -20.0 - 1e-9, "{}", e.lo);
    assert!(e.hi >= 20.0 && e.hi < 20.0 + 1e-9, "{}", e.hi);
    assert_eq!(p.vertices[0].a[(1, 0)], -100.0 + e.lo);
    assert_eq!(p.vertices[1].a[(1, 0)], -100.0 + e.hi);
    // the weights share the θ-weight equally, so Σ μ_l A_l = A + mid
    let mu = p.mu(&[]);
    assert_eq!(mu, vec![0.5, 0.5]);
    assert_eq!(p.theta_vertices().len(), 1);
}

const DUFFING: &str = "model d {
    state x1, x2;
    output y;
    der x1 = x2;
    der x2 = -x1 - 0.3*x2 - 0.5*x1^3;
    out y = x2;
    region box([0.5, 0.5]);
    state_bound Q = [1, 0; 0, 1];
}";

#[test]
fn a_cubic_term_has_no_global_bound_and_is_bounded_on_s_at_gamma() {
    let m = one(DUFFING);
    assert!(!m.is_lpv(), "the set S needs the region");
    let p = m.polytopic();
    assert_eq!(p.nv(), 1, "not expanded before γ is known");
    assert!(p.jacobian_needs_set());
    assert!(p.with_jacobian(None).is_err(), "no γ: no set");
    let e = p.with_jacobian(Some(0.5)).expect("bounded on S");
    let b = e
        .jacobian
        .as_ref()
        .and_then(|j| j.bound.as_ref())
        .expect("bound");
    // |z_k| ≤ 1 + 0.5/0.5 = 2: -1.5 x1² ∈ [-6, 0]
    let sb = b.state_box.as_ref().expect("a box");
    assert!(sb[0].1 >= 2.0 && sb[0].1 < 2.0 + 1e-12, "{sb:?}");
    let d = &b.entries[0];
    assert!(d.lo <= -6.0 && d.lo > -6.0 - 1e-9, "{}", d.lo);
    assert!(d.hi >= 0.0 && d.hi < 1e-12, "{}", d.hi);
    assert_eq!(e.nv(), 2);
    // a smaller γ widens S and the bound
    let wide = p.with_jacobian(Some(0.25)).expect("bounded");
    let w = &wide
        .jacobian
        .as_ref()
        .and_then(|j| j.bound.as_ref())
        .expect("b")
        .entries[0];
    assert!(w.lo < d.lo - 1.0, "{} vs {}", w.lo, d.lo);
}

#[test]
fn a_quadratic_model_written_as_equations_is_unchanged() {
    let m = one(include_str!("../../examples/paper_equations.qpv"));
    assert!(m.nonlinear.is_empty());
    let p = m.polytopic();
    assert!(p.jacobian.is_none());
    assert_eq!(p.gain_shift(), 0);
}

#[test]
fn a_term_undefined_on_s_has_no_bound() {
    // sin(x1)/x1 divides by a state that reaches 0 on every S
    let m = one(&DUFFING.replace("- 0.5*x1^3", "- sin(x1)/x1"));
    assert_eq!(m.nonlinear.len(), 1);
    let p = m.polytopic();
    let err = p.with_jacobian(Some(0.5)).expect_err("undefined at 0");
    assert!(err.contains("der x2"), "{err}");
}

/// A term of degree 3 or more goes to the scheduling on a measured output
/// when what is left after its measured factors is at most quadratic, and
/// is bounded through its Jacobian otherwise (never refused for having a
/// measured factor).
#[test]
fn a_cubic_term_is_scheduled_or_bounded_by_what_its_measured_factors_leave() {
    let src = |term: &str| {
        format!(
            "model m {{ state x1, x2; output y; der x1 = x2; der x2 = -x2 - x1 + {term};
             out y = x1; region box(0.5); state_bound Q = [1, 0; 0, 1]; design {{ alpha = 1; }} }}"
        )
    };
    // x1 measured: x1^2*x2 leaves x2, scheduled (no nonlinear term)
    let m = one(&src("-x1^2*x2"));
    assert!(m.nonlinear.is_empty(), "{:?}", m.nonlinear);
    // x1*x2^3 leaves x2^3: bounded through its Jacobian
    let m = one(&src("-x1*x2*x2*x2"));
    assert_eq!(m.nonlinear.len(), 1);
    assert_eq!(m.nonlinear[0].text, "-x1*x2*x2*x2");
    // (x1 + x2)^3 has x2^3 in it: bounded too
    let m = one(&src("-(x1 + x2)^3"));
    assert_eq!(m.nonlinear.len(), 1);
}
