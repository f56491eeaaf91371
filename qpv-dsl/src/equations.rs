//! Equation form → matrices: `der x_k = ...;` gives row k of A, N_k and row k
//! of B; `out y_k = ...;` gives row k of C and M_k.
//!
//! Split convention ([`Split::AsWritten`], the only one for now): a term
//! c·x_i·x_j goes to N_k[i][j] with x_i the first state factor as written
//! and x_j the second (x_i² → N_k[i][i]). Only the symmetric part of N_k
//! affects the dynamics, but the matrix enters the LMIs, so the choice is
//! kept explicit; with the same factor order the equation form reproduces
//! the matrix form exactly.

use crate::diagnostic::{Diag, Span};
use crate::expr::PolyMatrix;
use crate::poly::{quote, Mono, Names, Poly, Var};

/// How a quadratic term x_i·x_j is placed in N_k (M_k).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum Split {
    /// N_k[i][j] += c for the factors in written order (first → row).
    #[default]
    AsWritten,
}

/// A, N_k, B extracted from the `der` equations.
pub(crate) struct Dynamics {
    pub a: PolyMatrix,
    pub n: Vec<PolyMatrix>,
    pub b: PolyMatrix,
    /// B_w(θ), nx × n_w: the process disturbances' terms.
    pub b_w: PolyMatrix,
}

/// C(θ), M_k(θ) extracted from the `out` equations.
pub(crate) struct Outputs {
    pub c: PolyMatrix,
    pub m: Vec<PolyMatrix>,
}

fn place(split: Split, i: usize, j: usize) -> (usize, usize) {
    match split {
        Split::AsWritten => (i, j),
    }
}

fn constant_term(src: &str, names: &Names, eq: &str, mono: &Mono, span: Span) -> Diag {
    let what = if mono.theta == 0 {
        "a constant term".to_string()
    } else {
        format!("the term {} without a state", names.mono_text(mono))
    };
    let remedy = if eq.starts_with("out ") {
        "Shift the state to an equilibrium, or subtract the known offset from the \
         measurement before giving it to the observer"
    } else {
        "Shift the state to an equilibrium, or give the offset as a known input (for \
         example `input one;` and `... + 5*one`)"
    };
    Diag::new(
        span,
        format!(
            "`{eq}` has {what} ({}): the system class x' = A(θ)x + N(θ,x)x + B(θ)u, \
             y = C(θ)x + M(θ,x)x has no offsets. {remedy}",
            quote(src, span)
        ),
    )
}

/// Builds A, N_k, B from one polynomial per state (in state order).
pub(crate) fn dynamics(
    src: &str,
    names: &Names,
    eqs: &[Poly],
    split: Split,
) -> Result<Dynamics, Diag> {
    let nx = names.states.len();
    let nu = names.inputs.len();
    let mut a = PolyMatrix::zeros(nx, nx);
    let mut n = vec![PolyMatrix::zeros(nx, nx); nx];
    let mut b = PolyMatrix::zeros(nx, nu);
    let mut b_w = PolyMatrix::zeros(nx, names.disturbances.len());
    for (k, eq) in eqs.iter().enumerate() {
        let label = format!("der {}", names.states[k]);
        for (mono, term) in &eq.terms {
            match mono.vars.as_slice() {
                [Var::State(i)] => a.get_mut(k, *i).add_term(mono.theta, term.coef),
                [Var::Input(j)] => b.get_mut(k, *j).add_term(mono.theta, term.coef),
                [Var::Disturbance(j)] => b_w.get_mut(k, *j).add_term(mono.theta, term.coef),
                [Var::State(i), Var::State(j)] => {
                    let (r, c) = place(split, *i, *j);
                    n[k].get_mut(r, c).add_term(mono.theta, term.coef)
                }
                [] => return Err(constant_term(src, names, &label, mono, term.span)),
                _ => {
                    return Err(Diag::new(
                        term.span,
                        format!(
                            "internal error: unexpected term {} in `{label}`",
                            names.mono_text(mono)
                        ),
                    ))
                }
            }
        }
    }
    Ok(Dynamics { a, n, b, b_w })
}

/// Builds C, M_k from one polynomial per output (in output order).
pub(crate) fn outputs(
    src: &str,
    names: &Names,
    eqs: &[Poly],
    split: Split,
) -> Result<Outputs, Diag> {
    let nx = names.states.len();
    let ny = names.outputs.len();
    let mut c = PolyMatrix::zeros(ny, nx);
    let mut m = vec![PolyMatrix::zeros(nx, nx); ny];
    for (k, eq) in eqs.iter().enumerate() {
        let label = format!("out {}", names.outputs[k]);
        for (mono, term) in &eq.terms {
            match mono.vars.as_slice() {
                [Var::State(i)] => {
                    c.get_mut(k, *i).add_term(mono.theta, term.coef);
                }
                [Var::State(i), Var::State(j)] => {
                    let (r, col) = place(split, *i, *j);
                    m[k].get_mut(r, col).add_term(mono.theta, term.coef);
                }
                [Var::Input(u)] => {
                    return Err(Diag::new(
                        term.span,
                        format!(
                        "`{label}` depends on the input `{}`: direct feedthrough (y = ... + D u) \
                             is not supported; subtract D u from the measurement and give the \
                             observer y − D u instead",
                        names.inputs[*u]
                    ),
                    ))
                }
                [Var::Disturbance(w)] => {
                    return Err(Diag::new(
                        term.span,
                        format!(
                            "`{label}` depends on the disturbance `{}`: disturbances enter the \
                             state equations only (`der`); noise on a measurement is declared \
                             with `noise {};`",
                            names.disturbances[*w], names.outputs[k]
                        ),
                    ))
                }
                [] => return Err(constant_term(src, names, &label, mono, term.span)),
                _ => {
                    return Err(Diag::new(
                        term.span,
                        format!(
                            "internal error: unexpected term {} in `{label}`",
                            names.mono_text(mono)
                        ),
                    ))
                }
            }
        }
    }
    Ok(Outputs { c, m })
}
