//! `state_bound auto`: the computed F contains the region, lies
//! in its box, passes the independent check, improves γ_max over the
//! paper's Q, and trajectories started at the region's vertices stay in F.

use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, PolytopicModel, Split, StateBound};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::falsify::falsify_design;
use qpv_solve::simulate::{simulate, Scenario, Signal};
use qpv_solve::state_bound::{check, compute, resolve, BoundSearch};
use qpv_solve::{design, Design, Settings, SolveError};

fn auto_paper(h: Option<f64>) -> PolytopicModel {
    let mut m = paper_model();
    m.state_bound = StateBound::Auto { h };
    m
}

fn paper_gamma_max() -> f64 {
    qpv_solve::conditions::gamma_max(&paper_model()).unwrap()
}

#[test]
fn paper_auto_bound_beats_the_papers_q() {
    let t0 = std::time::Instant::now();
    let (model, info) = resolve(&auto_paper(None), &Settings::default()).unwrap();
    let secs = t0.elapsed().as_secs_f64();
    let StateBound::Given(q) = &model.state_bound else {
        panic!("resolve must give Q");
    };
    let g = info.gamma_max.unwrap();
    let h = info.h.unwrap();
    eprintln!(
        "auto Q: h = {h:.5}, γ_max = {g:.5} (paper's Q: {:.5}), split {:?}, {} solves, {secs:.3} s\nQ = {q:.6}",
        paper_gamma_max(),
        info.split,
        info.solves
    );
    assert_eq!(info.source, "auto");
    assert!(!info.h_fixed);
    assert!(g > paper_gamma_max(), "γ_max {g} not above the paper's");
    // the reported γ_max is that of the returned Q
    assert!((qpv_solve::conditions::gamma_max(&model).unwrap() - g).abs() <= 1e-12 * g);
    // re-check independently from Q alone
    let w = q.clone().cholesky().unwrap().inverse();
    let split = if info.split == Some(qpv_dsl::Split::Symmetric) {
        Split::Symmetric
    } else {
        Split::AsWritten
    };
    let c = check(&model.with_split(split), &w, h);
    assert!(c.passed, "{c:?}");
    assert!(c.region <= 1.0 && c.in_box <= 1.0 && c.invariance < 0.0 && c.w_min_eig > 0.0);
    // a given Q passes through untouched
    let (same, given) = resolve(&paper_model(), &Settings::default()).unwrap();
    assert_eq!(same, paper_model());
    assert_eq!(given.source, "given");
    assert!((given.gamma_max.unwrap() - paper_gamma_max()).abs() < 1e-15);
}

#[test]
fn fixed_h_is_respected_and_smaller_boxes_cost_gamma() {
    let search = BoundSearch::default();
    let s = Settings::default();
    let at = |h: f64| compute(&paper_model(), Some(h), &s, &search);
    let b = at(0.09).unwrap();
    assert_eq!(b.h, 0.09);
    assert_eq!(b.steps.len(), 1);
    for j in 0..3 {
        assert!(b.q[(j, j)] <= 0.09 * 0.09, "F leaves the box in x{}", j + 1);
    }
    // the searched h does at least as well as this fixed one
    let searched = compute(&paper_model(), None, &s, &search).unwrap();
    assert!(searched.gamma_max >= b.gamma_max);
    assert!(searched.steps.len() == search.grid + search.refine);
    // a box barely larger than the region cannot hold an ellipsoid around it
    // (an ellipsoid containing the cube |x_j| ≤ r has some Q_jj ≥ 3r²)
    match at(0.03) {
        Err(SolveError::StateBound(msg)) => {
            assert!(msg.contains("no invariant ellipsoid"), "{msg}")
        }
        other => panic!("expected no bound at h = 0.03, got {other:?}"),
    }
    // h must exceed the region: bad input, not an outcome of a solve
    assert!(matches!(at(0.01), Err(SolveError::StateBoundInput(_))));
    assert!(matches!(at(f64::NAN), Err(SolveError::StateBoundInput(_))));
}

