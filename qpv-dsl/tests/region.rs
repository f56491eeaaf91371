//! Region conversion: V → H → V (and H → V → H) round trips on a box, a
//! simplex, a cross-polytope and random polytopes, with an independent
//! brute-force facet enumeration as the reference in low dimension.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{Region, RegionError};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn sym(&mut self) -> f64 {
        2.0 * ((self.next() >> 11) as f64 / (1u64 << 53) as f64) - 1.0
    }
}

fn same_set(a: &[DVector<f64>], b: &[DVector<f64>], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: {} vs {}", a.len(), b.len());
    for x in a {
        assert!(
            b.iter().any(|y| (x - y).norm() <= 1e-9 * (1.0 + x.norm())),
            "{what}: {x} missing"
        );
    }
}

/// Every vertex satisfies every facet, and each facet is tight at ≥ n vertices.
fn consistent(r: &Region, what: &str) {
    let n = r.dim();
    for a in &r.facets {
        let mut on = 0;
        for v in &r.vertices {
            let s = a.dot(v);
            assert!(
                s <= 1.0 + 1e-9,
                "{what}: vertex {v} violates facet {a} ({s})"
            );
            if (s - 1.0).abs() <= 1e-9 {
                on += 1;
            }
        }
        assert!(on >= n, "{what}: facet {a} touches only {on} vertices");
    }
}

fn round_trip(points: &[DVector<f64>], facets_expected: Option<usize>, what: &str) -> Region {
    let v = Region::from_vertices(points).unwrap_or_else(|e| panic!("{what}: {e}"));
    consistent(&v, what);
    if let Some(k) = facets_expected {
        assert_eq!(v.facets.len(), k, "{what}: facet count");
    }
    let h = Region::from_halfspaces(&v.facets).unwrap_or_else(|e| panic!("{what}: {e}"));
    same_set(&v.vertices, &h.vertices, &format!("{what}: V→H→V vertices"));
    same_set(&v.facets, &h.facets, &format!("{what}: V→H→V facets"));
    for p in points {
        assert!(v.contains(p), "{what}: input point outside its hull");
    }
    v
}

fn unit(n: usize, i: usize, s: f64) -> DVector<f64> {
    let mut e = DVector::zeros(n);
    e[i] = s;
    e
}

#[test]
fn boxes() {
    for n in 1..=6 {
        let radii: Vec<f64> = (0..n).map(|i| 0.5 + i as f64).collect();
        let b = Region::from_box(&radii).unwrap();
        assert_eq!(b.vertices.len(), 1 << n);
        assert_eq!(b.facets.len(), 2 * n);
        let v = round_trip(&b.vertices, Some(2 * n), &format!("box {n}"));
        same_set(&v.facets, &b.facets, &format!("box {n}: facets"));
        let h = Region::from_halfspaces(&b.facets).unwrap();
        same_set(&h.vertices, &b.vertices, &format!("box {n}: H→V"));
    }
}

#[test]
fn simplices() {
    for n in 1..=6 {
        let c = 1.0 / (n as f64 + 1.0);
        let mut pts: Vec<DVector<f64>> = (0..n).map(|i| unit(n, i, 1.0).add_scalar(-c)).collect();
        pts.push(DVector::from_element(n, -c));
        let r = round_trip(&pts, Some(n + 1), &format!("simplex {n}"));
        assert_eq!(r.vertices.len(), n + 1);
    }
}

#[test]
fn cross_polytopes() {
    for n in 1..=6 {
        let pts: Vec<DVector<f64>> = (0..n)
            .flat_map(|i| [unit(n, i, 2.0), unit(n, i, -2.0)])
            .collect();
        let r = round_trip(&pts, Some(1 << n), &format!("cross-polytope {n}"));
        // facets are (±1, ..., ±1)/2
        for a in &r.facets {
            assert!(a.iter().all(|x| (x.abs() - 0.5).abs() < 1e-12), "{a}");
        }
    }
}

