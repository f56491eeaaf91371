//! The practical `alpha = max` (issue: the fastest design a user can run)
//! and `max_gain = G`: the smallest-gain design certified within the
//! tolerance of the certified supremum, the min-gain objective's bound, the
//! certified gain bound and its data check.

use qpv_dsl::{AlphaSpec, GammaSpec, Mode, Split};
use qpv_solve::certificate::Gains;
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::conditions::ConditionSet;
use qpv_solve::lmi::{Objective, Problem};
use qpv_solve::vocab::Candidate;
use qpv_solve::{check, design, Design, Settings};

fn max_gain(d: &Design) -> f64 {
    d.gain_norms.iter().copied().fold(0.0, f64::max)
}

fn paper_request(gamma: GammaSpec) -> qpv_dsl::DesignRequest {
    let mut r = qpv_solve::request(AlphaSpec::Max, gamma, Mode::Sound);
    r.split = Split::Symmetric;
    r
}

/// The default α = max returns a design at ≥ 99 % of the certified
/// supremum with a smaller gain than the fastest point, and the paper's
/// acceptance target α ≥ 12.27 still holds.
#[test]
fn default_alpha_max_is_within_one_percent_with_a_smaller_gain() {
    let model = paper_model();
    let d = design(
        &model,
        &paper_request(GammaSpec::Search),
        &Settings::default(),
    )
    .unwrap();
    assert!(d.certifies(), "{}", d.summary);
    let p = d
        .practical
        .as_ref()
        .expect("α = max reports the practical choice");
    assert_eq!(p.within, 0.01);
    assert!(!p.high_gain);
    assert!(
        d.alpha >= 0.99 * p.alpha_sup * (1.0 - 1e-12),
        "{} vs {}",
        d.alpha,
        p.alpha_sup
    );
    assert!(d.alpha <= p.alpha_sup);
    assert!(d.alpha >= 12.27, "paper acceptance: α = {}", d.alpha);
    assert!(
        max_gain(&d) <= p.gain_sup,
        "{} vs {}",
        max_gain(&d),
        p.gain_sup
    );
    // Certified from its JSON alone, at the reported α.
    let back = Design::from_json(&d.to_json()).unwrap();
    assert!(back.recheck(&model).passed);
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("of the certified supremum")));
    assert!(d
        .search
        .iter()
        .any(|s| s.phase == "practical" && s.certified));
}

/// `within = 0` keeps the fastest point: no practical step, α at the
/// supremum the search found.
#[test]
fn within_zero_keeps_the_fastest_point() {
    let model = paper_model();
    let mut r = paper_request(GammaSpec::Fixed(0.1889));
    r.within = 0.0;
    let d0 = design(&model, &r, &Settings::default()).unwrap();
    r.within = 0.05;
    let d5 = design(&model, &r, &Settings::default()).unwrap();
    assert!(d0.certifies() && d5.certifies());
    assert!(d0.practical.is_none());
    assert!(!d0.search.iter().any(|s| s.phase == "practical"));
    let p = d5.practical.as_ref().unwrap();
    assert!((p.alpha_sup - d0.alpha).abs() <= 1e-9 * d0.alpha);
    assert!((d5.alpha - 0.95 * p.alpha_sup).abs() <= 1e-9 * d5.alpha);
    assert!(
        max_gain(&d5) < max_gain(&d0),
        "{} vs {}",
        max_gain(&d5),
        max_gain(&d0)
    );
}

/// The min-gain objective: its κ bounds every ‖L_l‖₂ of the point it
/// returns, and that gain is no larger than the fastest solve's at the
/// same (α, γ).
#[test]
fn min_gain_objective_bounds_the_gain_it_returns() {
    let model = paper_model().with_split(Split::Symmetric);
    let prob = Problem::new(&model, ConditionSet::Sound).unwrap();
    let s = Settings::default();
    let (alpha, gamma) = (10.0, 0.1889);
    let r = prob.solve(alpha, gamma, &s, Objective::MinGain).unwrap();
    let p = r.p.expect("a point");
    let l: Vec<_> = r
        .gammas
        .iter()
        .map(|g| p.clone().cholesky().unwrap().solve(g))
        .collect();
    let cert = check(
        &model,
        &Gains::new(&p, &l),
        &Candidate::new(alpha, gamma),
        Mode::Sound,
    );
    assert!(cert.passed, "{:?}", cert.families);
    let gain = l
        .iter()
        .map(|li| li.clone().singular_values().max())
        .fold(0.0, f64::max);
    assert!(
        r.margin.is_finite() && gain <= r.margin * (1.0 + 1e-6),
        "{gain} vs κ = {}",
        r.margin
    );
    let m = prob.solve(alpha, gamma, &s, Objective::MaxMargin).unwrap();
    let pm = m.p.unwrap();
    let gm = m
        .gammas
        .iter()
        .map(|g| {
            pm.clone()
                .cholesky()
                .unwrap()
                .solve(g)
                .singular_values()
                .max()
        })
        .fold(0.0, f64::max);
    assert!(gain <= gm, "min-gain {gain} vs max-margin {gm}");
}

/// `max_gain = G`: the design respects G at every vertex, the report
/// carries the claim, and its data check fails for a claim the reported
/// gains do not meet.
#[test]
fn max_gain_is_imposed_and_certified_from_the_reported_gains() {
    let model = paper_model();
    let mut r = paper_request(GammaSpec::Fixed(0.1889));
    r.within = 0.0;
    let free = design(&model, &r, &Settings::default()).unwrap();
    let g = 0.5 * max_gain(&free);
    r.max_gain = Some(g);
    let d = design(&model, &r, &Settings::default()).unwrap();
    assert!(d.certifies(), "{}", d.summary);
    assert!(max_gain(&d) <= g, "{} > {g}", max_gain(&d));
    assert!(d.alpha < free.alpha, "the bound costs speed here");
    assert_eq!(d.max_gain, Some(g));
    let c = d.recheck(&model);
    assert!(c.passed);
    assert!(c.data_checks["max_gain"].passed);
    // A report claiming a bound its gains exceed is refused.
    let mut forged = d.clone();
    forged.max_gain = Some(0.5 * max_gain(&d));
    let c = forged.recheck(&model);
    assert!(!c.passed);
    assert!(c.families_passed(), "only the gain claim fails");
    assert!(!c.data_checks["max_gain"].passed);
}

/// An unreachable bound is a failure that names the smallest gain the
/// conditions certify without it.
#[test]
fn an_unreachable_gain_bound_says_the_smallest_certified_gain() {
    let model = paper_model();
    let mut r = paper_request(GammaSpec::Fixed(0.1889));
    r.max_gain = Some(1e-3);
    let d = design(&model, &r, &Settings::default()).unwrap();
    assert!(!d.certifies() && !d.feasible());
    let note = d
        .notes
        .iter()
        .map(ToString::to_string)
        .find(|n| n.contains("max_gain = 0.001 is not reached"))
        .unwrap_or_else(|| panic!("{:?}", d.notes));
    assert!(note.contains("max ‖L_l‖₂ ="), "{note}");
}
