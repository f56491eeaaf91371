//! Soundness of the scheduling-function embedding, checked against the model
//! text itself: for random θ ∈ Θ (and random x, u), the right-hand side
//! rebuilt from the vertex matrices, Σ_l μ_l(θ)(A_l x + N_l(x)x + B_l u),
//! equals the `der` equations evaluated directly from their syntax tree, and
//! every derived variable's range contains its sampled values. The same
//! holds on a piece of Θ (`restricted`) and on every piece of a `cover`,
//! whose ranges are thinner.

use qpv_dsl::__internals::parse_file;
use qpv_dsl::ast::{Expr, ExprKind, Item};
use qpv_dsl::{parse, Model};
use std::collections::HashMap;

/// A small deterministic generator (xorshift64*), uniform in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The value of an expression with every name looked up in `env`.
fn direct(e: &Expr, env: &HashMap<String, f64>) -> f64 {
    match &e.kind {
        ExprKind::Number(v) => *v,
        ExprKind::Name(n) => env[n],
        ExprKind::Neg(x) => -direct(x, env),
        ExprKind::Sum(t) => t.iter().fold(0.0, |a, (neg, x)| {
            if *neg {
                a - direct(x, env)
            } else {
                a + direct(x, env)
            }
        }),
        ExprKind::Product(f) => f.iter().fold(1.0, |a, (div, x)| {
            if *div {
                a / direct(x, env)
            } else {
                a * direct(x, env)
            }
        }),
        ExprKind::Pow(x, n) => direct(x, env).powi(*n as i32),
        ExprKind::Call(f, _, x) => f.apply(direct(x, env)),
    }
}

/// Checks one model text (equation form for the dynamics) on `samples`
/// random points; returns the largest relative deviation.
fn check(src: &str, samples: usize) -> f64 {
    let file = parse_file(src).expect("parses");
    let ast = &file.models[0];
    let model = &parse(src).expect("valid")[0];
    let poly = model.polytopic();
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut worst: f64 = 0.0;
    for _ in 0..samples {
        let mut env = HashMap::new();
        let theta: Vec<f64> = model
            .params
            .iter()
            .map(|p| {
                let v = p.lo + (p.hi - p.lo) * rng.next();
                env.insert(p.name.clone(), v);
                v
            })
            .collect();
        let x: Vec<f64> = model
            .states
            .iter()
            .map(|_| 2.0 * rng.next() - 1.0)
            .collect();
        let u: Vec<f64> = model
            .inputs
            .iter()
            .map(|_| 2.0 * rng.next() - 1.0)
            .collect();
        for (n, v) in model
            .states
            .iter()
            .zip(&x)
            .chain(model.inputs.iter().zip(&u))
        {
            env.insert(n.clone(), *v);
        }
        let mut ders: HashMap<String, f64> = HashMap::new();
        for item in &ast.items {
            match item {
                Item::Const(id, e, _) | Item::Let(id, e, _) => {
                    let v = direct(e, &env);
                    env.insert(id.name.clone(), v);
                }
                Item::Der(eq) => {
                    ders.insert(eq.target.name.clone(), direct(&eq.rhs, &env));
                }
                _ => {}
            }
        }
        let xv = nalgebra::DVector::from_vec(x.clone());
        let mut f = poly.a_at(&theta) * &xv;
        if !u.is_empty() {
            f += poly.b_at(&theta) * nalgebra::DVector::from_vec(u.clone());
        }
        for (k, nk) in poly.n_at(&theta).iter().enumerate() {
            f[k] += xv.dot(&(nk * &xv));
        }
        for (k, name) in model.states.iter().enumerate() {
            let want = ders[name];
            let dev = (f[k] - want).abs() / (1.0 + want.abs());
            worst = worst.max(dev);
        }
    }
    worst
}

