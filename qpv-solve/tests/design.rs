//! Spec §7 acceptance: the paper's example designed in both modes.
//!
//! Reference results (docs/method.md §14): paper mode feasible at α = 10, γ = 0.4 with
//! (15)/(S4) violated (γ² a_kᵀQa_k = 4.48); sound mode rejected at γ = 0.4
//! ((S4) fails and the LMIs are infeasible); γ_max = 0.18898; sound mode
//! certified at α = 10, γ = 0.1889.

#![allow(clippy::needless_range_loop)]

use qpv_dsl::{
    AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, PolytopicModel, Split, StateBound,
};
use qpv_solve::certificate::Gains;
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::vocab::{Candidate, Verdict};
use qpv_solve::{
    check, design, design_with_progress, Design, SearchStep, Settings, SolveError, Status,
};

/// N_k, M_k exactly as printed (the reference results are about this split).
/// The α search's own tests: the fastest certified point (`within = 0`);
/// the practical design below it is tested in `practical.rs`.
fn req(alpha: AlphaSpec, gamma: GammaSpec, mode: Mode) -> DesignRequest {
    let mut r = qpv_solve::request(alpha, gamma, mode);
    r.split = Split::AsWritten;
    r.within = 0.0;
    r
}

fn fixed(alpha: f64, gamma: f64, mode: Mode) -> DesignRequest {
    req(AlphaSpec::Fixed(alpha), GammaSpec::Fixed(gamma), mode)
}

fn run(model: &PolytopicModel, r: &DesignRequest) -> Design {
    design(model, r, &Settings::default()).expect("design runs")
}

/// Re-checks a design from its JSON (P and L only), as an outside user would.
fn recheck_json(model: &PolytopicModel, d: &Design) -> qpv_solve::Certificate {
    let back = Design::from_json(&d.to_json()).expect("JSON round trip");
    assert_eq!(&back, d, "Design survives a JSON round trip unchanged");
    back.recheck(model)
}

#[test]
fn paper_mode_published_point_satisfies_printed_conditions() {
    let model = paper_model();
    let d = run(&model, &fixed(10.0, 0.4, Mode::Paper));
    assert!(d.feasible(), "{}", d.summary);
    assert!(!d.certifies(), "paper mode never certifies");
    assert_eq!(d.solver.status, Status::Solved);
    for key in ["S1", "13", "14", "26"] {
        assert!(d.margins[key] > 0.0, "{key}: {}", d.margins[key]);
    }
    let s4 = &d.data_checks["S4"];
    assert!((s4.value - 4.48).abs() < 1e-9, "S4 value {}", s4.value);
    assert!(!s4.passed && !s4.required);
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("certifies nothing")));
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("violated assumption (15)/(S4)") && n.contains("4.48")));
    assert!(d.summary.contains("certifies nothing"));
    // The independent checker agrees from the JSON alone.
    let c = recheck_json(&model, &d);
    assert!(c.families_passed());
    // ... and the same gains fail the sound conditions.
    let s = check(
        &model,
        &Gains::new(&d.p_matrix(), &d.l_matrices()),
        &Candidate::new(10.0, 0.4),
        Mode::Sound,
    );
    assert!(!s.passed);
}

#[test]
fn sound_mode_rejected_at_gamma_04() {
    let model = paper_model();
    let d = run(&model, &fixed(10.0, 0.4, Mode::Sound));
    assert!(!d.feasible() && !d.certifies(), "{}", d.summary);
    // With N_k as printed the LMIs are infeasible: Clarabel's certificate.
    assert_eq!(d.solver.status, Status::Infeasible, "{:?}", d.solver);
    assert_eq!(d.solver.detail, "PrimalInfeasible");
    let s4 = &d.data_checks["S4"];
    assert!((s4.value - 4.48).abs() < 1e-9 && !s4.passed && s4.required);
    assert!(d.p.is_empty() && d.l.is_empty());
    assert!(d.summary.contains("NOT CERTIFIED"));
}

