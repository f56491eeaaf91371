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
//! arithmetic is covered by a relative pad of 1e-9 on every result. A fused
//! multiply-add (a compiler contracting a·b + c) rounds once where the rule
//! counts two, so the bound covers it.
//!
//! **Error-dependent bounds.** The estimate is x̂ = x − e with e in
//! E_ρ = {eᵀPe ≤ ρ²}, ρ ∈ [0, 1]. A [`Val`] carries its range and error as
//! affine functions of ρ (`lo − rad·ρ ≤ exact ≤ hi + rad·ρ`,
//! `|computed − exact| ≤ err + err1·ρ`); the rules above hold with A, B,
//! M, ε replaced by those affine bounds and every ρ² bounded by ρ. The
//! output residual y − h(x̂) = h(x) − h(x̂) is 0 at e = 0 and at most R·ρ,
//! so the gain's term, large on the whole set E, shrinks with the error
//! ([`rhs_error`]; docs/method.md §15, "The f32 error floor"). Division,
//! the math functions, clamping and a cover's selection take their
//! arguments at ρ = 1 (none of them sees x̂ in generated code).
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

/// A real value known to lie in [lo − rad·ρ, hi + rad·ρ], computed in f32
/// with an absolute error of at most err + err1·ρ, for every ρ ∈ [0, 1]:
/// ρ measures the estimation error, e ∈ E_ρ = {eᵀPe ≤ ρ²}, and the parts
/// proportional to ρ (`rad`, `err1`) are what shrinks with e
/// (docs/method.md §15, "The f32 error floor"). Values that do not depend
/// on e (θ, φ, μ, the gain) have `rad = err1 = 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Val {
    /// Lower end of the exact value's range at ρ = 0.
    pub lo: f64,
    /// Upper end of the exact value's range at ρ = 0.
    pub hi: f64,
    /// How far the range widens per unit ρ, on each side.
    pub rad: f64,
    /// Bound on |computed − exact| at ρ = 0.
    pub err: f64,
    /// How much the error bound grows per unit ρ.
    pub err1: f64,
}

impl Val {
    /// An exactly known input range (no error).
    pub fn range(lo: f64, hi: f64) -> Val {
        Val {
            lo,
            hi,
            rad: 0.0,
            err: 0.0,
            err1: 0.0,
        }
    }

    /// An input range whose value reaches the code rounded to f32 (an
    /// argument passed as `f32`): error u·max|v|.
    pub fn rounded_input(lo: f64, hi: f64) -> Val {
        Val {
            err: UNIT_ROUNDOFF * lo.abs().max(hi.abs()),
            ..Val::range(lo, hi)
        }
    }

    /// An exact input in [lo, hi] at ρ = 0 that moves by at most `rad`·ρ
    /// (an estimate x̂ = x − e, |e_k| ≤ ρ·√((P⁻¹)_kk)).
    pub fn moving(lo: f64, hi: f64, rad: f64) -> Val {
        Val {
            rad,
            ..Val::range(lo, hi)
        }
    }

    /// The largest magnitude of the exact value at ρ = 0.
    pub fn mag(&self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }

    /// The largest magnitude of the exact value for any ρ ≤ 1.
    pub fn mag_full(&self) -> f64 {
        self.mag() + self.rad
    }

    /// The error bound at ρ = 1 (the largest for ρ ≤ 1).
    pub fn err_full(&self) -> f64 {
        self.err + self.err1
    }

    /// The same value with its ρ-dependence folded in at ρ = 1 (valid for
    /// every ρ ≤ 1, no longer shrinking with e).
    fn collapsed(self) -> Val {
        Val {
            lo: self.lo - self.rad,
            hi: self.hi + self.rad,
            rad: 0.0,
            err: self.err_full(),
            err1: 0.0,
        }
    }

    /// True if the range and the error are finite and far from f32 overflow.
    pub fn finite(&self) -> bool {
        let lim = f64::from(f32::MAX) / 4.0;
        [self.lo, self.hi, self.rad, self.err, self.err1]
            .iter()
            .all(|v| v.is_finite())
            && self.mag_full() + self.err_full() < lim
    }

    fn exact(c: f64) -> Val {
        Val::range(c, c)
    }

    fn padded(lo: f64, hi: f64, rad: f64, (err, err1): (f64, f64)) -> Val {
        let m = lo.abs().max(hi.abs());
        Val {
            lo: lo - PAD * m,
            hi: hi + PAD * m,
            rad: rad * (1.0 + PAD),
            err: err * (1.0 + PAD),
            err1: err1 * (1.0 + PAD),
        }
    }
}