/// Samples each derived variable 10⁵ times on Θ: every value must lie in
/// its range.
fn ranges_contain_samples(src: &str) {
    let model = &parse(src).expect("valid")[0];
    let mut rng = Rng(0x1234_5678_9ABC_DEF1);
    for d in &model.derived {
        for _ in 0..100_000 {
            let theta: Vec<f64> = model
                .params
                .iter()
                .map(|p| p.lo + (p.hi - p.lo) * rng.next())
                .collect();
            let v = d.expr.eval(&theta);
            assert!(
                d.lo <= v && v <= d.hi,
                "{} = {} at {theta:?}: {v} outside [{}, {}]",
                d.name,
                d.text,
                d.lo,
                d.hi
            );
        }
    }
}

const MIXED: &str = "model mixed {
    state x1, x2, x3; input u; output y;
    param m in [0, 0.8]; param q in [-1.2, 1.2]; param T in [300, 360];
    const E = 5000; const R = 8.314;
    let I1 = 4 - m;
    let k = 2e3*exp(-E/(R*T));
    der x1 = (3 - 2*m - (2 - m))/I1*x2*x3 + sin(q)^2*x1 - k*x1 + u/I1;
    der x2 = -x2/(2 + cos(q)) + m^2*x1 + q*q*x3 - sqrt(1 + q^2)*x2*x2;
    der x3 = -(1 + abs(q))*x3 + tanh(q)*x1 + x1/I1 - atan(m)*x1*x2 + tan(q/2)*u;
    out y = x1;
    region box(1);
}";

#[test]
fn vertex_decomposition_reproduces_the_equations() {
    let worst = check(MIXED, 2000);
    assert!(worst < 1e-10, "largest deviation {worst:e}");
}

#[test]
fn derived_ranges_contain_sampled_values() {
    ranges_contain_samples(MIXED);
}

#[test]
fn recurring_functions_share_one_derived_variable() {
    let model = &parse(MIXED).expect("valid")[0];
    let texts: Vec<&str> = model.derived.iter().map(|d| d.text.as_str()).collect();
    // 1/I1 is used in three places, q*q and q^2 are the same function
    assert_eq!(
        texts.iter().filter(|t| **t == "1/I1").count(),
        1,
        "{texts:?}"
    );
    assert_eq!(
        texts.iter().filter(|t| **t == "q^2").count(),
        1,
        "{texts:?}"
    );
    // `let k = ...` is one variable named k, not split further
    assert!(model.derived.iter().any(|d| d.name == "k"), "{texts:?}");
    assert_eq!(
        texts.iter().filter(|t| t.contains("exp")).count(),
        1,
        "{texts:?}"
    );
    let poly = model.polytopic();
    let ns = poly.scheduling.len() + poly.derived.len();
    assert_eq!(poly.nv(), 1 << ns);
}

#[test]
fn multi_affine_models_have_no_derived_variables() {
    let src = include_str!("../../examples/paper.qpv");
    let model = &parse(src).expect("valid")[0];
    assert!(model.derived.is_empty());
}

#[test]
fn examples_with_scheduling_functions_are_exact_and_enclosed() {
    for src in [
        include_str!("../../examples/spacecraft.qpv"),
        include_str!("../../examples/manipulator.qpv"),
        include_str!("../../examples/arrhenius_reactor.qpv"),
    ] {
        let worst = check(src, 300);
        assert!(worst < 1e-10, "largest deviation {worst:e}");
        ranges_contain_samples(src);
    }
}

