//! The certified noise bound, the noise-optimal design, the trade-off sweep
//! and the largest safe sampling step, on the paper's example (sound mode,
//! N_k and M_k split symmetrically, the paper's Q, γ = γ_max = 0.18898,
//! noise on both outputs, no disturbance).

use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, GammaSpec, Mode, Split};
use qpv_solve::analysis::euler::simulate_euler;
use qpv_solve::certificate::noise::{check_noise, noise_bound};
use qpv_solve::certificate::sampling::{euler_margin, vertex_dynamics};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::model::noise::NoiseChannels;
use qpv_solve::search::noise::{design_noise, tradeoff};
use qpv_solve::simulate::Scenario;
use qpv_solve::{design, request, Design, Settings};
use std::sync::OnceLock;

const GAMMA: f64 = 0.18898;

fn noise_design(alpha: f64) -> Design {
    let req = request(
        AlphaSpec::Fixed(alpha),
        GammaSpec::Fixed(GAMMA),
        Mode::Sound,
    );
    assert_eq!(req.split, Split::Symmetric);
    design_noise(
        &paper_model(),
        &req,
        &NoiseChannels::all_outputs(),
        &Settings::default(),
    )
    .unwrap()
}

/// The noise-optimal design at α = 5, solved once for the tests that use it.
fn noise_design_5() -> &'static Design {
    static D: OnceLock<Design> = OnceLock::new();
    D.get_or_init(|| noise_design(5.0))
}

fn max_gain(d: &Design) -> f64 {
    d.gain_norms.iter().copied().fold(0.0, f64::max)
}

/// The symmetric-split paper model (what the designs are certified on).
fn sym_model() -> qpv_dsl::PolytopicModel {
    paper_model().with_split(Split::Symmetric)
}

/// Re-checks a noise design from its report alone: (S1)-(S5) and the noise
/// block LMI at the reported σ, both by the independent checks.
fn recheck(d: &Design) {
    assert!(d.recheck(&paper_model()).passed, "{}", d.summary);
    let nb = d.noise.as_ref().expect("a certified noise design has σ");
    let m = sym_model();
    let p = d.p_matrix();
    let gammas: Vec<DMatrix<f64>> = d.l_matrices().iter().map(|l| &p * l).collect();
    let c = check_noise(
        &m,
        &NoiseChannels::all_outputs(),
        d.alpha,
        d.gamma,
        &p,
        &gammas,
        nb.sigma,
    );
    assert!(c.passed, "{c:?}");
    assert_eq!(c.count, 4 * 64);
    // Slightly below σ the block LMI fails somewhere: σ is tight.
    let c = check_noise(
        &m,
        &NoiseChannels::all_outputs(),
        d.alpha,
        d.gamma,
        &p,
        &gammas,
        nb.sigma * 0.999,
    );
    assert!(!c.passed);
}

#[test]
fn noise_optimal_design_alpha_5_matches_reference() {
    let d = noise_design_5();
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    let nb = d.noise.clone().unwrap();
    eprintln!(
        "α = 5: σ = {}, bound = {}, ν_max = {}, max‖L‖ = {}, {:.2} s",
        nb.sigma,
        nb.error_bound,
        nb.max_amplitude,
        max_gain(d),
        d.seconds_total
    );
    assert!(
        nb.sigma >= 0.99 * 590.0 && nb.sigma <= 1.05 * 590.0,
        "σ = {}",
        nb.sigma
    );
    assert!(
        nb.error_bound > 1.2 && nb.error_bound < 1.36,
        "{}",
        nb.error_bound
    );
    assert!((nb.max_amplitude - 0.092).abs() < 0.005);
    assert!(
        (nb.max_amplitude - (5.0 / nb.sigma).sqrt()).abs() < 1e-12,
        "ν_max = √(α/σ)"
    );
    assert_eq!(nb.per_state.len(), 3);
    assert!(nb
        .per_state
        .iter()
        .all(|&b| b > 0.0 && b <= nb.error_bound * 1.000001));
    assert!(max_gain(d) < 20.0, "max ‖L‖ = {}", max_gain(d));
    recheck(d);
    // The report round-trips with its noise key.
    let back = Design::from_json(&d.to_json()).unwrap();
    assert_eq!(back.noise, d.noise);
}