/// c₀ + c₁ρ times d₀ + d₁ρ, bounded by an affine function of ρ ∈ [0, 1]
/// (ρ² ≤ ρ; every coefficient non-negative).
fn times((c0, c1): (f64, f64), (d0, d1): (f64, f64)) -> (f64, f64) {
    (c0 * d0, c0 * d1 + c1 * d0 + c1 * d1)
}

/// A literal as the f32 code holds it: `c` rounded to nearest, and its error.
fn constant(c: f64) -> Val {
    let r = f64::from(c as f32);
    Val {
        err: (c - r).abs(),
        ..Val::exact(c)
    }
}

fn neg(a: Val) -> Val {
    Val {
        lo: -a.hi,
        hi: -a.lo,
        ..a
    }
}

fn add(a: Val, b: Val, sub: bool) -> Val {
    let b = if sub { neg(b) } else { b };
    let (lo, hi) = (a.lo + b.lo, a.hi + b.hi);
    let rad = a.rad + b.rad;
    let m = lo.abs().max(hi.abs());
    let (e0, e1) = (a.err + b.err, a.err1 + b.err1);
    Val::padded(
        lo,
        hi,
        rad,
        (
            e0 + UNIT_ROUNDOFF * (m + e0),
            e1 + UNIT_ROUNDOFF * (rad + e1),
        ),
    )
}

fn mul(a: Val, b: Val) -> Val {
    let c = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
    let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let m = lo.abs().max(hi.abs());
    // a = a₀ + δa, |δa| ≤ rad_a·ρ: |ab − a₀b₀| ≤ (|a₀|rad_b + |b₀|rad_a + rad_a rad_b)ρ
    let rad = a.mag() * b.rad + b.mag() * a.rad + a.rad * b.rad;
    let (ma, mb) = ((a.mag(), a.rad), (b.mag(), b.rad));
    let (ea, eb) = ((a.err, a.err1), (b.err, b.err1));
    let (p0, p1) = [times(ma, eb), times(mb, ea), times(ea, eb)]
        .iter()
        .fold((0.0, 0.0), |s, t| (s.0 + t.0, s.1 + t.1));
    Val::padded(
        lo,
        hi,
        rad,
        (
            p0 + UNIT_ROUNDOFF * (m + p0) + ETA,
            p1 + UNIT_ROUNDOFF * (rad + p1),
        ),
    )
}

fn div(a: Val, b: Val) -> Option<Val> {
    let (a, b) = (a.collapsed(), b.collapsed());
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
    Some(Val::padded(
        lo,
        hi,
        0.0,
        (prop + UNIT_ROUNDOFF * (m + prop) + ETA, 0.0),
    ))
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
    let a = a.collapsed();
    let (lo, hi) = (a.lo - a.err, a.hi + a.err);
    let (wlo, whi, lip) = func_range(f, lo, hi)?;
    let (rlo, rhi, _) = func_range(f, a.lo, a.hi)?;
    let m = wlo.abs().max(whi.abs());
    Some(Val::padded(
        rlo.min(rhi),
        rhi.max(rlo),
        0.0,
        (lip * a.err + 2.0 * UNIT_ROUNDOFF * m + ETA, 0.0),
    ))
}

