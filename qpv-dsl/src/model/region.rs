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

impl<'a> Builder<'a> {
    /// The rows of a constant matrix of the region (`what` names a row):
    /// at most [`MAX_REGION_VERTICES`] of them, each with one entry per state.
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
        let decl = self.region_decl()?;
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
        match &decl.shape {
            ast::RegionShape::BoxScalar(e) => {
                let r = self.box_radius(e)?;
                self.box_region(decl, &vec![r; nx])
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
                let r = v
                    .iter()
                    .map(|e| self.box_radius(e))
                    .collect::<R<Vec<f64>>>()?;
                self.box_region(decl, &r)
            }
            ast::RegionShape::Vertices(lit) => {
                let pts = self.constant_rows(lit, "vertex", ctx)?;
                self.hull_region(hull_from_vertices(&pts), lit, "vertex")
            }
            ast::RegionShape::Halfspaces(lit) => {
                let rows = self.constant_rows(lit, "halfspace", ctx)?;
                self.hull_region(hull_from_halfspaces(&rows), lit, "halfspace")
            }
            ast::RegionShape::Zonotope(lit) => {
                let gens = self.constant_rows(lit, "generator", ctx)?;
                self.zonotope_region(&gens, lit)
            }
        }
    }

    /// The model's one `region` statement, if any; an error if there are two.
    fn region_decl(&self) -> R<Option<&'a ast::RegionDecl>> {
        let mut decl: Option<&'a ast::RegionDecl> = None;
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
        Ok(decl)
    }

    /// A box radius: a positive constant.
    fn box_radius(&self, e: &Expr) -> R<f64> {
        let r = self.constant(e, "the region")?;
        if r > 0.0 {
            Ok(r)
        } else {
            Err(Diag::new(
                e.span,
                format!("a box radius must be positive, found {}", fmt_num(r)),
            ))
        }
    }

    /// The box with these radii; an error at the statement if it has too
    /// many vertices.
    fn box_region(&self, decl: &ast::RegionDecl, radii: &[f64]) -> R<Region> {
        let nx = self.names.states.len();
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
    }

    /// The zonotope of these generators; an error at the matrix if it has
    /// too many vertices or does not span the state space.
    fn zonotope_region(&self, gens: &[DVector<f64>], lit: &MatrixLit) -> R<Region> {
        let nx = self.names.states.len();
        let r = gens.len();
        Region::from_zonotope(gens).map_err(|e| match e {
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
        })
    }

    /// The hull of a `vertices` or `halfspaces` matrix (`what` names its
    /// rows), with a warning for every row it drops.
    fn hull_region(
        &mut self,
        result: Result<(Region, Vec<usize>), RegionError>,
        lit: &MatrixLit,
        what: &str,
    ) -> R<Region> {
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