/// Facets of Co(points) by brute force: every n-subset spanning a hyperplane
/// with all points on one side (origin side), normalised to aᵀx = 1.
fn brute_facets(points: &[DVector<f64>], n: usize) -> Vec<DVector<f64>> {
    let mut out: Vec<DVector<f64>> = Vec::new();
    let m = points.len();
    let mut idx: Vec<usize> = (0..n).collect();
    loop {
        let a = DMatrix::from_fn(n, n, |i, j| points[idx[i]][j]);
        if let Some(inv) = a.clone().try_inverse() {
            // aᵀx = 1 through the n points: a = A⁻¹ 1
            let normal = inv * DVector::from_element(n, 1.0);
            if points.iter().all(|p| normal.dot(p) <= 1.0 + 1e-9)
                && !out
                    .iter()
                    .any(|o| (o - &normal).norm() < 1e-9 * (1.0 + normal.norm()))
            {
                out.push(normal);
            }
        }
        // next combination
        let mut i = n;
        loop {
            if i == 0 {
                return out;
            }
            i -= 1;
            if idx[i] < m - n + i {
                idx[i] += 1;
                for j in i + 1..n {
                    idx[j] = idx[j - 1] + 1;
                }
                break;
            }
        }
    }
}

#[test]
fn random_polytopes() {
    let mut rng = Rng(0xDEAD_BEEF_CAFE_F00D);
    for n in 2..=6 {
        for trial in 0..4 {
            let count = match n {
                2 | 3 => 18,
                4 => 16,
                5 => 14,
                _ => 12,
            };
            let mut pts: Vec<DVector<f64>> = (0..count)
                .map(|_| DVector::from_fn(n, |_, _| rng.sym()))
                .collect();
            // guarantee the origin strictly inside: a small cross-polytope
            for i in 0..n {
                pts.push(unit(n, i, 0.05));
                pts.push(unit(n, i, -0.05));
            }
            let what = format!("random polytope n={n} #{trial}");
            let r = round_trip(&pts, None, &what);
            assert!(r.vertices.len() <= pts.len());
            // the dropped points are inside the hull of the kept ones
            let again = Region::from_vertices(&r.vertices).unwrap();
            same_set(&again.facets, &r.facets, &what);
            if n <= 4 {
                let brute = brute_facets(&pts, n);
                same_set(&r.facets, &brute, &format!("{what}: vs brute force"));
            }
        }
    }
}

#[test]
fn h_to_v_to_h_with_redundant_rows() {
    // a square with a redundant and a repeated facet
    let rows = vec![
        DVector::from_vec(vec![1.0, 0.0]),
        DVector::from_vec(vec![-1.0, 0.0]),
        DVector::from_vec(vec![0.0, 1.0]),
        DVector::from_vec(vec![0.0, -1.0]),
        DVector::from_vec(vec![0.5, 0.5]),
        DVector::from_vec(vec![1.0, 0.0]),
    ];
    let r = Region::from_halfspaces(&rows).unwrap();
    assert_eq!(r.facets.len(), 4);
    assert_eq!(r.vertices.len(), 4);
    let back = Region::from_vertices(&r.vertices).unwrap();
    same_set(&back.facets, &r.facets, "square");
}

#[test]
fn rejects_bad_regions() {
    let v = |x: &[f64]| DVector::from_column_slice(x);
    assert!(matches!(
        Region::from_halfspaces(&[v(&[1.0, 0.0]), v(&[-1.0, 0.0])]),
        Err(RegionError::Unbounded { .. })
    ));
    assert!(matches!(
        Region::from_vertices(&[v(&[1.0, 1.0]), v(&[2.0, 1.0]), v(&[1.0, 2.0])]),
        Err(RegionError::OriginNotInterior { .. })
    ));
    assert!(matches!(
        Region::from_box(&[1.0, 0.0]),
        Err(RegionError::BadRadius { index: 1 })
    ));
    // Boxes and parallelotopes go up to 16 states (cube conditions never
    // enumerate their 2^16 vertices pairwise); 17 is refused.
    assert!(Region::from_box(&[1.0; 16]).is_ok());
    assert!(matches!(
        Region::from_box(&[1.0; 17]),
        Err(RegionError::TooComplex)
    ));
    assert!(matches!(
        Region::from_vertices(&[]),
        Err(RegionError::Empty)
    ));
    assert!(matches!(
        Region::from_vertices(&[v(&[1.0, f64::NAN])]),
        Err(RegionError::BadPoint { index: 0 })
    ));
}