fn hull(vs: &[Val]) -> Option<Val> {
    let first = vs.first()?.collapsed();
    Some(vs.iter().skip(1).fold(first, |acc, v| {
        let v = v.collapsed();
        Val {
            lo: acc.lo.min(v.lo),
            hi: acc.hi.max(v.hi),
            err: acc.err.max(v.err),
            ..acc
        }
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
            let (a, l, h) = (r(a)?.collapsed(), r(l)?.collapsed(), r(h)?.collapsed());
            Val {
                lo: a.lo.max(l.lo).min(h.lo),
                hi: a.hi.max(l.hi).min(h.hi),
                err: a.err.max(l.err).max(h.err),
                ..a
            }
        }
        Expr::Ge(_, _) => Val::range(0.0, 1.0),
        Expr::Select(on, arms) => match env.get(on) {
            // a pinned piece index: its arm (the last for any other value)
            Some(k) if k.lo == k.hi && k.rad == 0.0 && !arms.is_empty() => {
                r(&arms[(k.lo.max(0.0) as usize).min(arms.len() - 1)])?
            }
            _ => {
                let vs = arms.iter().map(r).collect::<Result<Vec<_>, _>>()?;
                hull(&vs).unwrap_or(Val::exact(0.0))
            }
        },
    };
    if v.finite() {
        Ok(v)
    } else {
        Err("a value or its rounding error is unbounded or near f32 overflow".into())
    }
}

/// The outputs of a body: its lets evaluated in order into `env`, then
/// its results. An index let already bound in `env` keeps that value.
pub fn eval_body(b: &Body, env: &mut Env, coefs: &[Val]) -> Result<Vec<Val>, String> {
    for l in &b.lets {
        if l.ty == crate::ir::Ty::Index && env.contains_key(&l.name) {
            continue; // pinned by the caller (a cover's piece, [`rhs_error`])
        }
        let v = eval(&l.value, env, coefs)?;
        env.insert(l.name.clone(), v);
    }
    b.out.iter().map(|e| eval(e, env, coefs)).collect()
}

/// The sets the generated right-hand side is evaluated over: the plant
/// state x in a box, the estimate x̂ = x − e with e ∈ E_ρ = {eᵀPe ≤ ρ²},
/// |e_k| ≤ ρ·√((P⁻¹)_kk), for every ρ ∈ [0, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct Boxes {
    /// The plant's state x (also the range of the estimate at e = 0).
    pub plant_state: Vec<(f64, f64)>,
    /// √((P⁻¹)_kk) per state: |e_k| ≤ ρ times this on E_ρ.
    pub error: Vec<f64>,
}

/// The rounding error of one evaluation of the observer's right-hand side,
/// per observer state k: |computed − exact| ≤ `constant[k]` +
/// `proportional[k]`·ρ whenever e ∈ E_ρ, ρ ≤ 1 (docs/method.md §15, "The
/// f32 error floor").
#[derive(Debug, Clone, PartialEq)]
pub struct RhsError {
    /// The part that does not shrink with e (d₀).
    pub constant: Vec<f64>,
    /// The part per unit ρ = √(eᵀPe) (d₁).
    pub proportional: Vec<f64>,
    /// A bound on |computed derivative| over the whole set (ρ ≤ 1), for the
    /// rounding of the state update x̂ + h·k.
    pub derivative: Vec<f64>,
    /// A bound on |x̂_k| over the whole set (ρ ≤ 1).
    pub state: Vec<f64>,
}

/// A box of θ, one (lo, hi) per declared parameter.
type ThetaBox = Vec<(f64, f64)>;

/// The magnitude of a θ-polynomial over the ranges of `t<i>` in `env`:
/// Σ |c| Π |t_i|.
fn poly_mag(p: &qpv_dsl::ThetaPoly, env: &Env) -> Result<f64, String> {
    let mut total = 0.0;
    for &(mask, c) in &p.terms {
        let mut t = c.abs();
        for i in (0..64usize).filter(|i| mask >> i & 1 == 1) {
            t *= env
                .get(&format!("t{i}"))
                .ok_or_else(|| format!("no range for `t{i}`"))?
                .mag_full();
        }
        total += t;
    }
    Ok(total * (1.0 + PAD))
}

/// Per output o, R_o with |h_o(x) − h_o(x̂)| ≤ R_o·ρ for x in the box and
/// e ∈ E_ρ: the exact residual y − C(θ)x̂ − M(θ,x̂)x̂ the gain multiplies
/// (x_i x_j − x̂_i x̂_j = e_i x_j + x̂_i e_j).
fn residual_radius(
    out_eqs: &[crate::build::equations::Equation],
    theta: &Env,
    boxes: &Boxes,
) -> Result<Vec<f64>, String> {
    use crate::build::equations::Mono;
    let x = |i: usize| {
        boxes
            .plant_state
            .get(i)
            .map_or(0.0, |(lo, hi)| lo.abs().max(hi.abs()))
    };
    let e = |i: usize| boxes.error.get(i).copied().unwrap_or(0.0);
    out_eqs
        .iter()
        .map(|eq| {
            let mut r = 0.0;
            for (m, p) in eq {
                let c = poly_mag(p, theta)?;
                r += c * match *m {
                    Mono::X(j) => e(j),
                    Mono::XX(i, j) => e(i) * x(j) + (x(i) + e(i)) * e(j),
                    Mono::U(_) => 0.0,
                    // output equations have no nonlinear terms
                    Mono::F(_) => f64::INFINITY,
                };
            }
            Ok(r * (1.0 + PAD))
        })
        .collect()
}

