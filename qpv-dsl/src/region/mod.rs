//! The convergence region P: a polytope containing the origin in its
//! interior, held both as vertices and as facets a_kᵀ x ≤ 1.
//!
//! Conversions are exact enumerations (no sampling): both directions reduce
//! to enumerating the vertices of {x : a_kᵀ x ≤ 1}, done with the double
//! description method (Motzkin et al.; Fukuda & Prodon's combinatorial
//! adjacency test) on the homogenised cone {(x, t) : a_kᵀ x ≤ t, t ≥ 0}.
//! Going from vertices to facets uses polarity: with 0 strictly inside,
//! the facets of Co{x_i} are the vertices of {a : x_iᵀ a ≤ 1}.
//!
//! The enumeration is scale-invariant: before it runs, every coordinate is
//! divided by its largest magnitude in the data (a diagonal change of
//! variables, which maps vertices to vertices and facets to facets), every
//! homogenised row is normalised, and every test is relative (a dot product
//! aᵀx is compared with 1 up to 1e-9 · Σ_j |a_j x_j|). A region whose
//! coordinates differ in scale by many orders of magnitude is therefore
//! converted exactly like its rescaled copy. The result is verified (every
//! vertex satisfies every facet, with at least n + 1 of each), and a result
//! that cannot be verified or represented in double precision is refused
//! ([`RegionError::Degenerate`]) rather than returned. Tested against an
//! exact rational enumeration up to five dimensions and against round trips
//! up to six.

mod dd;

use dd::{enumerate_within, Enum};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use std::fmt;

/// A bounded polytope P = Co{x_(1..p)} = {x : a_kᵀ x ≤ 1, k = 1..q}.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Region {
    /// The vertices x_(i).
    pub vertices: Vec<DVector<f64>>,
    /// The facet normals a_k, each facet being a_kᵀ x ≤ 1.
    pub facets: Vec<DVector<f64>>,
    /// The generators g_k of a region given as a zonotope
    /// {Σ_k t_k g_k : |t_k| ≤ 1} (`region zonotope [...]`); empty otherwise.
    /// Boxes and other parallelotopes are recognised from their facets by
    /// [`Region::zonotope_generators`], so they leave this empty.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub generators: Vec<DVector<f64>>,
}

/// Most vertices (or facets) a region may have.
pub const MAX_REGION_VERTICES: usize = 4096;

/// Most vertices of a box or parallelotope (2^16: up to 16 states). Their
/// vertices are listed without a hull computation, and the conditions that
/// scale (`conditions = cube`) never enumerate them.
pub const MAX_PARALLELOTOPE_VERTICES: usize = 65_536;

/// Relative tolerance of the enumeration.
const TOL: f64 = 1e-9;

/// Most intermediate rays the enumeration keeps before giving up.
const MAX_RAYS: usize = 20_000;

/// The work limit of one vertex enumeration, in 64-bit word operations of
/// the double description's bit sets (about 6 s on one core of the CI
/// machine): a region whose enumeration would need more is refused with
/// [`RegionError::TooComplex`] instead of running for minutes.
pub const MAX_ENUMERATION_WORK: u64 = 3_000_000_000;

/// Why a set of vertices or facets is not an acceptable region.
#[derive(Debug, Clone, PartialEq)]
pub enum RegionError {
    /// The facets do not bound the region: it contains every t·d, t ≥ 0.
    Unbounded {
        /// A direction of unboundedness.
        direction: DVector<f64>,
    },
    /// The origin is not strictly inside: the region lies in {x : dᵀx ≤ 0}.
    OriginNotInterior {
        /// Normal of a halfspace through the origin containing the region.
        direction: DVector<f64>,
    },
    /// A box radius that is not a positive finite number.
    BadRadius {
        /// Which coordinate.
        index: usize,
    },
    /// A vertex or facet with a non-finite entry, or of the wrong length.
    BadPoint {
        /// Which row.
        index: usize,
    },
    /// Nothing was given, or the dimension is zero.
    Empty,
    /// More than [`MAX_REGION_VERTICES`] vertices or facets (given or
    /// computed), or the enumeration grew beyond its work limit.
    TooComplex,
    /// The conversion cannot be carried out reliably in double precision:
    /// a coordinate of the result overflows, the region is nearly flat or
    /// the origin nearly on its boundary (relative to the region's own
    /// scale), or the computed polytope fails its verification.
    Degenerate {
        /// What went wrong, in words.
        reason: String,
    },
}