// ---------------------------------------------------------------------------
// Exact reference: integer data, i128 arithmetic with overflow checks.
//
// The random regions below have coordinates m · 2^e_j with small integers m
// and a power-of-two scale 2^e_j per coordinate (2^-20 ≈ 1e-6 to 2^20 ≈ 1e6),
// so the floating-point input is exactly a diagonal rescaling of integer
// data. The reference enumerates the integer problem with exact rationals
// (facets and vertices by brute force over n-subsets) and applies the same
// diagonal scaling to its answer; degenerate configurations (points on
// faces, repeated rows, redundant halfspaces) are frequent with small
// integers, so the tolerances of the conversion are exercised too.
// ---------------------------------------------------------------------------

fn checked(x: Option<i128>) -> i128 {
    x.expect("exact reference overflowed i128 (use smaller integers)")
}

/// Determinant of an integer n × n matrix (Bareiss elimination).
fn det(m: &[Vec<i128>]) -> i128 {
    let n = m.len();
    let mut a: Vec<Vec<i128>> = m.to_vec();
    let mut sign = 1i128;
    let mut prev = 1i128;
    for k in 0..n {
        if a[k][k] == 0 {
            match (k + 1..n).find(|&i| a[i][k] != 0) {
                Some(i) => {
                    a.swap(k, i);
                    sign = -sign;
                }
                None => return 0,
            }
        }
        for i in k + 1..n {
            for j in k + 1..n {
                let v = checked(
                    checked(a[i][j].checked_mul(a[k][k]))
                        .checked_sub(checked(a[i][k].checked_mul(a[k][j]))),
                );
                a[i][j] = v / prev;
            }
        }
        prev = a[k][k];
    }
    sign * a[n - 1][n - 1]
}

fn gcd(a: i128, b: i128) -> i128 {
    if b == 0 {
        a.abs()
    } else {
        gcd(b, a % b)
    }
}

/// Rank of a set of integer vectors (elimination with gcd-reduced rows).
fn rank(rows: &[Vec<i128>], n: usize) -> usize {
    let mut a: Vec<Vec<i128>> = rows.to_vec();
    let mut r = 0;
    for c in 0..n {
        let Some(p) = (r..a.len()).find(|&i| a[i][c] != 0) else {
            continue;
        };
        a.swap(r, p);
        for i in 0..a.len() {
            if i != r && a[i][c] != 0 {
                let (x, y) = (a[r][c], a[i][c]);
                let pivot = a[r].clone();
                let mut g = 0;
                for (v, p) in a[i].iter_mut().zip(&pivot) {
                    *v = checked(checked(v.checked_mul(x)).checked_sub(checked(p.checked_mul(y))));
                    g = gcd(g, *v);
                }
                if g > 1 {
                    for v in a[i].iter_mut() {
                        *v /= g;
                    }
                }
            }
        }
        r += 1;
    }
    r
}

/// A rational vector num/den with den > 0, reduced.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Rat {
    num: Vec<i128>,
    den: i128,
}

impl Rat {
    fn new(mut num: Vec<i128>, mut den: i128) -> Rat {
        if den < 0 {
            den = -den;
            num.iter_mut().for_each(|x| *x = -*x);
        }
        let g = num.iter().fold(den, |g, x| gcd(g, *x));
        Rat {
            num: num.iter().map(|x| x / g).collect(),
            den: den / g,
        }
    }
    /// aᵀ(num/den) compared with 1: the sign of aᵀnum − den.
    fn side(&self, a: &[i128]) -> i128 {
        let s = a.iter().zip(&self.num).fold(0i128, |s, (x, y)| {
            checked(s.checked_add(checked(x.checked_mul(*y))))
        });
        (s - self.den).signum()
    }
    fn to_f64(&self) -> Vec<f64> {
        self.num
            .iter()
            .map(|x| *x as f64 / self.den as f64)
            .collect()
    }
}

/// Every n-subset of 0..m.
fn subsets(m: usize, n: usize, mut f: impl FnMut(&[usize])) {
    if n > m {
        return;
    }
    let mut idx: Vec<usize> = (0..n).collect();
    loop {
        f(&idx);
        let mut i = n;
        loop {
            if i == 0 {
                return;
            }
            i -= 1;
            if idx[i] < m - n + i {
                idx[i] += 1;
                for j in i + 1..n {
                    idx[j] = idx[j - 1] + 1;
                }
                break;
            }
        }
    }
}

