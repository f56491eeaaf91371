//! `qpv simulate` says only what is certified, compares the run with the
//! certified envelope only then, exits 1 when a run diverges, takes inputs
//! and parameters as expressions of t or a CSV, streams its CSV with the
//! model's names; `qpv design` explains a failure (no α, margins, a
//! diagnosis) and refuses a problem too large to solve.

use crate::common;

use common::{qpv, text};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    common::tmp("simulate", name)
}

/// Designs `args` into the report `name` and returns its path.
fn design(name: &str, args: &[&str]) -> PathBuf {
    let report = tmp(name);
    let r = report.to_str().expect("utf-8 path");
    let mut all = vec!["design"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--json", r]);
    let out = qpv(&all);
    assert!(report.exists(), "no report: {}", text(&out));
    report
}

/// The paper example's sound design at a fixed point (certified).
fn certified_paper() -> PathBuf {
    design(
        "paper_sound.json",
        &["examples/paper.qpv", "--alpha", "10", "--gamma", "0.1889"],
    )
}

#[test]
fn a_certified_design_is_compared_with_its_envelope_and_the_csv_uses_the_models_names() {
    let report = certified_paper();
    let dir = tmp("certified");
    let out = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        report.to_str().expect("utf-8"),
        "--scenario",
        "paper",
        "--every",
        "0.01",
        "--plot",
        dir.to_str().expect("utf-8"),
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("certified (independent re-check on this model)"),
        "{t}"
    );
    assert!(t.contains("stays inside the certified envelope"), "{t}");
    let svg = std::fs::read_to_string(dir.join("error.svg")).expect("error.svg");
    assert!(svg.contains("certified envelope"));
    let csv = std::fs::read_to_string(dir.join("trajectories.csv")).expect("csv");
    let header = csv.lines().next().expect("header");
    assert_eq!(
        header,
        "t,x1,x2,x3,xhat1,xhat2,xhat3,th1,th2,y1,y2,mu1,mu2,mu3,mu4,error_norm"
    );
    assert_eq!(csv.lines().count(), 202, "header + 201 rows every 0.01 s");
}

#[test]
fn a_report_that_does_not_certify_claims_no_decay_rate_and_draws_no_envelope() {
    let report = design(
        "paper_mode.json",
        &[
            "examples/paper.qpv",
            "--mode",
            "paper",
            "--alpha",
            "10",
            "--gamma",
            "0.4",
        ],
    );
    let dir = tmp("paper_mode");
    let out = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        report.to_str().expect("utf-8"),
        "--plot",
        dir.to_str().expect("utf-8"),
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("NOT certified"), "{t}");
    assert!(!t.contains("certified decay rate"), "{t}");
    assert!(!t.contains("certified (independent"), "{t}");
    let svg = std::fs::read_to_string(dir.join("error.svg")).expect("error.svg");
    assert!(!svg.contains("envelope"));
}

#[test]
fn tampered_gains_are_rechecked_and_a_diverging_run_exits_1() {
    let report = certified_paper();
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let d = &mut j["designs"][0];
    assert_eq!(d["verdict"], "certified");
    // Gains scaled by −1e4: the report still says `certifies: true`.
    for l in d["L"].as_array_mut().expect("L") {
        for row in l.as_array_mut().expect("rows") {
            for v in row.as_array_mut().expect("row") {
                *v = serde_json::json!(v.as_f64().expect("number") * -1e4);
            }
        }
    }
    let bad = tmp("tampered.json");
    std::fs::write(&bad, j.to_string()).expect("write");
    let out = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        bad.to_str().expect("utf-8"),
        "--t-end",
        "0.5",
    ]);
    let t = text(&out);
    assert!(
        t.contains("NOT certified: the independent certificate fails"),
        "{t}"
    );
    assert!(t.contains("simulation diverged at t ="), "{t}");
    assert_eq!(out.status.code(), Some(1), "{t}");
}

#[test]
fn leaving_the_state_bound_is_a_warning() {
    let report = certified_paper();
    let out = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        report.to_str().expect("utf-8"),
        "--x0",
        "0.15,0,0",
        "--t-end",
        "0.2",
    ]);
    let t = text(&out);
    assert!(
        t.contains("warning: the plant leaves the state bound F"),
        "{t}"
    );
}

