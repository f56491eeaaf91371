//! The one builder of the observer's model: a Q that a report claims for a
//! `state_bound auto` model is verified against the model as it is now, and
//! a stale or tampered Q is refused with the reason (never silently used).

use qpv_dsl::{AlphaSpec, GammaSpec, Mode, StateBound};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::model::{ClaimedBound, ObserverModel, ObserverOptions, StateBoundClaim};
use qpv_solve::{design, request, Design, Settings};

/// The paper's example with `state_bound auto`, as the user writes it.
const PAPER_AUTO: &str = include_str!("../../examples/paper_auto.qpv");

fn auto_model() -> qpv_dsl::PolytopicModel {
    qpv_dsl::parse(PAPER_AUTO).unwrap().remove(0).polytopic()
}

/// A certified sound design of the auto model at a fixed (α, γ).
fn auto_design(model: &qpv_dsl::PolytopicModel) -> Design {
    let req = request(AlphaSpec::Fixed(5.0), GammaSpec::Fixed(0.15), Mode::Sound);
    let d = design(model, &req, &Settings::default()).unwrap();
    assert!(d.certifies(), "{}", d.summary);
    d
}

/// The design with its reported Q replaced.
fn with_q(d: &Design, q: Vec<Vec<f64>>) -> Design {
    let mut out = d.clone();
    out.state_bound.as_mut().unwrap().q = Some(q);
    out
}

/// The re-check of `d` on `model` fails, and says why (`why` in its reason).
fn refused(d: &Design, model: &qpv_dsl::PolytopicModel, why: &str) {
    let c = d.recheck(model);
    assert!(!c.passed, "a wrong Q must not certify");
    let reason = c.input_errors.join("; ");
    assert!(
        reason.contains(why),
        "reason {reason:?} should mention {why:?}"
    );
    let e = d.observer_model(model).unwrap_err().to_string();
    assert!(e.contains(why), "{e}");
}

#[test]
fn a_claimed_state_bound_is_verified_on_recheck() {
    let model = auto_model();
    assert!(matches!(model.state_bound, StateBound::Auto { .. }));
    let d = auto_design(&model);
    // The untouched report passes, also after a JSON round trip.
    assert!(d.recheck(&model).passed);
    let back = Design::from_json(&d.to_json()).unwrap();
    assert!(back.recheck(&model).passed);

    let q = d.state_bound_q().unwrap();
    let rows = |m: &nalgebra::DMatrix<f64>| qpv_solve::report::matrix_to_rows(m);
    // Shrunk 100×: the region is no longer inside F.
    refused(
        &with_q(&d, rows(&(&q * 0.01))),
        &model,
        "region is not inside F",
    );
    // Not positive definite: −I and 0.
    let eye = nalgebra::DMatrix::<f64>::identity(3, 3);
    refused(&with_q(&d, rows(&(-&eye))), &model, "not positive definite");
    refused(
        &with_q(&d, rows(&(&eye * 0.0))),
        &model,
        "not positive definite",
    );
    // Not symmetric.
    let mut asym = q.clone();
    asym[(0, 1)] += 1e-3;
    refused(&with_q(&d, rows(&asym)), &model, "not symmetric");
    // Badly scaled: a huge but finite entry.
    let mut huge = q.clone();
    huge[(2, 2)] = 1e300;
    refused(&with_q(&d, rows(&huge)), &model, "badly scaled");
}

#[test]
fn an_edited_model_refuses_the_old_state_bound() {
    let model = auto_model();
    let d = auto_design(&model);
    // One `der` line changed: x1' now grows (A_11 = 4 − θ1 > 0), and no
    // ellipsoid around the region is invariant any more.
    let edited_text = PAPER_AUTO.replace("[ -4 - th1,", "[ 4 - th1,");
    assert_ne!(edited_text, PAPER_AUTO);
    let edited = qpv_dsl::parse(&edited_text).unwrap().remove(0).polytopic();
    refused(&d, &edited, "not invariant");
    // The untouched model still accepts it.
    assert!(d.recheck(&model).passed);
}

#[test]
fn the_builder_verifies_claims_and_ignores_them_for_a_given_q() {
    let model = auto_model();
    let d = auto_design(&model);
    let route = d.route();
    let options = ObserverOptions {
        output_route: &route,
        split: d.split,
        skew: None,
    };
    let claim = ClaimedBound {
        q: d.state_bound_q().unwrap(),
        h: None,
        split: None,
    };
    // Without h and split, the tightest box and both splits are tried.
    let ok = ObserverModel::prepare(&model, &options, StateBoundClaim::Claimed(&claim)).unwrap();
    assert_eq!(ok.state_bound.source, "auto");
    assert!(ok.state_bound.check.as_ref().unwrap().passed);
    assert!(matches!(ok.model.state_bound, StateBound::Given(_)));
    let bad = ClaimedBound {
        q: claim.q.clone() * 0.01,
        ..claim.clone()
    };
    let err = ObserverModel::prepare(&model, &options, StateBoundClaim::Claimed(&bad)).unwrap_err();
    assert!(err.to_string().contains("refused"), "{err}");
    // A model with a given Q uses its own; a claim does not replace it.
    let given = paper_model();
    let m = ObserverModel::prepare(&given, &options, StateBoundClaim::Claimed(&bad)).unwrap();
    assert_eq!(m.state_bound.source, "given");
    assert_eq!(m.plant.state_bound, given.state_bound);
}

/// A Jacobian box on the set S = F ⊕ (−P/γ) grows as γ falls: the
/// observer model a design's figures and re-checks use carries the box at
/// the design's own γ, not at the top of the γ range.
#[test]
fn a_jacobian_box_on_the_set_is_the_one_at_the_designs_gamma() {
    let src = include_str!("../../examples/duffing_position.qpv");
    let model = qpv_dsl::parse(src).unwrap().remove(0).polytopic();
    assert!(model.jacobian_needs_set());
    let box_of = |m: &qpv_dsl::PolytopicModel| {
        let b = m
            .jacobian
            .as_ref()
            .and_then(|j| j.bound.clone())
            .expect("expanded");
        (b.gamma, b.state_box)
    };
    for g in [0.2, 0.5] {
        let req = request(AlphaSpec::Fixed(0.1), GammaSpec::Fixed(g), Mode::Sound);
        let d = design(&model, &req, &Settings::default()).unwrap();
        assert!(d.certifies(), "γ = {g}: {}", d.summary);
        let obs = d.observer_model(&model).unwrap();
        let want = model.with_jacobian(Some(g)).unwrap();
        assert_eq!(box_of(&obs), box_of(&want), "γ = {g}");
    }
}
