//! The `state_bound` statement: a given Q (symmetric, positive definite,
//! checked against the region) or `auto` with its options.

use super::build::{bad_value, pos, Builder, R};
use super::validate::MAX_COEFFICIENT;
use crate::ast::{self, Item};
use crate::diagnostic::fmt_num;
use crate::diagnostic::{suggest, Diag, Span, Warning};
use crate::region::Region;
use nalgebra::DMatrix;
use serde::Serialize;

/// Smallest ratio of the smallest to the largest eigenvalue of a given Q:
/// below it, rounding errors of size 1e-16 · ‖Q‖ can decide positive
/// definiteness, so the bound cannot be certified in double precision.
const MIN_EIGEN_RATIO: f64 = 1e-12;

/// The set F = {x : xᵀ Q⁻¹ x ≤ 1} known to contain the state trajectory.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum StateBound {
    /// No `state_bound` given.
    None,
    /// `state_bound Q = [...]`: a symmetric positive definite Q (nx × nx).
    Given(nalgebra::DMatrix<f64>),
    /// `state_bound auto;` or `state_bound auto(h = ...);`: Q is computed by
    /// the solver (an invariant ellipsoid containing the region, inside the
    /// box |x_i| ≤ h, maximising γ_max). With `h` given the box size is
    /// fixed; otherwise it is searched.
    Auto {
        /// The half-width of the enclosing box, if fixed by the model.
        h: Option<f64>,
    },
}

