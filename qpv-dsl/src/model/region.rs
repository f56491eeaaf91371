//! The `region` statement: a box, vertices or halfspaces → [`Region`], with
//! warnings for the rows the conversion drops.

use super::build::{pos, Builder, R};
use crate::ast::{self, Expr, Item, MatrixLit};
use crate::diagnostic::fmt_num;
use crate::diagnostic::{Diag, Warning};
use crate::region::{
    hull_from_halfspaces, hull_from_vertices, Region, RegionError, MAX_PARALLELOTOPE_VERTICES,
    MAX_REGION_VERTICES,
};
use nalgebra::DVector;

impl Builder<'_> {
    pub(super) fn constant_rows(
        &self,
        lit: &MatrixLit,
        what: &str,
        context: &str,
    ) -> R<Vec<DVector<f64>>> {
        let nx = self.names.states.len();
        if let Some(row) = lit.rows.get(MAX_REGION_VERTICES) {
            return Err(Diag::new(
                row.span,
                format!(
                    "the region lists {} rows: at most {MAX_REGION_VERTICES} {what} rows are \
                     supported",
                    lit.rows.len()
                ),
            ));
        }
        for (r, row) in lit.rows.iter().enumerate() {
            if row.entries.len() != nx {
                return Err(Diag::new(
                    row.span,
                    format!(
                        "{what} {} has {} {}, expected {nx} (one per state)",
                        r + 1,
                        row.entries.len(),
                        if row.entries.len() == 1 {
                            "coordinate"
                        } else {
                            "coordinates"
                        }
                    ),
                ));
            }
        }
        lit.rows
            .iter()
            .map(|row| {
                let v = row
                    .entries
                    .iter()
                    .map(|e| self.constant(e, context))
                    .collect::<R<Vec<f64>>>()?;
                Ok(DVector::from_vec(v))
            })
            .collect()
    }

    /// The region; `lpv`: the plant has N = 0 and M = 0, so its observer is
    /// global and a missing region is [`Region::none`] (a given one is
    /// kept, with a warning that the global design does not use it).
    pub(super) fn region(&mut self, lpv: bool) -> R<Region> {
        let nx = self.names.states.len();
        let mut decl: Option<&ast::RegionDecl> = None;
        for item in &self.ast.items {
            if let Item::Region(r) = item {
                if let Some(prev) = decl {
                    return Err(Diag::new(
                        r.span,
                        format!(
                            "the region is given twice (first at {})",
                            pos(self.src, prev.span)
                        ),
                    ));
                }
                decl = Some(r);
            }
        }
        if let (true, Some(decl)) = (lpv, decl) {
            self.warnings.push(Warning {
                message: "the plant is LPV (every N_k and M_k is zero): its observer is global \
                          (e' = (A(θ) − L(θ)C(θ))e is linear), so the region is not used by the \
                          design (it is kept for simulation only)"
                    .into(),
                span: decl.span,
            });
        }
        let Some(decl) = decl else {
            if lpv {
                return Ok(Region::none());
            }
            return Err(Diag::new(
                self.ast.name.span,
                format!(
                    "model `{}` has no region: add `region box(r);`, `region vertices [...];`, \
                     `region halfspaces [...];` or `region zonotope [...];`",
                    self.ast.name.name
                ),
            ));
        };
        let ctx = "the region";
        let radius = |e: &Expr| -> R<f64> {
            let r = self.constant(e, ctx)?;
            if r > 0.0 {
                Ok(r)
            } else {
                Err(Diag::new(
                    e.span,
                    format!("a box radius must be positive, found {}", fmt_num(r)),
                ))
            }
        };
        let boxed = |radii: &[f64]| {
            Region::from_box(radii).map_err(|e| match e {
                RegionError::TooComplex => Diag::new(
                    decl.span,
                    format!(
                        "a box in {nx} dimensions has 2^{nx} vertices; at most \
                         {MAX_PARALLELOTOPE_VERTICES} (16 states) are supported"
                    ),
                ),
                e => Diag::new(decl.span, e.to_string()),
            })
        };
        let (result, lit, what) = match &decl.shape {
            ast::RegionShape::BoxScalar(e) => {
                let r = radius(e)?;
                return boxed(&vec![r; nx]);
            }
            ast::RegionShape::BoxVector(v, span) => {
                if v.len() != nx {
                    return Err(Diag::new(
                        *span,
                        format!(
                            "box radii: expected {nx} values (one per state), found {}",
                            v.len()
                        ),
                    ));
                }
                let r = v.iter().map(radius).collect::<R<Vec<f64>>>()?;
                return boxed(&r);
            }
            ast::RegionShape::Vertices(lit) => {
                let pts = self.constant_rows(lit, "vertex", ctx)?;
                (hull_from_vertices(&pts), lit, "vertex")
            }
            ast::RegionShape::Halfspaces(lit) => {
                let rows = self.constant_rows(lit, "halfspace", ctx)?;
                (hull_from_halfspaces(&rows), lit, "halfspace")
            }
            ast::RegionShape::Zonotope(lit) => {
                let gens = self.constant_rows(lit, "generator", ctx)?;
                let r = gens.len();
                return Region::from_zonotope(&gens).map_err(|e| match e {
                    RegionError::TooComplex => Diag::new(
                        lit.span,
                        format!(
                            "a zonotope with {r} generators has up to 2^{r} vertices; at most \
                             {nx} generators (a parallelotope, up to 16 states) or \
                             {} generators are supported",
                            MAX_REGION_VERTICES.trailing_zeros()
                        ),
                    ),
                    RegionError::Degenerate { .. } if r < nx => Diag::new(
                        lit.span,
                        format!(
                            "a zonotope in {nx} dimensions needs at least {nx} generators (one \
                             per state, spanning the space), found {r}"
                        ),
                    ),
                    e => Diag::new(lit.span, e.to_string()),
                });
            }
        };
        match result {
            Ok((region, dropped)) => {
                for i in dropped {
                    let msg = if what == "vertex" {
                        format!(
                            "vertex {} is not a vertex of the region (it lies inside, on a face, or repeats \
                             another); it is ignored",
                            i + 1
                        )
                    } else {
                        format!(
                            "halfspace {} is redundant (implied by the others, or repeated); it is ignored",
                            i + 1
                        )
                    };
                    self.warnings.push(Warning {
                        message: msg,
                        span: lit.rows[i].span,
                    });
                }
                Ok(region)
            }
            Err(e) => Err(Diag::new(lit.span, e.to_string())),
        }
    }
}