fn fmt_vec(v: &DVector<f64>) -> String {
    let parts: Vec<String> = v
        .iter()
        .map(|x| {
            let r = (x * 1e6).round() / 1e6;
            format!("{}", if r == 0.0 { 0.0 } else { r })
        })
        .collect();
    format!("({})", parts.join(", "))
}

impl fmt::Display for RegionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RegionError::Unbounded { direction } => write!(
                f,
                "the region is unbounded: it contains the whole ray t·d, t ≥ 0, for d = {}; \
                 add halfspaces that close it in that direction",
                fmt_vec(direction)
            ),
            RegionError::OriginNotInterior { direction } => write!(
                f,
                "the origin must lie strictly inside the region, but every vertex x satisfies \
                 dᵀx ≤ 0 for d = {} (the region is flat or on one side of the origin)",
                fmt_vec(direction)
            ),
            RegionError::BadRadius { index } => {
                write!(f, "box radius {} must be a positive number", index + 1)
            }
            RegionError::BadPoint { index } => write!(f, "row {} is not a finite vector", index + 1),
            RegionError::Empty => write!(f, "the region is empty"),
            RegionError::TooComplex => write!(
                f,
                "the region is too complex: at most {MAX_REGION_VERTICES} vertices and facets are \
                 supported, and its vertex enumeration must fit a fixed work limit (give the region \
                 by fewer halfspaces, by its vertices, or as a box or zonotope)"
            ),
            RegionError::Degenerate { reason } => write!(
                f,
                "the region cannot be represented reliably in double precision: {reason}"
            ),
        }
    }
}

impl std::error::Error for RegionError {}

impl Region {
    /// No region: what an LPV plant written without `region` has (its
    /// observer is global, docs/method.md). Every list is empty.
    pub fn none() -> Region {
        Region {
            vertices: Vec::new(),
            facets: Vec::new(),
            generators: Vec::new(),
        }
    }

    /// Whether this is [`Region::none`].
    pub fn is_none(&self) -> bool {
        self.vertices.is_empty() && self.facets.is_empty()
    }

    /// Dimension of the space.
    pub fn dim(&self) -> usize {
        self.vertices.first().map_or(0, |v| v.len())
    }