#[test]
fn noise_optimal_design_alpha_10_and_12() {
    for (alpha, sigma_ref, bound_ref) in [(10.0, 2965.0, 2.33), (12.0, 5.3e4, 7.8)] {
        let d = noise_design(alpha);
        assert!(d.certifies(), "{}", d.summary);
        let nb = d.noise.clone().unwrap();
        eprintln!(
            "α = {alpha}: σ = {}, bound = {}, max‖L‖ = {}",
            nb.sigma,
            nb.error_bound,
            max_gain(&d)
        );
        assert!(
            nb.sigma >= 0.97 * sigma_ref && nb.sigma <= 1.10 * sigma_ref,
            "α = {alpha}: σ = {}",
            nb.sigma
        );
        assert!(
            nb.error_bound >= 0.97 * bound_ref && nb.error_bound <= 1.10 * bound_ref,
            "α = {alpha}: bound = {}",
            nb.error_bound
        );
        recheck(&d);
    }
}

#[test]
fn ordinary_designs_carry_a_checked_noise_bound_and_sampling() {
    let req = request(AlphaSpec::Fixed(5.0), GammaSpec::Fixed(GAMMA), Mode::Sound);
    let d = design(&paper_model(), &req, &Settings::default()).unwrap();
    assert!(d.certifies());
    let nb = d.noise.clone().expect("noise bound of a certified design");
    assert!(nb.check.passed);
    // The gain-regularised design is not noise-optimal: its σ is no smaller.
    let opt = noise_design_5().noise.clone().unwrap();
    assert!(
        nb.sigma >= opt.sigma * 0.999,
        "{} vs {}",
        nb.sigma,
        opt.sigma
    );
    // The same number from the public function.
    let again = noise_bound(
        &sym_model(),
        &NoiseChannels::all_outputs(),
        d.alpha,
        d.gamma,
        &d.p_matrix(),
        &d.l_matrices(),
    )
    .unwrap();
    assert_eq!(again.sigma, nb.sigma);
    let s = d.sampling.clone().expect("sampling figures");
    assert!(s.max_step_euler > 0.0 && s.step_estimate_rk4 > 0.0);
    assert_eq!(s.beta, 2.5);
    // Paper mode certifies nothing, so it carries no noise claim.
    let paper = request(AlphaSpec::Fixed(10.0), GammaSpec::Fixed(0.4), Mode::Paper);
    let dp = design(&paper_model(), &paper, &Settings::default()).unwrap();
    assert!(dp.noise.is_none() && dp.sampling.is_none());
}

#[test]
fn noisy_outputs_subset_and_disturbance_channels() {
    let m = sym_model();
    let req = request(AlphaSpec::Fixed(5.0), GammaSpec::Fixed(GAMMA), Mode::Sound);
    let d = design(&paper_model(), &req, &Settings::default()).unwrap();
    let (p, l) = (d.p_matrix(), d.l_matrices());
    let all = noise_bound(&m, &NoiseChannels::all_outputs(), 5.0, GAMMA, &p, &l).unwrap();
    let one = NoiseChannels {
        outputs: Some(vec![0]),
        b_w: None,
    };
    let b1 = noise_bound(&m, &one, 5.0, GAMMA, &p, &l).unwrap();
    assert!(b1.sigma <= all.sigma, "fewer channels, smaller σ");
    assert_eq!(b1.noisy_outputs, vec!["y1".to_string()]);
    let dist = NoiseChannels {
        outputs: None,
        b_w: Some(vec![DMatrix::from_column_slice(3, 1, &[0.0, 0.0, 1.0]); 4]),
    };
    let b2 = noise_bound(&m, &dist, 5.0, GAMMA, &p, &l).unwrap();
    assert!(b2.sigma >= all.sigma);
    assert_eq!(b2.disturbances, 1);
    // Malformed channels are errors, not panics.
    let bad = NoiseChannels {
        outputs: Some(vec![5]),
        b_w: None,
    };
    assert!(bad.validate(&m).is_err());
    assert!(noise_bound(&m, &bad, 5.0, GAMMA, &p, &l).is_none());
    let err = design_noise(&paper_model(), &req, &bad, &Settings::default()).unwrap_err();
    assert!(err.to_string().contains("output index 5"), "{err}");
    let max = request(AlphaSpec::Max, GammaSpec::Fixed(GAMMA), Mode::Sound);
    assert!(design_noise(
        &paper_model(),
        &max,
        &NoiseChannels::all_outputs(),
        &Settings::default()
    )
    .is_err());
}

#[test]
fn noise_claim_not_falsified_on_the_true_error_dynamics() {
    let d = noise_design_5();
    let nb = d.noise.clone().unwrap();
    let report = qpv_solve::analysis::noise::falsify_noise(
        &paper_model(),
        d,
        &NoiseChannels::all_outputs(),
        100_000,
        11,
    )
    .unwrap();
    eprintln!("{report:?}");
    assert_eq!(report.samples, 100_000);
    assert!(report.passed(), "{report:?}");
    assert!(report.worst_ratio < 0.0 && report.worst_ratio > -nb.sigma);
}

