//! `poles = ...` in a design block: the LMI regions of the complex plane
//! (Chilali & Gahinet) the eigenvalues of the frozen error dynamics must lie
//! in, with a common Lyapunov matrix (docs/method.md §18, "Pole regions").

use super::build::{bad_value, pos, Builder, R};
use crate::ast::{self, Expr, ExprKind};
use crate::diagnostic::{fmt_num, suggest, Diag, Span};
use serde::{Deserialize, Serialize};

/// One pole region: the open set of the complex plane every eigenvalue of
/// the frozen error dynamics A_l − L_l C (and, for a QPV plant, of its
/// region-vertex terms) must lie in. Several regions are intersected.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "region", rename_all = "lowercase", try_from = "RawPoleRegion")]
pub enum PoleRegion {
    /// |λ − centre| < radius (centre on the real axis): bounds the fastest
    /// mode by |centre| + radius and, through P, the gains.
    Disk {
        /// The centre (a real number, usually negative).
        centre: f64,
        /// The radius, positive.
        radius: f64,
    },
    /// The conic sector |Im λ| < tan(angle)·(−Re λ): the angle from the
    /// negative real axis is below `angle` (degrees, in (0, 90)), i.e. a
    /// damping ratio above cos(angle).
    Sector {
        /// The half-angle of the sector, degrees.
        angle: f64,
    },
    /// The vertical strip lo < Re λ < hi.
    Strip {
        /// The left edge.
        lo: f64,
        /// The right edge, above `lo`.
        hi: f64,
    },
}

/// A region as read from a report, before [`PoleRegion::invalid`] accepts
/// it: a report reaches the solver and the certificate only through the
/// same rule as a design block.
#[derive(Deserialize)]
#[serde(tag = "region", rename_all = "lowercase")]
enum RawPoleRegion {
    Disk { centre: f64, radius: f64 },
    Sector { angle: f64 },
    Strip { lo: f64, hi: f64 },
}

impl TryFrom<RawPoleRegion> for PoleRegion {
    type Error = String;
    fn try_from(raw: RawPoleRegion) -> Result<Self, String> {
        let r = match raw {
            RawPoleRegion::Disk { centre, radius } => PoleRegion::Disk { centre, radius },
            RawPoleRegion::Sector { angle } => PoleRegion::Sector { angle },
            RawPoleRegion::Strip { lo, hi } => PoleRegion::Strip { lo, hi },
        };
        match r.invalid() {
            None => Ok(r),
            Some((key, want)) => Err(format!(
                "pole region `{}`: `{key}` must be {want}",
                r.name()
            )),
        }
    }
}

impl PoleRegion {
    /// The one rule every region obeys, wherever it comes from (a design
    /// block or a report): `None` if the region is well formed, else the
    /// option at fault and what it must be. Every number is finite; a disk
    /// has a positive radius; a sector's half-angle is in (0, 90) degrees,
    /// taken as written (no angle is reduced modulo 360 or mirrored: 120°
    /// or 405° is refused, not read as another sector); a strip has lo < hi.
    pub fn invalid(&self) -> Option<(&'static str, &'static str)> {
        const FINITE: &str = "a finite number";
        match *self {
            PoleRegion::Disk { centre, .. } if !centre.is_finite() => Some(("centre", FINITE)),
            PoleRegion::Disk { radius, .. } if !(radius.is_finite() && radius > 0.0) => Some((
                "radius",
                "a positive number (the disk |λ − centre| < radius)",
            )),
            PoleRegion::Sector { angle } if !(angle > 0.0 && angle < 90.0) => Some((
                "angle",
                "an angle in degrees strictly between 0 and 90 (the half-angle of the sector \
                 from the negative real axis)",
            )),
            PoleRegion::Strip { lo, hi } if !(lo.is_finite() && hi.is_finite()) => {
                Some((if lo.is_finite() { "hi" } else { "lo" }, FINITE))
            }
            PoleRegion::Strip { lo, hi } if lo >= hi => Some((
                "hi",
                "above `lo` (`strip(lo = a, hi = b)` is the strip a < Re λ < b)",
            )),
            _ => None,
        }
    }

    /// How many LMI blocks the region adds beside each rate block (Chilali
    /// & Gahinet's characteristic functions: one for a disk or a sector,
    /// one per edge for a strip).
    pub fn n_blocks(&self) -> usize {
        match self {
            PoleRegion::Strip { .. } => 2,
            _ => 1,
        }
    }

    /// The side of each of the region's blocks for nx states: 2nx for a
    /// disk or a sector, nx for a strip's.
    pub fn block_side(&self, nx: usize) -> usize {
        match self {
            PoleRegion::Strip { .. } => nx,
            _ => 2 * nx,
        }
    }

    /// Whether the point `re + i·im` lies in the (open) region.
    pub fn contains(&self, re: f64, im: f64) -> bool {
        match *self {
            PoleRegion::Disk { centre, radius } => (re - centre).hypot(im) < radius,
            PoleRegion::Sector { angle } => {
                let b = angle.to_radians();
                re * b.sin() < -im.abs() * b.cos()
            }
            PoleRegion::Strip { lo, hi } => lo < re && re < hi,
        }
    }