    /// The box |x_i| ≤ r_i. Vertices are ordered with the first coordinate
    /// most significant, −r before +r; facets are e_1/r_1, −e_1/r_1, e_2/r_2, ...
    pub fn from_box(radii: &[f64]) -> Result<Region, RegionError> {
        let n = radii.len();
        if n == 0 {
            return Err(RegionError::Empty);
        }
        if let Some(index) = radii.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
            return Err(RegionError::BadRadius { index });
        }
        if n >= 63 || (1usize << n) > MAX_PARALLELOTOPE_VERTICES {
            return Err(RegionError::TooComplex);
        }
        let vertices = (0..1usize << n)
            .map(|l| {
                DVector::from_fn(n, |i, _| {
                    if (l >> (n - 1 - i)) & 1 == 1 {
                        radii[i]
                    } else {
                        -radii[i]
                    }
                })
            })
            .collect();
        let mut facets = Vec::with_capacity(2 * n);
        for (i, r) in radii.iter().enumerate() {
            if !(1.0 / r).is_finite() {
                return Err(RegionError::Degenerate {
                    reason: format!(
                        "box radius {} is {r:e}: its facet normal 1/r overflows",
                        i + 1
                    ),
                });
            }
            for s in [1.0, -1.0] {
                let mut a = DVector::zeros(n);
                a[i] = s / r;
                facets.push(a);
            }
        }
        Ok(Region {
            vertices,
            facets,
            generators: Vec::new(),
        })
    }

    /// The zonotope {Σ_k t_k g_k : |t_k| ≤ 1} of the generators `gens`
    /// (which must span the space). With as many generators as dimensions
    /// it is a parallelotope: its 2^n vertices are listed directly (at most
    /// [`MAX_PARALLELOTOPE_VERTICES`]) and its facets are ±(rows of G⁻¹);
    /// with more, the 2^r sign combinations (at most [`MAX_REGION_VERTICES`])
    /// go through the hull computation. The generators are kept.
    pub fn from_zonotope(gens: &[DVector<f64>]) -> Result<Region, RegionError> {
        let n = check_points_limit(gens, usize::MAX)?;
        let r = gens.len();
        if r < n {
            return Err(RegionError::Degenerate {
                reason: format!("{r} generators cannot span {n} dimensions (the zonotope is flat)"),
            });
        }
        let limit = if r == n {
            MAX_PARALLELOTOPE_VERTICES
        } else {
            MAX_REGION_VERTICES
        };
        if r >= 63 || (1usize << r) > limit {
            return Err(RegionError::TooComplex);
        }
        let sums: Vec<DVector<f64>> = (0..1usize << r)
            .map(|l| {
                let mut v = DVector::zeros(n);
                for (k, g) in gens.iter().enumerate() {
                    if (l >> (r - 1 - k)) & 1 == 1 {
                        v += g;
                    } else {
                        v -= g;
                    }
                }
                v
            })
            .collect();
        let mut region = if r == n {
            let g = DMatrix::from_columns(gens);
            let inv = g
                .clone()
                .try_inverse()
                .filter(|m| m.iter().all(|v| v.is_finite()));
            let Some(inv) = inv.filter(|_| g.rank(1e-12 * g.norm()) == n) else {
                return Err(RegionError::Degenerate {
                    reason: "the generators do not span the space (the zonotope is flat)"
                        .to_string(),
                });
            };
            let mut facets = Vec::with_capacity(2 * n);
            for k in 0..n {
                let a: DVector<f64> = inv.row(k).transpose();
                facets.push(a.clone());
                facets.push(-a);
            }
            Region {
                vertices: sums,
                facets,
                generators: Vec::new(),
            }
        } else {
            hull_from_vertices(&sums)?.0
        };
        region.generators = gens.to_vec();
        Ok(region)
    }

    /// The generators g_k of the region as a zonotope {Σ t_k g_k : |t_k| ≤ 1},
    /// if it is one that can be recognised: the stored generators of a
    /// `region zonotope`, else a parallelotope (2n facets in opposite pairs
    /// ±a_k with independent a_k: the generators are the columns of A⁻¹; for
    /// an axis-aligned box, exactly r_k e_k with r_k from the vertices).
    /// None for any other polytope.
    pub fn zonotope_generators(&self) -> Option<Vec<DVector<f64>>> {
        if !self.generators.is_empty() {
            return Some(self.generators.clone());
        }
        let n = self.dim();
        if n == 0 || self.facets.len() != 2 * n || self.vertices.len() != 1usize << n.min(62) {
            return None;
        }
        // One normal of each opposite pair.
        let mut rows: Vec<DVector<f64>> = Vec::with_capacity(n);
        let mut used = vec![false; self.facets.len()];
        for i in 0..self.facets.len() {
            if used[i] {
                continue;
            }
            let a = &self.facets[i];
            let scale = a.norm().max(f64::MIN_POSITIVE);
            let j = (i + 1..self.facets.len())
                .find(|&j| !used[j] && (a + &self.facets[j]).norm() <= 1e-12 * scale)?;
            used[i] = true;
            used[j] = true;
            rows.push(a.clone());
        }
        if rows.len() != n {
            return None;
        }
        let axis = |a: &DVector<f64>| a.iter().filter(|v| **v != 0.0).count() == 1;
        if rows.iter().all(axis) {
            // A box: r_k = max_i |x_(i),k|, exact.
            let mut gens = Vec::with_capacity(n);
            for a in &rows {
                let k = a.iter().position(|v| *v != 0.0)?;
                let r = self.vertices.iter().map(|x| x[k].abs()).fold(0.0, f64::max);
                let mut g = DVector::zeros(n);
                g[k] = r;
                gens.push(g);
            }
            gens.sort_by_key(|g| g.iter().position(|v| *v != 0.0));
            return Some(gens);
        }
        let a = DMatrix::from_fn(n, n, |r, c| rows[r][c]);
        let inv = a.try_inverse()?;
        let gens: Vec<DVector<f64>> = (0..n).map(|k| inv.column(k).into_owned()).collect();
        gens.iter()
            .all(|g| g.iter().all(|v| v.is_finite()))
            .then_some(gens)
    }

    /// The convex hull of `points` (origin strictly inside); points that are
    /// not vertices of the hull (or repeat one) are dropped.
    pub fn from_vertices(points: &[DVector<f64>]) -> Result<Region, RegionError> {
        hull_from_vertices(points).map(|(r, _)| r)
    }

    /// The polytope {x : a_kᵀ x ≤ 1} (must be bounded); redundant rows are
    /// dropped.
    pub fn from_halfspaces(normals: &[DVector<f64>]) -> Result<Region, RegionError> {
        hull_from_halfspaces(normals).map(|(r, _)| r)
    }

    /// [`Region::from_halfspaces`] with a work limit of `work` word
    /// operations for the vertex enumeration instead of [`MAX_ENUMERATION_WORK`]
    /// (about 6 s on one core): a caller can allow a large region more time,
    /// or refuse sooner. Beyond the limit the result is
    /// [`RegionError::TooComplex`].
    pub fn from_halfspaces_within(
        normals: &[DVector<f64>],
        work: u64,
    ) -> Result<Region, RegionError> {
        hull_within(normals, work).map(|(r, _)| r)
    }

    /// True if every facet inequality holds at `x`, up to a relative
    /// tolerance of 1e-9 · (1 + Σ_j |a_j x_j|) per facet (scale-invariant).
    pub fn contains(&self, x: &DVector<f64>) -> bool {
        self.facets.iter().all(|a| slack(a, x) >= -tol(a, x))
    }

    /// The largest xᵀ W x over the vertices (e.g. W = Q⁻¹ to test P ⊂ F),
    /// with the vertex attaining it.
    pub fn max_quadratic(&self, w: &DMatrix<f64>) -> Option<(f64, usize)> {
        self.vertices
            .iter()
            .enumerate()
            .map(|(i, v)| ((v.transpose() * w * v)[(0, 0)], i))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    }
}

