//! The failure diagnosis (detectability at the θ-vertices, the (S4) bound,
//! region vertices outside F) and the size guard that refuses a design too
//! large to solve before anything is assembled.

use qpv_dsl::{AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode};
use qpv_solve::conditions::reference::{paper_model, synthetic_model};
use qpv_solve::model::diagnosis::{diagnose, undetectable_modes};
use qpv_solve::model::size::{estimate, guard, Verdict, CERTIFICATE_BUDGET, MEMORY_BUDGET};
use qpv_solve::{design, request, Settings, SolveError};

fn model(src: &str) -> qpv_dsl::PolytopicModel {
    qpv_dsl::parse(src)
        .expect("valid model")
        .remove(0)
        .polytopic()
}

const UNDETECTABLE: &str = "model u {
    state x1, x2;  output y;  param th in [0, 1];
    der x1 = -(1 + th)*x1 + 0.5*x1*x2;
    der x2 = (0.5 - th)*x2;
    out y = x1;
    region box(0.1);
    state_bound Q = [0.04, 0; 0, 0.04];
}";

/// With a cover, the undetectable vertex is named with its piece: x2' =
/// (0.5 − th) x2 is unseen and unstable for th < 0.5, so on 4 pieces of
/// [0, 1] the corners th = 0, 0.25 (and th = 0.5, where λ = 0) fail.
#[test]
fn an_undetectable_vertex_of_a_cover_is_named_with_its_piece() {
    let m = model(&UNDETECTABLE.replace("region box(0.1);", "region box(0.1); cover th into 4;"));
    assert_eq!(m.nv(), 8);
    let unstable = undetectable_modes(&m, 0.0);
    let vertices: Vec<usize> = unstable.iter().map(|u| u.vertex).collect();
    // pieces [0, 0.25] and [0.25, 0.5] (both corners), and the low corner of [0.5, 0.75]
    assert_eq!(vertices, [0, 1, 2, 3, 4], "{unstable:?}");
    let req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    let found = diagnose(&m, &req, 1e-4);
    let text: Vec<&str> = found.iter().map(|f| f.message.as_str()).collect();
    assert!(
        text.iter()
            .any(|t| t.contains("vertex 3 (th = 0.25) of piece 2 (th ∈ [0.25, 0.5])")),
        "{text:?}"
    );
}

#[test]
fn the_pbh_test_names_the_vertex_and_the_state_of_an_undetectable_mode() {
    let m = model(UNDETECTABLE);
    // x2' = (0.5 − θ) x2 is unseen: λ = 0.5 at θ = 0, λ = −0.5 at θ = 1.
    let unstable = undetectable_modes(&m, 0.0);
    assert_eq!(unstable.len(), 1, "{unstable:?}");
    assert_eq!(unstable[0].vertex, 0);
    assert_eq!(unstable[0].state, 1);
    assert!((unstable[0].lambda.re - 0.5).abs() < 1e-12);
    // With α = 2, modes down to −1 matter: both vertices.
    assert_eq!(undetectable_modes(&m, -1.0).len(), 2);

    let req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    let found = diagnose(&m, &req, 1e-4);
    let pbh: Vec<_> = found.iter().filter(|f| f.kind == "detectability").collect();
    assert_eq!(pbh.len(), 1, "{found:?}");
    assert!(pbh[0].blocking);
    assert!(
        pbh[0].message.contains("vertex 1 (th = 0)"),
        "{}",
        pbh[0].message
    );
    assert!(pbh[0].message.contains("state x2"), "{}", pbh[0].message);
}

#[test]
fn a_detectable_model_has_no_pbh_finding_and_gets_the_s4_bound() {
    let m = paper_model();
    let req = request(AlphaSpec::Fixed(10.0), GammaSpec::Fixed(0.4), Mode::Sound);
    let found = diagnose(&m, &req, 1e-4);
    assert!(found.iter().all(|f| f.kind != "detectability"), "{found:?}");
    let s4 = found.iter().find(|f| f.kind == "S4").expect("S4 finding");
    // γ = 0.4 is above the paper's γ_max ≈ 0.189: blocking.
    assert!(s4.blocking, "{}", s4.message);
    assert!(s4.message.contains("gamma_max"), "{}", s4.message);
}

