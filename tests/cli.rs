//! End-to-end tests of the `qpv` command line: exit codes, JSON report keys,
//! stdout discipline with `--json -`, positioned errors, figures.
//!
//! The root of the `cli` test binary: the other command-line test files are
//! its modules (one link instead of six), sharing the helpers of
//! tests/common.

mod cli_claims;
mod cli_codegen;
mod cli_cover;
mod cli_decoupled;
mod cli_docs;
mod cli_golden;
mod cli_jacobian;
mod cli_measured;
mod cli_noise;
mod cli_output;
mod cli_output_route;
mod cli_practical;
mod cli_rms;
mod cli_round3;
mod cli_sampled;
mod cli_simulate;
mod cli_state_bound;
mod cli_time_unit;
mod common;

use common::{json_stdout, qpv};
use std::path::PathBuf;
use std::process::Output;

fn tmp(name: &str) -> PathBuf {
    common::tmp("test", name)
}

/// The envelope every `--json` document has: the schema version, the
/// command and the model's name.
fn assert_envelope(doc: &serde_json::Value, command: &str) {
    assert_eq!(doc["schema"], "qpv/1", "{doc}");
    assert_eq!(doc["command"], command);
    assert!(doc["model"].is_string(), "the model's name: {doc}");
}

#[test]
fn paper_mode_reproduces_the_published_point_with_json_on_stdout_only() {
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--mode",
        "paper",
        "--alpha",
        "10",
        "--gamma",
        "0.4",
        "--json",
        "-",
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc = json_stdout(&out);
    assert_envelope(&doc, "design");
    let designs = doc["designs"].as_array().expect("designs");
    assert_eq!(designs.len(), 1, "one request: one entry");
    let j = &designs[0];
    for key in [
        "model",
        "mode",
        "verdict",
        "alpha",
        "gamma",
        "P",
        "L",
        "margins",
        "data_checks",
        "solver",
        "seconds_total",
    ] {
        assert!(j.get(key).is_some(), "report lacks key {key}");
    }
    assert_eq!(j["mode"], "paper");
    assert_eq!(j["verdict"], "reproduction");
    assert!(j["solver"]["status"].is_string() && j["solver"]["iterations"].is_number());
    // (S4) is reported as a violated assumption: γ² a_kᵀQa_k = 4.48.
    let s4 = j["data_checks"]["S4"]["value"].as_f64().expect("S4 value");
    assert!((s4 - 4.48).abs() < 1e-9, "S4 value {s4}");
    assert_eq!(j["data_checks"]["S4"]["passed"], false);
    // The human summary went to stderr.
    assert!(String::from_utf8_lossy(&out.stderr).contains("certifies nothing"));
}

#[test]
fn sound_mode_at_the_papers_gamma_is_rejected_with_exit_1() {
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "10",
        "--gamma",
        "0.4",
        "--json",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let doc = json_stdout(&out);
    let j = &doc["designs"][0];
    assert_eq!(j["verdict"], "not_certified");
    assert_eq!(j["data_checks"]["S4"]["passed"], false);
}

#[test]
fn sound_design_certifies_and_check_and_simulate_accept_it() {
    let report = tmp("sound.json");
    let r = report.to_str().expect("utf-8 path");
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "10",
        "--gamma",
        "0.1889",
        "--json",
        r,
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("CERTIFIED"));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report written"))
            .expect("json");
    assert_envelope(&doc, "design");
    let j = &doc["designs"][0];
    assert_eq!(j["verdict"], "certified");
    for fam in ["S1", "S2", "S3", "S5"] {
        assert!(
            j["margins"][fam].as_f64().expect("margin") > 0.0,
            "family {fam}"
        );
    }
    assert_eq!(j["L"].as_array().expect("L").len(), 4);

    // The same gains pass `qpv check`, and fail it at a much larger α.
    let ok = qpv(&["check", "examples/paper.qpv", "--gains", r]);
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stdout)
    );
    let bad = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        r,
        "--alpha",
        "1000",
        "--json",
        "-",
    ]);
    assert_eq!(bad.status.code(), Some(1));
    let c = json_stdout(&bad);
    assert_envelope(&c, "check");
    assert_eq!(c["verdict"], "not_certified");
    assert_eq!(c["exit_code"], 1);

    // Simulation writes the figures and the CSV.
    let dir = tmp("figs");
    let d = dir.to_str().expect("utf-8 path");
    let sim = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        r,
        "--scenario",
        "paper",
        "--plot",
        d,
    ]);
    assert_eq!(
        sim.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&sim.stderr)
    );
    for f in [
        "x1.svg",
        "x2.svg",
        "x3.svg",
        "mu.svg",
        "error.svg",
        "trajectories.csv",
    ] {
        let meta = std::fs::metadata(dir.join(f)).unwrap_or_else(|_| panic!("{f} missing"));
        assert!(meta.len() > 100, "{f} is empty");
    }
    let csv = std::fs::read_to_string(dir.join("trajectories.csv")).expect("csv");
    assert!(csv.starts_with("t,x1,x2,x3,xhat1"));
    assert_eq!(
        csv.lines().count(),
        2002,
        "header + 2001 samples of 2 s at 1 ms"
    );
}