/// The vertices of {x : a_kᵀx ≤ 1} for integer rows (assumed bounded), and
/// the indices of the rows that are facets (the first of repeated rows).
fn exact_h_to_v(rows: &[Vec<i128>], n: usize) -> (Vec<Rat>, Vec<usize>) {
    let mut vertices: Vec<Rat> = Vec::new();
    subsets(rows.len(), n, |s| {
        let m: Vec<Vec<i128>> = s.iter().map(|&i| rows[i].clone()).collect();
        let d = det(&m);
        if d == 0 {
            return;
        }
        // Cramer: x_j = det(M with column j replaced by 1) / det(M)
        let num: Vec<i128> = (0..n)
            .map(|j| {
                let mj: Vec<Vec<i128>> = m
                    .iter()
                    .map(|r| {
                        let mut r = r.clone();
                        r[j] = 1;
                        r
                    })
                    .collect();
                det(&mj)
            })
            .collect();
        let x = Rat::new(num, d);
        if rows.iter().all(|a| x.side(a) <= 0) && !vertices.contains(&x) {
            vertices.push(x);
        }
    });
    let mut facets = Vec::new();
    for (k, a) in rows.iter().enumerate() {
        if rows[..k].contains(a) {
            continue;
        }
        let on: Vec<Vec<i128>> = vertices
            .iter()
            .filter(|x| x.side(a) == 0)
            .map(|x| x.num.clone())
            .collect();
        // a hyperplane off the origin: n linearly independent points on it
        // span an (n−1)-dimensional face
        if rank(&on, n) == n {
            facets.push(k);
        }
    }
    (vertices, facets)
}

/// Scale exponents e_j in [-20, 20] (2^±20 ≈ 1e±6), always including both
/// extremes when n ≥ 2.
fn exponents(rng: &mut Rng, n: usize) -> Vec<i32> {
    let mut e: Vec<i32> = (0..n).map(|_| ((rng.next() % 41) as i32) - 20).collect();
    if n >= 2 {
        e[0] = -20;
        e[n - 1] = 20;
    }
    e
}

/// Random integer rows in [-k, k]ⁿ plus ±e_j (so that the origin is
/// strictly inside their hull).
fn integer_rows(rng: &mut Rng, n: usize, count: usize, k: i128) -> Vec<Vec<i128>> {
    let mut rows: Vec<Vec<i128>> = (0..count)
        .map(|_| {
            (0..n)
                .map(|_| (rng.next() % (2 * k as u64 + 1)) as i128 - k)
                .collect()
        })
        .collect();
    for j in 0..n {
        for s in [1, -1] {
            let mut e = vec![0i128; n];
            e[j] = s;
            rows.push(e);
        }
    }
    // a few exact repeats and scaled copies inside, to exercise degeneracy
    let r0 = rows[0].clone();
    rows.push(r0);
    rows
}

fn close(x: &[f64], y: &[f64]) -> bool {
    let scale = 1.0 + y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    x.iter().zip(y).all(|(a, b)| (a - b).abs() <= 1e-9 * scale)
}

/// Compares a computed set of vectors (already mapped back to the integer
/// problem's coordinates) with the exact reference, as sets.
fn same_as_exact(got: &[Vec<f64>], exact: &[Rat], what: &str) {
    assert_eq!(
        got.len(),
        exact.len(),
        "{what}: {} computed, {} exact",
        got.len(),
        exact.len()
    );
    for r in exact {
        let e = r.to_f64();
        assert!(
            got.iter().any(|g| close(g, &e)),
            "{what}: exact {e:?} missing from {got:?}"
        );
    }
}