#[test]
fn a_region_outside_the_state_bound_is_reported_with_the_factor_to_shrink_it() {
    let m = model(
        "model big {
            state x1, x2;  output y;  param th in [0, 1];
            der x1 = -x1 + x2;  der x2 = -(1 + th)*x2;  out y = x1;
            region box(1);
            state_bound Q = [0.5, 0; 0, 0.5];
        }",
    );
    let req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    let found = diagnose(&m, &req, 1e-4);
    let f = found
        .iter()
        .find(|f| f.kind == "region_in_F")
        .expect("region finding");
    // Vertex (±1, ±1): xᵀQ⁻¹x = 4, shrink by 1/2.
    assert!(f.message.contains("= 4.0000"), "{}", f.message);
    assert!(f.message.contains("factor 0.5000"), "{}", f.message);
}

#[test]
fn a_failed_design_carries_margins_and_its_diagnosis() {
    let m = model(UNDETECTABLE);
    let req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    let d = design(&m, &req, &Settings::default()).expect("design runs");
    assert!(!d.feasible() && !d.certifies());
    assert!(d.margins.contains_key("S5"), "{:?}", d.margins);
    assert!(d.margins["S5"] <= 0.0);
    let diag = d.diagnosis.as_ref().expect("diagnosis");
    assert!(diag.iter().any(|f| f.kind == "detectability" && f.blocking));
    // It survives the JSON round trip; certified reports have none.
    let back = qpv_solve::Design::from_json(&d.to_json()).expect("json");
    assert_eq!(back.diagnosis, d.diagnosis);
}

#[test]
fn the_size_estimate_grows_with_the_region_and_decoupled_is_smaller() {
    let mut last = 0.0;
    for nx in 3..=8 {
        let m = synthetic_model(nx);
        let mut f = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
        f.conditions = Conditions::Full;
        let full = estimate(&m, &f);
        let mut r = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
        r.conditions = Conditions::Decoupled;
        let dec = estimate(&m, &r);
        assert_eq!(full.region_vertices, 1 << nx);
        assert_eq!(full.certificate_blocks, 4.0 * (1u64 << (2 * nx)) as f64);
        assert_eq!(dec.certificate_blocks, full.certificate_blocks);
        assert!(dec.bytes < full.bytes, "nx = {nx}");
        assert!(full.bytes > last, "nx = {nx}");
        last = full.bytes;
    }
}

#[test]
fn a_ten_state_box_is_refused_before_solving_and_three_states_fit() {
    let big = synthetic_model(10);
    let mut req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    req.conditions = Conditions::Full;
    match guard(&big, &req) {
        Verdict::TooLarge(m) => {
            assert!(m.contains("1024 region vertices"), "{m}");
            assert!(m.contains("region with fewer vertices"), "{m}");
        }
        v => panic!("nx = 10 full must be refused: {v:?}"),
    }
    let e = estimate(&big, &req);
    assert!(e.bytes > MEMORY_BUDGET || e.certificate_blocks > CERTIFICATE_BUDGET);
    match design(&big, &req, &Settings::default()) {
        Err(SolveError::TooLarge(m)) => assert!(m.contains("too large"), "{m}"),
        other => panic!("expected TooLarge, got {other:?}"),
    }
    assert_eq!(guard(&synthetic_model(3), &req), Verdict::Fits);
    // Left to choose (`conditions = auto`, the default), the same model gets
    // the cube conditions, which fit.
    let auto = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    assert_eq!(auto.conditions, Conditions::Auto);
    let (chosen, why) = qpv_solve::model::size::choose(&big, &auto);
    assert_eq!(chosen, Conditions::Cube, "{why}");
    let cube = DesignRequest {
        conditions: chosen,
        ..auto
    };
    let v = guard(&big, &cube);
    assert!(!matches!(v, Verdict::TooLarge(_)), "{v:?}");
}

#[test]
fn the_pbh_test_names_the_derived_scheduling_variables_of_the_corner() {
    // x2' = (0.5 − 1/θ) x2 is unseen and unstable where r = 1/θ is at its
    // lower end 1/4: the corners (th = 1, r = 1/4) and (th = 4, r = 1/4).
    let m = model(
        "model u {
        state x1, x2;  output y;  param th in [1, 4];
        let r = 1/th;
        der x1 = -(1 + th)*x1 + 0.5*x1*x2;
        der x2 = (0.5 - r)*x2;
        out y = x1;
        region box(0.1);
        state_bound Q = [0.04, 0; 0, 0.04];
    }",
    );
    assert_eq!(m.nv(), 4);
    let req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    let found = diagnose(&m, &req, 1e-4);
    let pbh: Vec<_> = found.iter().filter(|f| f.kind == "detectability").collect();
    assert!(!pbh.is_empty(), "{found:?}");
    assert!(
        pbh[0].message.contains("vertex 1 (th = 1, r = 0.2"),
        "{}",
        pbh[0].message
    );
}

