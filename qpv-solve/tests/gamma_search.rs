//! The γ search's strategy on functions γ ↦ α with known maxima: the
//! logarithmic grid, a narrow global peak found below a wide local one, the
//! grid extended downwards while α grows, local maxima out of reach
//! recorded but not refined, and nothing certified giving zero, each γ
//! evaluated once.

use qpv_solve::search::gamma::{maximise, GammaOutcome, GammaPlan};
use qpv_solve::Settings;

fn plan() -> GammaPlan {
    GammaPlan::from_settings(0.5, &Settings::default())
}

fn run(f: impl Fn(f64) -> f64) -> (GammaOutcome, usize) {
    let mut calls = 0;
    let out = maximise::<()>(&plan(), &mut |g, _| {
        calls += 1;
        Ok(f(g))
    })
    .unwrap();
    (out, calls)
}

/// A bump of height h at γ = c, width w in ln γ.
fn bump(g: f64, c: f64, w: f64, h: f64) -> f64 {
    let u = (g.ln() - c.ln()) / w;
    h / (1.0 + u * u)
}

#[test]
fn grid_is_logarithmic_from_hi_over_span_to_hi() {
    let p = plan();
    let g = p.grid();
    assert_eq!(g.len(), p.points);
    assert!((g[0] - 0.5 / Settings::default().gamma_span).abs() < 1e-12);
    assert_eq!(*g.last().unwrap(), 0.5);
    let r = g[1] / g[0];
    for w in g.windows(2) {
        assert!((w[1] / w[0] - r).abs() < 1e-9 * r);
    }
}

#[test]
fn finds_the_narrow_global_peak_below_a_wide_local_one() {
    // A wide peak of 42.6 at γ = 0.03 and a narrower, higher one of
    // 74.2 at γ = 0.0017 (between grid points), like the plants where
    // a top-down grid and one bracket settled on the wrong one.
    let f = |g: f64| bump(g, 0.03, 1.0, 42.6).max(bump(g, 0.0017, 0.5, 74.2));
    let (out, calls) = run(f);
    assert!(out.alpha >= 0.99 * 74.2, "α = {}", out.alpha);
    assert!((out.gamma / 0.0017).ln().abs() < 0.1, "γ = {}", out.gamma);
    assert_eq!(out.info.local_maxima.len(), 2);
    assert!(out.info.local_maxima[0].alpha > out.info.local_maxima[1].alpha);
    assert!(out.info.local_maxima.iter().all(|m| m.refined));
    assert_eq!(out.info.points, calls, "each γ evaluated once");
}

#[test]
fn extends_the_grid_downwards_while_alpha_grows() {
    let lo = plan().lo;
    let f = |g: f64| bump(g, lo / 3.0, 1.5, 10.0);
    let (out, _) = run(f);
    assert!(out.info.gamma_lo < lo);
    assert!(out.alpha > 0.99 * 10.0, "α = {}", out.alpha);
}

#[test]
fn local_maxima_out_of_reach_are_recorded_not_refined() {
    let f = |g: f64| bump(g, 0.2, 0.4, 50.0).max(bump(g, 0.002, 0.4, 5.0));
    let (out, _) = run(f);
    assert_eq!(out.info.local_maxima.len(), 2);
    assert!(out.info.local_maxima[0].refined);
    assert!(!out.info.local_maxima[1].refined);
    assert!(out.alpha > 0.99 * 50.0);
}

#[test]
fn nothing_certified_gives_zero() {
    let (out, calls) = run(|_| 0.0);
    assert_eq!(out.alpha, 0.0);
    assert!(out.info.local_maxima.is_empty());
    assert_eq!(calls, plan().points);
}

/// A false cliff, like the elastic arm's: α_max(γ) = 1/γ down to
/// γ = 0.005 (nothing below), but an evaluation from scratch certifies only
/// for γ ≥ 0.03; below that a value is found only near an earlier
/// certified point (within a factor 1.2 above it, as a seeded solve lifts
/// a neighbour's P). The grid and its refinement stop at the false cliff;
/// the continuation walks down to the real one.
#[test]
fn continues_past_a_cliff_that_only_seeded_evaluations_cross() {
    let mut seen: Vec<(f64, f64)> = Vec::new();
    let mut calls = 0;
    let out = maximise::<()>(&plan(), &mut |g, _| {
        calls += 1;
        let seeded = seen.iter().any(|&(x, a)| a > 0.0 && x > g && x <= 1.2 * g);
        let a = if g >= 0.005 && (g >= 0.03 || seeded) {
            1.0 / g
        } else {
            0.0
        };
        seen.push((g, a));
        Ok(a)
    })
    .unwrap();
    assert!(out.alpha >= 0.99 * 200.0, "α = {}", out.alpha);
    assert!(out.gamma >= 0.005, "γ = {}", out.gamma);
    assert!(out.info.continued > 0);
    assert!(out.info.continued <= qpv_solve::search::gamma::MAX_CONTINUATION);
    assert_eq!(out.info.local_maxima[0].alpha, out.alpha);
    assert_eq!(out.info.points, calls, "each γ evaluated once");
    assert!(out.info.statement().contains("continued below a cliff"));
}

#[test]
fn no_continuation_where_the_best_point_is_not_at_a_cliff() {
    // A smooth peak whose lower neighbours certify (less).
    let (out, _) = run(|g| bump(g, 0.05, 1.0, 20.0));
    assert_eq!(out.info.continued, 0);
    assert!(!out.info.statement().contains("continued"));
}
