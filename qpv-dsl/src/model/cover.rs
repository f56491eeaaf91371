//! The `cover` statement: which parameters are cut into how many equal
//! pieces, checked against the model, and the ranges of the derived
//! scheduling variables on every piece (see [`crate::cover`]).

use super::build::{kind_word, pos, Builder, R};
use super::validate::MAX_SCHEDULING;
use super::Model;
use crate::ast::{CoverAxisAst, Item};
use crate::cover::{equal_breaks, Cover, CoverAxis, Piece, MAX_PIECES};
use crate::diagnostic::{suggest, Diag, Span};
use crate::poly::NameRef;

impl Builder<'_> {
    /// The model's cover, `None` without a `cover` statement. Needs the
    /// finished matrices and derived variables (a cut parameter must be
    /// used by one of them).
    pub(super) fn cover(&self, model: &Model) -> R<Option<Cover>> {
        let mut decls = self.ast.items.iter().filter_map(|i| match i {
            Item::Cover(axes, span) => Some((axes, *span)),
            _ => None,
        });
        let Some((axes_ast, span)) = decls.next() else {
            return Ok(None);
        };
        if let Some((_, again)) = decls.next() {
            return Err(Diag::new(
                again,
                format!(
                    "a `cover` statement is already given at {}: name every parameter to cut in \
                     one statement (`cover q2 into 4, m into 2;`)",
                    pos(self.src, span)
                ),
            ));
        }
        let np = model.ntheta();
        let used = model
            .derived
            .iter()
            .fold(model.param_mask() & super::low_bits(np), |m, d| {
                m | d.expr.param_mask()
            });
        let mut axes: Vec<(CoverAxis, usize)> = Vec::new();
        for a in axes_ast {
            let param = self.cover_param(a, used)?;
            if let Some((prev, _)) = axes.iter().find(|(c, _)| c.param == param) {
                return Err(Diag::new(
                    a.param.span,
                    format!(
                        "`{}` is cut twice in this `cover` statement (its first count is {})",
                        prev.name,
                        prev.breaks.len() - 1
                    ),
                ));
            }
            let n = self.piece_count(a)?;
            let p = &model.params[param];
            let breaks = equal_breaks(p.lo, p.hi, n);
            if breaks.windows(2).any(|w| w[0] >= w[1]) {
                return Err(Diag::new(
                    a.span,
                    format!(
                        "the range [{}, {}] of `{}` is too narrow for {n} distinct pieces in \
                         64-bit floats",
                        p.lo, p.hi, p.name
                    ),
                ));
            }
            axes.push((
                CoverAxis {
                    param,
                    name: p.name.clone(),
                    breaks,
                },
                n,
            ));
        }
        let total = axes
            .iter()
            .try_fold(1usize, |t, (_, n)| t.checked_mul(*n))
            .unwrap_or(usize::MAX);
        if total > MAX_PIECES {
            return Err(Diag::new(
                span,
                format!(
                    "the cover has {total} pieces: at most {MAX_PIECES} are supported (each \
                     piece adds the corners of its box to the vertices, and the solve time grows \
                     with them)"
                ),
            ));
        }
        let s = model.scheduling().len() + model.derived.len();
        let per_piece = 1usize << s.min(MAX_SCHEDULING);
        if total.saturating_mul(per_piece) > 1usize << MAX_SCHEDULING {
            return Err(Diag::new(
                span,
                format!(
                    "{total} pieces of 2^{s} corners each would give {} vertices: at most 2^{} \
                     are supported (fewer pieces, or fewer scheduling variables)",
                    total.saturating_mul(per_piece),
                    MAX_SCHEDULING
                ),
            ));
        }
        let axes: Vec<CoverAxis> = axes.into_iter().map(|(a, _)| a).collect();
        let mut cover = Cover {
            axes,
            pieces: Vec::with_capacity(total),
        };
        let names: Vec<String> = model.params.iter().map(|p| p.name.clone()).collect();
        for k in 0..total {
            let mut theta: Vec<(f64, f64)> = model.params.iter().map(|p| (p.lo, p.hi)).collect();
            for (a, i) in cover.axes.iter().zip(cover.indices(k)) {
                theta[a.param] = (a.breaks[i], a.breaks[i + 1]);
            }
            let mut phi = Vec::with_capacity(model.derived.len());
            let mut range = Vec::with_capacity(model.derived.len());
            for d in &model.derived {
                let (lo, hi, info) = crate::sched::range(&d.expr, &theta, &names).map_err(|e| {
                    Diag::new(
                        span,
                        format!(
                            "on the piece {} of the cover, `{}` = {}: {}",
                            cover.label(k),
                            d.name,
                            d.text,
                            e.message
                        ),
                    )
                })?;
                phi.push((lo, hi));
                range.push(info);
            }
            cover.pieces.push(Piece { theta, phi, range });
        }
        Ok(Some(cover))
    }

    /// The parameter an axis of the cover names, checked: declared, a
    /// parameter, and used by the model.
    fn cover_param(&self, a: &CoverAxisAst, used: u64) -> R<usize> {
        let name = &a.param.name;
        match self.names.lookup.get(name).copied() {
            Some(NameRef::Param(i)) => {
                if used & (1u64 << i) == 0 {
                    return Err(Diag::new(
                        a.param.span,
                        format!(
                            "parameter `{name}` appears in no matrix and no scheduling function: \
                             cutting its range into pieces changes nothing"
                        ),
                    ));
                }
                Ok(i)
            }
            Some(other) => Err(Diag::new(
                a.param.span,
                format!(
                    "`{name}` is {}, not a parameter: `cover` cuts the range of a declared \
                     parameter (`param {name} in [lo, hi];`)",
                    kind_word(other)
                ),
            )),
            None => {
                let params = self.names.lookup.iter().filter_map(|(n, r)| match r {
                    NameRef::Param(_) => Some(n.as_str()),
                    _ => None,
                });
                let hint = suggest(name, params)
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                Err(Diag::new(
                    a.param.span,
                    format!("unknown parameter `{name}` in `cover`{hint}"),
                ))
            }
        }
    }

    /// The number of pieces of an axis: a whole number from 1 to
    /// [`MAX_PIECES`].
    fn piece_count(&self, a: &CoverAxisAst) -> R<usize> {
        let v = self.constant(&a.pieces, "the number of pieces")?;
        let at: Span = a.pieces.span;
        if !(v.is_finite() && v.fract() == 0.0) {
            return Err(Diag::new(
                at,
                format!("the number of pieces must be a whole number, found {v}"),
            ));
        }
        if v < 1.0 {
            return Err(Diag::new(
                at,
                format!("the number of pieces must be at least 1, found {v}"),
            ));
        }
        if v > MAX_PIECES as f64 {
            return Err(Diag::new(
                at,
                format!(
                    "{v} pieces: at most {MAX_PIECES} are supported (each piece adds the corners \
                     of its box to the vertices, and the solve time grows with them)"
                ),
            ));
        }
        Ok(v as usize)
    }
}