/// The two-link arm of examples/manipulator.qpv with |q2| ≤ 1 rad, without
/// its cover, velocities within 0.2 rad/s, α = max at γ = 0.45 under
/// `conditions` (the diagnosis of a failed design).
fn natural_arm(conditions: &str) -> qpv_dsl::PolytopicModel {
    let src = include_str!("../../examples/manipulator.qpv")
        .replace("param  q2 in [0.2, 2.0]", "param  q2 in [-1, 1]")
        .replace("    cover q2 into 4;", "")
        .replace(
            "region box([0.5, 0.5, 0.07, 0.07])",
            "region box([0.5, 0.5, 0.2, 0.2])",
        )
        .replace(
            "0, 0, 0.0196, 0 ; 0, 0, 0, 0.0196",
            "0, 0, 0.16, 0 ; 0, 0, 0, 0.16",
        )
        .replace(
            "design { alpha = 0.15; gamma = 0.45; conditions = cube; }",
            &format!("design {{ alpha = max; gamma = 0.45; conditions = {conditions}; }}"),
        );
    assert!(src.contains("in [-1, 1]") && !src.contains("cover q2") && src.contains("alpha = max"));
    qpv_dsl::parse(&src).expect("the arm parses")[0].polytopic()
}

/// Wide ranges of the scheduling functions: the failure's diagnosis says
/// so and proposes the cover, with the measured shrink; and every point of
/// the decoupled problem failed the full certificate: it says so and
/// proposes `conditions = full`.
#[test]
fn wide_scheduling_ranges_propose_a_cover_and_failed_decoupled_points_full_conditions() {
    let m = natural_arm("decoupled");
    assert!(m.cover.is_none() && !m.derived.is_empty());
    let est = qpv_solve::model::diagnosis::cover_estimate(&m, 4).expect("an estimate");
    assert_eq!(m.params[est.param].name, "q2");
    assert!(est.ratio > 0.0 && est.ratio < 0.6, "ratio {}", est.ratio);
    let d = qpv_solve::design(&m, &m.designs[0], &qpv_solve::Settings::default()).unwrap();
    assert!(!d.certifies(), "{}", d.summary);
    let findings = d.diagnosis.as_ref().expect("a diagnosis");
    let cover = findings
        .iter()
        .find(|f| f.kind == "cover")
        .unwrap_or_else(|| panic!("no cover finding: {findings:?}"));
    assert!(
        cover.message.contains("`cover q2 into 4;`"),
        "{}",
        cover.message
    );
    assert!(
        cover
            .message
            .contains(&format!("{:.0} %", 100.0 * est.ratio)),
        "{}",
        cover.message
    );
    let cond = findings
        .iter()
        .find(|f| f.kind == "conditions")
        .unwrap_or_else(|| panic!("no conditions finding: {findings:?}"));
    assert!(
        cond.message.contains("`conditions = full`"),
        "{}",
        cond.message
    );
    // "k of k": as many failed as were returned, at least one.
    let counts: Vec<&str> = cond.message.split(['(', ')']).collect();
    let of = counts.iter().find(|s| s.contains(" of ")).expect("k of n");
    let (k, n) = of.split_once(" of ").unwrap();
    assert_eq!(k, n);
    assert!(n.parse::<usize>().unwrap() >= 1);
}

/// Neither finding where it does not apply: the cover is not proposed for
/// the example with its cover, nor for a model without scheduling
/// functions; `conditions = full` is not proposed to a full design.
#[test]
fn cover_and_conditions_findings_only_where_they_apply() {
    let with_cover =
        qpv_dsl::parse(include_str!("../../examples/manipulator.qpv")).unwrap()[0].polytopic();
    let mut req = with_cover.designs[0].clone();
    req.alpha = qpv_dsl::AlphaSpec::Fixed(0.15);
    let f = qpv_solve::model::diagnosis::diagnose(&with_cover, &req, 1e-4);
    assert!(!f.iter().any(|f| f.kind == "cover"), "{f:?}");
    let paper = qpv_solve::conditions::reference::paper_model();
    assert_eq!(qpv_solve::model::diagnosis::cover_estimate(&paper, 4), None);
    let m = natural_arm("full");
    let d = qpv_solve::design(&m, &m.designs[0], &qpv_solve::Settings::default()).unwrap();
    assert!(!d.certifies());
    let findings = d.diagnosis.expect("a diagnosis");
    assert!(findings.iter().any(|f| f.kind == "cover"), "{findings:?}");
    assert!(
        !findings.iter().any(|f| f.kind == "conditions"),
        "{findings:?}"
    );
}
