//! Parameters computed from a measured output: `param p = y1 in [lo, hi];`
//! (the interval optional), and the parameters added when a term of degree
//! 3 or more is scheduled on a measured factor (`crate::measured`).
//!
//! Such a parameter is a bounded measured parameter like any other for the
//! design; what is particular is where its value comes from (the generated
//! observer computes it from y) and its interval, which must cover the
//! output over the state bound F: for y = cᵀx, F = {xᵀQ⁻¹x ≤ 1} gives
//! y ∈ [−√(cᵀQc), √(cᵀQc)]. A declared interval is checked against it here
//! when Q is given (and by the certificate against the design's F); an
//! omitted one is derived from it (Q given).

use super::build::{pos, Builder, R};
use super::names::Param;
use crate::ast::{self, BoundDecl, Item, MatrixValue};
use crate::diagnostic::{fmt_num, suggest, Diag, Span, Warning};
use crate::expr::bits;
use crate::measured::{Measured, MeasuredOrigin, MeasuredState, Rewrite, Wanted};
use crate::poly::{eval, Allowed, NameRef, Names, Scope, Var};
use std::cmp::Reverse;

/// Whether `e` is built from numbers, states and `const` names alone (no
/// function, parameter or division by anything but a number): evaluating
/// it then creates no derived variable, which this early read must not.
fn plain(e: &ast::Expr, names: &Names) -> bool {
    use crate::ast::ExprKind;
    match &e.kind {
        ExprKind::Number(_) => true,
        ExprKind::Name(n) => matches!(
            names.lookup.get(n),
            Some(NameRef::State(_) | NameRef::Const(_))
        ),
        ExprKind::Neg(x) | ExprKind::Pow(x, _) => plain(x, names),
        ExprKind::Sum(t) => t.iter().all(|(_, x)| plain(x, names)),
        ExprKind::Product(f) => f
            .iter()
            .all(|(div, x)| plain(x, names) && (!div || matches!(x.kind, ExprKind::Number(_)))),
        ExprKind::Call(..) => false,
    }
}

/// How far the derived interval is widened past √(cᵀQc) at least
/// (relative), before rounding up to six significant digits: the
/// certificate recomputes the range and must find it covered.
const WIDEN: f64 = 1e-12;

