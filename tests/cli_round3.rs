//! Never a wrong claim, round three: each test reproduces one class an
//! adversarial run of the command line found (a report's pole region read
//! as another region, a verdict short of certified used as certified, an
//! empty design list, input-derived loops and SVDs without a bound, notes
//! that state what no search established, `max_gain` stopping short of
//! designs that meet it, the envelope compared below the arithmetic's
//! resolution, flag values refused for the wrong reason).

use crate::common;

use common::{qpv, text};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    common::tmp("round3", name)
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn read(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("json")
}

fn write(name: &str, text: &str) -> PathBuf {
    let path = tmp(name);
    std::fs::write(&path, text).expect("write");
    path
}

/// The paper example with one sound design block carrying `extra`.
fn paper_with(name: &str, design: &str) -> PathBuf {
    let src = std::fs::read_to_string("examples/paper.qpv").expect("paper.qpv");
    let start = src.find("    design {").expect("a design block");
    let end = src.rfind('}').expect("the model's closing brace");
    write(
        name,
        &format!(
            "{}    design {{ {design} }}\n{}",
            &src[..start],
            &src[end..]
        ),
    )
}

/// Runs `qpv design FILE ARGS --json REPORT` and returns the report's path
/// (exit 0 required).
fn design(model: &Path, args: &[&str], report: &str) -> PathBuf {
    let out_path = tmp(report);
    let mut all = vec!["design", s(model)];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--json", s(&out_path)]);
    let out = qpv(&all);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    out_path
}

/// The paper's sector design (α = 5, γ = 0.18898, sector 45°) and its report.
fn sector_report() -> (PathBuf, PathBuf) {
    let model = paper_with(
        "sector.qpv",
        "alpha = 5; gamma = 0.18898; poles = sector(angle = 45);",
    );
    let report = design(&model, &[], "sector.json");
    (model, report)
}

#[test]
fn a_pole_region_in_a_report_obeys_the_design_blocks_rule() {
    // Used to be checked as the mirrored sector 180° − β and certified.
    let (model, report) = sector_report();
    let doc = read(&report);
    for angle in [120.0, 90.0, 405.0, -315.0, 0.0] {
        let mut d = doc.clone();
        d["designs"][0]["poles"] = serde_json::json!([{"region": "sector", "angle": angle}]);
        let forged = write(&format!("sector{angle}.json"), &d.to_string());
        for args in [
            vec!["check", s(&model), "--gains", s(&forged)],
            vec![
                "codegen",
                s(&model),
                "--gains",
                s(&forged),
                "--out",
                s(&tmp("sector-out")),
            ],
        ] {
            let out = qpv(&args);
            let t = text(&out);
            assert_eq!(out.status.code(), Some(2), "{angle}: {t}");
            assert!(
                t.contains("`angle` must be an angle in degrees strictly between 0 and 90"),
                "{angle}: {t}"
            );
            assert!(!t.contains("certified"), "{angle}: {t}");
        }
    }
    // A disk without a positive radius, a strip with lo ≥ hi: the same rule.
    for (region, want) in [
        (
            serde_json::json!({"region": "disk", "centre": -5, "radius": -1}),
            "`radius`",
        ),
        (
            serde_json::json!({"region": "strip", "lo": -1, "hi": -2}),
            "`hi`",
        ),
    ] {
        let mut d = doc.clone();
        d["designs"][0]["poles"] = serde_json::json!([region]);
        let forged = write("region.json", &d.to_string());
        let out = qpv(&["check", s(&model), "--gains", s(&forged)]);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{t}");
        assert!(t.contains(want), "{t}");
    }
}

