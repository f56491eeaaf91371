//! Region construction from a box, from half-spaces and from vertices: a
//! square built each way is the same square, and unbounded half-spaces or
//! vertices whose hull does not have the origin inside (off it, on its
//! boundary, flat) are refused.

use nalgebra::DVector;
use qpv_dsl::{Region, RegionError};

fn v(x: &[f64]) -> DVector<f64> {
    DVector::from_column_slice(x)
}

#[test]
fn square_both_ways() {
    let b = Region::from_box(&[1.0, 2.0]).unwrap();
    assert_eq!(b.vertices.len(), 4);
    let h = Region::from_halfspaces(&b.facets).unwrap();
    assert_eq!(h.vertices.len(), 4);
    for x in &b.vertices {
        assert!(h.vertices.iter().any(|y| (x - y).norm() < 1e-12));
    }
    let w = Region::from_vertices(&b.vertices).unwrap();
    assert_eq!(w.facets.len(), 4);
}

#[test]
fn unbounded_and_off_origin() {
    assert!(matches!(
        Region::from_halfspaces(&[v(&[1.0, 0.0]), v(&[-1.0, 0.0]), v(&[0.0, 1.0])]),
        Err(RegionError::Unbounded { .. })
    ));
    assert!(matches!(
        Region::from_vertices(&[v(&[1.0, 0.0]), v(&[0.0, 1.0]), v(&[1.0, 1.0])]),
        Err(RegionError::OriginNotInterior { .. })
    ));
    // origin on the boundary
    assert!(matches!(
        Region::from_vertices(&[
            v(&[0.0, 0.0]),
            v(&[1.0, 0.0]),
            v(&[0.0, 1.0]),
            v(&[-1.0, 1.0])
        ]),
        Err(RegionError::OriginNotInterior { .. })
    ));
    // flat
    assert!(matches!(
        Region::from_vertices(&[v(&[1.0, 0.0]), v(&[-1.0, 0.0])]),
        Err(RegionError::OriginNotInterior { .. })
    ));
}