#[test]
fn bad_input_exits_2_with_a_positioned_message() {
    let bad = tmp("bad.qpv");
    std::fs::write(
        &bad,
        "model m {\n    state x1;\n    output y1;\n    A = [ -1, 2 ];\n}\n",
    )
    .expect("write");
    let out = qpv(&["vertices", bad.to_str().expect("utf-8")]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(":4:"), "no line number in: {err}");

    let missing = qpv(&["design", "examples/does-not-exist.qpv"]);
    assert_eq!(missing.status.code(), Some(2));
    let flag = qpv(&["design", "examples/paper.qpv", "--gamma", "1.5"]);
    assert_eq!(flag.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&flag.stderr).contains("--gamma"));
}

#[test]
fn vertices_lists_the_documented_vertex_order() {
    let out = qpv(&["vertices", "examples/paper.qpv", "--json", "-"]);
    assert_eq!(out.status.code(), Some(0));
    let j = json_stdout(&out);
    assert_envelope(&j, "vertices");
    let v = j["vertices"].as_array().expect("vertices");
    assert_eq!(v.len(), 4);
    // Vertex 2 is θ1 = lo, θ2 = hi; its A(1,3) = 2 + 2θ2 = 4.
    assert_eq!(v[1]["theta"], serde_json::json!([0.0, 1.0]));
    assert_eq!(v[1]["A"][0][2], 4.0, "A as rows: {}", v[1]["A"]);
    let text = qpv(&["vertices", "examples/paper.qpv"]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("first most significant"));
}

#[test]
fn a_report_of_several_designs_feeds_check_and_simulate() {
    let report = tmp("several.json");
    let r = report.to_str().expect("utf-8 path");
    let out = qpv(&["design", "examples/van_de_vusse.qpv", "--json", r]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report written"))
            .expect("json");
    assert_envelope(&j, "design");
    assert_eq!(
        j["designs"].as_array().map(Vec::len),
        Some(2),
        "one report per design block"
    );
    let ok = qpv(&["check", "examples/van_de_vusse.qpv", "--gains", r]);
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert!(String::from_utf8_lossy(&ok.stderr).contains("using report 1"));
    // The first report is the α = max design (α ≈ 2.8e4, γ ≈ 0.003): its
    // certified Euler step is a few µs, so the run uses a step below it.
    let sim = qpv(&[
        "simulate",
        "examples/van_de_vusse.qpv",
        "--design",
        r,
        "--t-end",
        "0.001",
        "--dt",
        "1e-6",
    ]);
    assert_eq!(
        sim.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&sim.stderr)
    );
}

/// The fixtures in tests/fixtures/: reports in the older unversioned forms.
fn fixture(name: &str) -> String {
    format!("tests/fixtures/{name}")
}

fn stdout_of(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).to_string()
}

fn stderr_of(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).to_string()
}

