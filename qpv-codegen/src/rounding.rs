//! A forward error bound of the generated arithmetic in `f32`: every
//! sub-expression of a [`Body`] is evaluated over boxes of its inputs as a
//! [`Val`], an interval containing the exact value (real arithmetic on the
//! model's f64 constants) and a bound on |computed − exact| when the
//! expression is computed as printed, in IEEE single precision with round
//! to nearest (unit roundoff u = 2⁻²⁴, products may underflow by at most
//! η = 2⁻¹⁵⁰).
//!
//! The rules, for operands with exact values a, b and computed values
//! a' = a + e_a, b' = b + e_b (|e_a| ≤ ε_a, |e_b| ≤ ε_b), |a| ≤ A, |b| ≤ B:
//!
//! ```text
//!     constant c:  ε = |c − fl(c)|          (the literal rounded to f32)
//!     a ± b:       ε = ε_a + ε_b + u (M + ε_a + ε_b),          M ≥ |a ± b|
//!     a · b:       ε = A ε_b + B ε_a + ε_a ε_b + u (M + A ε_b + B ε_a + ε_a ε_b) + η
//!     a / b:       ε = (A ε_b + B' ε_a)/(b_min (b_min − ε_b)) + u (M + that) + η
//!     f(a):        ε = Lip_f · ε_a + 2u · max|f|  (the math library within 1 ulp)
//!     clamp(a, l, h): ε = max(ε_a, ε_l, ε_h)     (1-Lipschitz, no rounding)
//! ```
//!
//! each a first-order-free (rigorous) form of fl(a op b) = (a op b)(1 + δ),
//! |δ| ≤ u. Sums are accumulated left to right as printed; a coefficient c
//! of a folded sum is the product c·f unless |c| = 1. The bound's own f64
//! arithmetic is covered by a relative pad of 1e-9 on every result.
//!
//! Assumptions: no overflow (every interval here is far below f32::MAX, and
//! [`Val::finite`] checks it), the math functions of a scheduling function
//! (`sinf`, `cosf`, ...) are within one ulp, and a cover's piece index
//! ([`Expr::Select`]) is the exact one (θ within f32 rounding of a
//! breakpoint may select the neighbouring piece, whose gain is certified at
//! the breakpoint but evaluated a rounding away from it; not bounded here).

use crate::ir::{Body, Expr, Op};
use qpv_dsl::Func;
use std::collections::HashMap;

/// The unit roundoff of IEEE single precision, 2⁻²⁴.
pub const UNIT_ROUNDOFF: f64 = 1.0 / 16_777_216.0;
/// Half the smallest subnormal f32, 2⁻¹⁵⁰: the absolute error of an underflowing product.
const ETA: f64 = 7.006_492_321_624_085e-46;
/// The relative pad on every result for the f64 arithmetic of the bound itself.
const PAD: f64 = 1e-9;

/// A real value known to lie in [lo, hi], computed in f32 with an absolute
/// error of at most `err`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Val {
    /// Lower end of the exact value's range.
    pub lo: f64,
    /// Upper end of the exact value's range.
    pub hi: f64,
    /// Bound on |computed − exact|.
    pub err: f64,
}

impl Val {
    /// An exactly known input range (no error).
    pub fn range(lo: f64, hi: f64) -> Val {
        Val { lo, hi, err: 0.0 }
    }

    /// An input range whose value reaches the code rounded to f32 (an
    /// argument passed as `f32`): error u·max|v|.
    pub fn rounded_input(lo: f64, hi: f64) -> Val {
        Val {
            lo,
            hi,
            err: UNIT_ROUNDOFF * lo.abs().max(hi.abs()),
        }
    }

    /// The largest magnitude of the exact value.
    pub fn mag(&self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }

    /// True if the range and the error are finite and far from f32 overflow.
    pub fn finite(&self) -> bool {
        let lim = f64::from(f32::MAX) / 4.0;
        self.lo.is_finite()
            && self.hi.is_finite()
            && self.err.is_finite()
            && self.mag() + self.err < lim
    }

