//! The certified f32 error floor (`qpv_solve::certificate::rounding`,
//! docs/method.md §15, "The f32 error floor") from the baked numbers of
//! the paper's example at α = 5, γ = 0.18898, for given rounding bounds.

use nalgebra::DMatrix;
use qpv_dsl::{DesignRequest, Float, GammaSpec, PolytopicModel};
use qpv_solve::certificate::rounding::{box_p_norm, RhsRounding};
use qpv_solve::export::Baked;
use qpv_solve::{design, Settings};

fn baked() -> Baked {
    let models = qpv_dsl::parse(include_str!("../../tests/nostd/paper_sound.qpv"))
        .expect("the paper model parses");
    let poly: PolytopicModel = models[0].polytopic();
    let req = DesignRequest {
        alpha: qpv_dsl::AlphaSpec::Fixed(5.0),
        gamma: GammaSpec::Fixed(0.18898),
        ..DesignRequest::default()
    };
    let d = design(&poly, &req, &Settings::default()).expect("design runs");
    Baked::solved(&poly, d, Float::F32).expect("certified after rounding")
}

fn rounding(d0: f64, d1: f64) -> RhsRounding {
    RhsRounding {
        constant: vec![d0; 3],
        proportional: vec![d1; 3],
        derivative: vec![1.0; 3],
        state: vec![1.0; 3],
    }
}

#[test]
fn box_norm_is_the_worst_corner() {
    let p = DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 2.0]);
    // corners (1, 1): vᵀPv = 2; (1, −1): 6
    let v = box_p_norm(&p, &[1.0, 1.0]);
    assert!((v - 6f64.sqrt()).abs() < 1e-8, "{v}");
}

#[test]
fn the_floor_follows_the_split_and_refuses_what_eats_the_rate() {
    let b = baked();
    let d = b.design();
    let p = d.p_matrix();
    // no rounding: no floor
    let zero = b
        .f32_floor(|_, _| Ok(rounding(0.0, 0.0)))
        .expect("certified");
    assert_eq!(zero.error_bound, 0.0);
    // the direct bound: ρ* = 2 D₀ / (α − 2 D₁), ‖e‖ ≤ ρ*/√λ_min(P)
    let f = b
        .f32_floor(|_, _| Ok(rounding(1e-6, 0.01)))
        .expect("certified");
    let (d0, d1) = (box_p_norm(&p, &[1e-6; 3]), box_p_norm(&p, &[0.01; 3]));
    assert!((f.constant - d0).abs() <= 1e-12 * d0 && (f.proportional - d1).abs() <= 1e-12 * d1);
    let lmin = p.clone().symmetric_eigenvalues().min();
    let direct = 2.0 * d0 / (d.alpha - 2.0 * d1) / lmin.sqrt();
    assert!(
        f.error_bound <= direct * (1.0 + 1e-6),
        "{} > {direct}",
        f.error_bound
    );
    assert!(f.error_bound > 0.0);
    // a larger proportional part gives a larger floor
    let g = b
        .f32_floor(|_, _| Ok(rounding(1e-6, 0.05)))
        .expect("certified");
    assert!(g.error_bound > f.error_bound);
    // D₁ ≥ α/2 leaves no rate: refused, and said why
    let big = d.alpha / box_p_norm(&p, &[1.0; 3]);
    let err = b
        .f32_floor(|_, _| Ok(rounding(1e-6, big)))
        .expect_err("the rate is gone");
    assert!(err.contains("takes the whole rate"), "{err}");
    // a constant part that ends outside E: refused
    let err = b
        .f32_floor(|_, _| Ok(rounding(1.0, 0.0)))
        .expect_err("not invariant");
    assert!(err.contains("not below 1"), "{err}");
    // the Euler floor exists for this design (it has a certified Euler step)
    let e = f.euler.expect("an Euler floor");
    assert!(e.base >= f.error_bound && e.per_step > 0.0 && e.min_step > 0.0);
}
