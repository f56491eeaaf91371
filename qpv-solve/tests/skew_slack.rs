//! The skew-symmetric slack K_k. The alternation
//! keeps the plant, raises the certified α on the paper example, and its
//! result survives the independent certificate and falsification.

use nalgebra::DVector;
use qpv_dsl::{AlphaSpec, Conditions, GammaSpec, Mode, Split};
use qpv_solve::certificate::Gains;
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::falsify::falsify;
use qpv_solve::vocab::Candidate;
use qpv_solve::{check, design, request, Settings};

#[test]
fn skew_slack_keeps_the_plant_and_raises_the_certified_alpha() {
    let model = paper_model();
    let settings = Settings::default();
    let mut req = request(AlphaSpec::Max, GammaSpec::Fixed(0.1889), Mode::Sound);
    req.split = Split::Symmetric;
    let start = design(&model, &req, &settings).unwrap();
    assert!(start.certifies(), "{}", start.summary);
    let r = qpv_solve::search::skew_search(&model, &start, 2, &settings, Conditions::Full).unwrap();
    assert!(!r.rounds.is_empty());
    assert!(
        r.alpha_best() > start.alpha * 1.02,
        "K buys more than 2 %: {} vs {}",
        r.alpha_best(),
        start.alpha
    );
    // N_k + K_k − sym(N_k) is skew-symmetric at every vertex: the same plant
    let sym = model.with_split(Split::Symmetric);
    for (a, b) in r.model.vertices.iter().zip(&sym.vertices) {
        for (na, nb) in a.n.iter().zip(&b.n) {
            let k = na - nb;
            assert!((&k + k.transpose()).amax() < 1e-12);
        }
    }
    let theta = [0.3, 0.6];
    let x = DVector::from_vec(vec![0.01, -0.015, 0.007]);
    let (fa, fb) = (r.model.n_at(&theta), model.n_at(&theta));
    for k in 0..3 {
        assert!((x.dot(&(&fa[k] * &x)) - x.dot(&(&fb[k] * &x))).abs() < 1e-15);
    }
    // independently certified on N + K, and not falsified on the plant
    let d = &r.design;
    let c = check(
        &r.model,
        &Gains::new(&d.p_matrix(), &d.l_matrices()),
        &Candidate::new(d.alpha, d.gamma),
        Mode::Sound,
    );
    assert!(c.passed);
    let f = falsify(
        &model,
        &d.p_matrix(),
        &d.l_matrices(),
        d.alpha,
        d.gamma,
        20_000,
        9,
    )
    .unwrap();
    assert_eq!(f.counterexamples, 0, "worst ratio {}", f.worst_ratio);
}

#[test]
fn split_skew_slack_reports_k_and_rechecks_from_json() {
    let model = paper_model();
    let mut req = request(AlphaSpec::Max, GammaSpec::Fixed(0.1889), Mode::Sound);
    req.split = Split::SkewSlack;
    let d = design(&model, &req, &Settings::default()).unwrap();
    assert!(d.certifies(), "{}", d.summary);
    assert_eq!(d.split, Split::SkewSlack);
    assert!(d.alpha > 13.0, "α = {}", d.alpha);
    let k = d.skew.as_ref().expect("the slack is reported");
    assert_eq!((k.len(), k[0].len(), k[0][0].len()), (4, 3, 3));
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("skew-symmetric slack")));
    // an outside user re-checks from the JSON alone (K included) …
    let back = qpv_solve::Design::from_json(&d.to_json()).unwrap();
    assert_eq!(back, d);
    assert!(back.recheck(&model).passed);
    // … and without K the same gains are not certified at this α
    let mut no_k = back.clone();
    no_k.skew = None;
    assert!(!no_k.recheck(&model).passed);
    // the paper's printed conditions take no slack
    let mut paper = req.clone();
    paper.mode = Mode::Paper;
    assert!(design(&model, &paper, &Settings::default()).is_err());
}
