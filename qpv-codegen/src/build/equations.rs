//! The plant's polynomial equations in the form the emitters print them:
//! each row of x' = A(θ)x + N(θ,x)x + B(θ)u (and of y = C(θ)x + M(θ,x)x)
//! as a map from state/input monomial to θ-polynomial coefficient.

use super::coeffs::Coeffs;
use crate::ir::{Expr, Let, Sum};
use qpv_dsl::{Model, PolyMatrix, ThetaPoly};
use std::collections::BTreeMap;

/// A monomial of the state and input: the key under which θ-coefficients
/// of one equation are collected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Mono {
    /// x_j
    X(usize),
    /// x_i x_j with i ≤ j
    XX(usize, usize),
    /// u_j
    U(usize),
    /// The k-th nonlinear term of unmeasured states, as written (`nl<k>`,
    /// bound by [`nonlinear_lets`]).
    F(usize),
}

/// The right-hand side of one polynomial equation: monomial → θ-polynomial.
pub type Equation = BTreeMap<Mono, ThetaPoly>;

/// Adds `p` to the coefficient of `key`, dropping it if the sum is zero.
fn add_poly(eq: &mut Equation, key: Mono, p: &ThetaPoly) {
    if p.is_zero() {
        return;
    }
    let e = eq.entry(key).or_default();
    for &(mask, c) in &p.terms {
        e.add_term(mask, c);
    }
    if e.is_zero() {
        eq.remove(&key);
    }
}

/// Row k of `lin · x + Σ_ij quad_k[i][j] x_i x_j + inp · u`.
fn equation(
    lin: &PolyMatrix,
    quad: Option<&PolyMatrix>,
    inp: Option<&PolyMatrix>,
    k: usize,
) -> Equation {
    let mut eq = Equation::new();
    for j in 0..lin.cols {
        if let Some(p) = lin.entries.get(k * lin.cols + j) {
            add_poly(&mut eq, Mono::X(j), p);
        }
    }
    if let Some(q) = quad {
        for i in 0..q.rows {
            for j in 0..q.cols {
                if let Some(p) = q.entries.get(i * q.cols + j) {
                    add_poly(&mut eq, Mono::XX(i.min(j), i.max(j)), p);
                }
            }
        }
    }
    if let Some(b) = inp {
        for j in 0..b.cols {
            if let Some(p) = b.entries.get(k * b.cols + j) {
                add_poly(&mut eq, Mono::U(j), p);
            }
        }
    }
    eq
}

/// The plant's state equations (one per state) and output equations (one per output).
pub fn equations(m: &Model) -> (Vec<Equation>, Vec<Equation>) {
    let nx = m.nx();
    let ny = m.ny();
    let mut states: Vec<Equation> = (0..nx)
        .map(|k| {
            let b = (m.nu() > 0).then_some(&m.b);
            equation(&m.a, m.n.get(k), b, k)
        })
        .collect();
    for (k, t) in m.nonlinear.iter().enumerate() {
        if let Some(eq) = states.get_mut(t.row) {
            add_poly(eq, Mono::F(k), &ThetaPoly::constant(1.0));
        }
    }
    let outputs = (0..ny)
        .map(|o| equation(&m.c, m.m.get(o), None, o))
        .collect();
    (states, outputs)
}

/// The name a monomial stands for in generated code.
fn mono_expr(m: Mono) -> Expr {
    match m {
        Mono::X(j) => Expr::var(format!("x{j}")),
        Mono::XX(i, j) => Expr::var(format!("x{i}x{j}")),
        Mono::U(j) => Expr::var(format!("u{j}")),
        Mono::F(k) => Expr::var(format!("nl{k}")),
    }
}

/// `let nl<k> = ...;` for every nonlinear term of unmeasured states of the
/// model, as written (over `x<i>`, in the evaluation order of the model
/// compiler): the lets a body that reads [`Mono::F`] starts with.
pub fn nonlinear_lets(m: &Model) -> Vec<Let> {
    m.nonlinear
        .iter()
        .enumerate()
        .map(|(k, t)| Let::real(format!("nl{k}"), state_expr(&t.expr)))
        .collect()
}

/// A nonlinear term over the states (variable i is `x<i>`).
fn state_expr(e: &qpv_dsl::SchedExpr) -> Expr {
    use crate::ir::Op;
    use qpv_dsl::SchedExpr;
    match e {
        SchedExpr::Num(c) => Expr::paren(Expr::Num(*c)),
        SchedExpr::Param(i) => Expr::var(format!("x{i}")),
        SchedExpr::Named(_, e) => state_expr(e),
        SchedExpr::Neg(e) => Expr::paren(Expr::Neg(Box::new(state_expr(e)))),
        SchedExpr::Sum(terms) => terms.iter().fold(Expr::Num(0.0), |acc, (neg, t)| {
            let op = if *neg { Op::Sub } else { Op::Add };
            Expr::paren(Expr::bin(op, acc, state_expr(t)))
        }),
        SchedExpr::Product(factors) => factors.iter().fold(Expr::Num(1.0), |acc, (div, f)| {
            let op = if *div { Op::Div } else { Op::Mul };
            Expr::paren(Expr::bin(op, acc, state_expr(f)))
        }),
        SchedExpr::Pow(e, n) => Expr::PowI(Box::new(state_expr(e)), *n),
        SchedExpr::Call(f, e) => Expr::Call(*f, Box::new(state_expr(e))),
    }
}

/// Adds `sign ×` one equation to a sum, monomial by monomial (θ-dependent
/// coefficients are interned into `coeffs`).
pub fn push_equation(eq: &Equation, coeffs: &mut Coeffs, sum: &mut Sum, sign: f64) {
    for (&m, p) in eq {
        coeffs.push_term(sum, p, mono_expr(m), sign);
    }
}

/// One equation alone, as an expression.
pub fn alone(eq: &Equation, coeffs: &mut Coeffs) -> Expr {
    let mut s = Sum::default();
    push_equation(eq, coeffs, &mut s, 1.0);
    s.expr()
}

/// `let x0x1 = x0 * x1;` for every product the equations use.
pub fn product_lets(eqs: &[&Equation]) -> Vec<Let> {
    let mut seen = std::collections::BTreeSet::new();
    for eq in eqs {
        for m in eq.keys() {
            if let Mono::XX(i, j) = *m {
                seen.insert((i, j));
            }
        }
    }
    seen.into_iter()
        .map(|(i, j)| {
            Let::real(
                format!("x{i}x{j}"),
                Expr::Product(vec![Expr::var(format!("x{i}")), Expr::var(format!("x{j}"))]),
            )
        })
        .collect()
}