fn check_points(points: &[DVector<f64>]) -> Result<usize, RegionError> {
    check_points_limit(points, MAX_REGION_VERTICES)
}

/// As [`check_points`] with a different limit on the number of rows.
fn check_points_limit(points: &[DVector<f64>], limit: usize) -> Result<usize, RegionError> {
    let n = points.first().map(|p| p.len()).ok_or(RegionError::Empty)?;
    if n == 0 {
        return Err(RegionError::Empty);
    }
    for (index, p) in points.iter().enumerate() {
        if p.len() != n || p.iter().any(|x| !x.is_finite()) {
            return Err(RegionError::BadPoint { index });
        }
    }
    if points.len() > limit {
        return Err(RegionError::TooComplex);
    }
    Ok(n)
}

/// 1 − aᵀx: nonnegative when x satisfies aᵀx ≤ 1.
fn slack(a: &DVector<f64>, x: &DVector<f64>) -> f64 {
    1.0 - a.dot(x)
}

/// The tolerance of a test aᵀx ⋚ 1: relative to the terms of the dot
/// product, so that it does not change under a diagonal rescaling.
fn tol(a: &DVector<f64>, x: &DVector<f64>) -> f64 {
    TOL * (1.0
        + a.iter()
            .zip(x.iter())
            .map(|(p, q)| (p * q).abs())
            .sum::<f64>())
}

/// The scale of each coordinate in `rows`: its largest magnitude (1 for a
/// coordinate that is zero in every row).
fn column_scales(rows: &[DVector<f64>], n: usize) -> Vec<f64> {
    (0..n)
        .map(|j| {
            let m = rows.iter().fold(0.0f64, |m, r| m.max(r[j].abs()));
            if m > 0.0 {
                m
            } else {
                1.0
            }
        })
        .collect()
}

