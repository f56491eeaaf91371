//! Declarations: the states, inputs, outputs and parameters of a model, in
//! one namespace, with their limits.

use super::build::{kind_word, pos, Builder, R};
use super::validate::MAX_COEFFICIENT;
use crate::ast::{self, Item};
use crate::diagnostic::fmt_num;
use crate::diagnostic::{Diag, Span};
use crate::poly::{eval, sched_expr, Allowed, LetValue, NameRef};
use serde::Serialize;

/// A bounded scheduling parameter `param NAME in [lo, hi];`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Param {
    /// The parameter's name as declared.
    pub name: String,
    /// Lower bound of θ_i.
    pub lo: f64,
    /// Upper bound of θ_i (strictly greater than `lo`).
    pub hi: f64,
    /// Where it was declared.
    pub span: Span,
    /// `rate r`: the declared bound |θ_i'| ≤ r (None: no rate declared;
    /// a sampled design then assumes θ constant over each step).
    pub rate: Option<f64>,
    /// `param p = y1 ...`: the output the parameter is computed from (the
    /// generated observer reads it from y); `None` for a parameter fed by
    /// the caller.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured: Option<crate::measured::Measured>,
}

/// Most states, inputs or outputs of a model.
pub const MAX_DIM: usize = 64;
/// Most declared parameters of a model (θ masks are 64-bit).
pub const MAX_PARAMS: usize = 63;

