//! The `der` equations split into their polynomial part (affine plus
//! quadratic in the states: A, N_k, B, B_w exactly as before) and their
//! nonlinear terms of the states (a state inside a function or a
//! denominator, or a term of degree three or more), kept as expressions
//! ([`crate::jacobian`]).
//!
//! The split is by summand, written order and signs kept: a summand of the
//! right-hand side (after flattening sums and minus signs) whose state
//! degree is at most two is evaluated as before; any other is one
//! nonlinear term. An equation without such a summand is evaluated exactly
//! as before, so every QPV model compiles to the same matrices.

use super::build::{Builder, R};
use crate::ast::{Expr, ExprKind};
use crate::diagnostic::Diag;
use crate::jacobian::{global_entries, Jacobian, NonlinearTerm};
use crate::poly::{eval, quote, NameRef, Poly, Scope};
use crate::sched::SchedExpr;

/// The state degree of `e` if it is a polynomial in the states (inputs and
/// disturbances count as degree one), `None` if a state sits inside a
/// function or a denominator.
fn degree(e: &Expr, scope: &Scope<'_>) -> Option<u32> {
    Some(match &e.kind {
        ExprKind::Number(_) => 0,
        ExprKind::Name(n) => match scope.names.lookup.get(n) {
            Some(NameRef::State(_) | NameRef::Input(_) | NameRef::Disturbance(_)) => 1,
            _ => 0,
        },
        ExprKind::Neg(x) => degree(x, scope)?,
        ExprKind::Sum(t) => t
            .iter()
            .try_fold(0, |m, (_, x)| Some(m.max(degree(x, scope)?)))?,
        ExprKind::Product(f) => f.iter().try_fold(0u32, |m, (div, x)| {
            let d = degree(x, scope)?;
            if *div && d > 0 {
                None
            } else {
                Some(m.saturating_add(d))
            }
        })?,
        ExprKind::Pow(x, n) => degree(x, scope)?.saturating_mul(*n),
        ExprKind::Call(_, _, x) => match degree(x, scope)? {
            0 => 0,
            _ => return None,
        },
    })
}

/// The summands of `e` with their signs (`true`: subtracted), through
/// nested sums and minus signs.
fn summands<'e>(e: &'e Expr, neg: bool, out: &mut Vec<(bool, &'e Expr)>) {
    match &e.kind {
        ExprKind::Sum(t) => {
            for (n, x) in t {
                summands(x, neg != *n, out);
            }
        }
        ExprKind::Neg(x) => summands(x, !neg, out),
        _ => out.push((neg, e)),
    }
}

/// Splits the right-hand side of `der x_row` into its polynomial part and
/// its nonlinear terms (see the module documentation).
pub(super) fn split(
    row: usize,
    rhs: &Expr,
    scope: &Scope<'_>,
) -> Result<(Poly, Vec<NonlinearTerm>), Diag> {
    let mut all = Vec::new();
    summands(rhs, false, &mut all);
    // A polynomial term of degree 3 or more with a measured factor is
    // scheduled on the measurement (exact; crate::measured), not bounded,
    // when what is left after its measured factors is at most quadratic.
    let nonlinear = |x: &Expr| match degree(x, scope) {
        None => true,
        Some(d) => d > 2 && !(has_measured_state(x, scope) && unmeasured_degree(x, scope) <= 2),
    };
    if !all.iter().any(|(_, x)| nonlinear(x)) {
        return Ok((eval(rhs, scope)?, Vec::new()));
    }
    let mut poly: Vec<(bool, Expr)> = Vec::new();
    let mut terms = Vec::new();
    for (neg, x) in all {
        if !nonlinear(x) {
            poly.push((neg, x.clone()));
            continue;
        }
        let e = to_expr(x, scope)?;
        let e = if neg { SchedExpr::Neg(Box::new(e)) } else { e };
        let text = format!("{}{}", if neg { "-" } else { "" }, x.span.text(scope.src));
        terms.push(NonlinearTerm {
            row,
            expr: e,
            text: text.split_whitespace().collect::<Vec<_>>().join(" "),
            span: x.span,
        });
    }
    let p = if poly.is_empty() {
        Poly::default()
    } else {
        eval(
            &Expr {
                kind: ExprKind::Sum(poly),
                span: rhs.span,
            },
            scope,
        )?
    };
    Ok((p, terms))
}

/// The degree of `e` in the states no output measures directly (an upper
/// bound for a sum: its largest term's), for a polynomial `e`.
fn unmeasured_degree(e: &Expr, scope: &Scope<'_>) -> u32 {
    match &e.kind {
        ExprKind::Number(_) | ExprKind::Call(..) => 0,
        ExprKind::Name(_) if has_measured_state(e, scope) => 0,
        ExprKind::Name(_) => degree(e, scope).unwrap_or(0),
        ExprKind::Neg(x) => unmeasured_degree(x, scope),
        ExprKind::Pow(x, n) => unmeasured_degree(x, scope).saturating_mul(*n),
        ExprKind::Sum(t) => t
            .iter()
            .map(|(_, x)| unmeasured_degree(x, scope))
            .max()
            .unwrap_or(0),
        ExprKind::Product(f) => f.iter().map(|(_, x)| unmeasured_degree(x, scope)).sum(),
    }
}