#[test]
fn largest_euler_step_is_tight_and_the_euler_observer_converges_below_it() {
    let d = noise_design_5();
    let s = d.sampling.clone().unwrap();
    eprintln!("{s:?}");
    let m = sym_model();
    let (p, l) = (d.p_matrix(), d.l_matrices());
    let fs = vertex_dynamics(&m, d.gamma, &l);
    assert_eq!(fs.len(), 4 * 64);
    assert!(euler_margin(&p, &fs, s.beta, s.max_step_euler).1);
    // Not vacuous: the contraction fails just above h_max.
    let (margin, ok, at) = euler_margin(&p, &fs, s.beta, s.max_step_euler * 1.01);
    assert!(!ok && margin < 0.0, "{margin} at {at}");
    // The Euler-discretised plant and observer (same step) converge at 0.8 h_max
    // on the paper's scenario ...
    let mut sc = Scenario::paper(&paper_model());
    sc.dt = 0.8 * s.max_step_euler;
    sc.t_end = 3.0;
    let tr = simulate_euler(&paper_model(), &l, &sc).unwrap();
    assert!(tr.diverged_at.is_none());
    let e0 = tr.error_norm[0];
    let e_end = *tr.error_norm.last().unwrap();
    assert!(e_end < 1e-3 * e0, "{e0} → {e_end}");
    // ... and V decays at least like (1 − hβ)^k.
    let v = tr.lyapunov(&p).unwrap();
    for (k, vk) in v.iter().enumerate() {
        let bound = v[0] * (1.0 - sc.dt * s.beta).powi(k as i32);
        assert!(
            *vk <= bound * (1.0 + 1e-9) + 1e-300,
            "step {k}: {vk} > {bound}"
        );
    }
    // The RK4 figure is an estimate above the Euler step (RK4's stability
    // region is larger).
    assert!(s.step_estimate_rk4 > s.max_step_euler);
}

#[test]
fn tradeoff_sweep_and_knee() {
    let req = request(AlphaSpec::Fixed(1.0), GammaSpec::Fixed(GAMMA), Mode::Sound);
    let t = tradeoff(
        &paper_model(),
        &req,
        &NoiseChannels::all_outputs(),
        &[1.0, 5.0, 10.0, 12.0],
        &Settings::default(),
    )
    .unwrap();
    for p in &t.points {
        eprintln!("{p:?}");
    }
    assert_eq!(t.points.len(), 4);
    assert!(t.points.iter().all(|p| p.certified));
    let eb: Vec<f64> = t.points.iter().map(|p| p.error_bound.unwrap()).collect();
    // The error bound per unit noise falls from α = 1 to 5, then grows.
    assert!(eb[1] < eb[0] && eb[2] > eb[1] && eb[3] > eb[2], "{eb:?}");
    // Knee: the largest α within 2× the smallest bound (α = 10 here:
    // 2.33 ≤ 2 × 1.27 < 7.8).
    assert_eq!(t.knee, Some(2));
    // σ grows with α.
    assert!(t
        .points
        .windows(2)
        .all(|w| w[1].sigma.unwrap() > w[0].sigma.unwrap()));
}

#[test]
fn gamma_search_never_does_worse_than_the_top_of_the_range() {
    // The γ grid contains γ_hi = γ_max(1 − 1e-6) and the search ranks γ by
    // the error bound per unit noise, so its bound is at most the one there
    // (σ itself is not comparable across γ), and the result certifies like
    // any noise design.
    let req = request(AlphaSpec::Fixed(5.0), GammaSpec::Search, Mode::Sound);
    let d = design_noise(
        &paper_model(),
        &req,
        &NoiseChannels::all_outputs(),
        &Settings::default(),
    )
    .unwrap();
    assert!(d.certifies(), "{}", d.summary);
    let top = noise_design_5().noise.clone().unwrap().error_bound;
    let got = d.noise.clone().unwrap();
    eprintln!(
        "γ search: σ = {}, bound = {} at γ = {} ({} solves)",
        got.sigma,
        got.error_bound,
        d.gamma,
        d.search.len()
    );
    assert!(
        got.error_bound <= top * 1.001,
        "{got:?} vs {top} at γ = {GAMMA}"
    );
    assert!(d.search.iter().all(|s| s.phase.name().starts_with("noise")));
    recheck(&d);
}
