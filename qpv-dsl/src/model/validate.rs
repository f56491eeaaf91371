//! Checks that need the whole model: parameters and inputs that are never
//! used (warnings) and the limit on scheduling parameters.

use super::build::{Builder, R};
use super::Model;
use crate::diagnostic::{Diag, Span, Warning};
use crate::expr::bits;
use crate::poly::{quote, Poly, Var};

/// Most parameters that may generate vertices (2^16 vertices).
pub const MAX_SCHEDULING: usize = 16;

impl Builder<'_> {
    pub(super) fn usage(&mut self, model: &Model) -> R<()> {
        let np = model.ntheta();
        let direct = model.param_mask() & super::low_bits(np);
        let used = model
            .derived
            .iter()
            .fold(direct, |m, d| m | d.expr.param_mask());
        for (i, p) in model.params.iter().enumerate() {
            if used & (1 << i) == 0 {
                self.warnings.push(Warning {
                    message: format!(
                        "parameter `{}` appears in no matrix: it adds no vertices (remove it, or check \
                         the equations)",
                        p.name
                    ),
                    span: p.span,
                });
            }
        }
        let sched: Vec<usize> = bits(direct).collect();
        if sched.len() + model.derived.len() > MAX_SCHEDULING && !model.derived.is_empty() {
            let costly: Vec<String> = model
                .derived
                .iter()
                .map(|d| format!("{} = {}", d.name, d.text))
                .collect();
            return Err(Diag::new(
                model.derived[0].span,
                format!(
                    "too many scheduling variables: {} parameters and {} derived functions ({}) \
                     would give 2^{} vertices; at most {MAX_SCHEDULING} are supported (name a \
                     recurring function with `let` so it is shared, or fix a parameter)",
                    sched.len(),
                    model.derived.len(),
                    costly.join(", "),
                    sched.len() + model.derived.len()
                ),
            ));
        }
        if sched.len() > MAX_SCHEDULING {
            let p = &model.params[sched[MAX_SCHEDULING]];
            return Err(Diag::new(
                p.span,
                format!(
                    "too many scheduling parameters ({}): the polytopic model would have 2^{} vertices; \
                     at most {MAX_SCHEDULING} parameters may appear in the matrices",
                    sched.len(),
                    sched.len()
                ),
            ));
        }
        for (j, u) in model.inputs.iter().enumerate() {
            if (0..model.nx()).all(|i| model.b.get(i, j).is_zero()) {
                self.warnings.push(Warning {
                    message: format!("input `{u}` has no effect: its column of B is zero"),
                    span: self.decl_spans.get(u).copied().unwrap_or(model.span),
                });
            }
        }
        Ok(())
    }
}

/// Largest magnitude a matrix entry may reach on the parameter box (and
/// largest parameter bound). Products of two such numbers (as in P·A) stay
/// far from overflow, so the solver and the certificate never meet an
/// infinity that the model text did not show.
pub const MAX_COEFFICIENT: f64 = 1e100;

impl Builder<'_> {
    /// An upper bound of |c(θ)| on the parameter box for c(θ) = Σ c_S θ^S:
    /// Σ |c_S| Π_{i∈S} max(|lo_i|, |hi_i|).
    fn magnitude_bound(&self, terms: impl Iterator<Item = (u64, f64)>) -> f64 {
        terms
            .map(|(mask, c)| {
                bits(mask).fold(c.abs(), |acc, i| {
                    acc * self.param_reach.get(i).copied().unwrap_or_else(|| {
                        let atoms = self.names.atoms.borrow();
                        atoms
                            .list
                            .get(i - atoms.np)
                            .map_or(1.0, |a| a.lo.abs().max(a.hi.abs()))
                    })
                })
            })
            .sum()
    }

    /// Refuses a matrix entry (at `span`) that may exceed
    /// [`MAX_COEFFICIENT`] in magnitude (or overflow) on the parameter box.
    pub(super) fn check_magnitude(
        &self,
        terms: impl Iterator<Item = (u64, f64)>,
        span: Span,
    ) -> R<()> {
        let bound = self.magnitude_bound(terms);
        if bound <= MAX_COEFFICIENT {
            return Ok(());
        }
        let reach = if bound.is_finite() {
            format!("reaches {bound:e} in magnitude")
        } else {
            "overflows a 64-bit float".to_string()
        };
        Err(Diag::new(
            span,
            format!(
                "the value of {} {reach} on the parameter box: matrix entries up to \
                 {MAX_COEFFICIENT:e} in magnitude are supported (rescale the states, inputs or \
                 parameters)",
                quote(self.src, span)
            ),
        ))
    }

    /// [`Self::check_magnitude`] for every coefficient c(θ) of an equation's
    /// right-hand side (one per state, input or product of states), at the
    /// span of the largest term.
    pub(super) fn check_equation_magnitude(&self, p: &Poly) -> R<()> {
        /// The terms of one coefficient c(θ), and its largest term's span.
        struct Coefficient<'p> {
            vars: &'p [Var],
            terms: Vec<(u64, f64)>,
            span: Span,
            largest: f64,
        }
        let mut groups: Vec<Coefficient<'_>> = Vec::new();
        for (mono, term) in &p.terms {
            let size = self.magnitude_bound(std::iter::once((mono.theta, term.coef)));
            match groups.iter_mut().find(|g| g.vars == mono.vars.as_slice()) {
                Some(g) => {
                    g.terms.push((mono.theta, term.coef));
                    if size > g.largest {
                        g.span = term.span;
                        g.largest = size;
                    }
                }
                None => groups.push(Coefficient {
                    vars: &mono.vars,
                    terms: vec![(mono.theta, term.coef)],
                    span: term.span,
                    largest: size,
                }),
            }
        }
        for g in groups {
            self.check_magnitude(g.terms.into_iter(), g.span)?;
        }
        Ok(())
    }
}