#[test]
fn sound_mode_certified_at_gamma_01889() {
    let model = paper_model();
    let d = run(&model, &fixed(10.0, 0.1889, Mode::Sound));
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    for key in ["S1", "S2", "S3", "S5"] {
        assert!(d.margins[key] > 0.0, "{key}: {}", d.margins[key]);
    }
    let s4 = &d.data_checks["S4"];
    assert!(s4.passed && s4.value < 1.0);
    assert!(d.data_checks["region_in_F"].passed);
    assert_eq!(d.l.len(), 4);
    assert_eq!((d.l[0].len(), d.l[0][0].len()), (3, 2));
    // Moderate gains (the default objective).
    assert!(
        d.gain_norms.iter().all(|&g| g > 0.0 && g < 100.0),
        "{:?}",
        d.gain_norms
    );
    let c = recheck_json(&model, &d);
    assert!(c.passed, "{c:?}");
    // Not certifiable at a slightly larger α with the same gains ⇒ the
    // checker is not vacuous.
    let c2 = check(
        &model,
        &Gains::new(&d.p_matrix(), &d.l_matrices()),
        &Candidate::new(10.0, 0.4),
        Mode::Sound,
    );
    assert!(!c2.passed);
}

#[test]
fn gamma_max_from_s4() {
    let g = qpv_solve::conditions::gamma_max(&paper_model()).unwrap();
    assert!((g - 0.18898).abs() < 1e-5, "{g}");
}

#[test]
fn alpha_max_paper_mode_at_gamma_04() {
    let model = paper_model();
    let d = run(
        &model,
        &req(AlphaSpec::Max, GammaSpec::Fixed(0.4), Mode::Paper),
    );
    assert!(d.feasible(), "{}", d.summary);
    // The published α = 10 is feasible, so α_max ≥ 10; measured 10.03.
    assert!(d.alpha >= 10.0 && d.alpha < 10.1, "α_max = {}", d.alpha);
    // The bisection brackets α_max: some step above α was not certified.
    let tol = Settings::default().bisection_rel_tol;
    assert!(d
        .search
        .iter()
        .any(|s| !s.certified && s.alpha > d.alpha && s.alpha <= d.alpha * (1.0 + tol)));
    println!(
        "paper α_max(γ=0.4) = {:.5} in {} solves, {:.3} s",
        d.alpha,
        d.search.len(),
        d.seconds_total
    );
}

#[test]
fn alpha_max_sound_mode_at_gamma_01889() {
    let model = paper_model();
    let d = run(
        &model,
        &req(AlphaSpec::Max, GammaSpec::Fixed(0.1889), Mode::Sound),
    );
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    assert!(d.alpha >= 10.0 && d.alpha < 11.0, "α_max = {}", d.alpha);
    let tol = Settings::default().bisection_rel_tol;
    assert!(d
        .search
        .iter()
        .any(|s| !s.certified && s.alpha > d.alpha && s.alpha <= d.alpha * (1.0 + tol)));
    assert!(recheck_json(&model, &d).passed);
    println!(
        "sound α_max(γ=0.1889) = {:.5} in {} solves, {:.3} s",
        d.alpha,
        d.search.len(),
        d.seconds_total
    );
}