#[test]
fn every_command_writes_the_same_envelope_with_matrices_as_rows() {
    let vertices = json_stdout(&qpv(&["vertices", "examples/paper.qpv", "--json", "-"]));
    assert_envelope(&vertices, "vertices");
    assert_eq!(vertices["model"], "paper_example");
    let v1 = &vertices["vertices"][0];
    assert_eq!(v1["A"].as_array().map(Vec::len), Some(3), "A: 3 rows");
    assert_eq!(v1["N"].as_array().map(Vec::len), Some(3), "N_k, k = 1..3");
    assert_eq!(v1["C"].as_array().map(Vec::len), Some(2), "C: 2 rows");
    assert_eq!(vertices["state_bound"]["source"], "given");
    assert_eq!(vertices["state_bound"]["Q"][0][1], 0.0017);
    assert_eq!(vertices["scheduling"], serde_json::json!(["th1", "th2"]));
    assert_eq!(vertices["requests"][0]["mode"], "paper");
    assert_eq!(vertices["requests"][1]["alpha"], "max");
    assert_eq!(
        vertices["region"]["vertices"].as_array().map(Vec::len),
        Some(8)
    );
    let text = serde_json::to_string(&vertices).unwrap();
    for internal in ["\"Given\"", "\"span\"", "\"name\":\"paper_example\""] {
        assert!(
            !text.contains(internal),
            "internal type {internal} in {text}"
        );
    }

    let design = qpv(&[
        "design",
        "examples/paper.qpv",
        "--mode",
        "paper",
        "--alpha",
        "10",
        "--gamma",
        "0.4",
        "--json",
        "-",
    ]);
    let design = json_stdout(&design);
    assert_envelope(&design, "design");
    assert_eq!(design["model"], "paper_example");
    assert_eq!(design["skipped"], serde_json::json!([]));
    assert_eq!(design["failures"], serde_json::json!([]));
    let d = &design["designs"][0];
    assert_eq!(d["P"].as_array().map(Vec::len), Some(3), "P: 3 rows");
    assert!(d["margins"].is_object());

    let check = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        &fixture("old-report-object.json"),
        "--json",
        "-",
    ]);
    assert_eq!(check.status.code(), Some(0), "{}", stderr_of(&check));
    let c = json_stdout(&check);
    assert_envelope(&c, "check");
    assert_eq!(c["model"], "paper_example");
    assert_eq!(c["mode"], "sound");
    assert_eq!(c["verdict"], "certified");
    assert_eq!(c["exit_code"], 0);
    let margins = c["margins"]
        .as_object()
        .expect("margins: family → worst margin");
    for fam in ["S1", "S2", "S3", "S5"] {
        assert!(margins[fam].as_f64().expect("a number") > 0.0, "{fam}");
        assert_eq!(c["families"][fam]["margin"], margins[fam]);
    }
}

#[test]
fn old_reports_still_load_in_check_and_simulate() {
    for name in ["old-report-object.json", "old-report-array.json"] {
        let report = fixture(name);
        let ok = qpv(&["check", "examples/paper.qpv", "--gains", &report]);
        assert_eq!(ok.status.code(), Some(0), "{name}: {}", stdout_of(&ok));
        assert!(stdout_of(&ok).contains("certified: all conditions hold"));
        let sim = qpv(&[
            "simulate",
            "examples/paper.qpv",
            "--design",
            &report,
            "--t-end",
            "0.05",
        ]);
        assert_eq!(sim.status.code(), Some(0), "{name}: {}", stderr_of(&sim));
    }
    // The array's certified report is its second.
    let ok = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        &fixture("old-report-array.json"),
    ]);
    assert!(
        stderr_of(&ok).contains("using report 2"),
        "{}",
        stderr_of(&ok)
    );
}

#[test]
fn a_new_report_feeds_check_and_other_documents_are_refused() {
    let report = tmp("fixed.json");
    let r = report.to_str().expect("utf-8 path");
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "10",
        "--gamma",
        "0.1889",
        "--json",
        r,
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr_of(&out));
    let ok = qpv(&["check", "examples/paper.qpv", "--gains", r]);
    assert_eq!(ok.status.code(), Some(0), "{}", stdout_of(&ok));

    let vertices = tmp("vertices.json");
    let v = vertices.to_str().expect("utf-8 path");
    let out = qpv(&["vertices", "examples/paper.qpv", "--json", v]);
    assert_eq!(out.status.code(), Some(0));
    let refused = qpv(&["check", "examples/paper.qpv", "--gains", v]);
    assert_eq!(refused.status.code(), Some(2));
    assert!(
        stderr_of(&refused).contains("`qpv vertices` document holds no gains"),
        "{}",
        stderr_of(&refused)
    );
    let future = tmp("future.json");
    std::fs::write(
        &future,
        r#"{"schema": "qpv/99", "command": "design", "designs": []}"#,
    )
    .expect("write");
    let refused = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        future.to_str().unwrap(),
    ]);
    assert_eq!(refused.status.code(), Some(2));
    assert!(
        stderr_of(&refused).contains("qpv/99"),
        "{}",
        stderr_of(&refused)
    );
}

/// A gains file with only P, L, α and γ of the paper-mode design of the
/// published point.
fn paper_gains() -> PathBuf {
    let text = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(fixture("old-report-array.json")),
    )
    .expect("fixture");
    let reports: serde_json::Value = serde_json::from_str(&text).expect("json");
    let paper = &reports[0];
    assert_eq!(paper["mode"], "paper");
    let bare = serde_json::json!({
        "P": paper["P"],
        "L": paper["L"],
        "alpha": paper["alpha"],
        "gamma": paper["gamma"],
    });
    let path = tmp("paper-gains.json");
    std::fs::write(&path, bare.to_string()).expect("write");
    path
}