#[test]
fn inputs_and_parameters_come_from_expressions_or_a_csv() {
    let report = design(
        "vdv.json",
        &[
            "examples/van_de_vusse.qpv",
            "--alpha",
            "20",
            "--gamma",
            "0.5",
        ],
    );
    let r = report.to_str().expect("utf-8");
    let dir = tmp("inputs");
    let d = dir.to_str().expect("utf-8");
    let out = qpv(&[
        "simulate",
        "examples/van_de_vusse.qpv",
        "--design",
        r,
        "--t-end",
        "0.1",
        "--every",
        "0.05",
        "--input",
        "u=2*t + 1",
        "--param",
        "th=35",
        "--plot",
        d,
    ]);
    assert!(out.status.code() != Some(2), "{}", text(&out));
    let csv = std::fs::read_to_string(dir.join("trajectories.csv")).expect("csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(&header[..6], &["t", "x1", "x2", "xhat1", "xhat2", "th"]);
    assert_eq!(header[6], "u");
    assert_eq!(header[7], "cb");
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().expect("number")).collect())
        .collect();
    assert_eq!(rows.len(), 3, "t = 0, 0.05, 0.1");
    for row in &rows {
        assert!((row[5] - 35.0).abs() < 1e-12, "th = 35: {row:?}");
        assert!(
            (row[6] - (2.0 * row[0] + 1.0)).abs() < 1e-12,
            "u = 2t + 1: {row:?}"
        );
    }

    let table = tmp("u.csv");
    std::fs::write(&table, "t,u\n0,0\n0.1,4\n").expect("write");
    let dir2 = tmp("inputs_csv");
    let out = qpv(&[
        "simulate",
        "examples/van_de_vusse.qpv",
        "--design",
        r,
        "--t-end",
        "0.1",
        "--every",
        "0.05",
        "--input-csv",
        table.to_str().expect("utf-8"),
        "--plot",
        dir2.to_str().expect("utf-8"),
    ]);
    assert!(out.status.code() != Some(2), "{}", text(&out));
    let csv = std::fs::read_to_string(dir2.join("trajectories.csv")).expect("csv");
    let mid: Vec<f64> = csv
        .lines()
        .nth(2)
        .expect("row at t = 0.05")
        .split(',')
        .map(|c| c.parse().expect("number"))
        .collect();
    assert!((mid[6] - 2.0).abs() < 1e-9, "linear interpolation: {mid:?}");

    for (flag, arg, want) in [
        ("--input", "v=1", "`v` is neither an input"),
        ("--input", "u=2*x", "unknown name `x`"),
        ("--input", "u", "expected NAME=EXPR"),
        ("--param", "u=1", "`u` is an input"),
    ] {
        let out = qpv(&[
            "simulate",
            "examples/van_de_vusse.qpv",
            "--design",
            r,
            flag,
            arg,
        ]);
        assert_eq!(out.status.code(), Some(2), "{flag} {arg}: {}", text(&out));
        assert!(text(&out).contains(want), "{flag} {arg}: {}", text(&out));
    }
}

#[test]
fn tiny_steps_are_streamed_or_refused_with_the_flag_to_change() {
    let report = certified_paper();
    let r = report.to_str().expect("utf-8");
    let refused = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        r,
        "--dt",
        "1e-9",
        "--t-end",
        "2",
    ]);
    assert_eq!(refused.status.code(), Some(2));
    let t = text(&refused);
    assert!(t.contains("increase --dt") && t.contains("--t-end"), "{t}");

    // 1e5 steps: the CSV keeps its default of at most 10 001 rows.
    let dir = tmp("tiny_dt");
    let out = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        r,
        "--dt",
        "1e-7",
        "--t-end",
        "0.01",
        "--plot",
        dir.to_str().expect("utf-8"),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let csv = std::fs::read_to_string(dir.join("trajectories.csv")).expect("csv");
    let rows = csv.lines().count() - 1;
    assert!((10_000..=10_001).contains(&rows), "{rows} rows");
    let last: f64 = csv
        .lines()
        .last()
        .and_then(|l| l.split(',').next())
        .and_then(|t| t.parse().ok())
        .expect("last time");
    assert!((last - 0.01).abs() < 1e-12, "ends at t_end: {last}");
}