#[test]
fn sound_mode_gamma_search_optimum() {
    let model = paper_model();
    let mut steps: Vec<SearchStep> = Vec::new();
    let d = design_with_progress(
        &model,
        &req(AlphaSpec::Max, GammaSpec::Search, Mode::Sound),
        &Settings::default(),
        &mut |s| steps.push(s.clone()),
    )
    .unwrap();
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    let gmax = qpv_solve::conditions::gamma_max(&model).unwrap();
    assert!(d.gamma > 0.0 && d.gamma <= gmax, "γ = {}", d.gamma);
    // At least as good as the fixed γ = 0.1889 point (α_max ≈ 10.605).
    assert!(d.alpha >= 10.55, "α = {}", d.alpha);
    assert_eq!(steps, d.search, "progress saw every step");
    assert!(steps.iter().any(|s| s.phase == "grid"));
    assert!(recheck_json(&model, &d).passed);
    // The report states what was searched, consistently with the search log.
    let g = d
        .gamma_search
        .as_ref()
        .expect("a γ search states what it searched");
    assert!(g.gamma_lo <= d.gamma && d.gamma <= g.gamma_hi, "{g:?}");
    assert!(
        g.gamma_hi / g.gamma_lo >= 999.0,
        "the grid reaches γ_hi/1000: {g:?}"
    );
    assert!(g.grid_points >= Settings::default().gamma_grid && g.points >= g.grid_points);
    let searched = d.search.iter().filter(|s| s.phase != "final").count();
    assert_eq!(
        g.solves, searched,
        "every solve but the final one is the search's"
    );
    assert!(!g.local_maxima.is_empty() && g.local_maxima[0].refined);
    assert!(g
        .local_maxima
        .iter()
        .all(|m| m.alpha <= d.alpha * (1.0 + 1e-12)));
    assert!(
        (g.local_maxima[0].gamma - d.gamma).abs() <= 1e-12,
        "the best local maximum is the reported γ"
    );
    assert!(d.notes.contains(&g.statement().into()), "{:?}", d.notes);
    let v: serde_json::Value = serde_json::from_str(&d.to_json()).unwrap();
    assert_eq!(v["gamma_search"]["grid_points"], g.grid_points);
    println!(
        "sound optimum α = {:.5}, γ = {:.5} in {} solves, {:.3} s",
        d.alpha,
        d.gamma,
        d.search.len(),
        d.seconds_total
    );
}

#[test]
fn paper_mode_gamma_search_stays_in_open_unit_interval() {
    let model = paper_model();
    let d = run(&model, &req(AlphaSpec::Max, GammaSpec::Search, Mode::Paper));
    assert!(d.feasible() && !d.certifies(), "{}", d.summary);
    assert!(d.gamma > 0.0 && d.gamma < 1.0);
    assert!(d.alpha >= 10.0, "α = {}", d.alpha);
    println!("paper optimum α = {:.5}, γ = {:.5}", d.alpha, d.gamma);
}

#[test]
fn fixed_alpha_with_gamma_search() {
    let model = paper_model();
    let d = run(
        &model,
        &req(AlphaSpec::Fixed(10.0), GammaSpec::Search, Mode::Sound),
    );
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    assert_eq!(d.alpha, 10.0);
    // Too fast a rate: no γ works, and the report says so.
    let d = run(
        &model,
        &req(AlphaSpec::Fixed(50.0), GammaSpec::Search, Mode::Sound),
    );
    assert!(!d.feasible(), "{}", d.summary);
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("exceeds the best certified")));
}

#[test]
fn unknown_solver_status_counts_only_through_the_certificate() {
    let model = paper_model();
    let mut seen_uncertified = false;
    for max_iter in [1, 2, 3, 5] {
        let settings = Settings {
            max_iter,
            ..Settings::default()
        };
        let d = design(&model, &fixed(10.0, 0.1889, Mode::Sound), &settings).unwrap();
        assert_eq!(d.solver.status, Status::Unknown, "{:?}", d.solver);
        assert_eq!(d.solver.detail, "MaxIterations");
        assert!(d
            .notes
            .iter()
            .map(ToString::to_string)
            .any(|n| n.contains("unknown status")));
        // An unfinished solve may still return a point that passes the
        // independent certificate; feasible is exactly "the certificate passed".
        let passed = !d.p.is_empty() && recheck_json(&model, &d).passed;
        assert_eq!(d.feasible(), passed, "max_iter {max_iter}: {}", d.summary);
        seen_uncertified |= !d.feasible();
        // The search treats unknowns as "not certified" and reports them.
        let d = design(
            &model,
            &req(AlphaSpec::Max, GammaSpec::Fixed(0.1889), Mode::Sound),
            &settings,
        )
        .unwrap();
        assert!(d.search.iter().all(|s| s.status == Status::Unknown));
        assert!(d
            .search
            .iter()
            .all(|s| !s.certified || s.alpha_certified > 0.0));
    }
    assert!(
        seen_uncertified,
        "at least the 1-iteration point is rejected"
    );
}

