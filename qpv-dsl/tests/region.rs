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
    assert!(matches!(
        Region::from_box(&[1.0; 13]),
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