#[test]
fn an_undetectable_plant_fails_with_margins_and_a_diagnosis_but_no_alpha() {
    let out = qpv(&["design", "tests/fixtures/undetectable.qpv"]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("NOT CERTIFIED"), "{t}");
    assert!(!t.contains("alpha = "), "no alpha is claimed: {t}");
    assert!(!t.contains("CERTIFIED:"), "{t}");
    assert!(t.contains("margins of the best attempt"), "{t}");
    assert!(t.contains("S5"), "{t}");
    assert!(t.contains("BLOCKING: not detectable at vertex 1"), "{t}");
    assert!(t.contains("mainly state x2"), "{t}");

    let json = qpv(&["design", "tests/fixtures/undetectable.qpv", "--json", "-"]);
    let j: serde_json::Value =
        serde_json::from_str(&String::from_utf8_lossy(&json.stdout)).expect("json");
    let failed = &j["designs"][0];
    assert_eq!(failed["verdict"], "not_certified");
    let kinds: Vec<&str> = failed["diagnosis"]
        .as_array()
        .expect("diagnosis")
        .iter()
        .filter_map(|f| f["kind"].as_str())
        .collect();
    assert!(kinds.contains(&"detectability"), "{kinds:?}");
}

#[test]
fn a_certified_design_says_once_what_was_certified() {
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "10",
        "--gamma",
        "0.1889",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert_eq!(t.matches("CERTIFIED:").count(), 1, "{t}");
    assert!(t.contains("every sound condition family holds"), "{t}");
    assert!(
        !t.contains("failed the independent certificate and were rejected"),
        "{t}"
    );
}