/// Whether a state that an output measures directly appears in `e`.
fn has_measured_state(e: &Expr, scope: &Scope<'_>) -> bool {
    match &e.kind {
        ExprKind::Number(_) => false,
        ExprKind::Name(n) => match scope.names.lookup.get(n) {
            Some(NameRef::State(i)) => scope.names.measured_states.iter().any(|m| m.state == *i),
            _ => false,
        },
        ExprKind::Neg(x) | ExprKind::Pow(x, _) | ExprKind::Call(_, _, x) => {
            has_measured_state(x, scope)
        }
        ExprKind::Sum(t) | ExprKind::Product(t) => {
            t.iter().any(|(_, x)| has_measured_state(x, scope))
        }
    }
}

/// A nonlinear term as an expression over (x, θ): a state is variable i,
/// a `const` is its number. Inputs, disturbances and outputs are refused
/// (they enter linearly), and so are parameters and `let` functions (the
/// generated observer evaluates the terms from its state alone).
fn to_expr(e: &Expr, scope: &Scope<'_>) -> Result<SchedExpr, Diag> {
    let names = scope.names;
    let list = |items: &[(bool, Expr)]| -> Result<Vec<(bool, SchedExpr)>, Diag> {
        items
            .iter()
            .map(|(flag, x)| Ok((*flag, to_expr(x, scope)?)))
            .collect()
    };
    Ok(match &e.kind {
        ExprKind::Number(v) => SchedExpr::Num(*v),
        ExprKind::Name(n) => match names.lookup.get(n).copied() {
            Some(NameRef::State(i)) => SchedExpr::Param(i),
            Some(NameRef::Const(k)) => SchedExpr::Num(names.consts[k].1.unwrap_or(f64::NAN)),
            Some(NameRef::Param(_) | NameRef::Let(_)) => {
                return Err(refused(
                    e,
                    scope,
                    "is a scheduling parameter inside a nonlinear term of the states: such terms \
                     may hold states, `const` names and numbers only (the generated observer \
                     evaluates them from its state alone)",
                ))
            }
            Some(NameRef::Input(_)) => return Err(refused(
                e,
                scope,
                "is an input inside a nonlinear term of the states: inputs enter linearly only \
                     (B(θ)u); nonlinear terms may hold states, `const` names and numbers",
            )),
            Some(NameRef::Disturbance(_)) => {
                return Err(refused(
                    e,
                    scope,
                    "is a disturbance inside a nonlinear term of the states: disturbances enter \
                     linearly only (B_w(θ)w)",
                ))
            }
            Some(NameRef::Output(_)) => {
                return Err(refused(
                    e,
                    scope,
                    "is an output: outputs cannot appear in expressions",
                ))
            }
            None => return Err(refused(e, scope, "is not a declared name")),
        },
        ExprKind::Neg(x) => SchedExpr::Neg(Box::new(to_expr(x, scope)?)),
        ExprKind::Sum(t) => SchedExpr::Sum(list(t)?),
        ExprKind::Product(f) => SchedExpr::Product(list(f)?),
        ExprKind::Pow(x, n) => SchedExpr::Pow(Box::new(to_expr(x, scope)?), *n),
        ExprKind::Call(f, _, x) => SchedExpr::Call(*f, Box::new(to_expr(x, scope)?)),
    })
}

/// The error for a name a nonlinear term cannot hold, at the name.
fn refused(e: &Expr, scope: &Scope<'_>, why: &str) -> Diag {
    Diag::new(e.span, format!("{} {why}", quote(scope.src, e.span)))
}

impl Builder<'_> {
    /// Whether the nonlinear terms read so far leave the plant LPV in the
    /// sense of the global observer: none, or every Jacobian entry bounded
    /// globally (then no region is needed).
    pub(super) fn nonlinear_is_lpv(&self, params: &[super::Param]) -> R<bool> {
        if self.nonlinear.is_empty() {
            return Ok(true);
        }
        let j = Jacobian {
            terms: self.nonlinear.clone(),
            global: None,
            on_set: false,
            bound: None,
        };
        let names: Vec<String> = params.iter().map(|p| p.name.clone()).collect();
        let theta: Vec<(f64, f64)> = params.iter().map(|p| (p.lo, p.hi)).collect();
        let rows = j.rows(self.names.states.len());
        Ok(global_entries(&rows, &self.names.states, &names, &theta).is_some())
    }
}
