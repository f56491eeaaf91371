//! End-to-end tests of the `qpv` command line: exit codes, JSON report keys,
//! stdout discipline with `--json -`, positioned errors, figures.

mod common;
use common::qpv;
use std::path::PathBuf;
use std::process::Output;

fn tmp(name: &str) -> PathBuf {
    common::tmp("test", name)
}

fn json_stdout(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not exactly one JSON document ({e}):\n{}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
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
    let j = json_stdout(&out);
    for key in [
        "model",
        "mode",
        "feasible",
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
    assert_eq!(j["feasible"], true);
    assert_eq!(j["certifies"], false);
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
    let j = json_stdout(&out);
    assert_eq!(j["feasible"], false);
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
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report written"))
            .expect("json");
    assert_eq!(j["feasible"], true);
    assert_eq!(j["certifies"], true);
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
    assert_eq!(c["passed"], false);

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
    let v = j["vertices"].as_array().expect("vertices");
    assert_eq!(v.len(), 4);
    // Vertex 2 is θ1 = lo, θ2 = hi; its A(1,3) = 2 + 2θ2 = 4.
    assert_eq!(v[1]["theta"], serde_json::json!([0.0, 1.0]));
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
    assert_eq!(
        j.as_array().map(Vec::len),
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
    let sim = qpv(&[
        "simulate",
        "examples/van_de_vusse.qpv",
        "--design",
        r,
        "--t-end",
        "0.1",
    ]);
    assert_eq!(
        sim.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&sim.stderr)
    );
}
