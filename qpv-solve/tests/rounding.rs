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

/// A sampled design's step (docs/embedded.md, "A sampled design's `step`"):
/// the floor is the fixed point ρ* = (D₀ + H_b + H_a/h)/(κ − D₁),
/// κ = (1 − √(1 − hα))/h, of ρ ↦ √(1 − hα)ρ + h(D₀ + D₁ρ) + H_a + hH_b,
/// over √λ_min(P); the recursion from ρ = 0 never passes it; none when
/// ρ* ≥ 1; a continuous design has none.
#[test]
fn a_sampled_design_has_the_floor_of_its_step() {
    let models = qpv_dsl::parse(include_str!("../../tests/fixtures/paper_sampled.qpv"))
        .expect("the sampled paper model parses");
    let poly: PolytopicModel = models[0].polytopic();
    let d = design(&poly, &models[0].designs[0], &Settings::default()).expect("design runs");
    let b = Baked::solved(&poly, d, Float::F32).expect("certified after rounding");
    let (h, alpha) = (b.design().sample.expect("sampled").h, b.design().alpha);
    assert_eq!(h, f64::from(1e-3f32), "the f32 period is certified");
    let p = b.design().p_matrix();
    let r = RhsRounding {
        constant: vec![1e-6; 3],
        proportional: vec![1e-3; 3],
        derivative: vec![0.5; 3],
        state: vec![0.05; 3],
    };
    let f = b.f32_floor(|_, _| Ok(r.clone())).expect("certified");
    let floor = f.sampled.expect("a floor for the step");
    let u = 1.0 / 16_777_216.0;
    let n = |v: f64| box_p_norm(&p, &[v; 3]);
    let (d0, d1, ha, hb) = (n(1e-6), n(1e-3), n(u * 0.05), n(u * (2.0 + u) * 0.5));
    let kappa = (1.0 - (1.0 - h * alpha).sqrt()) / h;
    let rho = (d0 + hb + ha / h) / (kappa - d1);
    let lmin = p.clone().symmetric_eigenvalues().min();
    assert!(rho < 1.0);
    let want = rho / lmin.sqrt();
    assert!(
        floor >= want && floor <= want * (1.0 + 1e-6),
        "{floor} vs {want}"
    );
    // the recursion from ρ = 0 approaches ρ* from below
    let (mut r_k, c) = (0.0f64, (1.0 - h * alpha).sqrt());
    for _ in 0..100_000 {
        r_k = c * r_k + h * (d0 + d1 * r_k) + ha + h * hb;
        assert!(r_k <= rho * (1.0 + 1e-12));
    }
    assert!(r_k >= 0.99 * rho, "{r_k} vs {rho}");
    // an update rounding that pushes ρ* past 1: none for the step
    let big = RhsRounding {
        state: vec![1e5; 3],
        ..r.clone()
    };
    let g = b
        .f32_floor(|_, _| Ok(big))
        .expect("the continuous floor still holds");
    assert!(g.sampled.is_none());
    // a continuous design has no step floor
    let c = baked()
        .f32_floor(|_, _| Ok(rounding(1e-6, 0.01)))
        .expect("certified");
    assert!(c.sampled.is_none());
}