#[test]
fn agrees_with_exact_enumeration_across_scales() {
    let mut rng = Rng(0x5CA1_E1DE_A5E5_0001);
    for n in 2..=5 {
        for trial in 0..8 {
            let count = [0, 0, 10, 10, 9, 8][n];
            let k = if n == 5 { 6 } else { 9 };
            let e = exponents(&mut rng, n);
            let what = format!("n={n} #{trial} exponents {e:?}");

            // vertices form: x_ij = m_ij · 2^e_j; facets a_j = b_j / 2^e_j
            let pts = integer_rows(&mut rng, n, count, k);
            let x: Vec<DVector<f64>> = pts
                .iter()
                .map(|p| DVector::from_fn(n, |j, _| p[j] as f64 * 2f64.powi(e[j])))
                .collect();
            let (exact_facets, exact_vertex_rows) = exact_v_to_h(&pts, n);
            let r = Region::from_vertices(&x).unwrap_or_else(|err| panic!("{what}: {err}"));
            let facets: Vec<Vec<f64>> = r
                .facets
                .iter()
                .map(|a| (0..n).map(|j| a[j] * 2f64.powi(e[j])).collect())
                .collect();
            same_as_exact(&facets, &exact_facets, &format!("{what}: V→H facets"));
            assert_eq!(
                r.vertices.len(),
                exact_vertex_rows.len(),
                "{what}: V→H kept vertices"
            );
            for i in &exact_vertex_rows {
                assert!(r.vertices.contains(&x[*i]), "{what}: vertex {i} dropped");
            }

            // halfspaces form: rows a_kj = m_kj / 2^e_j; vertices x_j = y_j · 2^e_j
            let rows = integer_rows(&mut rng, n, count, k);
            let a: Vec<DVector<f64>> = rows
                .iter()
                .map(|p| DVector::from_fn(n, |j, _| p[j] as f64 / 2f64.powi(e[j])))
                .collect();
            let (exact_vertices, exact_facet_rows) = exact_h_to_v(&rows, n);
            let r = Region::from_halfspaces(&a).unwrap_or_else(|err| panic!("{what}: {err}"));
            let vertices: Vec<Vec<f64>> = r
                .vertices
                .iter()
                .map(|v| (0..n).map(|j| v[j] / 2f64.powi(e[j])).collect())
                .collect();
            same_as_exact(&vertices, &exact_vertices, &format!("{what}: H→V vertices"));
            assert_eq!(
                r.facets.len(),
                exact_facet_rows.len(),
                "{what}: H→V kept facets"
            );
            for k in &exact_facet_rows {
                assert!(r.facets.contains(&a[*k]), "{what}: facet {k} dropped");
            }
            // every computed vertex lies in the region it came from
            for v in &r.vertices {
                assert!(r.contains(v), "{what}: vertex outside");
            }
        }
    }
}

/// The facets of Co{p_i} for integer points (origin strictly inside), and
/// the indices of the points that are vertices (the first of repeats).
fn exact_v_to_h(points: &[Vec<i128>], n: usize) -> (Vec<Rat>, Vec<usize>) {
    // polarity: the facets of Co{p_i} are the vertices of {a : p_iᵀa ≤ 1}
    exact_h_to_v(points, n)
}

fn diamond(n: usize, r: f64) -> Vec<DVector<f64>> {
    (0..n)
        .flat_map(|i| [unit(n, i, r), unit(n, i, -r)])
        .collect()
}

#[test]
fn extreme_radii_are_converted_or_refused() {
    for n in 2..=4 {
        for r in [1e-300, 1e-12, 1e-9, 1e-6, 1e6, 1e9, 1e12, 1e300] {
            // box by halfspaces
            let b = Region::from_box(&vec![r; n]).unwrap();
            let h = Region::from_halfspaces(&b.facets)
                .unwrap_or_else(|e| panic!("box {r:e} in {n}D by halfspaces: {e}"));
            assert_eq!(h.vertices.len(), 1 << n, "box {r:e}");
            assert_eq!(h.facets.len(), 2 * n, "box {r:e}");
            for v in &h.vertices {
                assert!(
                    b.vertices.iter().any(|w| (v - w).norm() <= 1e-9 * w.norm()),
                    "box {r:e}: vertex {v}"
                );
            }
            // box by vertices
            let v = Region::from_vertices(&b.vertices)
                .unwrap_or_else(|e| panic!("box {r:e} in {n}D by vertices: {e}"));
            assert_eq!(v.facets.len(), 2 * n, "box {r:e}");
            // diamond by vertices and back
            let d = Region::from_vertices(&diamond(n, r))
                .unwrap_or_else(|e| panic!("diamond {r:e} in {n}D: {e}"));
            assert_eq!(d.vertices.len(), 2 * n, "diamond {r:e}");
            assert_eq!(d.facets.len(), 1 << n, "diamond {r:e}");
            for a in &d.facets {
                assert!(
                    a.iter().all(|x| (x.abs() * r - 1.0).abs() < 1e-9),
                    "diamond {r:e}: facet {a}"
                );
            }
            let back = Region::from_halfspaces(&d.facets).unwrap();
            assert_eq!(back.vertices.len(), 2 * n, "diamond {r:e} back");
        }
    }
    // mixed scales in one region: 1e-9 and 1e9 side by side
    let b = Region::from_box(&[1e-9, 1e9, 1.0]).unwrap();
    let h = Region::from_halfspaces(&b.facets).unwrap();
    assert_eq!(h.vertices.len(), 8);
    let v = Region::from_vertices(&b.vertices).unwrap();
    assert_eq!(v.facets.len(), 6);
    // a point just outside in the small coordinate is outside
    assert!(!h.contains(&DVector::from_vec(vec![1.5e-9, 0.0, 0.0])));
    assert!(h.contains(&DVector::from_vec(vec![0.5e-9, 0.9e9, 0.0])));
}