/// The bound, per observer state, on the f32 rounding error of one
/// evaluation of the observer's right-hand side as generated (θ clamping,
/// φ(θ), the coefficients, μ(θ), the gain, then the rows), split into a
/// part independent of e and one proportional to ρ = √(eᵀPe), over θ ∈ Θ,
/// the sets of `boxes`, y = h(x), and u in the model's declared input
/// ranges. θ, y and u reach the code rounded to f32 (their rounding is
/// included); the observer state is an f32 value (exact input). The
/// residual y − h(x̂) is known to vanish at e = 0 ([`residual_radius`]);
/// that is what makes the gain's contribution proportional to ρ. `Err`
/// says why no bound exists (an input without a declared range, a divisor
/// through zero, the filter route).
pub fn rhs_error(
    m: &qpv_dsl::Model,
    scheduling: &[usize],
    d: &crate::design::CertifiedDesign,
    shape: crate::design::Shape,
    boxes: &Boxes,
) -> Result<RhsError, String> {
    if shape.filter.is_some() {
        return Err("the f32 floor is not computed for the filter route".into());
    }
    if !m.nonlinear.is_empty() {
        return Err(
            "the f32 floor is not computed for nonlinear terms of unmeasured states".into(),
        );
    }
    // With a cover, piece by piece (θ in the piece, its arm selected): the
    // piece's thin box is what keeps its weights, and so the gain, tight.
    let declared: Vec<(f64, f64)> = m.params.iter().map(|p| (p.lo, p.hi)).collect();
    let pieces: Vec<(ThetaBox, Option<usize>)> = match &m.cover {
        Some(c) => c
            .pieces
            .iter()
            .enumerate()
            .map(|(k, p)| (p.theta.clone(), Some(k)))
            .collect(),
        None => vec![(declared, None)],
    };
    let mut out: Option<RhsError> = None;
    for (theta, piece) in &pieces {
        let r = rhs_error_on(m, scheduling, d, shape, boxes, (theta, *piece))?;
        out = Some(match out {
            None => r,
            Some(o) => {
                let max = |a: &[f64], b: &[f64]| -> Vec<f64> {
                    a.iter().zip(b).map(|(x, y)| x.max(*y)).collect()
                };
                RhsError {
                    constant: max(&o.constant, &r.constant),
                    proportional: max(&o.proportional, &r.proportional),
                    derivative: max(&o.derivative, &r.derivative),
                    state: o.state,
                }
            }
        });
    }
    out.ok_or_else(|| "a cover without pieces".into())
}