impl Builder<'_> {
    /// Every output as a row of constants c (y = cᵀx), `None` for an output
    /// that depends on θ, is not linear, or is not known before the
    /// dynamics (evaluated on a copy of the names: no side effect).
    pub(super) fn linear_outputs(&self) -> Vec<Option<Vec<f64>>> {
        let (nx, ny) = (self.names.states.len(), self.names.outputs.len());
        let mut rows: Vec<Option<Vec<f64>>> = vec![None; ny];
        let names: Names = self.names.clone();
        let scope = Scope {
            src: self.src,
            names: &names,
            allowed: Allowed::Equation,
            context: "an equation",
        };
        let mut m_given = false;
        for item in &self.ast.items {
            match item {
                Item::Out(eq) => {
                    let Some(NameRef::Output(k)) = self.names.lookup.get(&eq.target.name) else {
                        continue;
                    };
                    if !plain(&eq.rhs, &self.names) {
                        continue;
                    }
                    let Ok(p) = eval(&eq.rhs, &scope) else {
                        continue;
                    };
                    let mut row = vec![0.0; nx];
                    let linear = p.terms.iter().all(|(m, t)| match m.vars.as_slice() {
                        [Var::State(i)] if m.theta == 0 => {
                            row[*i] += t.coef;
                            true
                        }
                        _ => false,
                    });
                    rows[*k] = linear.then_some(row);
                }
                Item::Matrix(def) if def.name.name.starts_with('M') => {
                    let zero = match &def.value {
                        MatrixValue::Scalar(e) => self.constant(e, "M").ok() == Some(0.0),
                        MatrixValue::Literal(l) => l.rows.iter().all(|r| {
                            r.entries
                                .iter()
                                .all(|e| self.constant(e, "M").ok() == Some(0.0))
                        }),
                    };
                    m_given |= !zero;
                }
                Item::Matrix(def) if def.name.name == "C" => {
                    let MatrixValue::Literal(l) = &def.value else {
                        continue;
                    };
                    for (k, r) in l.rows.iter().enumerate().take(ny) {
                        let row: Option<Vec<f64>> = r
                            .entries
                            .iter()
                            .map(|e| self.constant(e, "C").ok())
                            .collect();
                        rows[k] = row.filter(|r| r.len() == nx);
                    }
                }
                _ => {}
            }
        }
        if m_given {
            // quadratic outputs: their range over F is not a linear form's
            return vec![None; ny];
        }
        rows
    }

    /// The given state bound's Q (`state_bound Q = [...]`), read early (a
    /// malformed one is reported by the state-bound step), or why there is
    /// none (`auto`, or no state bound).
    fn given_q(&self) -> Result<Vec<f64>, &'static str> {
        let nx = self.names.states.len();
        for item in &self.ast.items {
            let Item::StateBound(bound, _) = item else {
                continue;
            };
            let BoundDecl::Given(lit) = bound else {
                return Err("the state bound is `auto` (computed by the design)");
            };
            let q: Option<Vec<f64>> = lit
                .rows
                .iter()
                .flat_map(|r| r.entries.iter())
                .map(|e| self.constant(e, "Q").ok())
                .collect();
            return q
                .filter(|q| q.len() == nx * nx)
                .ok_or("the state bound Q is not a constant nx × nx matrix");
        }
        Err("the model has no state bound")
    }

    /// `param NAME = OUTPUT [in [lo, hi]] [rate r];`.
    pub(super) fn measured_param(&mut self, p: &ast::ParamDecl, output: &ast::Ident) -> R<Param> {
        if p.names.len() > 1 {
            return Err(Diag::new(
                p.names[1].span,
                format!(
                    "`param {} = {}`: a parameter computed from an output is declared alone \
                     (one name per `param ... = OUTPUT;`)",
                    p.names[0].name, output.name
                ),
            ));
        }
        let id = &p.names[0];
        let k = self.output_index(id, output)?;
        let Some(row) = self.rows[k].clone() else {
            return Err(Diag::new(
                output.span,
                format!(
                    "`param {} = {}`: the output `{}` must be linear in the states with constant \
                     coefficients (y = c1*x1 + ...), so that its range over the state bound is \
                     known; scheduling on an output that depends on θ or is quadratic is not \
                     supported",
                    id.name, output.name, output.name
                ),
            ));
        };
        let q = self.given_q();
        let reach = q.as_ref().ok().map(|q| self.reach_of(&row, q));
        let (lo, hi, origin) = match &p.range {
            Some((lo, hi, interval)) => {
                let (lo, hi) = self.param_bounds(lo, hi, *interval)?;
                if let Some(r) = reach {
                    if lo > -r || hi < r {
                        return Err(Diag::new(
                            *interval,
                            format!(
                                "the interval [{}, {}] of `{}` does not cover the output `{}` over \
                                 the state bound F: {} ranges over [{}, {}] there (write `param {} \
                                 = {};` to derive the interval)",
                                fmt_num(lo),
                                fmt_num(hi),
                                id.name,
                                output.name,
                                output.name,
                                fmt_num(-r),
                                fmt_num(r),
                                id.name,
                                output.name
                            ),
                        ));
                    }
                }
                if matches!(q, Err("the model has no state bound")) {
                    return Err(self.no_bound(id, &output.name, output.span));
                }
                (lo, hi, MeasuredOrigin::Declared)
            }
            None => {
                let r = match (reach, &q) {
                    (Some(r), _) => r,
                    (None, Err(why)) => {
                        return Err(Diag::new(
                            output.span,
                            format!(
                                "`param {} = {}` has no interval, and it can only be derived from \
                                 a given state bound (`state_bound Q = [...]`), but {why}: declare \
                                 it, `param {} = {} in [lo, hi];` (the certificate checks that it \
                                 covers {} over F)",
                                id.name, output.name, id.name, output.name, output.name
                            ),
                        ))
                    }
                    (None, Ok(_)) => f64::NAN,
                };
                let (lo, hi) = self.derived_interval(r, id.span, &output.name)?;
                (lo, hi, MeasuredOrigin::Derived)
            }
        };
        Ok(Param {
            name: id.name.clone(),
            lo,
            hi,
            span: id.span,
            rate: self.rate(&p.rate, "parameter")?,
            measured: Some(Measured {
                output: k,
                output_name: output.name.clone(),
                row,
                origin,
                rewrites: Vec::new(),
                bound: q.ok(),
            }),
        })
    }

    fn no_bound(&self, id: &ast::Ident, output: &str, at: Span) -> Diag {
        Diag::new(
            at,
            format!(
                "`param {} = {output}`: nothing bounds the output `{output}` (the model has no \
                 state bound): a parameter computed from an output needs a state bound F \
                 (`state_bound Q = [...];` or `state_bound auto;`) over which its interval is \
                 checked",
                id.name
            ),
        )
    }

    /// The index of the output `output` names, for the parameter `id`.
    fn output_index(&self, id: &ast::Ident, output: &ast::Ident) -> R<usize> {
        match self.names.lookup.get(&output.name) {
            Some(NameRef::Output(k)) => Ok(*k),
            Some(r) => Err(Diag::new(
                output.span,
                format!(
                    "`param {} = {}`: `{}` is {}, not an output: a parameter is computed from a \
                     measured output (declare `output y; out y = {};` and write `param {} = y`)",
                    id.name,
                    output.name,
                    output.name,
                    super::build::kind_word(*r),
                    output.name,
                    id.name
                ),
            )),
            None => {
                let hint = suggest(&output.name, self.names.outputs.iter().map(|s| s.as_str()))
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                Err(Diag::new(
                    output.span,
                    format!(
                        "`param {} = {}`: `{}` is not a declared output{hint}",
                        id.name, output.name, output.name
                    ),
                ))
            }
        }
    }

    /// √(cᵀQc) for Q row-major.
    fn reach_of(&self, row: &[f64], q: &[f64]) -> f64 {
        Measured {
            output: 0,
            output_name: String::new(),
            row: row.to_vec(),
            origin: MeasuredOrigin::Derived,
            rewrites: Vec::new(),
            bound: None,
        }
        .reach(q)
    }

    /// [−r, r] widened outward, or an error for r = 0 or not finite.
    fn derived_interval(&self, r: f64, at: Span, output: &str) -> R<(f64, f64)> {
        if !(r.is_finite() && r > 0.0) {
            return Err(Diag::new(
                at,
                format!(
                    "the range of the output `{output}` over the state bound F is {}: no interval \
                     can be derived from it (is Q positive definite?)",
                    fmt_num(r)
                ),
            ));
        }
        // six significant digits, rounded up past r (1 + WIDEN)
        let step = 10f64.powi(r.log10().floor() as i32 - 5);
        let mut v = (r * (1.0 + WIDEN) / step).ceil() * step;
        if v < r * (1.0 + WIDEN) {
            v += step;
        }
        Ok((-v, v))
    }

    /// The parameters a rewrite needs (the second build of a model whose
    /// first one found degree-3 terms with measured factors), appended to
    /// `out`; then the states measured directly, with their parameters.
    pub(super) fn auto_params(&mut self, out: &mut Vec<Param>) -> R<()> {
        for w in self.auto.clone() {
            let name = &self.names.outputs[w.output];
            let row = self.rows[w.output].clone().unwrap_or_default();
            let q = self.given_q();
            let r = match &q {
                Ok(q) => self.reach_of(&row, q),
                Err(why) => {
                    return Err(Diag::new(
                        w.span,
                        format!(
                            "{} contains the term {} of degree {} in the states: the system class \
                             allows at most quadratic terms (x' = A(θ)x + N(θ,x)x + B(θ)u). Its \
                             factor `{}` is measured (the output `{name}`), so the term can be \
                             scheduled on `{name}` exactly, but the interval of that parameter is \
                             derived from a given state bound and {why}: declare `param p = {name} \
                             in [lo, hi];` with [lo, hi] covering `{name}` over F (the certificate \
                             checks it); the term is then written as `{}` automatically",
                            crate::poly::quote(self.src, w.span),
                            w.term,
                            w.degree,
                            self.names.states[w.state],
                            w.scheduled
                        ),
                    ));
                }
            };
            let (lo, hi) = self.derived_interval(r, w.span, name)?;
            self.names.params.push(name.clone());
            self.param_reach.push(r);
            out.push(Param {
                name: name.clone(),
                lo,
                hi,
                span: w.span,
                rate: None,
                measured: Some(Measured {
                    output: w.output,
                    output_name: name.clone(),
                    row,
                    origin: MeasuredOrigin::Automatic,
                    rewrites: Vec::new(),
                    bound: q.ok(),
                }),
            });
        }
        self.names.scheduler = Some(schedule);
        self.names.measured_states = self
            .rows
            .iter()
            .enumerate()
            .filter_map(|(k, row)| {
                let row = row.as_ref()?;
                let mut nz = row.iter().enumerate().filter(|(_, c)| **c != 0.0);
                let (i, a) = nz.next()?;
                if nz.next().is_some() {
                    return None;
                }
                let param = out
                    .iter()
                    .position(|p| p.measured.as_ref().is_some_and(|m| m.output == k));
                Some(MeasuredState {
                    state: i,
                    output: k,
                    scale: *a,
                    param,
                })
            })
            .collect();
        Ok(())
    }

    /// A plant that turned out LPV (every quadratic term scheduled) has a
    /// global observer, which computes no state bound: its measured
    /// parameters need a given one.
    pub(super) fn measured_bound(
        &mut self,
        params: &[Param],
        bound: &super::StateBound,
        lpv: bool,
    ) -> R<()> {
        let Some(p) = params.iter().find(|p| p.measured.is_some()) else {
            return Ok(());
        };
        if lpv && matches!(bound, super::StateBound::Auto { .. }) {
            return Err(Diag::new(
                p.span,
                format!(
                    "the plant is LPV (every N_k and M_k is zero) and its observer global, which computes no state bound, but the parameter `{}` is computed from the output `{}`, whose range a state bound must give: write `state_bound Q = [...];`",
                    p.name,
                    p.measured.as_ref().map_or("", |m| m.output_name.as_str())
                ),
            ));
        }
        Ok(())
    }

    /// The rewrites done while reading the dynamics, recorded on their
    /// parameters and reported as warnings at the terms (nothing the user
    /// wrote changes silently).
    pub(super) fn report_rewrites(&mut self, params: &mut [Param]) {
        let rewrites = self.names.rewrites.borrow().clone();
        for r in rewrites {
            let Some(p) = params.get_mut(r.param) else {
                continue;
            };
            let at = pos(self.src, r.span);
            let Some(m) = p.measured.as_mut() else {
                continue;
            };
            m.rewrites
                .push(format!("`{}` at {at} as `{}`", r.from, r.to));
            self.warnings.push(Warning {
                message: format!(
                    "the term {} of degree {} is scheduled on the measured output {}: written as \
                     {}, with the parameter `{}` computed from the measurement, interval [{}, {}] \
                     (exact: the parameter equals the output at every instant)",
                    r.from,
                    r.degree,
                    m.output_name,
                    r.to,
                    p.name,
                    fmt_num(p.lo),
                    fmt_num(p.hi)
                ),
                span: r.span,
            });
        }
    }
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