impl Builder<'_> {
    /// The state bound; `lpv`: the plant has N = 0 and M = 0, and a given
    /// bound is kept with a warning that the global design does not use it.
    pub(super) fn state_bound(&mut self, region: &Region, lpv: bool) -> R<StateBound> {
        let mut decl: Option<(&ast::BoundDecl, Span)> = None;
        for item in &self.ast.items {
            if let Item::StateBound(bound, span) = item {
                if let Some((_, prev)) = decl {
                    return Err(Diag::new(
                        *span,
                        format!(
                            "the state bound is given twice (first at {})",
                            pos(self.src, prev)
                        ),
                    ));
                }
                decl = Some((bound, *span));
            }
        }
        let Some((bound, span)) = decl else {
            return Ok(StateBound::None);
        };
        if lpv && !self.measured_params {
            self.warnings.push(Warning {
                message: "the plant is LPV (every N_k and M_k is zero): its observer is global, \
                          so the state bound is not used by the design (a `sample = h` design \
                          takes it as the operating envelope of its continuous-plant bound)"
                    .into(),
                span,
            });
        }
        let lit = match bound {
            ast::BoundDecl::Given(lit) => lit,
            ast::BoundDecl::Auto(_) if !self.names.disturbances.is_empty() => {
                // The computed F is invariant for the undisturbed plant only;
                // the certificate assumes x stays in F, so a disturbed plant
                // needs a bound the user vouches for.
                return Err(Diag::new(
                    span,
                    "`state_bound auto` computes an invariant ellipsoid of the undisturbed \
                     plant, but this model declares process disturbances, which can drive x out \
                     of it; give a Q that contains the disturbed trajectory \
                     (`state_bound Q = [..];`)",
                ));
            }
            ast::BoundDecl::Auto(options) => return self.auto_bound(options, region),
        };
        let nx = self.names.states.len();
        self.check_shape(lit, "Q", nx, nx, "one per state", "one per state")?;
        let mut q = DMatrix::zeros(nx, nx);
        for (i, row) in lit.rows.iter().enumerate() {
            for (j, e) in row.entries.iter().enumerate() {
                q[(i, j)] = self.constant(e, "the state bound Q")?;
            }
        }
        let scale = q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for i in 0..nx {
            for j in 0..i {
                if (q[(i, j)] - q[(j, i)]).abs() > 1e-9 * scale {
                    return Err(Diag::new(
                        lit.rows[i].entries[j].span,
                        format!(
                            "Q must be symmetric: entry ({}, {}) is {} but entry ({}, {}) is {}",
                            i + 1,
                            j + 1,
                            fmt_num(q[(i, j)]),
                            j + 1,
                            i + 1,
                            fmt_num(q[(j, i)])
                        ),
                    ));
                }
            }
        }
        let q = (&q + q.transpose()) * 0.5;
        let chol = self.positive_definite(&q, lit)?;
        let qinv = chol.inverse();
        if let Some((worst, i)) = region.max_quadratic(&qinv) {
            if worst > 1.0 + 1e-9 {
                let v = &region.vertices[i];
                let coords: Vec<String> = v.iter().map(|x| fmt_num(*x)).collect();
                self.warnings.push(Warning {
                    message: format!(
                        "the region is not inside the state bound F = {{x : xᵀQ⁻¹x ≤ 1}} (Assumption 2, \
                         P ⊂ F): the vertex ({}) has xᵀQ⁻¹x = {:.4} > 1; the region would have to shrink \
                         by the factor {:.4} to fit",
                        coords.join(", "),
                        worst,
                        1.0 / worst.sqrt()
                    ),
                    span,
                });
            }
        }
        Ok(StateBound::Given(q))
    }

    /// The Cholesky factor of a symmetric Q that is positive definite with
    /// a margin double precision can certify: the ratio of its smallest to
    /// its largest eigenvalue must exceed 1e-12, and its entries must stay
    /// within [`MAX_COEFFICIENT`].
    fn positive_definite(
        &self,
        q: &DMatrix<f64>,
        lit: &ast::MatrixLit,
    ) -> R<nalgebra::linalg::Cholesky<f64, nalgebra::Dyn>> {
        let scale = q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if scale > MAX_COEFFICIENT {
            return Err(Diag::new(
                lit.span,
                format!(
                    "Q has an entry of magnitude {scale:e}: entries up to {MAX_COEFFICIENT:e} are \
                     supported (rescale the states)"
                ),
            ));
        }
        let eig = q.clone().symmetric_eigenvalues();
        let min_eig = eig.iter().fold(f64::INFINITY, |m, x| m.min(*x));
        let max_eig = eig.iter().fold(f64::NEG_INFINITY, |m, x| m.max(*x));
        if min_eig.is_nan() || min_eig <= 0.0 {
            return Err(Diag::new(
                lit.span,
                format!(
                    "Q must be positive definite (F = {{x : xᵀQ⁻¹x ≤ 1}} is then a bounded ellipsoid), \
                     but its smallest eigenvalue is {}",
                    fmt_num(min_eig)
                ),
            ));
        }
        let chol = if min_eig > MIN_EIGEN_RATIO * max_eig {
            q.clone().cholesky()
        } else {
            None
        };
        chol.ok_or_else(|| {
            Diag::new(
                lit.span,
                format!(
                    "Q is too badly scaled to be certified in double precision: its eigenvalues \
                     range from {min_eig:e} to {max_eig:e} (ratio {:.1e}; at most {:e} is \
                     supported). Rescale the states so that the state bound has comparable \
                     extents in every direction",
                    max_eig / min_eig,
                    1.0 / MIN_EIGEN_RATIO
                ),
            )
        })
    }

    /// `state_bound auto(h = ...);`: validates the options.
    fn auto_bound(&self, options: &[ast::DesignEntry], region: &Region) -> R<StateBound> {
        let mut h = None;
        let mut seen: Option<Span> = None;
        for entry in options {
            let key = entry.key.name.as_str();
            if key != "h" {
                let hint = suggest(key, ["h"])
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                return Err(Diag::new(
                    entry.key.span,
                    format!(
                        "unknown state bound option `{key}`: expected `h` (the half-width of the \
                         box |x_i| ≤ h that encloses F){hint}"
                    ),
                ));
            }
            if let Some(prev) = seen {
                return Err(Diag::new(
                    entry.key.span,
                    format!("`h` is set twice (first at {})", pos(self.src, prev)),
                ));
            }
            seen = Some(entry.key.span);
            let v = &entry.value;
            let value = self.constant(v, "the state bound option h")?;
            if !(value > 0.0 && value.is_finite()) {
                return Err(bad_value(v.span, "h", "a positive number", &fmt_num(value)));
            }
            let reach = region
                .vertices
                .iter()
                .flat_map(|x| x.iter())
                .fold(0.0f64, |m, x| m.max(x.abs()));
            if value <= reach {
                return Err(Diag::new(
                    v.span,
                    format!(
                        "`h` = {} is too small: F must contain the region and lie inside the box \
                         |x_i| ≤ h, but the region reaches |x_i| = {}; choose h > {}",
                        fmt_num(value),
                        fmt_num(reach),
                        fmt_num(reach)
                    ),
                ));
            }
            h = Some(value);
        }
        Ok(StateBound::Auto { h })
    }
}