/// [`rhs_error`] for θ in the box `theta` (declared order) and, with a
/// cover, the piece index pinned to `piece`.
fn rhs_error_on(
    m: &qpv_dsl::Model,
    scheduling: &[usize],
    d: &crate::design::CertifiedDesign,
    shape: crate::design::Shape,
    boxes: &Boxes,
    (theta, piece): (&[(f64, f64)], Option<usize>),
) -> Result<RhsError, String> {
    use crate::build::{coeffs::Coeffs, equations::equations, observer, weights};
    let (state_eqs, out_eqs) = equations(m);
    let mut coeffs = Coeffs::default();
    let (_, h) = observer::plant_bodies(&state_eqs, &out_eqs, &mut coeffs);
    let rhs = observer::rhs_body(d, shape, &state_eqs, &out_eqs, &mut coeffs);
    let nth = m.ntheta();
    // θ: rounded to f32 by the caller, clamped into the f32-rounded Θ
    let mut env = Env::new();
    for (i, (p, (lo, hi))) in m.params.iter().zip(theta).enumerate() {
        let clamp = Expr::Clamp(
            Box::new(Expr::var("raw")),
            Box::new(Expr::Num(p.lo)),
            Box::new(Expr::Num(p.hi)),
        );
        let mut e = Env::new();
        e.insert("raw".into(), Val::rounded_input(*lo, *hi));
        env.insert(format!("t{i}"), eval(&clamp, &e, &[])?);
    }
    if let Some(k) = piece {
        env.insert("k".into(), Val::exact(k as f64));
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
    let radius = residual_radius(&out_eqs, &env, boxes)?;
    // y = h(x): its range (exact), then rounded when passed as f32
    let mut xenv = Env::new();
    for (i, (lo, hi)) in boxes.plant_state.iter().enumerate() {
        xenv.insert(format!("x{i}"), Val::range(*lo, *hi));
    }
    let ys = eval_body(&h, &mut xenv, &coefs)?;
    let mut renv = Env::new();
    for (o, y) in ys.iter().enumerate() {
        let y = y.collapsed();
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
    for (k, (lo, hi)) in boxes.plant_state.iter().enumerate() {
        let rad = boxes.error.get(k).copied().unwrap_or(0.0);
        renv.insert(format!("x{k}"), Val::moving(*lo, *hi, rad));
    }
    for k in 0..shape.nz {
        for o in 0..shape.ny {
            if let Some(g) = gains.get(k * shape.ny + o) {
                renv.insert(format!("g{k}_{o}"), *g);
            }
        }
    }
    for l in &rhs.lets {
        let mut v = eval(&l.value, &renv, &coefs)?;
        if let Some(r) = l
            .name
            .strip_prefix('r')
            .and_then(|o| o.parse::<usize>().ok())
            .and_then(|o| radius.get(o))
        {
            // the exact residual h(x) − h(x̂) is 0 at e = 0 and at most R_o·ρ
            v = Val {
                lo: 0.0,
                hi: 0.0,
                rad: *r,
                ..v
            };
        }
        renv.insert(l.name.clone(), v);
    }
    let rows = rhs
        .out
        .iter()
        .map(|e| eval(e, &renv, &coefs))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(RhsError {
        constant: rows.iter().map(|v| v.err).collect(),
        proportional: rows.iter().map(|v| v.err1).collect(),
        derivative: rows.iter().map(|v| v.mag_full() + v.err_full()).collect(),
        state: boxes
            .plant_state
            .iter()
            .zip(&boxes.error)
            .map(|((lo, hi), e)| lo.abs().max(hi.abs()) + e)
            .collect(),
    })
}

/// [`rhs_error`] of design `d` of model `m` (its vertex count and shape
/// from the model), over the plant state's box `plant_state` and the
/// estimation error's per-state radius `error` (√((P⁻¹)_kk)): the bound
/// the certified f32 error floor is computed from.
pub fn design_error(
    m: &qpv_dsl::Model,
    scheduling: &[usize],
    d: &crate::design::CertifiedDesign,
    plant_state: &[(f64, f64)],
    error: &[f64],
) -> Result<RhsError, String> {
    let shape = crate::design::Shape::of(m, crate::design::vertex_count(m, scheduling), d);
    let boxes = Boxes {
        plant_state: plant_state.to_vec(),
        error: error.to_vec(),
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

    /// The ρ-split holds on random points: an estimate x̂ = x − e with
    /// |e| ≤ ρ·rad, the residual y − x̂ (y = x), the injection g·r and the
    /// row x̂ + g·r, computed in f32 against f64, for ρ from 0 to 1.
    #[test]
    fn error_dependent_bound_holds() {
        let (rad, g) = (0.3, 7.3);
        let mut env = Env::new();
        env.insert("xh".into(), Val::moving(-1.0, 2.0, rad));
        env.insert("y".into(), Val::rounded_input(-1.0, 2.0));
        let r = eval(
            &Expr::bin(Op::Sub, Expr::var("y"), Expr::var("xh")),
            &env,
            &[],
        )
        .expect("bounded");
        // the exact residual is y − x̂ = e: 0 at ρ = 0, at most rad·ρ
        env.insert(
            "r".into(),
            Val {
                lo: 0.0,
                hi: 0.0,
                rad,
                ..r
            },
        );
        let row = Expr::bin(
            Op::Add,
            Expr::var("xh"),
            Expr::Product(vec![Expr::Num(g), Expr::var("r")]),
        );
        let v = eval(&row, &env, &[]).expect("bounded");
        assert!(v.err1 > 0.0 && v.err < 1e-5, "{v:?}");
        for i in 0..400 {
            let rho = f64::from(i % 5) / 4.0;
            let x = -1.0 + 3.0 * f64::from(i * 7 % 400) / 399.0;
            let e = rad * rho * (f64::from(i * 13 % 400) / 199.5 - 1.0);
            let xh = f64::from((x - e) as f32); // the observer state is an f32
            let exact = xh + g * (x - xh);
            let yf = x as f32;
            let comp = f64::from(xh as f32 + (g as f32) * (yf - xh as f32));
            assert!(exact >= v.lo - v.rad * rho && exact <= v.hi + v.rad * rho);
            let bound = v.err + v.err1 * rho;
            assert!(
                (comp - exact).abs() <= bound,
                "ρ = {rho}: {} > {bound}",
                (comp - exact).abs()
            );
        }
    }

    #[test]
    fn a_divisor_through_zero_is_refused() {
        let e = Expr::bin(Op::Div, Expr::Num(1.0), Expr::var("a"));
        let mut env = Env::new();
        env.insert("a".into(), Val::range(-1.0, 1.0));
        assert!(eval(&e, &env, &[]).is_err());
    }
}
