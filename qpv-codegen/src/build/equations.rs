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
    let states = (0..nx)
        .map(|k| {
            let b = (m.nu() > 0).then_some(&m.b);
            equation(&m.a, m.n.get(k), b, k)
        })
        .collect();
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
