//! Terms of degree 3 or more in the states whose extra factors are measured:
//! a state that an output measures directly (y_k = a·x_i, a constant a ≠ 0)
//! is replaced in such a term by the parameter computed from that output
//! (x_i = p/a with p = y_k), every such factor while a state remains
//! (x1²·x2 → p²·x2 with y = x1; a power of p is a derived variable).
//! The rewrite is exact (p equals the output at every instant), recorded,
//! and reported with the model ([`Rewrite`]).

use crate::diagnostic::{Diag, Span};
use crate::expr::bits;
use crate::poly::{Names, Var};
use std::cmp::Reverse;

/// A state measured directly: output `output` is `scale`·x_`state`.
#[derive(Clone, Debug)]
pub(crate) struct MeasuredState {
    pub state: usize,
    pub output: usize,
    pub scale: f64,
    /// The bit of the parameter computed from the output, if the model has
    /// one (a declared `param p = y`, or one added for a rewrite).
    pub param: Option<usize>,
}

/// One term rewritten onto a measured parameter.
#[derive(Clone, Debug)]
pub(crate) struct Rewrite {
    /// The parameter's bit.
    pub param: usize,
    /// The expression the term came from.
    pub span: Span,
    /// The term as written (`x1^2*x2`) and as scheduled (`y1*x1*x2`).
    pub from: String,
    pub to: String,
    /// The degree of the term as written.
    pub degree: usize,
}

/// A term of degree 3 or more wanted a measured factor that has no
/// parameter yet: the output, where, and the term's text.
#[derive(Clone, Debug)]
pub(crate) struct Wanted {
    pub output: usize,
    pub span: Span,
    pub term: String,
    /// The term's degree in the states, the measured state, and the term
    /// as it would be scheduled on a parameter `p`.
    pub degree: usize,
    pub state: usize,
    pub scheduled: String,
}

/// The term `theta · vars` with measured factors moved into the
/// parameters until at most two states remain (or no measured factor is
/// left): the new mask, variables and the factor 1/a the coefficient takes
/// for each factor moved. A measured factor without a parameter is
/// recorded in [`Names::wanted`] and the term is left as it is.
pub(crate) fn schedule(
    names: &Names,
    mut theta: u64,
    mut vars: Vec<Var>,
    span: Span,
    src: &str,
) -> Result<(u64, Vec<Var>, f64), Diag> {
    if vars.len() <= 2 || names.measured_states.is_empty() {
        return Ok((theta, vars, 1.0));
    }
    let (theta0, vars0) = (theta, vars.clone());
    let mut factor = 1.0;
    // Every measured factor goes while a state remains (x1²·x2 → p²·x2,
    // x1³ → p²·x1): a factor left in the states would be bounded
    // independently of p in the error dynamics, p·x1 ranging over ±|p||x1|
    // where p·x1 = x1² ≥ 0.
    while vars.len() > 1 {
        // the measured factor written most often, else the first state
        let pick = names
            .measured_states
            .iter()
            .filter(|m| vars.contains(&Var::State(m.state)))
            .max_by_key(|m| {
                (
                    vars.iter().filter(|v| **v == Var::State(m.state)).count(),
                    Reverse(m.state),
                )
            });
        let Some(m) = pick else { break };
        let Some(bit) = m.param else {
            if vars.len() <= 2 {
                break;
            }
            let mut wanted = names.wanted.borrow_mut();
            if !wanted.iter().any(|w| w.output == m.output) {
                let x = Var::State(m.state);
                let c = vars.iter().filter(|v| **v == x).count();
                let k = if c == vars.len() { c - 1 } else { c };
                let mut rest = vars.clone();
                for _ in 0..k {
                    if let Some(i) = rest.iter().rposition(|v| *v == x) {
                        rest.remove(i);
                    }
                }
                let p = if k == 1 {
                    "p".to_string()
                } else {
                    format!("p^{k}")
                };
                wanted.push(Wanted {
                    output: m.output,
                    span,
                    term: names.term_text(&counts(theta0), &vars0),
                    degree: vars0.len(),
                    state: m.state,
                    scheduled: format!("{p}*{}", names.term_text(&counts(theta), &rest)),
                });
            }
            break;
        };
        // the last occurrence goes: the first factors keep their order
        if let Some(i) = vars.iter().rposition(|v| *v == Var::State(m.state)) {
            vars.remove(i);
        }
        theta = names.combine(theta, 1 << bit, span, src)?;
        factor /= m.scale;
    }
    if vars.len() < vars0.len() {
        let mut rewrites = names.rewrites.borrow_mut();
        let param = names
            .measured_states
            .iter()
            .filter(|m| vars0.contains(&Var::State(m.state)))
            .find_map(|m| m.param)
            .unwrap_or(0);
        if !rewrites.iter().any(|r| r.span == span) {
            rewrites.push(Rewrite {
                param,
                span,
                from: names.term_text(&counts(theta0), &vars0),
                to: names.term_text(&counts(theta), &vars),
                degree: vars0.len(),
            });
        }
    }
    Ok((theta, vars, factor))
}

fn counts(theta: u64) -> Vec<(usize, u32)> {
    bits(theta).map(|i| (i, 1)).collect()
}