/// `rows` with coordinate j divided by `scales[j]`.
fn divide(rows: &[DVector<f64>], scales: &[f64]) -> Vec<DVector<f64>> {
    rows.iter()
        .map(|r| DVector::from_fn(r.len(), |j, _| r[j] / scales[j]))
        .collect()
}

/// A direction d of the scaled space mapped back (coordinate j divided by
/// `scales[j]`) and normalised.
fn unscale_direction(d: &DVector<f64>, scales: &[f64]) -> DVector<f64> {
    let v = DVector::from_fn(d.len(), |j, _| d[j] / scales[j]);
    let m = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if m > 0.0 && m.is_finite() {
        let v = v / m;
        let norm = v.norm();
        v / norm
    } else {
        d.clone()
    }
}

/// Vectors of the scaled space mapped back (coordinate j divided by
/// `scales[j]`); an entry that overflows or underflows to zero from a
/// nonzero value is an error naming `what`.
fn unscale(
    rows: &[DVector<f64>],
    scales: &[f64],
    what: &str,
) -> Result<Vec<DVector<f64>>, RegionError> {
    let out = divide(rows, scales);
    for (r, o) in rows.iter().zip(&out) {
        for (x, y) in r.iter().zip(o.iter()) {
            if !y.is_finite() || (*y == 0.0 && x.abs() > TOL) {
                return Err(RegionError::Degenerate {
                    reason: format!(
                        "a coordinate of a computed {what} is outside the range of a 64-bit float"
                    ),
                });
            }
        }
    }
    Ok(out)
}

/// Checks a computed region on the scaled data: at least n + 1 vertices and
/// facets, every `points` row inside every facet.
fn verify(
    vertices: &[DVector<f64>],
    facets: &[DVector<f64>],
    points: &[DVector<f64>],
    n: usize,
) -> Result<(), RegionError> {
    if vertices.len() <= n || facets.len() <= n {
        return Err(RegionError::Degenerate {
            reason: format!(
                "only {} vertices and {} facets were found (a bounded region in {n} dimensions \
                 has at least {} of each); the region is too thin relative to its size",
                vertices.len(),
                facets.len(),
                n + 1
            ),
        });
    }
    for a in facets {
        for x in points {
            if slack(a, x) < -100.0 * tol(a, x) {
                return Err(RegionError::Degenerate {
                    reason: "the computed facets do not contain every vertex (the data are \
                             too close to degenerate)"
                        .into(),
                });
            }
        }
    }
    Ok(())
}

/// The half the two hulls share (each region is the polar of the other):
/// the rows scaled to balanced columns, the points of their polar
/// {b : rowᵢᵀb ≤ 1} and the rows those points keep as irredundant.
struct Polar {
    /// The column scales s.
    scales: Vec<f64>,
    /// The rows divided by s.
    rows: Vec<DVector<f64>>,
    /// The polar's points, in scaled coordinates.
    dual: Vec<DVector<f64>>,
    /// Indices of the rows kept.
    keep: Vec<usize>,
}

impl Polar {
    /// Scales `rows`, enumerates their polar within the work limit `work`
    /// and keeps the irredundant rows; an unbounded polar is the error
    /// `unbounded` gives for the direction (unscaled to the caller's
    /// coordinates).
    fn of(
        rows: &[DVector<f64>],
        work: u64,
        unbounded: impl Fn(DVector<f64>) -> RegionError,
    ) -> Result<(Polar, usize), RegionError> {
        let n = check_points(rows)?;
        let scales = column_scales(rows, n);
        let scaled = divide(rows, &scales);
        let dual = match enumerate_within(&scaled, n, work) {
            Ok(v) => v,
            // rowᵢᵀd ≤ 0 for all i in scaled coordinates: d/s in the caller's
            Err(Enum::Unbounded(d)) => return Err(unbounded(unscale_direction(&d, &scales))),
            Err(Enum::Degenerate(reason)) => return Err(RegionError::Degenerate { reason }),
            Err(Enum::TooComplex) => return Err(RegionError::TooComplex),
        };
        let keep = irredundant(&scaled, &dual, n);
        let polar = Polar {
            scales,
            rows: scaled,
            dual,
            keep,
        };
        Ok((polar, n))
    }