#[test]
fn request_errors() {
    let model = paper_model();
    let s = Settings::default();
    assert_eq!(
        design(&model, &fixed(10.0, 1.0, Mode::Sound), &s),
        Err(SolveError::BadGamma(1.0))
    );
    assert_eq!(
        design(&model, &fixed(10.0, 0.0, Mode::Paper), &s),
        Err(SolveError::BadGamma(0.0))
    );
    assert_eq!(
        design(&model, &fixed(-1.0, 0.1, Mode::Sound), &s),
        Err(SolveError::BadAlpha(-1.0))
    );
    assert!(matches!(
        design(&model, &fixed(f64::NAN, 0.1, Mode::Sound), &s),
        Err(SolveError::BadAlpha(_))
    ));
    let mut no_q = model.clone();
    no_q.state_bound = StateBound::None;
    assert!(matches!(
        design(&no_q, &fixed(10.0, 0.1, Mode::Sound), &s),
        Err(SolveError::MissingStateBound(_))
    ));
    // Paper mode runs without Q; (S4) is then reported as not checked.
    let d = design(&no_q, &fixed(10.0, 0.4, Mode::Paper), &s).unwrap();
    assert!(d.feasible() && d.data_checks.is_empty());
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("not checked")));
    // Decoupled conditions validate the request the same way.
    let mut dec = fixed(10.0, 1.5, Mode::Sound);
    dec.conditions = Conditions::Decoupled;
    assert_eq!(design(&model, &dec, &s), Err(SolveError::BadGamma(1.5)));
    let mut empty = model.clone();
    empty.region.vertices.clear();
    assert_eq!(
        design(&empty, &fixed(10.0, 0.1, Mode::Sound), &s),
        Err(SolveError::EmptyRegion)
    );
}

#[test]
fn reports_with_the_two_booleans_still_load() {
    // Reports written before `verdict` said it with `feasible` and
    // `certifies`: each of their combinations reads as one of the three
    // states, and the design is written back in the new form.
    let model = paper_model();
    let d = run(&model, &fixed(10.0, 0.1889, Mode::Sound));
    let mut v: serde_json::Value = serde_json::from_str(&d.to_json()).unwrap();
    let obj = v.as_object_mut().unwrap();
    obj.remove("verdict");
    for (feasible, certifies, verdict) in [
        (Some(true), Some(true), Verdict::Certified),
        (Some(true), Some(false), Verdict::Reproduction),
        (Some(false), Some(false), Verdict::NotCertified),
        (None, None, Verdict::NotCertified),
    ] {
        let mut old = obj.clone();
        for (key, flag) in [("feasible", feasible), ("certifies", certifies)] {
            if let Some(b) = flag {
                old.insert(key.into(), serde_json::Value::from(b));
            }
        }
        let back = Design::from_json(&serde_json::Value::from(old).to_string()).expect("old form");
        assert_eq!(back.verdict, verdict, "{feasible:?} {certifies:?}");
        let again: serde_json::Value = serde_json::from_str(&back.to_json()).unwrap();
        assert_eq!(again["verdict"], verdict.name());
        assert!(again.get("feasible").is_none() && again.get("certifies").is_none());
    }
}

