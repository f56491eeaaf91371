//! The one-dimensional search on functions with known extrema: a
//! minimiser in x with the classic two-point golden-section start (the
//! noise-optimal γ's), a maximiser in ln x that stops at its goal (the
//! state bound's h), only the best local maximum refined, "nothing
//! found" everywhere, the gains L = P⁻¹Γ, and each x evaluated once.

use nalgebra::DMatrix;
use qpv_solve::line_search::{Line, Peaks, Scale, Stage};

/// Runs `line` on `f`, returning what it found and every x evaluated, in
/// order, with its stage.
fn run(
    line: &Line,
    grid: &[f64],
    minimise: bool,
    f: impl Fn(f64) -> Option<f64>,
) -> (qpv_solve::line_search::Found, Vec<(f64, Stage)>) {
    let mut seen = Vec::new();
    let mut eval = |x: f64, s: Stage| -> Result<Option<f64>, ()> {
        seen.push((x, s));
        Ok(f(x))
    };
    let out = match minimise {
        true => line.minimise(grid, &mut eval, &|| false),
        false => line.maximise(grid, &mut eval, &|| false),
    }
    .unwrap();
    (out, seen)
}

#[test]
fn log_and_linear_grids_end_at_hi_exactly() {
    let g = Scale::Log.grid(0.01, 10.0, 4);
    assert_eq!(g.len(), 4);
    assert!((g[0] - 0.01).abs() < 1e-15);
    assert_eq!(g[3], 10.0);
    assert!((g[1] / g[0] - 10.0).abs() < 1e-9 && (g[2] / g[1] - 10.0).abs() < 1e-9);
    let l = Scale::Linear.grid(1.0, 4.0, 4);
    assert_eq!(l, vec![1.0, 2.0, 3.0, 4.0]);
    assert_eq!(
        Scale::Linear.grid(1.0, 2.0, 1).len(),
        2,
        "at least two points"
    );
}

#[test]
fn minimiser_probes_as_the_classic_golden_section() {
    // The noise-optimal γ's search: a grid top down, then `refine`
    // evaluations of the classic two-point golden section in x, on the
    // bracket of the best grid point's neighbours.
    let grid: Vec<f64> = (1..=4).map(|k| k as f64 / 4.0).collect();
    let line = Line {
        scale: Scale::Linear,
        descending: true,
        refine: 6,
        below: Some(grid[0] * 0.25),
        probe_first: true,
        ..Line::default()
    };
    let f = |x: f64| Some((x - 0.43).powi(2) + 1.0);
    let (out, seen) = run(&line, &grid, true, f);
    let xs: Vec<f64> = seen.iter().map(|s| s.0).collect();
    assert_eq!(&xs[..4], &[1.0, 0.75, 0.5, 0.25], "the grid, top down");
    assert!(seen[..4].iter().all(|s| s.1 == Stage::Grid));
    // The classic sequence on [0.25, 0.75] (the neighbours of 0.5).
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut c) = (0.25, 0.75);
    let (mut x1, mut x2) = (c - phi * (c - a), a + phi * (c - a));
    let (mut f1, mut f2) = (f(x1).unwrap(), f(x2).unwrap());
    let mut classic = vec![x1, x2];
    for _ in 2..line.refine {
        if f1 <= f2 {
            (c, x2, f2) = (x2, x1, f1);
            x1 = c - phi * (c - a);
            f1 = f(x1).unwrap();
            classic.push(x1);
        } else {
            (a, x1, f1) = (x1, x2, f2);
            x2 = a + phi * (c - a);
            f2 = f(x2).unwrap();
            classic.push(x2);
        }
    }
    assert_eq!(xs.len(), 4 + line.refine);
    for (x, y) in xs[4..].iter().zip(&classic) {
        assert!((x - y).abs() <= 1e-12, "{x} vs the classic {y}");
    }
    assert!(seen[4..].iter().all(|s| s.1 == Stage::Refine));
    let (bx, bf) = out.best.unwrap();
    assert!((bx - 0.43).abs() < 0.03, "x = {bx}");
    assert!(
        (1.0..1.0 + 1e-3).contains(&bf),
        "the minimum's own value: {bf}"
    );
    assert_eq!(out.peaks.len(), 1);
}

#[test]
fn maximiser_stops_once_its_goal_is_reached() {
    // The state bound's h: a grid from the bottom that stops as soon as a
    // value reaches the goal (the upper estimate), with no refinement.
    let grid = Scale::Log.grid(1.0, 40.0, 16);
    let line = Line {
        refine: 12,
        probe_first: true,
        goal: Some(0.45),
        ..Line::default()
    };
    let (out, seen) = run(&line, &grid, false, |x| Some(0.5 * (1.0 - (-x).exp())));
    let reached = grid.iter().position(|&x| 0.5 * (1.0 - (-x).exp()) >= 0.45);
    assert!(reached.is_some_and(|k| k > 1 && k + 1 < grid.len()));
    assert_eq!(reached.map(|k| k + 1), Some(seen.len()));
    assert!(seen.iter().all(|s| s.1 == Stage::Grid));
    assert_eq!(out.grid.len(), seen.len(), "the grid as evaluated");
}

#[test]
fn only_the_best_peak_is_refined_and_each_x_evaluated_once() {
    let bump = |x: f64, c: f64, h: f64| h / (1.0 + ((x.ln() - c.ln()) / 0.3).powi(2));
    let f = |x: f64| Some(bump(x, 0.05, 10.0).max(bump(x, 2.0, 30.0)));
    let grid = Scale::Log.grid(0.01, 10.0, 10);
    let line = Line {
        refine: 8,
        peaks: Peaks::Best,
        ..Line::default()
    };
    let (out, seen) = run(&line, &grid, false, f);
    assert_eq!(out.peaks.len(), 2);
    assert!(out.peaks[0].refined && !out.peaks[1].refined);
    let (bx, bf) = out.best.unwrap();
    assert!(
        (bx / 2.0).ln().abs() < 0.05 && bf > 0.99 * 30.0,
        "({bx}, {bf})"
    );
    assert_eq!(out.samples.len(), seen.len(), "each x evaluated once");
    // Within(reach) refines the lower one too when it is within reach.
    let all = Line {
        peaks: Peaks::Within(0.3),
        ..line
    };
    let (out, _) = run(&all, &grid, false, f);
    assert!(out.peaks.iter().all(|p| p.refined));
}

#[test]
fn nothing_found_anywhere_gives_no_best_and_no_refinement() {
    let grid = Scale::Log.grid(0.1, 1.0, 5);
    let line = Line {
        refine: 4,
        extend: 3,
        walk: 10,
        ..Line::default()
    };
    let (out, seen) = run(&line, &grid, false, |_| None);
    assert_eq!(out.best, None);
    assert!(out.peaks.is_empty() && out.walk.is_empty());
    assert_eq!(seen.len(), grid.len());
}

#[test]
fn gains_solve_p_l_equals_gamma() {
    let p = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
    let g = vec![DMatrix::from_row_slice(2, 1, &[1.0, -1.0])];
    let l = qpv_solve::linalg::gains(&p, &g).unwrap();
    assert!((&p * &l[0] - &g[0]).norm() < 1e-14);
    // An indefinite but regular P: through LU.
    let q = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
    let l = qpv_solve::linalg::gains(&q, &g).unwrap();
    assert!((&q * &l[0] - &g[0]).norm() < 1e-14);
    assert!(qpv_solve::linalg::gains(&DMatrix::zeros(2, 2), &g).is_none());
}
