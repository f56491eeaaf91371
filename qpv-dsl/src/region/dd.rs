//! The double-description kernel of [`super`]: the vertices of
//! {x ∈ Rⁿ : a_kᵀ x ≤ 1} (or a direction of unboundedness), enumerated on
//! the homogenised cone {(x, t) : a_kᵀ x ≤ t, t ≥ 0} by the double
//! description method (Motzkin et al.) with Fukuda & Prodon's
//! combinatorial adjacency test, under a work limit. The region's own
//! module does the scaling, the polarity and the verification around it.

use super::{MAX_RAYS, MAX_REGION_VERTICES, TOL};
use nalgebra::{DMatrix, DVector};

/// Failure of the vertex enumeration.
pub(super) enum Enum {
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
/// index from rows to the rays tight on them. The work is limited to
/// `limit` word operations (`MAX_ENUMERATION_WORK` for user input).
pub(super) fn enumerate_within(
    a: &[DVector<f64>],
    n: usize,
    limit: u64,
) -> Result<Vec<DVector<f64>>, Enum> {
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