#[test]
fn check_rejects_bad_bounds() {
    let m = paper_model();
    let b = compute(
        &m,
        Some(0.09),
        &Settings::default(),
        &BoundSearch::default(),
    )
    .unwrap();
    assert!(check(&m, &b.w, 0.09).passed);
    // the same F in a box too small to contain it
    assert!(!check(&m, &b.w, 0.03).passed);
    // a ball that does not contain the region
    let tiny = DMatrix::identity(3, 3) * (1.0 / (0.01 * 0.01));
    let c = check(&m, &tiny, 0.09);
    assert!(!c.passed && c.region > 1.0);
    // not positive definite, wrong size, non-finite
    assert!(!check(&m, &(-&b.w), 0.09).passed);
    assert!(!check(&m, &DMatrix::identity(2, 2), 0.09).passed);
    let mut nan = b.w.clone();
    nan[(0, 1)] = f64::NAN;
    assert!(!check(&m, &nan, 0.09).passed);
    // an unstable plant has no invariant ellipsoid: W of the stable one fails
    let mut unstable = m.clone();
    for v in &mut unstable.vertices {
        v.a = -&v.a;
    }
    let c = check(&unstable, &b.w, 0.09);
    assert!(!c.passed && c.invariance > 0.0);
}

/// Plant trajectories (zero gains; only x matters) from every region vertex
/// under fast and slow θ signals stay in F.
#[test]
fn trajectories_from_the_region_stay_in_f() {
    let (model, info) = resolve(&auto_paper(None), &Settings::default()).unwrap();
    let StateBound::Given(q) = &model.state_bound else {
        unreachable!()
    };
    let w = q.clone().cholesky().unwrap().inverse();
    let gains = vec![DMatrix::zeros(3, 2); model.nv()];
    let signals = [
        (
            Signal::Sin {
                offset: 0.5,
                amplitude: 0.5,
                omega: 4.0 * std::f64::consts::PI,
                phase: 0.0,
            },
            Signal::Cos {
                offset: 0.5,
                amplitude: 0.5,
                omega: 0.6,
                phase: 0.5,
            },
        ),
        (Signal::Constant(0.0), Signal::Constant(1.0)),
        (Signal::Constant(1.0), Signal::Constant(0.0)),
        (
            Signal::custom(|t| if (t * 20.0) as i64 % 2 == 0 { 0.0 } else { 1.0 }),
            Signal::custom(|t| if (t * 7.0) as i64 % 2 == 0 { 1.0 } else { 0.0 }),
        ),
    ];
    let mut worst: f64 = 0.0;
    let mut first_max: f64 = 0.0;
    for x0 in &model.region.vertices {
        for (s1, s2) in &signals {
            let sc = Scenario {
                theta: vec![s1.clone(), s2.clone()],
                u: vec![],
                x0: x0.iter().copied().collect(),
                xhat0: vec![0.0; 3],
                t_end: 2.0,
                dt: 1e-3,
            };
            let traj = simulate(&model, &gains, &sc).unwrap();
            assert_eq!(traj.diverged_at, None);
            let v: Vec<f64> = traj
                .x
                .iter()
                .map(|x| {
                    let x = nalgebra::DVector::from_column_slice(x);
                    x.dot(&(&w * &x))
                })
                .collect();
            first_max = first_max.max(v[0]);
            // V = xᵀWx never increases beyond its start (up to RK4 error)
            let vmax = v.iter().copied().fold(0.0, f64::max);
            assert!(
                vmax <= v[0] * (1.0 + 1e-9),
                "V rose from {} to {vmax}",
                v[0]
            );
            worst = worst.max(vmax);
        }
    }
    eprintln!(
        "max xᵀWx along trajectories: {worst:.6} (start ≤ {first_max:.6}), h = {:?}",
        info.h
    );
    assert!(worst <= 1.0, "a trajectory left F: {worst}");
    assert!(first_max > 0.5, "the region should reach well into F");
}

