//! The output post-filter: the augmented plant's right-hand side is the
//! plant's and the filter's, with the region and the state bound extended
//! as stated; the bound of the filter states holds on samples of the
//! boundary of F; a bad filter and an unresolved state bound are errors.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{OutputFilter, StateBound};
use qpv_solve::conditions::reference::{paper_model, paper_q};
use qpv_solve::linalg::sqrtm;
use qpv_solve::output_filter::{augment, filter_bound};

use crate::output_route::varying;

#[test]
fn augmented_plant_is_plant_plus_filter() {
    let m = varying();
    let f = OutputFilter {
        pole: 20.0,
        gain: 15.0,
    };
    let z = augment(&m, &f).unwrap();
    assert_eq!((z.nx(), z.ny(), z.nv()), (5, 2, 4));
    assert!(!z.output_varies());
    let theta = [0.3, 0.8];
    let x = DVector::from_vec(vec![0.01, -0.02, 0.015]);
    let xy = DVector::from_vec(vec![0.004, -0.007]);
    let mut zv = DVector::zeros(5);
    zv.rows_mut(0, 3).copy_from(&x);
    zv.rows_mut(3, 2).copy_from(&xy);
    // z' from the augmented polytopic data
    let mut dz = z.a_at(&theta) * &zv;
    for (k, nk) in z.n_at(&theta).iter().enumerate() {
        dz[k] += zv.dot(&(nk * &zv));
    }
    // the plant and the filter, directly
    let mut dx = m.a_at(&theta) * &x;
    for (k, nk) in m.n_at(&theta).iter().enumerate() {
        dx[k] += x.dot(&(nk * &x));
    }
    let y = m.output(&x, &theta);
    let dxy = &xy * (-f.pole) + &y * f.gain;
    for i in 0..3 {
        assert!((dz[i] - dx[i]).abs() < 1e-15);
    }
    for k in 0..2 {
        assert!((dz[3 + k] - dxy[k]).abs() < 1e-15);
    }
    assert!((z.output(&zv, &theta) - &xy).amax() < 1e-15);
    // region: (x_i, 0) and (a_k, 0); Q's plant block is Q
    assert!(z.region.vertices.iter().all(|v| v[3] == 0.0 && v[4] == 0.0));
    let StateBound::Given(qz) = &z.state_bound else {
        panic!("Q")
    };
    assert_eq!(
        qz.view((0, 0), (3, 3)),
        paper_model_q().view((0, 0), (3, 3))
    );
}

fn paper_model_q() -> DMatrix<f64> {
    paper_q()
}

#[test]
fn filter_bound_holds_on_samples() {
    let m = varying();
    let q = paper_model_q();
    let f = OutputFilter {
        pole: 10.0,
        gain: 10.0,
    };
    let h = filter_bound(&m, &q, &f);
    let r = sqrtm(&q);
    // |y_k| ≤ (a/|b|) h_k for x on the boundary of F and θ in the box
    let mut seed = 7u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64) / ((1u64 << 53) as f64)
    };
    for _ in 0..2000 {
        let u = DVector::from_fn(3, |_, _| rnd() - 0.5);
        let x = &r * u.normalize();
        let theta = [rnd(), rnd()];
        let y = m.output(&x, &theta);
        for k in 0..2 {
            assert!(y[k].abs() <= h[k] * f.pole / f.gain + 1e-12);
        }
    }
}

#[test]
fn bad_filter_and_unresolved_bound_are_errors() {
    let m = paper_model();
    let bad = OutputFilter {
        pole: -1.0,
        gain: 1.0,
    };
    assert!(augment(&m, &bad).is_err());
    let mut auto = m.clone();
    auto.state_bound = StateBound::Auto { h: None };
    assert!(augment(&auto, &OutputFilter::default()).is_err());
}
