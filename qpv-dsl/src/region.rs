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

/// [`Region::from_vertices`], also returning the indices of the dropped points.
pub(crate) fn hull_from_vertices(
    points: &[DVector<f64>],
) -> Result<(Region, Vec<usize>), RegionError> {
    let n = check_points(points)?;
    let scales = column_scales(points, n);
    let y = divide(points, &scales);
    // facets of Co{y_i} = vertices of the polar {b : y_iᵀ b ≤ 1}
    let facets_y = match enumerate_vertices(&y, n) {
        Ok(f) => f,
        Err(Enum::Unbounded(d)) => {
            // yᵢᵀd ≤ 0 for all i, and yᵢᵀd = xᵢᵀ(d/s)
            return Err(RegionError::OriginNotInterior {
                direction: unscale_direction(&d, &scales),
            });
        }
        Err(Enum::Degenerate(reason)) => return Err(RegionError::Degenerate { reason }),
        Err(Enum::TooComplex) => return Err(RegionError::TooComplex),
    };
    let keep = irredundant(&y, &facets_y, n);
    let kept: Vec<DVector<f64>> = keep.iter().map(|&i| y[i].clone()).collect();
    verify(&kept, &facets_y, &y, n)?;
    // bᵀy = bᵀ(x/s) = (b/s)ᵀx
    let facets = unscale(&facets_y, &scales, "facet normal")?;
    let dropped = (0..points.len()).filter(|i| !keep.contains(i)).collect();
    let vertices = keep.iter().map(|&i| points[i].clone()).collect();
    Ok((
        Region {
            vertices,
            facets,
            generators: Vec::new(),
        },
        dropped,
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
    let n = check_points(normals)?;
    let scales = column_scales(normals, n);
    // aᵀx = (a/s)ᵀ(s·x): rows b = a/s, coordinates y = s·x
    let b = divide(normals, &scales);
    let vertices_y = match enumerate_within(&b, n, work) {
        Ok(v) => v,
        Err(Enum::Unbounded(d)) => {
            // y = s·x, so the direction in x is d/s
            return Err(RegionError::Unbounded {
                direction: unscale_direction(&d, &scales),
            });
        }
        Err(Enum::Degenerate(reason)) => return Err(RegionError::Degenerate { reason }),
        Err(Enum::TooComplex) => return Err(RegionError::TooComplex),
    };
    let keep = irredundant(&b, &vertices_y, n);
    let kept: Vec<DVector<f64>> = keep.iter().map(|&i| b[i].clone()).collect();
    verify(&vertices_y, &kept, &vertices_y, n)?;
    // the vertices also satisfy the rows that were dropped as redundant
    verify(&vertices_y, &b, &vertices_y, n)?;
    let vertices = unscale(&vertices_y, &scales, "vertex")?;
    let dropped = (0..normals.len()).filter(|i| !keep.contains(i)).collect();
    let facets = keep.iter().map(|&i| normals[i].clone()).collect();
    Ok((
        Region {
            vertices,
            facets,
            generators: Vec::new(),
        },
        dropped,
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

/// Failure of the vertex enumeration.
enum Enum {
    /// A direction d ≠ 0 with a_kᵀ d ≤ 0 for every row.
    Unbounded(DVector<f64>),
    /// Work limit exceeded.
    TooComplex,
    /// A vertex so far out (relative to the scale of the rows) that it
    /// cannot be told from a direction of unboundedness.
    Degenerate(String),
}

/// A ray of the homogenised cone with the set of processed constraints it
/// makes tight (a bit set over the constraint rows).
#[derive(Clone)]
struct Ray {
    z: Vec<f64>,
    zero: Vec<u64>,
}

fn insert(set: &mut [u64], i: usize) {
    set[i / 64] |= 1 << (i % 64);
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut s = 0.0;
    for i in 0..a.len() {
        s += a[i] * b[i];
    }
    s
}

fn normalize(z: &mut [f64]) -> f64 {
    let norm = dot(z, z).sqrt();
    if norm > 0.0 {
        for x in z.iter_mut() {
            *x /= norm;
        }
    }
    norm
}

/// Vertices of {x ∈ Rⁿ : a_kᵀ x ≤ 1}, or a direction of unboundedness.
///
/// Double description on the cone {z = (x, t) : t − a_kᵀx ≥ 0, t ≥ 0}:
/// start from the simplicial cone of d = n + 1 independent rows, then add
/// the other rows one at a time (in the given order, which did best on
/// degenerate inputs), combining each pair of adjacent rays on both sides of
/// the new hyperplane; adjacency is the combinatorial test with an inverted
/// index from rows to the rays tight on them.
fn enumerate_vertices(a: &[DVector<f64>], n: usize) -> Result<Vec<DVector<f64>>, Enum> {
    enumerate_within(a, n, MAX_ENUMERATION_WORK)
}

/// [`enumerate_vertices`] with the work limit `limit` (word operations).
fn enumerate_within(a: &[DVector<f64>], n: usize, limit: u64) -> Result<Vec<DVector<f64>>, Enum> {
    let h = homogenised_rows(a, n);
    let m = h.len();
    let basis = initial_basis(&h, n)?;
    let mut rays = initial_rays(&h, &basis, m.div_ceil(64))?;
    let mut work = Workspace::new(m, limit);
    for k in (0..m).filter(|k| !basis.contains(k)) {
        rays = add_row(rays, &h, k, n + 1, &mut work)?;
    }
    rays_to_vertices(&rays, a, n)
}

/// The rows (−a_k, 1), normalised, and last the row of t ≥ 0.
fn homogenised_rows(a: &[DVector<f64>], n: usize) -> Vec<Vec<f64>> {
    let mut h: Vec<Vec<f64>> = a
        .iter()
        .map(|ak| {
            let mut r: Vec<f64> = ak.iter().map(|x| -x).collect();
            r.push(1.0);
            normalize(&mut r);
            r
        })
        .collect();
    let mut t_row = vec![0.0; n + 1];
    t_row[n] = 1.0;
    h.push(t_row);
    h
}

/// `v` minus its projection on the orthonormal vectors `ortho`.
fn residual(v: &[f64], ortho: &[Vec<f64>]) -> Vec<f64> {
    let mut r = v.to_vec();
    for q in ortho {
        let c = dot(q, &r);
        for (x, y) in r.iter_mut().zip(q) {
            *x -= c * y;
        }
    }
    r
}

/// d = n + 1 linearly independent rows, greedily the most independent,
/// starting with t ≥ 0 (the last row). If the rows have rank < d, a
/// direction in their null space is a line of the cone: the polyhedron is
/// unbounded along it.
fn initial_basis(h: &[Vec<f64>], n: usize) -> Result<Vec<usize>, Enum> {
    let d = n + 1;
    let m = h.len();
    let mut basis: Vec<usize> = vec![m - 1];
    let mut ortho: Vec<Vec<f64>> = vec![h[m - 1].clone()];
    while basis.len() < d {
        let mut best: Option<(f64, usize, Vec<f64>)> = None;
        for (i, hi) in h.iter().enumerate() {
            if basis.contains(&i) {
                continue;
            }
            let r = residual(hi, &ortho);
            let norm = dot(&r, &r).sqrt();
            if best.as_ref().map_or(true, |b| norm > b.0) {
                best = Some((norm, i, r));
            }
        }
        match best {
            Some((norm, i, mut r)) if norm > 1e-9 => {
                basis.push(i);
                normalize(&mut r);
                ortho.push(r);
            }
            _ => {
                let mut dir = vec![0.0; d];
                let mut best_norm = 0.0;
                for j in 0..d {
                    let mut e = vec![0.0; d];
                    e[j] = 1.0;
                    let r = residual(&e, &ortho);
                    let norm = dot(&r, &r).sqrt();
                    if norm > best_norm {
                        best_norm = norm;
                        dir = r;
                    }
                }
                dir.truncate(n);
                normalize(&mut dir);
                return Err(Enum::Unbounded(DVector::from_vec(dir)));
            }
        }
    }
    Ok(basis)
}

/// The extreme rays of the simplicial cone of the basis rows: the columns
/// of the inverse of the basis matrix, each tight on all basis rows but one.
fn initial_rays(h: &[Vec<f64>], basis: &[usize], words: usize) -> Result<Vec<Ray>, Enum> {
    let d = basis.len();
    let b = DMatrix::from_fn(d, d, |i, j| h[basis[i]][j]);
    let binv = b.try_inverse().ok_or(Enum::TooComplex)?;
    Ok((0..d)
        .map(|i| {
            let mut z: Vec<f64> = binv.column(i).iter().copied().collect();
            normalize(&mut z);
            let mut zero = vec![0u64; words];
            for (j, &row) in basis.iter().enumerate() {
                if j != i {
                    insert(&mut zero, row);
                }
            }
            Ray { z, zero }
        })
        .collect())
}

/// Buffers reused by every [`add_row`] step.
struct Workspace {
    /// h_kᵀz for each current ray.
    vals: Vec<f64>,
    /// The rows two rays are both tight on.
    common: Vec<u64>,
    /// The rays tight on every row of `common` seen so far.
    acc: Vec<u64>,
    /// tight[j]: bit set over the current rays that are tight on row j.
    tight: Vec<Vec<u64>>,
    /// Word operations spent so far.
    done: u64,
    /// The most word operations allowed.
    limit: u64,
}

impl Workspace {
    fn new(rows: usize, limit: u64) -> Workspace {
        Workspace {
            vals: Vec::new(),
            common: vec![0; rows.div_ceil(64)],
            acc: Vec::new(),
            tight: vec![Vec::new(); rows],
            done: 0,
            limit,
        }
    }
}

/// One double-description step: the rays of the cone cut by row k (the
/// rays on its nonnegative side, plus one new ray for each adjacent pair
/// on opposite sides).
fn add_row(
    rays: Vec<Ray>,
    h: &[Vec<f64>],
    k: usize,
    d: usize,
    work: &mut Workspace,
) -> Result<Vec<Ray>, Enum> {
    let hk = &h[k];
    work.vals.clear();
    work.vals.extend(rays.iter().map(|r| dot(hk, &r.z)));
    let has_pos = work.vals.iter().any(|v| *v > TOL);
    let has_neg = work.vals.iter().any(|v| *v < -TOL);
    let mut created = Vec::new();
    if has_pos && has_neg {
        created = new_rays(&rays, k, d, work)?;
    }
    let mut next: Vec<Ray> = Vec::with_capacity(rays.len() + created.len());
    for (r, &v) in rays.into_iter().zip(&work.vals) {
        if v >= -TOL {
            let mut r = r;
            if v <= TOL {
                insert(&mut r.zero, k);
            }
            next.push(r);
        }
    }
    next.extend(created);
    if next.len() > MAX_RAYS {
        return Err(Enum::TooComplex);
    }
    Ok(next)
}

/// The rays that row k creates: one per adjacent pair (p, q) with p on its
/// positive and q on its negative side, on the hyperplane between them.
/// Charges the work to `work.done` and stops at `work.limit`.
fn new_rays(rays: &[Ray], k: usize, d: usize, work: &mut Workspace) -> Result<Vec<Ray>, Enum> {
    let rwords = rays.len().div_ceil(64);
    let mut negative = vec![0u64; rwords];
    let mut needed = vec![0u64; work.common.len()];
    for (q, v) in work.vals.iter().enumerate() {
        if *v < -TOL {
            insert(&mut negative, q);
        } else if *v > TOL {
            for (n, z) in needed.iter_mut().zip(&rays[q].zero) {
                *n |= *z;
            }
        }
    }
    index_tight_rows(rays, &needed, &mut work.tight);
    let needed_rows = needed.iter().map(|w| w.count_ones()).sum::<u32>() as usize;
    work.done += (rays.len() * (2 * needed.len() + d) + needed_rows * rwords) as u64;
    let mut created = Vec::new();
    let mut candidates = vec![0u64; rwords];
    for p in 0..rays.len() {
        if work.vals[p] <= TOL {
            continue;
        }
        partners(&rays[p].zero, &negative, d, &work.tight, &mut candidates);
        let tight_rows = rays[p].zero.iter().map(|w| w.count_ones()).sum::<u32>() as u64;
        let tested = candidates.iter().map(|w| w.count_ones()).sum::<u32>() as u64;
        work.done += (tight_rows + 1 + tested) * rwords as u64 + tested * work.common.len() as u64;
        if work.done > work.limit {
            return Err(Enum::TooComplex);
        }
        for q in bits(&candidates) {
            if !adjacent(rays, p, q, d, work) {
                continue;
            }
            let (vp, vq) = (work.vals[p], work.vals[q]);
            let mut z: Vec<f64> = (0..d)
                .map(|i| vp * rays[q].z[i] - vq * rays[p].z[i])
                .collect();
            if normalize(&mut z) <= f64::MIN_POSITIVE {
                continue;
            }
            let mut zero = work.common.clone();
            insert(&mut zero, k);
            created.push(Ray { z, zero });
            if created.len() > MAX_RAYS {
                return Err(Enum::TooComplex);
            }
        }
    }
    Ok(created)
}

/// The rays on the negative side that may be adjacent to a ray whose tight
/// rows are `zero_p`: adjacent rays share at least d − 2 tight rows, so for
/// d > 2 they share at least one, and the candidates are the union of the
/// inverted index over p's tight rows (instead of every negative ray).
fn partners(zero_p: &[u64], negative: &[u64], d: usize, tight: &[Vec<u64>], out: &mut [u64]) {
    if d <= 2 {
        out.copy_from_slice(negative);
        return;
    }
    out.fill(0);
    for j in bits(zero_p) {
        for (o, t) in out.iter_mut().zip(&tight[j]) {
            *o |= *t;
        }
    }
    for (o, n) in out.iter_mut().zip(negative) {
        *o &= *n;
    }
}

/// The indices of the set bits of a bit set, in increasing order.
fn bits(set: &[u64]) -> impl Iterator<Item = usize> + '_ {
    set.iter().enumerate().flat_map(|(w, &word)| {
        let mut b = word;
        std::iter::from_fn(move || {
            if b == 0 {
                return None;
            }
            let j = w * 64 + b.trailing_zeros() as usize;
            b &= b - 1;
            Some(j)
        })
    })
}

/// The inverted index of the rays' zero sets, for the rows in `needed`
/// only (the rows a positive ray is tight on: the only ones the adjacency
/// tests of this step read): tight[j] = the rays tight on row j.
fn index_tight_rows(rays: &[Ray], needed: &[u64], tight: &mut [Vec<u64>]) {
    let rwords = rays.len().div_ceil(64);
    for j in bits(needed) {
        tight[j].clear();
        tight[j].resize(rwords, 0);
    }
    for (i, r) in rays.iter().enumerate() {
        for (w, (&bitsw, &need)) in r.zero.iter().zip(needed).enumerate() {
            let mut b = bitsw & need;
            while b != 0 {
                let j = w * 64 + b.trailing_zeros() as usize;
                insert(&mut tight[j], i);
                b &= b - 1;
            }
        }
    }
}

/// The combinatorial adjacency test of rays p and q: they share at least
/// d − 2 tight rows, and no other ray is tight on all of them. Leaves the
/// shared rows in `work.common`.
fn adjacent(rays: &[Ray], p: usize, q: usize, d: usize, work: &mut Workspace) -> bool {
    let (zp, zq) = (&rays[p].zero, &rays[q].zero);
    let mut count = 0u32;
    for (w, c) in work.common.iter_mut().enumerate() {
        *c = zp[w] & zq[w];
        count += c.count_ones();
    }
    if (count as usize) + 2 < d {
        return false;
    }
    let rwords = rays.len().div_ceil(64);
    work.acc.clear();
    work.acc.resize(rwords, u64::MAX);
    if rays.len() % 64 != 0 {
        work.acc[rwords - 1] = (1u64 << (rays.len() % 64)) - 1;
    }
    if rays.len() <= 2 {
        return true;
    }
    for (w, &cw) in work.common.iter().enumerate() {
        let mut b = cw;
        while b != 0 {
            let j = w * 64 + b.trailing_zeros() as usize;
            b &= b - 1;
            let mut left = 0u32;
            for (x, t) in work.acc.iter_mut().zip(&work.tight[j]) {
                *x &= *t;
                left += x.count_ones();
            }
            if left <= 2 {
                return true; // only p and q remain
            }
        }
    }
    false
}

/// The vertices x = z_x / t of the final rays (repeats removed), or a
/// direction of unboundedness if a ray has t = 0 (told apart from a vertex
/// that is merely very far out).
fn rays_to_vertices(rays: &[Ray], a: &[DVector<f64>], n: usize) -> Result<Vec<DVector<f64>>, Enum> {
    let mut vertices: Vec<DVector<f64>> = Vec::new();
    for r in rays {
        let t = r.z[n];
        let mut x = r.z[..n].to_vec();
        if t <= 1e-10 {
            normalize(&mut x);
            // a true direction of unboundedness has a_kᵀd ≤ 0 on every row
            if a.iter()
                .all(|ak| dot(ak.as_slice(), &x) <= 1e-7 * ak.norm())
            {
                return Err(Enum::Unbounded(DVector::from_vec(x)));
            }
            return Err(Enum::Degenerate(
                "a vertex lies more than 1e10 times farther out than the scale of the data \
                 (the region is nearly unbounded, or the origin nearly on its boundary)"
                    .into(),
            ));
        }
        let v = DVector::from_vec(x) / t;
        if !vertices
            .iter()
            .any(|w| (w - &v).norm() <= TOL * (1.0 + v.norm()))
        {
            vertices.push(v);
        }
        if vertices.len() > MAX_REGION_VERTICES {
            return Err(Enum::TooComplex);
        }
    }
    Ok(vertices)
}