#[test]
fn json_keys_are_exactly_the_documented_ones() {
    let model = paper_model();
    let d = run(&model, &fixed(10.0, 0.1889, Mode::Sound));
    let v: serde_json::Value = serde_json::from_str(&d.to_json()).unwrap();
    let obj = v.as_object().unwrap();
    for key in [
        "model",
        "mode",
        "split",
        "conditions",
        "verdict",
        "alpha",
        "gamma",
        "P",
        "Gamma",
        "L",
        "gain_norms",
        "margins",
        "data_checks",
        "solver",
        "seconds_total",
        "search",
        "notes",
        "summary",
        "state_bound",
        "output_route",
        "noise",
        "sampling",
    ] {
        assert!(obj.contains_key(key), "missing key {key}");
    }
    // 20 keys (the verdict one key where older reports had the two
    // booleans `feasible` and `certifies`), plus `noise` and `sampling` on
    // a certified sound design.
    assert_eq!(obj.len(), 22);
    assert_eq!(v["verdict"], "certified");
    for key in ["sigma", "max_amplitude", "error_bound", "per_state"] {
        assert!(v["noise"].get(key).is_some(), "noise.{key}");
    }
    for key in ["max_step_euler", "beta", "step_estimate_rk4"] {
        assert!(v["sampling"].get(key).is_some(), "sampling.{key}");
    }
    assert_eq!(v["output_route"]["route"], "double_sum");
    assert_eq!(v["output_route"]["output_varies"], false);
    assert_eq!(v["output_route"]["combinations"], 4);
    assert!(v["output_route"]["filter"].is_null());
    assert_eq!(v["state_bound"]["source"], "given");
    assert_eq!(v["mode"], "sound");
    assert_eq!(v["split"], "as_written");
    assert_eq!(v["conditions"], "full");
    assert_eq!(v["solver"]["status"], "solved");
    for key in ["status", "iterations", "seconds"] {
        assert!(v["solver"].get(key).is_some());
    }
    assert_eq!(v["P"].as_array().unwrap().len(), 3);
    assert_eq!(v["L"][0][0].as_array().unwrap().len(), 2);
}

#[test]
fn parsed_paper_example_matches_hand_built_model() {
    let models =
        qpv_dsl::parse(include_str!("../../examples/paper.qpv")).expect("paper.qpv parses");
    let parsed = models[0].polytopic();
    let hand = paper_model();
    assert_eq!(parsed.nv(), hand.nv());
    for (a, b) in parsed.vertices.iter().zip(&hand.vertices) {
        assert!((&a.a - &b.a).norm() < 1e-12);
        for (x, y) in a.n.iter().zip(&b.n) {
            assert!((x - y).norm() < 1e-12);
        }
    }
    // The model's own requests: the published paper point, then the sound search.
    let d0 = run(&parsed, &parsed.designs[0]);
    assert_eq!(d0.mode, Mode::Paper);
    assert!(d0.feasible() && !d0.certifies());
    // The gains designed on the hand-built model certify on the parsed one.
    let d = run(&hand, &fixed(10.0, 0.1889, Mode::Sound));
    assert!(
        check(
            &parsed,
            &Gains::new(&d.p_matrix(), &d.l_matrices()),
            &Candidate::new(10.0, 0.1889),
            Mode::Sound
        )
        .passed
    );
}

#[test]
fn symmetric_split_certifies_a_faster_rate() {
    // Reference: α_max 11.27 with the paper's Q and the
    // symmetric split (10.60 as written). Same plant, different LMIs.
    let model = paper_model();
    let r = qpv_solve::request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    assert_eq!(r.split, Split::Symmetric, "sound-mode default");
    let d = run(&model, &r);
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    assert_eq!(d.split, Split::Symmetric);
    assert!(d.alpha > 11.0, "α = {}", d.alpha);
    let c = recheck_json(&model, &d);
    assert!(c.passed);
    // The symmetrised model is the same plant: its gains make V decrease
    // along the true error dynamics of the model as written, which the
    // sound conditions on the symmetrised data guarantee.
    println!(
        "symmetric split: α = {:.5}, γ = {:.5} in {} solves, {:.3} s",
        d.alpha,
        d.gamma,
        d.search.len(),
        d.seconds_total
    );
}