/// The manipulator example without its `cover` statement (one box).
fn manipulator_box() -> String {
    include_str!("../../examples/manipulator.qpv")
        .lines()
        .filter(|l| !l.trim_start().starts_with("cover "))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_piece_of_the_parameter_box_is_exact_and_thinner() {
    let src = manipulator_box();
    let model = &parse(&src).expect("valid")[0];
    let full = model.polytopic();
    let piece = model.restricted(&[(0.2, 0.65)]).expect("inside Θ");
    let poly = piece.polytopic();
    assert_eq!(poly.nv(), full.nv());
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    for (d, f) in piece.derived.iter().zip(&model.derived) {
        assert!(
            f.lo <= d.lo && d.hi <= f.hi,
            "{}: [{}, {}]",
            d.name,
            d.lo,
            d.hi
        );
        assert!(d.hi - d.lo < f.hi - f.lo, "{} is no thinner", d.name);
    }
    for _ in 0..1000 {
        let theta = [0.2 + 0.45 * rng.next()];
        for (d, v) in piece.derived.iter().zip(poly.phi(&theta)) {
            let exact = d.expr.eval(&theta);
            assert!(d.lo <= exact && exact <= d.hi && v == exact, "{}", d.name);
        }
        let (a, a_ref) = (poly.a_at(&theta), full.a_at(&theta));
        let scale = a_ref.abs().max().max(1.0);
        let dev = (&a - &a_ref).abs().max();
        assert!(dev <= 1e-10 * scale, "{a} vs {a_ref}");
    }
    let err = model.restricted(&[(0.1, 0.65)]).unwrap_err();
    assert!(err.contains("q2") && err.contains("[0.2, 2]"), "{err}");
}

/// A model with a grid cover whose matrices all depend on θ through
/// scheduling functions: A, N_k, B, B_w, C and M_k.
const COVERED: &str = "model covered {
    state x1, x2; input u; output y; disturbance w;
    param q in [0.2, 2.0]; param m in [0, 1];
    let d = 2 - m*cos(q);
    der x1 = -x1/d + sin(q)*x2 + m*x1*x2 + u/d + cos(q)*w;
    der x2 = -(1 + m)*x2 + sin(q)*x1*x1/d + m*w/d;
    out y = x1 + cos(q)*x2 + m*sin(q)*x1*x2;
    cover q into 4, m into 3;
    region box(1);
}";

/// The next float above a finite `x` (`f64::next_up`, stable only since
/// Rust 1.86; the workspace supports 1.80).
fn next_up(x: f64) -> f64 {
    if x == 0.0 {
        f64::from_bits(1)
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() + 1)
    } else {
        f64::from_bits(x.to_bits() - 1)
    }
}

/// The next float below a finite `x` (`f64::next_down`).
fn next_down(x: f64) -> f64 {
    -next_up(-x)
}

/// θ values that exercise a cover: uniform in Θ, then every breakpoint
/// (and its neighbouring floats) along each cut parameter, the ends of Θ
/// and points outside it.
fn cover_thetas(model: &Model, rng: &mut Rng, n: usize) -> Vec<Vec<f64>> {
    let uniform = |rng: &mut Rng| -> Vec<f64> {
        model
            .params
            .iter()
            .map(|p| p.lo + (p.hi - p.lo) * rng.next())
            .collect()
    };
    let mut out: Vec<Vec<f64>> = (0..n).map(|_| uniform(rng)).collect();
    let cover = model.cover.as_ref().expect("a cover");
    for a in &cover.axes {
        for &b in &a.breaks {
            for t in [b, next_down(b), next_up(b), b - 0.3, b + 0.3] {
                let mut th = uniform(rng);
                th[a.param] = t;
                out.push(th);
            }
        }
    }
    out.push(vec![f64::NAN; model.ntheta()]);
    out
}