#[test]
fn unrepresentable_regions_are_refused() {
    let v = |x: &[f64]| DVector::from_column_slice(x);
    // a box radius whose facet normal 1/r overflows
    assert!(matches!(
        Region::from_box(&[1.0, 1e-320]),
        Err(RegionError::Degenerate { .. })
    ));
    // halfspaces so small that the vertices overflow
    let rows = [
        v(&[1e-320, 0.0]),
        v(&[-1e-320, 0.0]),
        v(&[0.0, 1.0]),
        v(&[0.0, -1.0]),
    ];
    let err = Region::from_halfspaces(&rows).unwrap_err();
    assert!(matches!(err, RegionError::Degenerate { .. }), "{err}");
    assert!(err.to_string().contains("double precision"), "{err}");
    // still unbounded and still flat, at any scale
    for s in [1e-12, 1.0, 1e12] {
        assert!(matches!(
            Region::from_halfspaces(&[v(&[s, 0.0]), v(&[-s, 0.0]), v(&[0.0, s])]),
            Err(RegionError::Unbounded { .. })
        ));
        assert!(matches!(
            Region::from_vertices(&[v(&[s, 0.0]), v(&[-s, 0.0])]),
            Err(RegionError::OriginNotInterior { .. })
        ));
    }
    // too many rows
    let many: Vec<DVector<f64>> = (0..5000)
        .map(|i| {
            let t = i as f64 * 0.001;
            v(&[t.cos(), t.sin()])
        })
        .collect();
    assert!(matches!(
        Region::from_vertices(&many),
        Err(RegionError::TooComplex)
    ));
}

/// `m` unit normals in `n` dimensions, spread by a xorshift generator: each
/// is a facet, so the polytope has many vertices.
fn sphere_rows(n: usize, m: usize) -> Vec<DVector<f64>> {
    let mut s: u64 = 12345;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..m)
        .map(|_| {
            let v = DVector::from_fn(n, |_, _| next());
            let norm = v.norm();
            v / norm
        })
        .collect()
}

/// Many halfspaces in a few dimensions: the enumeration is exact within its
/// work limit and refused (not run for minutes) beyond it.
#[test]
fn the_halfspace_enumeration_has_a_work_limit() {
    let rows = sphere_rows(4, 300);
    let r = Region::from_halfspaces(&rows).expect("300 halfspaces in 4-D fit the default limit");
    assert!(r.vertices.len() > 1000, "{} vertices", r.vertices.len());
    assert_eq!(r.facets.len(), 300);
    for v in &r.vertices {
        assert!(r.contains(v));
        assert!(rows.iter().all(|a| a.dot(v) <= 1.0 + 1e-7));
    }
    // the same rows with a limit far below what they need
    assert!(matches!(
        Region::from_halfspaces_within(&rows, 1_000_000),
        Err(RegionError::TooComplex)
    ));
    let e = Region::from_halfspaces_within(&rows, 1_000_000).unwrap_err();
    assert!(e.to_string().contains("work limit"), "{e}");
    // and enough work gives the same polytope as the default
    let again = Region::from_halfspaces_within(&rows, u64::MAX).expect("no limit");
    assert_eq!(again.vertices.len(), r.vertices.len());
}

/// A box with one corner cut off: degenerate (many rays tight on the same
/// rows), where a missed adjacent pair in the enumeration would lose a vertex.
#[test]
fn a_cut_box_keeps_every_vertex() {
    for n in 2..=6 {
        let mut rows = Vec::new();
        for j in 0..n {
            let mut e = DVector::zeros(n);
            e[j] = 1.0;
            rows.push(e.clone());
            rows.push(-e);
        }
        rows.push(DVector::from_element(n, 1.0 / (n as f64 - 0.5)));
        let r = Region::from_halfspaces(&rows).expect("cut box");
        // 2^n corners but the cut one, and n points on its edges
        assert_eq!(r.vertices.len(), (1 << n) - 1 + n, "n = {n}");
    }
}