#[test]
fn paper_mode_gains_are_never_certified() {
    let gains = paper_gains();
    let g = gains.to_str().expect("utf-8 path");
    // Without --mode: checked in sound mode (never the model's first design
    // block, which is paper mode), where (S4) fails.
    let out = qpv(&["check", "examples/paper.qpv", "--gains", g, "--json", "-"]);
    assert_ne!(out.status.code(), Some(0));
    assert_eq!(out.status.code(), Some(1), "{}", stderr_of(&out));
    let c = json_stdout(&out);
    assert_eq!(c["mode"], "sound");
    assert_eq!(c["mode_source"], "default");
    assert_eq!(c["verdict"], "not_certified");
    let text = stderr_of(&out);
    assert!(text.contains("NOT certified"), "{text}");
    assert!(!text.contains("all conditions hold"), "{text}");

    // Explicitly a reproduction: the printed conditions hold, exit 3.
    let out = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        g,
        "--mode",
        "paper",
        "--json",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(3), "{}", stderr_of(&out));
    let c = json_stdout(&out);
    assert_eq!(c["mode"], "paper");
    assert_eq!(c["verdict"], "reproduction");
    assert_eq!(c["exit_code"], 3);
    let text = stderr_of(&out);
    assert!(
        text.contains("reproduction") && text.contains("not a certificate"),
        "{text}"
    );
    assert!(!text.contains("all conditions hold"), "{text}");

    // A whole paper-mode report carries `mode: paper`: the same exit 3.
    let report = tmp("paper-report.json");
    let text = std::fs::read_to_string(fixture("old-report-array.json")).expect("fixture");
    let reports: serde_json::Value = serde_json::from_str(&text).expect("json");
    std::fs::write(&report, reports[0].to_string()).expect("write");
    let out = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        report.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(3), "{}", stdout_of(&out));
    assert!(stdout_of(&out).contains("from the gains file's `mode`"));

    // The untouched sound report is still certified.
    let ok = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        &fixture("old-report-object.json"),
    ]);
    assert_eq!(ok.status.code(), Some(0), "{}", stdout_of(&ok));
}

#[test]
fn bad_check_values_exit_2_and_name_their_source() {
    let sound = fixture("old-report-object.json");
    for (flag, value) in [
        ("--alpha", "NaN"),
        ("--alpha", "inf"),
        ("--alpha", "-1"),
        ("--alpha", "0"),
        ("--gamma", "NaN"),
        ("--gamma", "1.5"),
        ("--gamma", "-0.2"),
    ] {
        let out = qpv(&[
            "check",
            "examples/paper.qpv",
            "--gains",
            &sound,
            flag,
            value,
        ]);
        let err = stderr_of(&out);
        assert_eq!(out.status.code(), Some(2), "{flag} {value}: {err}");
        assert!(err.contains(flag), "{flag} {value}: {err}");
    }
    let cases = [
        (
            "mode",
            serde_json::json!("bogus"),
            "the gains file's `mode` is \"bogus\"",
        ),
        (
            "alpha",
            serde_json::json!(-1.0),
            "the gains file's `alpha` is -1",
        ),
        (
            "gamma",
            serde_json::json!(2.0),
            "the gains file's `gamma` is 2",
        ),
    ];
    for (key, value, message) in cases {
        let mut gains = serde_json::json!({
            "P": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            "L": [],
            "alpha": 1.0,
            "gamma": 0.1,
        });
        gains[key] = value;
        let path = tmp(&format!("bad-gains-{key}.json"));
        std::fs::write(&path, gains.to_string()).expect("write");
        let out = qpv(&[
            "check",
            "examples/paper.qpv",
            "--gains",
            path.to_str().unwrap(),
        ]);
        let err = stderr_of(&out);
        assert_eq!(out.status.code(), Some(2), "{key}: {err}");
        assert!(err.contains(message), "{key}: {err}");
        assert!(!err.contains("--mode"), "{key}: {err}");
    }
}