/// A model with `nx` decoupled stable states, a box region and Q = 2nx·h²·I.
fn chain_model(nx: usize) -> PathBuf {
    let states: Vec<String> = (1..=nx).map(|i| format!("x{i}")).collect();
    let mut src = format!(
        "model chain{nx} {{\n  state {};\n  output y;\n  param th in [0, 1];\n",
        states.join(", ")
    );
    for (i, s) in states.iter().enumerate() {
        let next = &states[(i + 1) % nx];
        // One small quadratic term: a QPV plant (an LPV one would be the
        // global observer, which has no region-vertex pairs to count).
        let quad = if i == 0 {
            format!(" + 0.01*{s}*{next}")
        } else {
            String::new()
        };
        src.push_str(&format!("  der {s} = -(2 + th)*{s} + 0.5*{next}{quad};\n"));
    }
    src.push_str("  out y = x1;\n  region box(0.1);\n  state_bound Q = [");
    let q = 2.0 * nx as f64 * 0.01;
    let rows: Vec<String> = (0..nx)
        .map(|r| {
            (0..nx)
                .map(|c| if r == c { format!("{q}") } else { "0".into() })
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect();
    src.push_str(&rows.join("; "));
    src.push_str("];\n}\n");
    let path = tmp(&format!("chain{nx}.qpv"));
    std::fs::write(&path, src).expect("write model");
    path
}

#[test]
fn a_problem_too_large_to_solve_is_refused_before_solving() {
    let big = chain_model(10);
    let out = qpv(&[
        "design",
        big.to_str().expect("utf-8"),
        "--conditions",
        "full",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("too large"), "{t}");
    assert!(t.contains("1024 region vertices"), "{t}");
    assert!(t.contains("budget"), "{t}");
    assert!(t.contains("region with fewer vertices"), "{t}");

    let small = chain_model(3);
    let out = qpv(&[
        "design",
        small.to_str().expect("utf-8"),
        "--alpha",
        "1",
        "--gamma",
        "0.1",
    ]);
    let t = text(&out);
    assert!(!t.contains("too large"), "{t}");
    assert_ne!(out.status.code(), Some(2), "{t}");
}

/// A stable two-state plant with both states measured, designed at the
/// fixed rate `alpha` (γ = 0.09, inside γ_max = 0.1): at α = 20000 its
/// gains are about 1e4 and the RK4 step estimate about 2.8e-4, below the
/// usual 1e-3; at α = 0.2 it decays slowly.
fn two_state_report(name: &str, alpha: &str) -> PathBuf {
    let model = tmp(&format!("{name}.qpv"));
    std::fs::write(
        &model,
        "model two_state {
    state x1, x2;
    output y1, y2;
    param th in [0, 1];
    der x1 = -(1 + th)*x1 + x2;
    der x2 = -x2 + 0.5*x1*x2;
    out y1 = x1;
    out y2 = x2;
    region box(0.1);
    state_bound Q = [1, 0; 0, 1];
}
",
    )
    .expect("write model");
    let m = model.to_str().expect("utf-8");
    let report = design(
        &format!("{name}.json"),
        &[m, "--alpha", alpha, "--gamma", "0.09"],
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    assert_eq!(doc["designs"][0]["verdict"], "certified", "{doc}");
    model
}

/// The times and errors of `qpv simulate`'s summary table.
fn summary_table(t: &str) -> Vec<(f64, f64)> {
    t.lines()
        .skip_while(|l| !l.contains("||x - xhat||"))
        .skip(1)
        .map_while(|l| {
            let mut cells = l.split_whitespace();
            let time = cells.next()?.parse().ok()?;
            let err = cells.next()?.parse().ok()?;
            cells.next().is_none().then_some((time, err))
        })
        .collect()
}

#[test]
fn the_default_step_lies_inside_a_fast_designs_rk4_step_estimate() {
    let model = two_state_report("fast", "20000");
    let m = model.to_str().expect("utf-8");
    let report = tmp("fast.json");
    let r = report.to_str().expect("utf-8");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let rk4 = doc["designs"][0]["sampling"]["step_estimate_rk4"]
        .as_f64()
        .expect("step_estimate_rk4");
    assert!(rk4 < 1e-3, "the RK4 step estimate {rk4} is below 1e-3");

    let out = qpv(&["simulate", m, "--design", r]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("default time grid: --dt 0.00007 (a quarter of the design's RK4 step estimate"),
        "{t}"
    );
    assert!(!t.contains("diverged"), "{t}");
    assert!(t.contains("stays inside the certified envelope"), "{t}");

    // An explicit --dt wins: at 1e-3 RK4 is unstable on these gains.
    let out = qpv(&["simulate", m, "--design", r, "--dt", "1e-3"]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("diverged"), "{t}");
    assert!(!t.contains("default time grid: --dt"), "{t}");
}

#[test]
fn a_slow_designs_default_horizon_follows_its_rate_and_the_table_ends_there() {
    let model = two_state_report("slow", "0.2");
    let m = model.to_str().expect("utf-8");
    let report = tmp("slow.json");
    let r = report.to_str().expect("utf-8");
    let out = qpv(&["simulate", m, "--design", r]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("--dt 0.001 (inside the design's RK4 step estimate"),
        "{t}"
    );
    assert!(t.contains("--t-end 100 (20/alpha with alpha = 0.2"), "{t}");
    // (a default horizon beyond 2e6 steps is cut there: the unit test of
    // `default_t_end` in src/cli/simulate.rs)
    let table = summary_table(&t);
    let times: Vec<f64> = table.iter().map(|r| r.0).collect();
    assert_eq!(times, [0.0, 5.0, 12.5, 25.0, 50.0, 75.0, 100.0], "{t}");
    assert!(
        t.contains("\n   100.0   "),
        "times printed to the run's scale: {t}"
    );
    assert!(table[6].1 < 1e-3 * table[0].1, "the error fell: {t}");

    // An explicit --t-end wins, and the table ends there.
    let out = qpv(&["simulate", m, "--design", r, "--t-end", "0.3"]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(!t.contains("--t-end"), "{t}");
    let times: Vec<f64> = summary_table(&t).iter().map(|r| r.0).collect();
    assert_eq!(times.last(), Some(&0.3), "{t}");
    assert_eq!(times.len(), 7, "{t}");
}

#[test]
fn a_parameter_fed_with_a_plant_state_is_checked_against_its_interval_as_the_run_goes() {
    let report = certified_paper();
    let r = report.to_str().expect("utf-8");
    let run = |extra: &[&str]| {
        let mut all = vec!["simulate", "examples/paper.qpv", "--design", r];
        all.extend_from_slice(extra);
        qpv(&all)
    };
    // x1 starts below 0, outside Θ = [0, 1] of th1: said as it happens,
    // and the certificate claims nothing about such a run.
    let out = run(&["--param", "th1=x1", "--x0", "-0.01,0,0", "--t-end", "0.2"]);
    let t = text(&out);
    assert!(
        t.contains("parameter th1 is fed with the plant's state x1 as the run goes"),
        "{t}"
    );
    assert!(
        t.contains("warning: the parameter th1 leaves its interval [0, 1] at t = 0.0000"),
        "{t}"
    );
    // A parameter given twice, or a state feeding something else, is bad input.
    let twice = run(&["--param", "th1=x1", "--param", "th1=0.5"]);
    assert_eq!(twice.status.code(), Some(2), "{}", text(&twice));
    assert!(
        text(&twice).contains("`th1` is given twice (first by --param th1=x1)"),
        "{}",
        text(&twice)
    );
    let not_param = run(&["--param", "x2=x1"]);
    assert_eq!(not_param.status.code(), Some(2), "{}", text(&not_param));
    assert!(
        text(&not_param).contains("`x2` is not a parameter of model paper_example"),
        "{}",
        text(&not_param)
    );
}