    fn exact(c: f64) -> Val {
        Val::range(c, c)
    }

    fn padded(lo: f64, hi: f64, err: f64) -> Val {
        let m = lo.abs().max(hi.abs());
        Val {
            lo: lo - PAD * m,
            hi: hi + PAD * m,
            err: err * (1.0 + PAD),
        }
    }
}

/// A literal as the f32 code holds it: `c` rounded to nearest, and its error.
fn constant(c: f64) -> Val {
    let r = f64::from(c as f32);
    Val {
        lo: c,
        hi: c,
        err: (c - r).abs(),
    }
}

fn neg(a: Val) -> Val {
    Val {
        lo: -a.hi,
        hi: -a.lo,
        err: a.err,
    }
}

fn add(a: Val, b: Val, sub: bool) -> Val {
    let b = if sub { neg(b) } else { b };
    let (lo, hi) = (a.lo + b.lo, a.hi + b.hi);
    let m = lo.abs().max(hi.abs());
    let e = a.err + b.err;
    Val::padded(lo, hi, e + UNIT_ROUNDOFF * (m + e))
}

fn mul(a: Val, b: Val) -> Val {
    let c = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
    let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let m = lo.abs().max(hi.abs());
    let prop = a.mag() * b.err + b.mag() * a.err + a.err * b.err;
    Val::padded(lo, hi, prop + UNIT_ROUNDOFF * (m + prop) + ETA)
}

fn div(a: Val, b: Val) -> Option<Val> {
    let bmin = if b.lo > 0.0 {
        b.lo
    } else if b.hi < 0.0 {
        -b.hi
    } else {
        return None;
    };
    if bmin <= b.err {
        return None;
    }
    let c = [a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi];
    let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let m = lo.abs().max(hi.abs());
    let prop = (a.mag() * b.err + b.mag() * a.err) / (bmin * (bmin - b.err));
    Some(Val::padded(lo, hi, prop + UNIT_ROUNDOFF * (m + prop) + ETA))
}

/// The range of `f` over [lo, hi] and its Lipschitz constant there; None
/// where `f` is not defined or not Lipschitz on the whole interval.
fn func_range(f: Func, lo: f64, hi: f64) -> Option<(f64, f64, f64)> {
    use std::f64::consts::{FRAC_PI_2, PI};
    let mono = |g: fn(f64) -> f64, lip: f64| Some((g(lo), g(hi), lip));
    match f {
        Func::Sqrt => (lo > 0.0).then(|| (lo.sqrt(), hi.sqrt(), 0.5 / lo.sqrt())),
        Func::Exp => mono(f64::exp, hi.exp()),
        Func::Ln => (lo > 0.0).then(|| (lo.ln(), hi.ln(), 1.0 / lo)),
        Func::Tanh => mono(f64::tanh, 1.0),
        Func::Atan => mono(f64::atan, 1.0),
        Func::Abs => {
            let (a, b) = (lo.abs(), hi.abs());
            let l = if lo <= 0.0 && hi >= 0.0 {
                0.0
            } else {
                a.min(b)
            };
            Some((l, a.max(b), 1.0))
        }
        Func::Tan => {
            let branch = |x: f64| ((x + FRAC_PI_2) / PI).floor();
            if branch(lo) != branch(hi) {
                return None;
            }
            let (a, b) = (lo.tan(), hi.tan());
            Some((a, b, 1.0 + a.abs().max(b.abs()).powi(2)))
        }
        Func::Sin | Func::Cos => {
            let g = if f == Func::Sin { f64::sin } else { f64::cos };
            if hi - lo >= 2.0 * PI {
                return Some((-1.0, 1.0, 1.0));
            }
            let (mut a, mut b) = (g(lo).min(g(hi)), g(lo).max(g(hi)));
            // the extrema inside: multiples of π/2
            let mut k = (lo / FRAC_PI_2).ceil();
            while k * FRAC_PI_2 <= hi {
                let v = g(k * FRAC_PI_2);
                a = a.min(v);
                b = b.max(v);
                k += 1.0;
            }
            Some((a.max(-1.0), b.min(1.0), 1.0))
        }
    }
}