/// A fixed (α, γ) request whose regularised solve returns a point that fails
/// the certificate (the elastic arm: ill-conditioned, AlmostSolved) is
/// answered by the α search at that γ: its certified point covers α and is
/// reported at exactly α, certified again from its JSON.
#[test]
fn a_fixed_request_falls_back_to_the_alpha_search_at_its_gamma() {
    let src = include_str!("../../examples/elastic_arm.qpv");
    let model = qpv_dsl::parse(src).expect("example parses")[0].polytopic();
    let mut r = qpv_solve::request(AlphaSpec::Fixed(35.0), GammaSpec::Fixed(0.035), Mode::Sound);
    r.conditions = Conditions::Decoupled;
    let d = run(&model, &r);
    assert!(d.certifies(), "{}", d.summary);
    assert_eq!((d.alpha, d.gamma), (35.0, 0.035));
    let final_step = d.search.iter().find(|s| s.phase == "final").expect("final");
    assert!(
        !final_step.certified,
        "the regularised solve itself fails here"
    );
    assert!(d.search.iter().any(|s| s.phase == "bisect" && s.certified));
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("the α search at this γ")));
    assert!(recheck_json(&model, &d).passed);
}

/// Notes are data: a structured note is written as its sentence (the
/// report keeps its form), read back as that sentence, and equal to it.
#[test]
fn notes_are_written_as_their_sentences_and_read_back_equal() {
    use qpv_solve::report::Note;
    let mut d = Design::claimed("m", Mode::Sound, 1.0, 0.5, vec![vec![1.0]], vec![]);
    d.notes.push(Note::Rejected { count: 2 });
    d.notes.push(Note::UnknownStatus {
        count: 1,
        solves: 7,
        kinds: vec!["MaxIterations".into()],
    });
    d.notes.push("a remark");
    assert!(d.notes[0].is_search_log() && !d.notes[2].is_search_log());
    let v: serde_json::Value = serde_json::from_str(&d.to_json()).unwrap();
    assert_eq!(
        v["notes"][0],
        "2 point(s) returned by the solver failed the independent certificate and were rejected"
    );
    assert_eq!(
        v["notes"][1],
        "1 of 7 solver calls ended with an unknown status (MaxIterations): neither feasible nor \
         infeasible, counted as not certified"
    );
    assert_eq!(v["notes"][2], "a remark");
    let back = Design::from_json(&d.to_json()).unwrap();
    assert_eq!(back.notes, d.notes);
    assert!(matches!(back.notes[0], Note::Text(_)));
}

#[test]
fn iteration_progress_sees_every_iteration_and_changes_nothing() {
    use std::cell::Cell;
    use std::rc::Rc;
    let model = paper_model();
    let r = fixed(5.0, 0.18898, Mode::Sound);
    let plain = run(&model, &r);
    let seen = Rc::new(Cell::new(0usize));
    let last = Rc::new(Cell::new(0u32));
    let (s, l) = (seen.clone(), last.clone());
    let observed = qpv_solve::backend::with_iteration_progress(
        move |it| {
            s.set(s.get() + 1);
            l.set(it.number);
            assert!(it.gap_rel.is_finite() || it.number == 0, "{it:?}");
        },
        || run(&model, &r),
    );
    assert!(seen.get() > 0, "the hook saw no iteration");
    assert!(last.get() >= 1);
    // Observing changes no result: the same point, bit for bit.
    assert_eq!(observed.alpha, plain.alpha);
    assert_eq!(observed.p_matrix(), plain.p_matrix());
    assert_eq!(observed.l_matrices(), plain.l_matrices());
    // The hook is gone once `with_iteration_progress` returns.
    let before = seen.get();
    let _ = run(&model, &r);
    assert_eq!(seen.get(), before);
}