    /// The region's name in the language (`disk`, `sector`, `strip`).
    pub fn name(&self) -> &'static str {
        match self {
            PoleRegion::Disk { .. } => "disk",
            PoleRegion::Sector { .. } => "sector",
            PoleRegion::Strip { .. } => "strip",
        }
    }
}

impl std::fmt::Display for PoleRegion {
    /// As written in a design block: `disk(centre = -5, radius = 5)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PoleRegion::Disk { centre, radius } => {
                write!(f, "disk(centre = {centre}, radius = {radius})")
            }
            PoleRegion::Sector { angle } => write!(f, "sector(angle = {angle})"),
            PoleRegion::Strip { lo, hi } => write!(f, "strip(lo = {lo}, hi = {hi})"),
        }
    }
}

/// What `poles = ...` expects, for messages.
const WANT: &str = "`disk(centre = c, radius = r)`, `sector(angle = degrees)` or \
                    `strip(lo = a, hi = b)`, or a list of them separated by `,`";

/// The options of one region kind, in order.
fn option_names(kind: &str) -> &'static [&'static str] {
    match kind {
        "disk" => &["centre", "radius"],
        "sector" => &["angle"],
        _ => &["lo", "hi"],
    }
}

impl Builder<'_> {
    /// `poles = R1, R2, ...`: every region of the entry, in order.
    pub(super) fn poles_value(&self, entry: &ast::DesignEntry) -> R<Vec<PoleRegion>> {
        std::iter::once((&entry.value, &entry.options))
            .chain(entry.more.iter().map(|(v, o)| (v, o)))
            .map(|(v, o)| self.pole_region(v, o.as_ref()))
            .collect()
    }

    /// One region: its kind, then its options (each exactly once).
    fn pole_region(&self, v: &Expr, options: Option<&ast::ValueOptions>) -> R<PoleRegion> {
        let kind = match &v.kind {
            ExprKind::Name(n) if ["disk", "sector", "strip"].contains(&n.as_str()) => n.as_str(),
            _ => {
                let found = crate::poly::quote(self.src, v.span).replace('`', "");
                return Err(bad_value(v.span, "poles", WANT, &found));
            }
        };
        let names = option_names(kind);
        let Some((opts, ospan)) = options else {
            return Err(Diag::new(
                v.span,
                format!(
                    "`{kind}` needs its options in parentheses: `{kind}({})`",
                    names
                        .iter()
                        .map(|n| format!("{n} = .."))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        };
        let mut values: Vec<Option<(f64, Span)>> = vec![None; names.len()];
        for o in opts {
            let key = o.key.name.as_str();
            let Some(k) = names.iter().position(|n| *n == key) else {
                let hint = suggest(key, names.iter().copied())
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                return Err(Diag::new(
                    o.key.span,
                    format!(
                        "unknown option `{key}` of `{kind}`: expected {}{hint}",
                        names
                            .iter()
                            .map(|n| format!("`{n}`"))
                            .collect::<Vec<_>>()
                            .join(" and ")
                    ),
                ));
            };
            if let Some((_, prev)) = values[k] {
                return Err(Diag::new(
                    o.key.span,
                    format!("`{key}` is set twice (first at {})", pos(self.src, prev)),
                ));
            }
            let x = self.constant(&o.value, &format!("the {kind} option {key}"))?;
            if !x.is_finite() {
                return Err(bad_value(o.value.span, key, "a finite number", &fmt_num(x)));
            }
            values[k] = Some((x, o.value.span));
        }
        if let Some(k) = values.iter().position(Option::is_none) {
            return Err(Diag::new(
                *ospan,
                format!("`{kind}` needs `{} = ..`", names[k]),
            ));
        }
        let val = |k: usize| values[k].map_or((0.0, *ospan), |x| x);
        match kind {
            "disk" => {
                let ((centre, _), (radius, rspan)) = (val(0), val(1));
                self.checked(PoleRegion::Disk { centre, radius }, rspan, radius)
            }
            "sector" => {
                let (angle, aspan) = val(0);
                self.checked(PoleRegion::Sector { angle }, aspan, angle)
            }
            _ => {
                let ((lo, _), (hi, hspan)) = (val(0), val(1));
                if lo >= hi {
                    return Err(Diag::new(
                        hspan,
                        format!(
                            "`strip(lo = a, hi = b)` is the strip a < Re λ < b and needs a < b; \
                             found lo = {} and hi = {}",
                            fmt_num(lo),
                            fmt_num(hi)
                        ),
                    ));
                }
                self.checked(PoleRegion::Strip { lo, hi }, hspan, hi)
            }
        }
    }

    /// `region` if [`PoleRegion::invalid`] accepts it, else its error at
    /// `span`, the option whose value `found` is at fault.
    fn checked(&self, region: PoleRegion, span: Span, found: f64) -> R<PoleRegion> {
        match region.invalid() {
            None => Ok(region),
            Some((key, want)) => Err(bad_value(span, key, want, &fmt_num(found))),
        }
    }
}