/// design() resolves `state_bound auto` first, reports it, and the design
/// re-checks and survives falsification against the auto model.
#[test]
fn design_uses_and_reports_the_computed_bound() {
    let model = auto_paper(None);
    // γ = 0.23 > 0.189 = γ_max of the paper's Q: only the computed Q allows it
    let req = DesignRequest {
        alpha: AlphaSpec::Fixed(10.5),
        gamma: GammaSpec::Fixed(0.23),
        split: Split::AsWritten,
        ..Default::default()
    };
    let d = design(&model, &req, &Settings::default()).unwrap();
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    let sb = d.state_bound.as_ref().unwrap();
    assert_eq!(sb.source, "auto");
    assert!(sb.gamma_max.unwrap() > 0.23 && sb.check.as_ref().unwrap().passed);
    assert!(d.data_checks["S4"].passed);
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("state_bound auto")));
    let with_paper_q = design(&paper_model(), &req, &Settings::default()).unwrap();
    assert!(!with_paper_q.feasible() && !with_paper_q.data_checks["S4"].passed);
    // re-check and falsify against the auto model use the design's Q
    assert!(d.recheck(&model).passed);
    let f = falsify_design(&model, &d, 20_000, 7).unwrap();
    assert!(f.passed(), "{f:?}");
    // the JSON report carries the bound and reloads to the same design
    let json = d.to_json();
    assert!(json.contains("\"state_bound\"") && json.contains("\"h_fixed\""));
    let back = Design::from_json(&json).unwrap();
    assert_eq!(back.state_bound, d.state_bound);
    assert!(back.recheck(&model).passed);
    // a given Q is reported as given
    let g = design(
        &paper_model(),
        &qpv_solve::request(AlphaSpec::Fixed(5.0), GammaSpec::Fixed(0.15), Mode::Sound),
        &Settings::default(),
    )
    .unwrap();
    let gsb = g.state_bound.unwrap();
    assert_eq!((gsb.source.as_str(), gsb.h), ("given", None));
}

/// When the invariance costs nothing, the search stops at the largest γ_max
/// any ellipsoid containing the region can have (the cube's circumscribed
/// ball, γ_max = 1/√nx) instead of running all its solves.
#[test]
fn search_stops_at_the_geometric_limit() {
    let mut m = qpv_solve::conditions::reference::synthetic_model(3);
    m.state_bound = StateBound::Auto { h: None };
    let (_, info) = resolve(&m, &Settings::default()).unwrap();
    let g = info.gamma_max.unwrap();
    let upper = info.gamma_upper.unwrap();
    assert!(
        g <= upper * (1.0 + 1e-6) && g >= upper * (1.0 - 1e-4),
        "{g} vs {upper}"
    );
    assert!((upper - 1.0 / 3f64.sqrt()).abs() < 1e-5, "{upper}");
    let full = BoundSearch::default();
    assert!(
        info.solves < full.grid + full.refine,
        "{} solves",
        info.solves
    );
}

/// Too many states for the 2^nx box vertices: an error, not a hang.
#[test]
fn too_large_models_are_refused() {
    let mut m = qpv_solve::conditions::reference::synthetic_model(13);
    m.state_bound = StateBound::Auto { h: None };
    match resolve(&m, &Settings::default()) {
        Err(SolveError::StateBoundInput(msg)) => assert!(msg.contains("at most"), "{msg}"),
        other => panic!("expected a refusal, got {:?}", other.map(|(_, i)| i)),
    }
}

/// The goal on the paper example: `state_bound auto` with the
/// symmetric split (the sound-mode default) certifies α ≥ 11.3, and the
/// falsifier (the true error dynamics, x sampled in the computed F) finds
/// no counterexample.
#[test]
fn paper_auto_example_reaches_the_issue_goal() {
    let src = include_str!("../../examples/paper_auto.qpv");
    let model = qpv_dsl::parse(src).unwrap().remove(0);
    let poly = model.polytopic();
    let req = &model.designs[0];
    assert_eq!(req.split, Split::Symmetric);
    let d = design(&poly, req, &Settings::default()).unwrap();
    assert!(d.certifies(), "{}", d.summary);
    assert!(d.alpha >= 11.3, "α = {}", d.alpha);
    assert_eq!(d.state_bound.as_ref().unwrap().source, "auto");
    assert!(d.recheck(&poly).passed);
    let f = falsify_design(&poly, &d, 50_000, 11).unwrap();
    assert!(f.passed(), "{f:?}");
    eprintln!(
        "paper_auto: α = {:.4} at γ = {:.4}; falsifier worst ratio {:.3e} over {} samples",
        d.alpha, d.gamma, f.worst_ratio, f.samples
    );
}