    /// The kept rows (scaled).
    fn kept(&self) -> Vec<DVector<f64>> {
        self.keep.iter().map(|&i| self.rows[i].clone()).collect()
    }

    /// The indices of the rows not kept.
    fn dropped(&self) -> Vec<usize> {
        (0..self.rows.len())
            .filter(|i| !self.keep.contains(i))
            .collect()
    }
}

/// [`Region::from_vertices`], also returning the indices of the dropped points.
pub(crate) fn hull_from_vertices(
    points: &[DVector<f64>],
) -> Result<(Region, Vec<usize>), RegionError> {
    // facets of Co{y_i} = vertices of the polar {b : y_iᵀ b ≤ 1}
    let (p, n) = Polar::of(points, MAX_ENUMERATION_WORK, |direction| {
        RegionError::OriginNotInterior { direction }
    })?;
    verify(&p.kept(), &p.dual, &p.rows, n)?;
    // bᵀy = bᵀ(x/s) = (b/s)ᵀx
    let facets = unscale(&p.dual, &p.scales, "facet normal")?;
    let vertices = p.keep.iter().map(|&i| points[i].clone()).collect();
    Ok((
        Region {
            vertices,
            facets,
            generators: Vec::new(),
        },
        p.dropped(),
    ))
}

/// [`Region::from_halfspaces`], also returning the indices of the dropped rows.
pub(crate) fn hull_from_halfspaces(
    normals: &[DVector<f64>],
) -> Result<(Region, Vec<usize>), RegionError> {
    hull_within(normals, MAX_ENUMERATION_WORK)
}

/// [`hull_from_halfspaces`] with the enumeration's work limit `work`.
fn hull_within(normals: &[DVector<f64>], work: u64) -> Result<(Region, Vec<usize>), RegionError> {
    // aᵀx = (a/s)ᵀ(s·x): rows b = a/s, coordinates y = s·x
    let (p, n) = Polar::of(normals, work, |direction| RegionError::Unbounded {
        direction,
    })?;
    verify(&p.dual, &p.kept(), &p.dual, n)?;
    // the vertices also satisfy the rows that were dropped as redundant
    verify(&p.dual, &p.rows, &p.dual, n)?;
    let vertices = unscale(&p.dual, &p.scales, "vertex")?;
    let facets = p.keep.iter().map(|&i| normals[i].clone()).collect();
    Ok((
        Region {
            vertices,
            facets,
            generators: Vec::new(),
        },
        p.dropped(),
    ))
}

fn tight(a: &DVector<f64>, x: &DVector<f64>) -> bool {
    slack(a, x).abs() <= tol(a, x)
}

/// Indices of the rows a_k of {x : a_kᵀx ≤ 1} that are facets, given the
/// vertices: a_k is a facet iff the vertices on it span an (n−1)-dimensional
/// affine set; repeated rows are kept once.
fn irredundant(rows: &[DVector<f64>], vertices: &[DVector<f64>], n: usize) -> Vec<usize> {
    let mut keep: Vec<usize> = Vec::new();
    for (k, a) in rows.iter().enumerate() {
        if keep
            .iter()
            .any(|&j| (&rows[j] - a).norm() <= TOL * (1.0 + a.norm()))
        {
            continue;
        }
        let on: Vec<&DVector<f64>> = vertices.iter().filter(|v| tight(a, v)).collect();
        if on.len() < n {
            continue;
        }
        if n == 1 {
            keep.push(k);
            continue;
        }
        let d = DMatrix::from_fn(on.len() - 1, n, |i, j| on[i + 1][j] - on[0][j]);
        let scale = d
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()))
            .max(f64::MIN_POSITIVE);
        if (d / scale).rank(1e-8) == n - 1 {
            keep.push(k);
        }
    }
    keep
}