#[test]
fn an_empty_design_list_is_refused_not_a_panic() {
    let (model, _) = sector_report();
    for (name, doc) in [
        ("empty-array.json", "[]".to_string()),
        (
            "empty-designs.json",
            r#"{"schema":"qpv/1","command":"design","designs":[]}"#.to_string(),
        ),
    ] {
        let f = write(name, &doc);
        for args in [
            vec!["check", s(&model), "--gains", s(&f)],
            vec!["simulate", s(&model), "--design", s(&f), "--t-end", "0.01"],
            vec![
                "codegen",
                s(&model),
                "--gains",
                s(&f),
                "--out",
                s(&tmp("empty-out")),
            ],
        ] {
            let out = qpv(&args);
            let t = text(&out);
            assert_eq!(out.status.code(), Some(2), "{args:?}: {t}");
            assert!(t.contains("holds no design"), "{args:?}: {t}");
            assert!(!t.contains("panicked"), "{args:?}: {t}");
        }
    }
}

#[test]
fn a_verdict_short_of_certified_is_respected_everywhere() {
    let (model, report) = sector_report();
    let mut d = read(&report);
    d["designs"][0]["verdict"] = Value::from("not_certified");
    let f = write("withdrawn.json", &d.to_string());
    // simulate --sample: no bound claimed, nothing compared.
    let out = qpv(&[
        "simulate",
        s(&model),
        "--design",
        s(&f),
        "--sample",
        "1e-3",
        "--t-end",
        "0.2",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("the report does not certify"), "{t}");
    assert!(!t.contains("continuous-plant bound"), "{t}");
    assert!(!t.contains("stays inside the certified bound"), "{t}");
    // codegen --gains: nothing exported.
    let dir = tmp("withdrawn-out");
    let out = qpv(&["codegen", s(&model), "--gains", s(&f), "--out", s(&dir)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("nothing written"), "{t}");
    assert!(!dir.join("paper_example.c").exists(), "{t}");
}

#[test]
fn input_derived_work_is_bounded_before_it_starts() {
    // SVDs of infinite blocks never returned (h = 1e305): now every figure
    // is refused or NaN at once and the commands finish.
    let (model, report) = sector_report();
    let out = qpv(&[
        "check",
        s(&model),
        "--gains",
        s(&report),
        "--sample",
        "1e305",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("NOT certified"), "{t}");
    let out = qpv(&[
        "simulate",
        s(&model),
        "--design",
        s(&report),
        "--sample",
        "1e305",
        "--t-end",
        "1e305",
        "--dt",
        "1e298",
    ]);
    assert!(out.status.code().is_some(), "{}", text(&out));
    let t = text(&out);
    assert!(!t.lines().any(|l| l.starts_with("certified at")), "{t}");
    // 100 000 pole regions: counted by the certificate's budget.
    let mut d = read(&report);
    d["designs"][0]["poles"] = Value::Array(vec![
        serde_json::json!({"region": "disk", "centre": -5, "radius": 100});
        100_000
    ]);
    let f = write("many-poles.json", &d.to_string());
    let out = qpv(&["check", s(&model), "--gains", s(&f)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("too large to re-check"), "{t}");
    assert!(t.contains("pole-region block"), "{t}");
}

/// A 12-state chain with a quadratic term, box(0.1) (4096 vertices) and a
/// state bound: far beyond the size budget.
fn big_qpv_chain() -> PathBuf {
    let n = 12;
    let states: Vec<String> = (1..=n).map(|i| format!("x{i}")).collect();
    let mut ders = String::from("  der x1 = -x1 + x1*x2;\n");
    for x in &states[1..] {
        ders.push_str(&format!("  der {x} = -{x};\n"));
    }
    let q: Vec<String> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| if i == j { "2" } else { "0" })
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect();
    write(
        "bigchain.qpv",
        &format!(
            "model bigchain {{\n  state {};\n  output y;\n{ders}  out y = x1;\n  region box(0.1);\n  state_bound Q = [ {} ];\n}}\n",
            states.join(", "),
            q.join(" ; ")
        ),
    )
}

#[test]
fn the_noise_design_has_the_size_guard_of_every_design() {
    let model = big_qpv_chain();
    // The noise design solves the full family whatever `conditions` says.
    for extra in [&["--conditions", "full"][..], &["--noise", "min"][..]] {
        let mut args = vec!["design", s(&model), "--alpha", "1", "--gamma", "0.2"];
        args.extend_from_slice(extra);
        let out = qpv(&args);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {t}");
        assert!(t.contains("too large"), "{extra:?}: {t}");
    }
}

/// The flexible-joint arm as an LPV plant (a sector parameter s for
/// sin(q1)/q1; Spong's constants), motor angle and speed measured.
const ARM: &str = "model flexarm {
    state q1, w1, q2, w2;
    input u in [-1, 1];
    output ym, wm;
    param s in [0.64, 1];
    der q1 = w1;
    der w1 = -(0.8/0.0059)*s*q1 - (1.61/0.0059)*(q1 - q2);
    der q2 = w2;
    der w2 = (1.61/0.0021)*(q1 - q2) - (0.0087/0.0021)*w2 + u/0.0021;
    out ym = q2;
    out wm = w2;
}
";

fn max_gain_of(report: &Path) -> f64 {
    read(report)["designs"][0]["gain_norms"]
        .as_array()
        .expect("gain_norms")
        .iter()
        .filter_map(Value::as_f64)
        .fold(0.0, f64::max)
}

#[test]
fn max_gain_returns_designs_that_meet_it() {
    // α = 40 certifies with max ‖L_l‖₂ = g40; `alpha = max; max_gain = G`
    // with G ≥ g40 used to stop at α ≈ 28 (the SDP's gain constraint is
    // only sufficient): the fastest design under G is at least as fast.
    let arm = write("arm.qpv", ARM);
    let at40 = design(&arm, &["--alpha", "40"], "arm40.json");
    let g40 = max_gain_of(&at40);
    let bound = format!("{}", (1.2 * g40).ceil());
    let bounded = design(&arm, &["--alpha", "max", "--max-gain", &bound], "armG.json");
    let d = &read(&bounded)["designs"][0];
    let alpha = d["alpha"].as_f64().expect("alpha");
    assert!(
        alpha >= 40.0,
        "α = {alpha} with max_gain = {bound} (g40 = {g40})"
    );
    assert!(max_gain_of(&bounded) <= 1.2 * g40 + 1.0);
    // And `qpv check` certifies it with the bound.
    let out = qpv(&["check", s(&arm), "--gains", s(&bounded)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
}

#[test]
fn a_failed_max_gain_note_names_the_requested_alpha_and_never_a_bound_below_it() {
    // Used to say "at α = 0.0001 … raise max_gain to at least 2.4e-9".
    let out = qpv(&[
        "design",
        "examples/three_tank.qpv",
        "--alpha",
        "0.09",
        "--max-gain",
        "1",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    let note = t
        .lines()
        .find(|l| l.contains("max_gain = 1 "))
        .unwrap_or_else(|| panic!("no max_gain note: {t}"));
    assert!(note.contains("α = 0.09"), "{note}");
    assert!(!note.contains("0.0001"), "{note}");
    let advised: f64 = note
        .split("max ‖L_l‖₂ = ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no gain in {note}"));
    assert!(advised > 1.0, "{note}");
}

#[test]
fn sampled_failure_notes_state_only_what_was_established() {
    // "the largest h for this α lies in [..)" and "the continuous design
    // does not reach it either" were never proved by the search.
    let out = qpv(&[
        "design",
        "examples/three_tank.qpv",
        "--alpha",
        "2.5",
        "--sample",
        "1e-3",
    ]);
    let t = text(&out);
    assert!(!t.contains("the largest h for this α"), "{t}");
    assert!(!t.contains("does not reach it either"), "{t}");
    // hα ≥ 1 is a proof that nothing certifies: said, and nothing solved.
    let model = paper_with("paper-h.qpv", "alpha = 10; gamma = 0.18898; sample = 0.2;");
    let out = qpv(&["design", s(&model)]);
    let t = text(&out);
    assert_ne!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("hα = 2.0000 ≥ 1"), "{t}");
    assert!(!t.contains("margins of the best attempt"), "{t}");
    // A cap below the search's floor is refused, not called the floor.
    let out = qpv(&[
        "design",
        "examples/lotka_volterra.qpv",
        "--alpha-cap",
        "1e-300",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("expected a number of at least 0.0001"), "{t}");
}

/// Van der Pol with the measured x1 as a parameter: x2' = (1 − p²)x2 − x1.
const VDP: &str = "model vdp {
    state x1, x2;
    output y;
    param p in [-2, 2];
    der x1 = x2;
    der x2 = (1 - p*p)*x2 - x1;
    out y = x1;
    design { alpha = 10; gamma = 0.5; sample = 1e-3; }
}
";

#[test]
fn a_run_converged_to_round_off_never_leaves_its_envelope() {
    // The error reaches 1e-14 while the envelope decays to 1e-22: the
    // difference is the arithmetic's, not the observer's.
    let model = write("vdp.qpv", VDP);
    let report = design(&model, &[], "vdp.json");
    let out = qpv(&[
        "simulate",
        s(&model),
        "--design",
        s(&report),
        "--t-end",
        "10",
        "--param",
        "p=0.5*sin(t)",
        "--x0",
        "1,0",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("the error stays inside the certified envelope"),
        "{t}"
    );
    assert!(!t.contains("LEAVES"), "{t}");
}

#[test]
fn flag_and_report_values_are_refused_for_their_real_reason() {
    let (model, report) = sector_report();
    // A negative number in exponent form is a value, not a flag.
    for (args, want) in [
        (
            vec!["design", s(&model), "--sample", "-1e-3"],
            "--sample -0.001: expected a positive sample period",
        ),
        (
            vec!["design", s(&model), "--alpha", "-1e-3"],
            "expected a positive number",
        ),
        (
            vec![
                "check",
                s(&model),
                "--gains",
                s(&report),
                "--sample",
                "-1e-3",
            ],
            "--sample -0.001: expected a positive sample period",
        ),
    ] {
        let out = qpv(&args);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {t}");
        assert!(t.contains(want), "{args:?}: {t}");
    }
    // A hand-written sample key needs only its period.
    let mut d = read(&report);
    d["designs"][0]["sample"] = serde_json::json!({"h": 0.001});
    let f = write("sample-h.json", &d.to_string());
    let out = qpv(&["check", s(&model), "--gains", s(&f)]);
    let t = text(&out);
    assert!(!t.contains("missing field"), "{t}");
    assert!(t.contains("1e-3"), "{t}");
    // A paper-mode report with a period: the message names the file, not a flag.
    d["designs"][0]["mode"] = Value::from("paper");
    let f = write("paper-sample.json", &d.to_string());
    let out = qpv(&["check", s(&model), "--gains", s(&f)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(!t.contains("drop --mode paper"), "{t}");
    assert!(t.contains("`mode: paper`"), "{t}");
}

/// The verdict line of `qpv check`'s text and its exit code.
fn verdict(model: &Path, report: &Path, extra: &[&str]) -> (Option<i32>, String) {
    let mut args = vec!["check", s(model), "--gains", s(report)];
    args.extend_from_slice(extra);
    let out = qpv(&args);
    let t = text(&out);
    assert!(!t.contains("panicked"), "{t}");
    let line = t
        .lines()
        .find(|l| l.contains("=> "))
        .map(str::to_string)
        .unwrap_or_default();
    (out.status.code(), line)
}

/// Sets `path` (keys separated by '/', numbers index arrays) in `doc`.
fn set(doc: &mut Value, path: &str, v: Value) {
    let mut at = doc;
    for key in path.split('/') {
        at = match key.parse::<usize>() {
            Ok(i) => &mut at[i],
            Err(_) => &mut at[key],
        };
    }
    *at = v;
}

#[test]
fn tampered_reports_of_every_claim_type_are_refused_or_rechecked() {
    // A generator over the report's keys: a *figure* (verdict, margins,
    // data checks, gain norms, σ, ν_max, step sizes, the continuous-plant
    // bound) is never read, so tampering leaves check's verdict as it was;
    // a *claim* (α, γ, P, L, poles, sample.h, max_gain) is re-checked, so a
    // false one is refused (2) or not certified (1), never certified, and
    // never a panic or a hang.
    let model = paper_with(
        "tamper.qpv",
        "alpha = 5; gamma = 0.18898; sample = 1e-3; max_gain = 200;",
    );
    let report = design(&model, &[], "tamper.json");
    let doc = read(&report);
    let base = verdict(&model, &report, &[]);
    assert_eq!(base.0, Some(0), "{base:?}");
    let figures = [
        "designs/0/verdict",
        "designs/0/margins/S5d",
        "designs/0/data_checks/S4/value",
        "designs/0/gain_norms/0",
        "designs/0/sample/decrease",
        "designs/0/sample/alpha_per_step",
        "designs/0/sample/continuous_bound/ultimate_error",
        "designs/0/summary",
    ];
    let junk = [
        Value::from(-1.0),
        Value::from(1e308),
        Value::from(0.0),
        Value::from("certified"),
        Value::Null,
    ];
    let mut cases = 0;
    for key in figures {
        for v in &junk {
            let mut d = doc.clone();
            set(&mut d, key, v.clone());
            let f = write("tampered-figure.json", &d.to_string());
            let got = verdict(&model, &f, &[]);
            // A figure of the wrong type may make the file unreadable (2);
            // read, it changes nothing.
            if got.0 != Some(2) {
                assert_eq!(got, base, "{key} = {v}");
            }
            cases += 1;
        }
    }
    let p00 = doc["designs"][0]["P"][0][0].as_f64().expect("P");
    let claims: Vec<(&str, Value)> = vec![
        ("designs/0/alpha", Value::from(50.0)),
        ("designs/0/alpha", Value::from(1e308)),
        ("designs/0/alpha", Value::from(-1.0)),
        ("designs/0/gamma", Value::from(0.99)),
        ("designs/0/gamma", Value::from(-0.5)),
        ("designs/0/P/0/0", Value::from(-p00)),
        ("designs/0/P/0/0", Value::from(1e308)),
        ("designs/0/L/0/0/0", Value::from(1e6)),
        ("designs/0/max_gain", Value::from(1e-9)),
        ("designs/0/sample/h", Value::from(1e305)),
        ("designs/0/sample/h", Value::from(0.5)),
        ("designs/0/sample/h", Value::from(-1e-3)),
        (
            "designs/0/poles",
            serde_json::json!([{"region": "sector", "angle": 135}]),
        ),
        (
            "designs/0/poles",
            serde_json::json!([{"region": "disk", "centre": 0, "radius": 1e-9}]),
        ),
    ];
    for (key, v) in claims {
        let mut d = doc.clone();
        set(&mut d, key, v.clone());
        let f = write("tampered-claim.json", &d.to_string());
        let got = verdict(&model, &f, &[]);
        assert!(
            matches!(got.0, Some(1) | Some(2)),
            "{key} = {v}: exit {:?}, {}",
            got.0,
            got.1
        );
        assert!(!got.1.contains("=> certified"), "{key} = {v}: {}", got.1);
        cases += 1;
    }
    // Input-derived loops: refused with their bound, before they start.
    for args in [
        vec![
            "simulate",
            s(&model),
            "--design",
            s(&report),
            "--t-end",
            "1e300",
            "--dt",
            "1e-300",
        ],
        vec![
            "simulate",
            s(&model),
            "--design",
            s(&report),
            "--sample",
            "1e-300",
            "--t-end",
            "1",
        ],
    ] {
        let out = qpv(&args);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {t}");
        assert!(t.contains("at most"), "{args:?}: {t}");
        cases += 1;
    }
    // Output paths that alias an input: refused, the input intact.
    let before = std::fs::read(&model).expect("model");
    for args in [
        vec!["design", s(&model), "--json", s(&model)],
        vec![
            "check",
            s(&model),
            "--gains",
            s(&report),
            "--json",
            s(&report),
        ],
    ] {
        let out = qpv(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", text(&out));
        cases += 1;
    }
    assert_eq!(std::fs::read(&model).expect("model"), before);
    assert_eq!(cases, 58, "{cases} cases");
}

#[test]
fn a_global_designs_c_certificate_claims_no_state_bound() {
    // It used to claim coverage of "the plant state in the model's state
    // bound F" and print "lim sup |e| <= none certified".
    let dir = tmp("global-c");
    let out = qpv(&[
        "codegen",
        "examples/three_tank.qpv",
        "--lang",
        "c",
        "--float",
        "f32",
        "--out",
        s(&dir),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let h = std::fs::read_to_string(dir.join("three_tank.h")).expect("header");
    assert!(!h.contains("state bound F."), "{h}");
    assert!(!h.contains("<= none certified"), "{h}");
    assert!(h.contains("assumes no state bound"), "{h}");
    assert!(h.contains("f32 error floor: none certified ("), "{h}");
}

#[test]
fn a_continuous_plant_bound_wider_than_the_envelope_says_it_is_vacuous() {
    // The arm at h = 1 ms: lim sup ‖e‖ ≤ 60 against states bounded by 10.
    let model = write(
        "arm-envelope.qpv",
        &ARM.replace(
            "    out wm = w2;\n",
            "    out wm = w2;\n    state_bound Q = [ 2.4649, 0, 0, 0 ; 0, 100, 0, 0 ; 0, 0, 2.4649, 0 ; 0, 0, 0, 100 ];\n    design { alpha = 40; sample = 1e-3; }\n",
        ),
    );
    let out = qpv(&["design", s(&model)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("vacuous as a statement of the estimate's accuracy"),
        "{t}"
    );
}

#[test]
fn a_request_predicted_to_be_slow_says_so_before_its_first_solve() {
    // The manipulator at h = 1 ms: 8 192 discrete blocks, minutes per solve;
    // it used to print nothing for minutes. The notice comes first (the run
    // is stopped after it: the test needs no solve).
    let line = first_stderr_line(&[
        "design",
        "examples/manipulator.qpv",
        "--sample",
        "1e-3",
        "--alpha",
        "1",
    ]);
    assert!(line.contains("is large"), "{line}");
    assert!(line.contains("s per solve"), "{line}");
}

#[test]
fn a_sampled_noise_design_reads_the_plants_own_state_bound() {
    // three_tank with a declared envelope: the sampled noise design asked
    // to "declare state_bound Q" (it looked on the global observer's model,
    // which has none).
    let src = std::fs::read_to_string("examples/three_tank.qpv").expect("three_tank");
    let end = src.rfind('}').expect("closing brace");
    let model = write(
        "tank-q.qpv",
        &format!(
            "{}    state_bound Q = [ 4, 0, 0 ; 0, 4, 0 ; 0, 0, 4 ];\n{}",
            &src[..end],
            &src[end..]
        ),
    );
    let out = qpv(&[
        "design",
        s(&model),
        "--noise",
        "min",
        "--alpha",
        "0.1",
        "--sample",
        "1e-2",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(!t.contains("declare the plant's operating envelope"), "{t}");
    assert!(
        t.contains("no bound for the continuous plant sampled at h (input"),
        "{t}"
    );
}

#[test]
fn codegen_says_so_before_a_slow_solve_too() {
    // `qpv codegen` solves the design block as `qpv design` does: the same
    // notice before its first solve (the run is stopped after it).
    let src = std::fs::read_to_string("examples/manipulator.qpv").expect("manipulator");
    let (start, end) = (
        src.find("design {").expect("a block"),
        src.rfind('}').expect("}"),
    );
    let model = write(
        "manipulator-sampled.qpv",
        &format!(
            "{}design {{ alpha = 1; sample = 1e-3; }}\n{}",
            &src[..start],
            &src[end..]
        ),
    );
    let line = first_stderr_line(&[
        "codegen",
        s(&model),
        "--lang",
        "c",
        "--out",
        s(&tmp("slow-c")),
    ]);
    assert!(line.contains("is large"), "{line}");
}

/// The first line `qpv ARGS` writes to stderr; the run is then stopped
/// (the tests that use it need no solve, only what is said before one).
fn first_stderr_line(args: &[&str]) -> String {
    use std::io::{BufRead, BufReader};
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_qpv"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("qpv runs");
    let mut line = String::new();
    let stderr = child.stderr.take().expect("stderr");
    BufReader::new(stderr).read_line(&mut line).expect("a line");
    let _ = child.kill();
    let _ = child.wait();
    line
}