fn call(f: Func, a: Val) -> Option<Val> {
    let (lo, hi) = (a.lo - a.err, a.hi + a.err);
    let (wlo, whi, lip) = func_range(f, lo, hi)?;
    let (rlo, rhi, _) = func_range(f, a.lo, a.hi)?;
    let m = wlo.abs().max(whi.abs());
    Some(Val::padded(
        rlo.min(rhi),
        rhi.max(rlo),
        lip * a.err + 2.0 * UNIT_ROUNDOFF * m + ETA,
    ))
}

fn hull(vs: &[Val]) -> Option<Val> {
    let first = *vs.first()?;
    Some(vs.iter().skip(1).fold(first, |acc, v| Val {
        lo: acc.lo.min(v.lo),
        hi: acc.hi.max(v.hi),
        err: acc.err.max(v.err),
    }))
}

/// The names a body reads, with their values.
pub type Env = HashMap<String, Val>;

/// The [`Val`] of an expression over `env` (names) and `coefs` (the
/// θ-coefficients `c.k<i>`); `Err` names what could not be bounded.
pub fn eval(e: &Expr, env: &Env, coefs: &[Val]) -> Result<Val, String> {
    let r = |x: &Expr| eval(x, env, coefs);
    let v = match e {
        Expr::Num(c) => constant(*c),
        Expr::Int(n) => Val::exact(*n as f64),
        Expr::Var(name) => *env
            .get(name)
            .ok_or_else(|| format!("no range for `{name}`"))?,
        Expr::Coef(i) => *coefs
            .get(*i)
            .ok_or_else(|| format!("no range for coefficient {i}"))?,
        Expr::Neg(a) => neg(r(a)?),
        Expr::Paren(a) => r(a)?,
        Expr::Product(fs) => {
            let mut it = fs.iter();
            let first = it.next().map_or(Ok(Val::exact(1.0)), r)?;
            it.try_fold(first, |acc, f| Ok::<_, String>(mul(acc, r(f)?)))?
        }
        Expr::Bin(op, a, b) => {
            let (a, b) = (r(a)?, r(b)?);
            match op {
                Op::Add => add(a, b, false),
                Op::Sub => add(a, b, true),
                Op::Mul => mul(a, b),
                Op::Div => div(a, b).ok_or("a divisor's range contains zero")?,
            }
        }
        Expr::Sum(terms) => {
            let mut acc: Option<Val> = None;
            for (c, f) in terms {
                let a = c.abs();
                let t = match f {
                    None => constant(a),
                    Some(f) if a == 1.0 => r(f)?,
                    // `c * f1 * f2` is ((c·f1)·f2), as printed
                    Some(Expr::Product(fs)) => fs
                        .iter()
                        .try_fold(constant(a), |acc, f| Ok::<_, String>(mul(acc, r(f)?)))?,
                    Some(f) => mul(constant(a), r(f)?),
                };
                acc = Some(match acc {
                    None if *c < 0.0 => neg(t),
                    None => t,
                    Some(s) => add(s, t, *c < 0.0),
                });
            }
            acc.unwrap_or(Val::exact(0.0))
        }
        Expr::Call(f, a) => call(*f, r(a)?).ok_or_else(|| {
            format!(
                "`{}` is not Lipschitz on the range of its argument",
                crate::ir::math_name(*f)
            )
        })?,
        Expr::PowI(a, n) => {
            let a = r(a)?;
            let mut acc = Val::exact(1.0);
            for i in 0..*n {
                acc = if i == 0 { a } else { mul(acc, a) };
            }
            acc
        }
        Expr::Clamp(a, l, h) => {
            let (a, l, h) = (r(a)?, r(l)?, r(h)?);
            Val {
                lo: a.lo.max(l.lo).min(h.lo),
                hi: a.hi.max(l.hi).min(h.hi),
                err: a.err.max(l.err).max(h.err),
            }
        }
        Expr::Ge(_, _) => Val::range(0.0, 1.0),
        Expr::Select(_, arms) => {
            let vs = arms.iter().map(r).collect::<Result<Vec<_>, _>>()?;
            hull(&vs).unwrap_or(Val::exact(0.0))
        }
    };
    if v.finite() {
        Ok(v)
    } else {
        Err("a value or its rounding error is unbounded or near f32 overflow".into())
    }
}