#[test]
fn a_cover_reproduces_every_matrix_of_the_model() {
    let model = &parse(COVERED).expect("valid")[0];
    let poly = model.polytopic();
    let cover = model.cover.as_ref().expect("a cover");
    assert_eq!(cover.len(), 12);
    let per_piece = 1usize << (poly.scheduling.len() + poly.derived.len());
    assert_eq!(poly.nv(), 12 * per_piece);
    assert_eq!(poly.nv(), model.nv());
    assert_eq!(poly.noise.b_w.len(), poly.nv());
    let mut rng = Rng(0x0BAD_5EED_1234_5678);
    let close = |a: &nalgebra::DMatrix<f64>, b: &nalgebra::DMatrix<f64>, what: &str| {
        let dev = (a - b).abs().max();
        assert!(dev <= 1e-10 * (1.0 + b.abs().max()), "{what}: {a} vs {b}");
    };
    for theta in cover_thetas(model, &mut rng, 2000) {
        let mu = poly.mu(&theta);
        assert_eq!(mu.len(), poly.nv());
        assert!(mu.iter().all(|&w| w >= 0.0), "{mu:?}");
        assert!((mu.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{mu:?}");
        // only the piece that contains the clamped θ carries weight
        let clamped: Vec<f64> = model
            .params
            .iter()
            .zip(&theta)
            .map(|(p, &t)| {
                if t.is_nan() {
                    p.lo
                } else {
                    t.clamp(p.lo, p.hi)
                }
            })
            .collect();
        let k = cover.locate(&clamped);
        for (l, &w) in mu.iter().enumerate() {
            assert!(
                l / per_piece == k || w == 0.0,
                "vertex {l} outside piece {k}"
            );
        }
        for (a, i) in cover.axes.iter().zip(cover.indices(k)) {
            let t = clamped[a.param];
            assert!(a.breaks[i] <= t && t <= a.breaks[i + 1]);
            assert!(
                t < a.breaks[i + 1] || i + 2 == a.breaks.len(),
                "breakpoint rule"
            );
        }
        close(&poly.a_at(&theta), &model.eval_a(&clamped), "A");
        close(&poly.b_at(&theta), &model.eval_b(&clamped), "B");
        close(&poly.c_at(&theta), &model.eval_c(&clamped), "C");
        for (x, y) in poly.n_at(&theta).iter().zip(model.eval_n(&clamped)) {
            close(x, &y, "N");
        }
        for (x, y) in poly.m_at(&theta).iter().zip(model.eval_m(&clamped)) {
            close(x, &y, "M");
        }
        let mut bw = nalgebra::DMatrix::zeros(model.nx(), 1);
        for (w, b) in mu.iter().zip(&poly.noise.b_w) {
            bw += b * *w;
        }
        close(&bw, &model.b_w.eval(&model.extended(&clamped)), "B_w");
    }
}

#[test]
fn piece_ranges_contain_sampled_values_and_are_thinner() {
    let model = &parse(COVERED).expect("valid")[0];
    let cover = model.cover.as_ref().expect("a cover");
    let mut rng = Rng(0x5151_2727_9090_AAAA);
    for piece in &cover.pieces {
        for (j, d) in model.derived.iter().enumerate() {
            let (lo, hi) = piece.phi[j];
            assert!(hi - lo <= d.hi - d.lo, "{}: no thinner on a piece", d.name);
            for _ in 0..100_000 {
                let theta: Vec<f64> = piece
                    .theta
                    .iter()
                    .map(|&(l, h)| l + (h - l) * rng.next())
                    .collect();
                let v = d.expr.eval(&theta);
                assert!(
                    lo <= v && v <= hi,
                    "{} at {theta:?}: {v} outside [{lo}, {hi}]",
                    d.name
                );
            }
        }
    }
}

#[test]
fn one_piece_is_the_box() {
    let src = manipulator_box();
    let plain = &parse(&src).expect("valid")[0];
    let one = src.replace("design {", "cover q2 into 1;\n    design {");
    let one = &parse(&one).expect("valid")[0];
    assert_eq!(plain.polytopic().vertices, one.polytopic().vertices);
    let four = src.replace("design {", "cover q2 into 4;\n    design {");
    let four = &parse(&four).expect("valid")[0];
    let poly = four.polytopic();
    assert_eq!(poly.nv(), 4 * plain.polytopic().nv());
    // the pieces of a cover are what `restricted` gives on each piece
    let cover = four.cover.as_ref().expect("a cover");
    for (k, piece) in cover.pieces.iter().enumerate() {
        let r = plain.restricted(&piece.theta).expect("inside Θ");
        let per = r.polytopic().vertices;
        assert_eq!(
            &poly.vertices[k * per.len()..(k + 1) * per.len()],
            per.as_slice()
        );
    }
}
