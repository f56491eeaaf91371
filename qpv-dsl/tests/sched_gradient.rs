//! The interval gradient of scheduling functions
//! (`qpv_dsl::sched::enclose_gradient`, `gradient_bound`; docs/method.md
//! §16): it contains central finite differences at random points for every
//! node and library function, the grid bound is sound and close to the
//! sampled maximum, and an unbounded derivative is an error.

use qpv_dsl::sched::{enclose_gradient, gradient_bound};
use qpv_dsl::{Func, SchedExpr};

/// A small deterministic generator (xorshift), enough for test points.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn p(i: usize) -> SchedExpr {
    SchedExpr::Param(i)
}
fn num(c: f64) -> SchedExpr {
    SchedExpr::Num(c)
}
fn call(f: Func, e: SchedExpr) -> SchedExpr {
    SchedExpr::Call(f, Box::new(e))
}

/// Functions of (a, b) on a ∈ [0.5, 2], b ∈ [−1, 1.5] covering every
/// node and every library function (arguments kept where each is
/// defined and differentiable).
fn cases() -> Vec<SchedExpr> {
    use SchedExpr::*;
    let sum = |t: Vec<(bool, SchedExpr)>| Sum(t);
    let prod = |t: Vec<(bool, SchedExpr)>| Product(t);
    vec![
        // Arrhenius: k0 exp(−E/a·1000)
        prod(vec![
            (false, num(3.0)),
            (
                false,
                call(
                    Func::Exp,
                    Neg(Box::new(prod(vec![(false, num(2.0)), (true, p(0))]))),
                ),
            ),
        ]),
        // 1/(4 − a b) and (a + b)/(3 + a²)
        prod(vec![
            (false, num(1.0)),
            (
                true,
                sum(vec![
                    (false, num(4.0)),
                    (true, prod(vec![(false, p(0)), (false, p(1))])),
                ]),
            ),
        ]),
        prod(vec![
            (false, sum(vec![(false, p(0)), (false, p(1))])),
            (
                true,
                sum(vec![(false, num(3.0)), (false, Pow(Box::new(p(0)), 2))]),
            ),
        ]),
        Pow(Box::new(sum(vec![(false, p(1)), (true, p(0))])), 3),
        call(Func::Sqrt, sum(vec![(false, p(0)), (false, num(0.1))])),
        call(Func::Ln, prod(vec![(false, p(0)), (false, num(2.0))])),
        call(Func::Sin, prod(vec![(false, p(0)), (false, p(1))])),
        call(Func::Cos, sum(vec![(false, p(1)), (true, p(0))])),
        call(Func::Tan, prod(vec![(false, num(0.5)), (false, p(1))])),
        call(Func::Tanh, prod(vec![(false, num(2.0)), (false, p(1))])),
        call(Func::Atan, prod(vec![(false, p(0)), (false, p(1))])),
        call(Func::Abs, sum(vec![(false, p(1)), (false, num(2.0))])),
        Named(
            "det".into(),
            Box::new(sum(vec![
                (false, num(1.0)),
                (
                    true,
                    prod(vec![
                        (false, num(0.2)),
                        (false, Pow(Box::new(call(Func::Cos, p(0))), 2)),
                    ]),
                ),
            ])),
        ),
    ]
}

/// The interval gradient on a small random box around a random point
/// contains the central finite difference at that point (to its
/// truncation error), and on the degenerate box it is narrow.
#[test]
fn the_interval_gradient_contains_finite_differences() {
    let names = vec!["a".to_string(), "b".to_string()];
    let theta = [(0.5, 2.0), (-1.0, 1.5)];
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for (c, e) in cases().iter().enumerate() {
        for _ in 0..200 {
            let x: Vec<f64> = theta
                .iter()
                .map(|&(lo, hi)| lo + (hi - lo) * rng.next())
                .collect();
            let r = 1e-3 * rng.next();
            let b: Vec<(f64, f64)> = x.iter().map(|&v| (v - r, v + r)).collect();
            let g = enclose_gradient(e, &b, &names).unwrap();
            let at = enclose_gradient(e, &[(x[0], x[0]), (x[1], x[1])], &names).unwrap();
            let v = e.eval(&x);
            assert!(g.value.0 <= v && v <= g.value.1, "case {c} at {x:?}");
            for i in 0..2 {
                let step = 1e-6;
                let mut xp = x.clone();
                let mut xm = x.clone();
                xp[i] += step;
                xm[i] -= step;
                let fd = (e.eval(&xp) - e.eval(&xm)) / (2.0 * step);
                let tol = 1e-6 * (1.0 + fd.abs());
                let (lo, hi) = g.grad[i];
                assert!(
                    lo - tol <= fd && fd <= hi + tol,
                    "case {c}, d/d{}: {fd} outside [{lo}, {hi}] at {x:?}",
                    names[i]
                );
                let (plo, phi) = at.grad[i];
                assert!(
                    (phi - plo) <= 1e-9 * (1.0 + fd.abs()) && (0.5 * (plo + phi) - fd).abs() <= tol,
                    "case {c}, d/d{}: point enclosure [{plo}, {phi}] against {fd}",
                    names[i]
                );
            }
        }
    }
}

/// The grid bound is at least every sampled |∂e/∂θ_i| and, for a
/// smooth function, within a few percent of the largest of them.
#[test]
fn the_gradient_bound_is_sound_and_close() {
    let names = vec!["a".to_string(), "b".to_string()];
    let theta = [(0.5, 2.0), (-1.0, 1.5)];
    let mut rng = Rng(12345);
    for (c, e) in cases().iter().enumerate() {
        let bound = gradient_bound(e, &theta, &names).unwrap();
        let mut seen = [0.0f64; 2];
        for k in 0..2004 {
            // the four corners first, then random points
            let x: Vec<f64> = theta
                .iter()
                .enumerate()
                .map(|(i, &(lo, hi))| match k {
                    0..=3 if (k >> i) & 1 == 1 => hi,
                    0..=3 => lo,
                    _ => lo + (hi - lo) * rng.next(),
                })
                .collect();
            for i in 0..2 {
                let at = enclose_gradient(e, &[(x[0], x[0]), (x[1], x[1])], &names).unwrap();
                let d = at.grad[i].0.abs().max(at.grad[i].1.abs());
                seen[i] = seen[i].max(d);
                assert!(
                    d <= bound[i] * (1.0 + 1e-9),
                    "case {c}: |d/d{}| = {d} > {}",
                    names[i],
                    bound[i]
                );
            }
        }
        for i in 0..2 {
            assert!(
                bound[i] <= 1.15 * seen[i] + 1e-12,
                "case {c}: bound {} against the largest sample {}",
                bound[i],
                seen[i]
            );
        }
    }
}

/// A derivative that is unbounded on the box is an error.
#[test]
fn an_unbounded_derivative_is_an_error() {
    let names = vec!["a".to_string()];
    let e = call(Func::Sqrt, p(0));
    let err = enclose_gradient(&e, &[(0.0, 1.0)], &names).unwrap_err();
    assert!(err.contains("derivative of sqrt"), "{err}");
    assert!(enclose_gradient(&e, &[(0.25, 1.0)], &names).is_ok());
}