/// The outputs of a body: its lets evaluated in order into `env`, then
/// its results.
pub fn eval_body(b: &Body, env: &mut Env, coefs: &[Val]) -> Result<Vec<Val>, String> {
    for l in &b.lets {
        let v = eval(&l.value, env, coefs)?;
        env.insert(l.name.clone(), v);
    }
    b.out.iter().map(|e| eval(e, env, coefs)).collect()
}

/// The boxes the generated right-hand side is evaluated over.
#[derive(Debug, Clone, PartialEq)]
pub struct Boxes {
    /// The plant's state x (for the range of the measurement y = h(x)).
    pub plant_state: Vec<(f64, f64)>,
    /// The observer's state as [`Shape::state_names`] orders it (x̂ = x − e).
    pub observer_state: Vec<(f64, f64)>,
}

/// The bound, per observer state, on the f32 rounding error of one
/// evaluation of the observer's right-hand side as generated (θ clamping,
/// φ(θ), the coefficients, μ(θ), the gain, then the rows), over θ ∈ Θ, the
/// observer state in `boxes.observer_state`, y = h(x) for x in
/// `boxes.plant_state`, and u in the model's declared input ranges. θ, y
/// and u reach the code rounded to f32 (their rounding is included); the
/// observer state is an f32 value (exact input). `Err` says why no bound
/// exists (an input without a declared range, a divisor through zero).
pub fn rhs_error(
    m: &qpv_dsl::Model,
    scheduling: &[usize],
    d: &crate::design::CertifiedDesign,
    shape: crate::design::Shape,
    boxes: &Boxes,
) -> Result<Vec<f64>, String> {
    use crate::build::{coeffs::Coeffs, equations::equations, observer, weights};
    let (state_eqs, out_eqs) = equations(m);
    let mut coeffs = Coeffs::default();
    let (_, h) = observer::plant_bodies(&state_eqs, &out_eqs, &mut coeffs);
    let rhs = observer::rhs_body(d, shape, &state_eqs, &out_eqs, &mut coeffs);
    let nth = m.ntheta();
    // θ: rounded to f32 by the caller, clamped into the f32-rounded Θ
    let mut env = Env::new();
    for (i, p) in m.params.iter().enumerate() {
        let clamp = Expr::Clamp(
            Box::new(Expr::var("raw")),
            Box::new(Expr::Num(p.lo)),
            Box::new(Expr::Num(p.hi)),
        );
        let mut e = Env::new();
        e.insert("raw".into(), Val::rounded_input(p.lo, p.hi));
        env.insert(format!("t{i}"), eval(&clamp, &e, &[])?);
    }
    let phi = eval_body(&weights::phi_body(m), &mut env.clone(), &[])?;
    for (j, v) in phi.iter().enumerate() {
        env.insert(format!("f{j}"), *v);
        env.insert(format!("t{}", nth + j), *v);
    }
    let coefs = eval_body(&coeffs.body(), &mut env.clone(), &[])?;
    let mu = eval_body(&weights::mu_body(m, scheduling), &mut env.clone(), &[])?;
    let mut genv = Env::new();
    for (l, v) in mu.iter().enumerate() {
        genv.insert(format!("m{l}"), *v);
    }
    let gains = eval_body(&observer::gains_body(d, shape), &mut genv, &[])?;
    // y = h(x): its range (exact), then rounded when passed as f32
    let mut xenv = Env::new();
    for (i, (lo, hi)) in boxes.plant_state.iter().enumerate() {
        xenv.insert(format!("x{i}"), Val::range(*lo, *hi));
    }
    let ys = eval_body(&h, &mut xenv, &coefs)?;
    let mut renv = Env::new();
    for (o, y) in ys.iter().enumerate() {
        renv.insert(format!("y{o}"), Val::rounded_input(y.lo, y.hi));
    }
    for (j, name) in m.inputs.iter().enumerate() {
        let Some((lo, hi)) = m.input_ranges.get(j).copied().flatten() else {
            return Err(format!(
                "input `{name}` has no declared range (`input {name} in [lo, hi];`): the \
                 rounding of B(θ)u cannot be bounded without one"
            ));
        };
        renv.insert(format!("u{j}"), Val::rounded_input(lo, hi));
    }
    for (name, (lo, hi)) in shape.state_names().iter().zip(&boxes.observer_state) {
        renv.insert(name.clone(), Val::range(*lo, *hi));
    }
    for k in 0..shape.nz {
        for o in 0..shape.ny {
            if let Some(g) = gains.get(k * shape.ny + o) {
                renv.insert(format!("g{k}_{o}"), *g);
            }
        }
    }
    Ok(eval_body(&rhs, &mut renv, &coefs)?
        .iter()
        .map(|v| v.err)
        .collect())
}