#[test]
fn endless_and_oversized_inputs_are_refused() {
    let out = qpv(&["vertices", "/dev/zero"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr_of(&out).contains("larger than 1 MiB"),
        "{}",
        stderr_of(&out)
    );
    let out = qpv(&["check", "examples/paper.qpv", "--gains", "/dev/zero"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr_of(&out).contains("larger than 64 MiB"),
        "{}",
        stderr_of(&out)
    );

    // A regular model file just over the limit (a comment of 1 MiB).
    let big = tmp("big.qpv");
    let model = std::fs::read_to_string("examples/paper.qpv").expect("example");
    std::fs::write(&big, format!("// {}\n{model}", "x".repeat(1 << 20))).expect("write");
    let out = qpv(&["vertices", big.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr_of(&out).contains("the limit for model files"));
}

#[test]
fn split_skew_slack_skips_the_paper_block_and_runs_the_sound_one() {
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--split",
        "skew_slack",
        "--json",
        "-",
    ]);
    let err = stderr_of(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert_eq!(
        err.matches("skipping design request 1").count(),
        1,
        "one line about the paper block: {err}"
    );
    let doc = json_stdout(&out);
    assert_eq!(doc["skipped"][0]["request"], 1);
    let designs = doc["designs"].as_array().expect("designs");
    assert_eq!(designs.len(), 1, "the sound block ran");
    assert_eq!(designs[0]["mode"], "sound");
    assert_eq!(designs[0]["split"], "skew_slack");
    assert_eq!(designs[0]["verdict"], "certified");

    // With nothing left to run it is an error.
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--mode",
        "paper",
        "--split",
        "skew_slack",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr_of(&out).contains("nothing to run"),
        "{}",
        stderr_of(&out)
    );
}

#[test]
fn help_documents_the_exit_codes() {
    let out = qpv(&["--help"]);
    let text = stdout_of(&out);
    assert!(text.contains("Exit codes:"), "{text}");
    for code in ["  0  ", "  1  ", "  2  ", "  3  "] {
        assert!(text.contains(code), "{code:?} in {text}");
    }
    assert!(text.contains("docs/schema.md"));
}

/// A file with two models: gains designed for the second are checked and
/// simulated against the second (the one the report names), never
/// silently against the first; a `--model` that disagrees is an error
/// naming both.
#[test]
fn check_and_simulate_use_the_model_the_report_names() {
    let lv = std::fs::read_to_string("examples/lotka_volterra.qpv").unwrap();
    let first = lv
        .replace("model lotka_volterra", "model first")
        .replace("- (4/3)*s*e1*e2;", "- (4/3)*s*e1*e2 - 5*e1;");
    let file = common::tmp("report-model", "two.qpv");
    std::fs::write(&file, format!("{first}\n{lv}")).unwrap();
    let report = common::tmp("report-model", "second.json");
    let (f, r) = (file.to_str().unwrap(), report.to_str().unwrap());
    let out = qpv(&[
        "design",
        f,
        "--model",
        "lotka_volterra",
        "--alpha",
        "1",
        "--gamma",
        "0.3",
        "--json",
        r,
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", common::text(&out));
    let out = qpv(&["check", f, "--gains", r, "--json", "-"]);
    assert_eq!(out.status.code(), Some(0), "{}", common::text(&out));
    assert_eq!(common::json_stdout(&out)["model"], "lotka_volterra");
    for cmd in [
        vec!["check", f, "--gains", r, "--model", "first"],
        vec!["simulate", f, "--design", r, "--model", "first"],
    ] {
        let out = qpv(&cmd);
        let text = common::text(&out);
        assert_eq!(out.status.code(), Some(2), "{cmd:?}: {text}");
        assert!(
            text.contains("--model first disagrees") && text.contains("`lotka_volterra`"),
            "{cmd:?}: {text}"
        );
    }
}

/// `check` on a model without a state bound: every family may hold, and
/// the verdict says which assumption is missing instead of a bare
/// "NOT certified".
#[test]
fn check_without_a_state_bound_names_the_missing_assumption() {
    let lv = std::fs::read_to_string("examples/lotka_volterra.qpv").unwrap();
    let report = common::tmp("no-bound", "lv.json");
    let out = qpv(&[
        "design",
        "examples/lotka_volterra.qpv",
        "--alpha",
        "1",
        "--gamma",
        "0.3",
        "--json",
        report.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", common::text(&out));
    let unbounded: String = lv
        .lines()
        .filter(|l| !l.trim_start().starts_with("state_bound"))
        .collect::<Vec<_>>()
        .join("\n");
    assert_ne!(unbounded, lv);
    let file = common::tmp("no-bound", "lv.qpv");
    std::fs::write(&file, unbounded).unwrap();
    let out = qpv(&[
        "check",
        file.to_str().unwrap(),
        "--gains",
        report.to_str().unwrap(),
    ]);
    let t = common::text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("NOT certified"), "{t}");
    assert!(t.contains("the model has no state bound F"), "{t}");
}