impl Builder<'_> {
    pub(super) fn declare(&mut self) -> R<()> {
        for item in &self.ast.items {
            let (list, kind): (&[ast::Ident], u8) = match item {
                Item::States(l) => (l, 0),
                Item::Inputs(l, _, _) => (l, 1),
                Item::Outputs(l) => (l, 2),
                Item::Params(p) => (&p.names, 3),
                Item::Disturbances(l) => (l, 4),
                Item::Let(id, _, _) => (std::slice::from_ref(id), 5),
                Item::Const(id, _, _) => (std::slice::from_ref(id), 6),
                _ => continue,
            };
            for id in list {
                if let Some(prev) = self.names.lookup.get(&id.name) {
                    let at = self.decl_spans[&id.name];
                    return Err(Diag::new(
                        id.span,
                        format!(
                            "`{}` is already declared as {} at {}: every name in a model must be unique",
                            id.name,
                            kind_word(*prev),
                            pos(self.src, at)
                        ),
                    ));
                }
                if kind >= 5 {
                    let (r, what) = if kind == 5 {
                        self.names.lets.push((id.name.clone(), None));
                        (NameRef::Let(self.names.lets.len() - 1), "`let` definitions")
                    } else {
                        self.names.consts.push((id.name.clone(), None));
                        (
                            NameRef::Const(self.names.consts.len() - 1),
                            "`const` definitions",
                        )
                    };
                    if self.names.lets.len() > MAX_DIM || self.names.consts.len() > MAX_DIM {
                        return Err(Diag::new(
                            id.span,
                            format!("too many {what}: at most {MAX_DIM} are supported"),
                        ));
                    }
                    self.names.lookup.insert(id.name.clone(), r);
                    self.decl_spans.insert(id.name.clone(), id.span);
                    continue;
                }
                let (vec, limit, what) = match kind {
                    0 => (&mut self.names.states, MAX_DIM, "states"),
                    1 => (&mut self.names.inputs, MAX_DIM, "inputs"),
                    2 => (&mut self.names.outputs, MAX_DIM, "outputs"),
                    4 => (&mut self.names.disturbances, MAX_DIM, "disturbances"),
                    _ => (&mut self.names.params, MAX_PARAMS, "parameters"),
                };
                if vec.len() >= limit {
                    return Err(Diag::new(
                        id.span,
                        format!("too many {what}: at most {limit} are supported"),
                    ));
                }
                let r = match kind {
                    0 => NameRef::State(vec.len()),
                    1 => NameRef::Input(vec.len()),
                    2 => NameRef::Output(vec.len()),
                    4 => NameRef::Disturbance(vec.len()),
                    _ => NameRef::Param(vec.len()),
                };
                vec.push(id.name.clone());
                self.names.lookup.insert(id.name.clone(), r);
                self.decl_spans.insert(id.name.clone(), id.span);
            }
        }
        let name = &self.ast.name;
        if self.names.states.is_empty() {
            return Err(Diag::new(
                name.span,
                format!(
                    "model `{}` declares no states: add `state x1, x2, ...;`",
                    name.name
                ),
            ));
        }
        if self.names.outputs.is_empty() {
            return Err(Diag::new(
                name.span,
                format!(
                    "model `{}` declares no outputs: an observer needs measurements, add `output y1, ...;`",
                    name.name
                ),
            ));
        }
        Ok(())
    }

    /// The `noise y1, y2;` declaration: the indices of the outputs measured
    /// with noise, or `None` (every output) without one. At most one
    /// declaration; every name an output, each once.
    pub(super) fn noise_outputs(&self) -> R<Option<Vec<usize>>> {
        let mut decl: Option<Span> = None;
        let mut out = Vec::new();
        for item in &self.ast.items {
            let Item::Noise(list, span) = item else {
                continue;
            };
            if let Some(prev) = decl {
                return Err(Diag::new(
                    *span,
                    format!(
                        "`noise` is declared twice (first at {}): list every noisy output in \
                         one declaration",
                        pos(self.src, prev)
                    ),
                ));
            }
            decl = Some(*span);
            for id in list {
                let i = match self.names.lookup.get(&id.name) {
                    Some(NameRef::Output(i)) => *i,
                    Some(r) => {
                        return Err(Diag::new(
                            id.span,
                            format!(
                                "`noise {}`: `{}` is {}, not an output: measurement noise is \
                                 declared on outputs (process noise is a `disturbance`)",
                                id.name,
                                id.name,
                                kind_word(*r)
                            ),
                        ))
                    }
                    None => {
                        let hint = crate::diagnostic::suggest(
                            &id.name,
                            self.names.outputs.iter().map(|s| s.as_str()),
                        )
                        .map(|s| format!(" (did you mean `{s}`?)"))
                        .unwrap_or_default();
                        return Err(Diag::new(
                            id.span,
                            format!(
                                "`noise {}`: `{}` is not a declared output{hint}",
                                id.name, id.name
                            ),
                        ));
                    }
                };
                if out.contains(&i) {
                    return Err(Diag::new(
                        id.span,
                        format!("`{}` is listed twice in the `noise` declaration", id.name),
                    ));
                }
                out.push(i);
            }
        }
        Ok(decl.map(|_| out))
    }

    /// Evaluates the `const` definitions in source order (each may use the
    /// ones before it).
    pub(super) fn consts(&mut self) -> R<()> {
        let mut k = 0;
        for item in &self.ast.items {
            let Item::Const(_, e, _) = item else { continue };
            let v = self.constant(e, "a `const` definition")?;
            self.names.consts[k].1 = Some(v);
            k += 1;
        }
        Ok(())
    }

    /// Evaluates the `let` definitions in source order: a polynomial in the
    /// parameters stands for itself, anything else is one derived
    /// scheduling variable named after the `let`.
    pub(super) fn lets(&mut self, params: &[Param]) -> R<()> {
        {
            let mut atoms = self.names.atoms.borrow_mut();
            atoms.np = params.len();
            atoms.boxes = params.iter().map(|p| (p.lo, p.hi)).collect();
        }
        let mut k = 0;
        for item in &self.ast.items {
            let Item::Let(id, e, _) = item else { continue };
            let context = format!("the definition of `{}`", id.name);
            let scope = self.scope(Allowed::Coefficient, &context);
            let p = eval(e, &scope)?;
            let def = sched_expr(e, &scope)?;
            let np = params.len();
            let value = if p.terms.keys().all(|m| m.theta >> np == 0) {
                LetValue::Inline(p)
            } else {
                LetValue::Atom(
                    self.names
                        .atom(def.clone(), Some(&id.name), e.span, self.src)?,
                )
            };
            self.names.lets[k].1 = Some((value, def));
            k += 1;
        }
        Ok(())
    }

    /// The declared range of every input (`input u in [lo, hi];`), in
    /// declaration order; `None` for an input declared without one.
    pub(super) fn input_ranges(&self) -> R<Vec<Option<(f64, f64)>>> {
        let mut out = Vec::new();
        for item in &self.ast.items {
            let Item::Inputs(names, range, _) = item else {
                continue;
            };
            let range = match range {
                None => None,
                Some((lo, hi, at)) => {
                    let lo = self.constant(lo, "an input bound")?;
                    let hi = self.constant(hi, "an input bound")?;
                    if !(lo <= hi && lo.is_finite() && hi.is_finite()) {
                        return Err(Diag::new(
                            *at,
                            format!(
                                "input range [{}, {}]: expected finite bounds, the lower one first",
                                fmt_num(lo),
                                fmt_num(hi)
                            ),
                        ));
                    }
                    Some((lo, hi))
                }
            };
            out.extend(names.iter().map(|_| range));
        }
        Ok(out)
    }

    pub(super) fn params(&mut self) -> R<Vec<Param>> {
        let mut out = Vec::new();
        for item in &self.ast.items {
            let Item::Params(p) = item else { continue };
            if let Some(output) = &p.measured {
                let param = self.measured_param(p, output)?;
                self.param_reach.push(param.lo.abs().max(param.hi.abs()));
                out.push(param);
                continue;
            }
            let Some((lo, hi, interval)) = &p.range else {
                return Err(Diag::new(
                    p.names[0].span,
                    "internal error: a parameter without an interval",
                ));
            };
            let (lo, hi) = self.param_bounds(lo, hi, *interval)?;
            let rate = self.rate(&p.rate, "parameter")?;
            for id in &p.names {
                self.param_reach.push(lo.abs().max(hi.abs()));
                out.push(Param {
                    name: id.name.clone(),
                    lo,
                    hi,
                    span: id.span,
                    rate,
                    measured: None,
                });
            }
        }
        self.auto_params(&mut out)?;
        self.measured_params = out.iter().any(|p| p.measured.is_some());
        Ok(out)
    }

    /// The bounds of a parameter's `[lo, hi]`: constants, lo < hi, finite
    /// and within the coefficient limit.
    pub(super) fn param_bounds(
        &self,
        lo: &ast::Expr,
        hi: &ast::Expr,
        interval: Span,
    ) -> R<(f64, f64)> {
        {
            let lo = self.constant(lo, "a parameter bound")?;
            let hi = self.constant(hi, "a parameter bound")?;
            if lo == hi {
                return Err(Diag::new(
                    interval,
                    format!(
                        "empty parameter range [{}, {}]: the upper bound must be greater than the lower \
                         bound (a parameter with a fixed value is a constant: write the number instead)",
                        fmt_num(lo),
                        fmt_num(hi)
                    ),
                ));
            }
            if lo > hi {
                return Err(Diag::new(
                    interval,
                    format!(
                        "reversed parameter range [{}, {}]: the lower bound comes first, write [{}, {}]",
                        fmt_num(lo),
                        fmt_num(hi),
                        fmt_num(hi),
                        fmt_num(lo)
                    ),
                ));
            }
            if !(hi - lo).is_finite() || lo.abs().max(hi.abs()) > MAX_COEFFICIENT {
                return Err(Diag::new(
                    interval,
                    format!(
                        "parameter range [{}, {}] is too wide: bounds up to {MAX_COEFFICIENT:e} in \
                         magnitude are supported (rescale the parameter)",
                        fmt_num(lo),
                        fmt_num(hi)
                    ),
                ));
            }
            Ok((lo, hi))
        }
    }

    /// The value of a `rate` clause: a constant ≥ 0 and finite.
    pub(super) fn rate(&self, clause: &Option<(ast::Expr, Span)>, what: &str) -> R<Option<f64>> {
        let Some((e, span)) = clause else {
            return Ok(None);
        };
        let r = self.constant(e, "a rate bound")?;
        if !(r.is_finite() && r >= 0.0) {
            return Err(Diag::new(
                *span,
                format!(
                    "{what} rate bound {}: expected a finite number ≥ 0 (the bound on the \
                     {what}'s time derivative, per second)",
                    fmt_num(r)
                ),
            ));
        }
        Ok(Some(r))
    }

    /// The `rate` bound of every input, in declaration order.
    pub(super) fn input_rates(&self) -> R<Vec<Option<f64>>> {
        let mut out = Vec::new();
        for item in &self.ast.items {
            if let Item::Inputs(l, _, rate) = item {
                let r = self.rate(rate, "input")?;
                out.extend(l.iter().map(|_| r));
            }
        }
        Ok(out)
    }
}