/// [`rhs_error`] of design `d` of model `m` (its vertex count and shape
/// from the model), over the plant state's box `plant_state` and the
/// observer state's box `observer_state`: the bound the certified f32
/// error floor is computed from.
pub fn design_error(
    m: &qpv_dsl::Model,
    scheduling: &[usize],
    d: &crate::design::CertifiedDesign,
    plant_state: &[(f64, f64)],
    observer_state: &[(f64, f64)],
) -> Result<Vec<f64>, String> {
    let shape = crate::design::Shape::of(m, crate::design::vertex_count(m, scheduling), d);
    let boxes = Boxes {
        plant_state: plant_state.to_vec(),
        observer_state: observer_state.to_vec(),
    };
    rhs_error(m, scheduling, d, shape, &boxes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::Sum;

    /// The bound holds on random points: the f32 evaluation of a sum of
    /// products against the f64 one.
    #[test]
    fn sum_of_products_bound_holds() {
        let mut s = Sum::default();
        s.push(
            0.1,
            Some(Expr::Product(vec![Expr::var("a"), Expr::var("b")])),
        );
        s.push(-3.7, Some(Expr::var("a")));
        s.push(1.0, Some(Expr::var("b")));
        s.push(2.3, None);
        let e = s.expr();
        let mut env = Env::new();
        env.insert("a".into(), Val::range(-2.0, 3.0));
        env.insert("b".into(), Val::rounded_input(0.5, 1.5));
        let v = eval(&e, &env, &[]).expect("bounded");
        let mut worst: f64 = 0.0;
        for i in 0..200 {
            let a = -2.0 + 5.0 * (f64::from(i) / 199.0);
            let a = f64::from(a as f32); // a is exact (err 0): an f32 value
            let b = 0.5 + (f64::from(i * 37 % 200) / 199.0);
            let exact = 0.1 * a * b - 3.7 * a + b + 2.3;
            let (af, bf) = (a as f32, b as f32);
            let comp = 0.1f32 * af * bf - 3.7f32 * af + bf + 2.3f32;
            assert!(exact >= v.lo && exact <= v.hi);
            worst = worst.max((f64::from(comp) - exact).abs());
        }
        assert!(worst <= v.err, "measured {worst} > bound {}", v.err);
        assert!(v.err < 1e-5, "{}", v.err);
    }

    #[test]
    fn a_divisor_through_zero_is_refused() {
        let e = Expr::bin(Op::Div, Expr::Num(1.0), Expr::var("a"));
        let mut env = Env::new();
        env.insert("a".into(), Val::range(-1.0, 1.0));
        assert!(eval(&e, &env, &[]).is_err());
    }
}
