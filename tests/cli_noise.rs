//! The noise features of the command line: `qpv design --noise min` on the
//! paper example against the reference noise gain, its refusal of
//! α = max, `qpv simulate --noise` inside the certified noise bound below
//! ν_max and without a claim above it, and `qpv tradeoff`'s table and
//! figure.

use crate::common;

use common::{num, qpv, text};
use serde_json::Value;
use std::path::PathBuf;
use std::sync::OnceLock;

fn tmp(name: &str) -> PathBuf {
    common::tmp("noise", name)
}

/// Reference of the method page for the paper example (sound mode,
/// symmetric split, γ = 0.18898, noise on both outputs, α = 5): σ_min = 590,
/// error bound 1.27 per unit noise, ν_max = 0.092.
const SIGMA_REF: f64 = 590.0;
const ERROR_BOUND_REF: f64 = 1.27;
const NU_MAX_REF: f64 = 0.092;

/// The noise-optimal paper design at α = 5, γ = 0.18898 (designed once),
/// its report path and its `designs[0]`.
fn paper_noise_min() -> &'static (PathBuf, Value) {
    static D: OnceLock<(PathBuf, Value)> = OnceLock::new();
    D.get_or_init(|| {
        let report = tmp("paper_noise_min.json");
        let out = qpv(&[
            "design",
            "examples/paper.qpv",
            "--alpha",
            "5",
            "--gamma",
            "0.18898",
            "--noise",
            "min",
            "--json",
            report.to_str().expect("utf-8"),
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out));
        let v: Value =
            serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
        (report, v["designs"][0].clone())
    })
}

#[test]
fn noise_min_on_the_paper_example_matches_the_reference_noise_gain() {
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "5",
        "--gamma",
        "0.18898",
        "--noise",
        "min",
        "--json",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let v: Value = serde_json::from_slice(&out.stdout).expect("json on stdout");
    assert_eq!(v["schema"], "qpv/1");
    let d = &v["designs"][0];
    assert_eq!(d["verdict"], "certified");
    let noise = &d["noise"];
    let sigma = num(noise, "sigma");
    assert!(
        (0.99 * SIGMA_REF..=1.05 * SIGMA_REF).contains(&sigma),
        "sigma = {sigma}"
    );
    let eb = num(noise, "error_bound");
    assert!(
        (0.99 * ERROR_BOUND_REF..=1.03 * ERROR_BOUND_REF).contains(&eb),
        "error_bound = {eb}"
    );
    let nu = num(noise, "max_amplitude");
    assert!(
        (0.97 * NU_MAX_REF..=1.01 * NU_MAX_REF).contains(&nu),
        "max_amplitude = {nu}"
    );
    assert_eq!(noise["check"]["passed"], true);
    assert!(num(&d["sampling"], "max_step_euler") > 0.0);
}

#[test]
fn the_text_report_prints_the_noise_and_sampling_figures() {
    let (report, d) = paper_noise_min();
    assert!(report.exists());
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "5",
        "--gamma",
        "0.18898",
        "--noise",
        "min",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("sigma"), "{t}");
    assert!(t.contains("per unit noise amplitude"), "{t}");
    assert!(t.contains("nu_max"), "{t}");
    assert!(t.contains("per-state"), "{t}");
    assert!(t.contains("largest Euler step"), "{t}");
    assert!(t.contains("RK4 step estimate"), "{t}");
    assert!(t.contains("an estimate"), "{t}");
    assert!(d["noise"]["per_state"]
        .as_array()
        .is_some_and(|a| a.len() == 3));
}

#[test]
fn noise_min_refuses_alpha_max_and_bad_values() {
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "max",
        "--noise",
        "min",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("--noise min needs a fixed alpha"), "{t}");
    assert!(!t.contains("panicked"), "{t}");
    let out = qpv(&["design", "examples/paper.qpv", "--noise", "lots"]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("expected `min`, `rms` or `free`"), "{t}");
}

fn simulate_with_noise(nu: f64, dir: &str) -> std::process::Output {
    let (report, _) = paper_noise_min();
    let dir = tmp(dir);
    qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        report.to_str().expect("utf-8"),
        "--scenario",
        "paper",
        "--noise",
        &nu.to_string(),
        "--seed",
        "7",
        "--plot",
        dir.to_str().expect("utf-8"),
    ])
}

#[test]
fn a_run_at_half_the_largest_noise_stays_inside_the_certified_bound() {
    let (_, d) = paper_noise_min();
    let nu_max = num(&d["noise"], "max_amplitude");
    let out = simulate_with_noise(0.5 * nu_max, "half");
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("certified under noise"), "{t}");
    assert!(
        t.contains("the error stays inside the certified noise bound"),
        "{t}"
    );
    let svg = std::fs::read_to_string(tmp("half").join("error.svg")).expect("error.svg");
    assert!(svg.contains("certified noise bound"));
}

#[test]
fn a_run_at_twice_the_largest_noise_makes_no_claim() {
    let (_, d) = paper_noise_min();
    let nu_max = num(&d["noise"], "max_amplitude");
    let out = simulate_with_noise(2.0 * nu_max, "twice");
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("no bound is certified at this noise level"),
        "{t}"
    );
    assert!(!t.contains("certified noise bound"), "{t}");
    assert!(!t.contains("certified envelope"), "{t}");
    let svg = std::fs::read_to_string(tmp("twice").join("error.svg")).expect("error.svg");
    assert!(!svg.contains("certified"));
}

#[test]
fn tradeoff_writes_the_table_and_the_figure() {
    let json = tmp("tradeoff.json");
    let dir = tmp("tradeoff");
    let out = qpv(&[
        "tradeoff",
        "examples/paper.qpv",
        "--gamma",
        "0.18898",
        "--points",
        "3",
        "--json",
        json.to_str().expect("utf-8"),
        "--plot",
        dir.to_str().expect("utf-8"),
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
    assert_eq!(v["schema"], "qpv/1");
    assert_eq!(v["command"], "tradeoff");
    assert_eq!(v["model"], "paper_example");
    let points = v["points"].as_array().expect("points");
    // 3 requested, and up to 3 more below 5 % while the gain still falls.
    assert!((3..=6).contains(&points.len()), "{points:?}");
    let alpha_sup = num(&v["alpha_max"], "alpha_sup");
    for p in points {
        for key in [
            "alpha",
            "gamma",
            "sigma",
            "error_bound",
            "max_gain",
            "max_step_euler",
        ] {
            assert!(p[key].is_number(), "{key} in {p}");
        }
        assert!(num(p, "alpha") <= 0.99 * alpha_sup * (1.0 + 1e-12));
    }
    assert!(t.contains("euler_step"), "{t}");
    let alphas: Vec<f64> = points.iter().map(|p| num(p, "alpha")).collect();
    assert!(alphas.windows(2).all(|w| w[0] < w[1]), "{alphas:?}");
    let knee = v["knee"].as_u64().expect("a knee") as usize;
    assert_eq!(points[knee]["knee"], true);
    assert_eq!(
        points.iter().filter(|p| p["knee"] == true).count(),
        1,
        "{points:?}"
    );
    assert!(t.contains("<- knee"), "{t}");
    let svg = std::fs::read_to_string(dir.join("tradeoff.svg")).expect("tradeoff.svg");
    assert!(svg.contains("knee"));
}

#[test]
fn tradeoff_rejects_too_few_points() {
    let out = qpv(&["tradeoff", "examples/paper.qpv", "--points", "1"]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("--points 1"), "{t}");
}

#[test]
fn simulate_recomputes_sigma_and_never_trusts_the_reports() {
    // σ divided by 10⁴ (ν_max × 100) in the report: a run at twice the
    // true ν_max used to print "certified under noise" from the forged
    // figures; σ is recomputed from the model and the gains instead.
    let (report, d) = paper_noise_min();
    let nu_max = num(&d["noise"], "max_amplitude");
    let mut doc: Value =
        serde_json::from_str(&std::fs::read_to_string(report).expect("report")).expect("json");
    let noise = &mut doc["designs"][0]["noise"];
    noise["sigma"] = Value::from(num(noise, "sigma") / 1e4);
    noise["max_amplitude"] = Value::from(nu_max * 100.0);
    let forged = tmp("forged_sigma.json");
    std::fs::write(&forged, doc.to_string()).expect("write");
    let out = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        forged.to_str().expect("utf-8"),
        "--scenario",
        "paper",
        "--noise",
        &(2.0 * nu_max).to_string(),
        "--seed",
        "7",
    ]);
    let t = text(&out);
    assert!(!t.contains("certified under noise"), "{t}");
    assert!(
        t.contains("no bound is certified at this noise level"),
        "{t}"
    );
}

/// `qpv tradeoff` on an LPV plant (three-tank): the global observer's
/// noise-optimal designs (γ unused, unlimited amplitude), swept below the
/// knee the high-gain `alpha = max` returned rather than up to its
/// supremum, where no noise design certifies.
#[test]
fn tradeoff_on_an_lpv_plant_sweeps_below_the_knee() {
    let out = qpv(&["tradeoff", "examples/three_tank.qpv"]);
    let s = text(&out);
    assert_eq!(out.status.code(), Some(0), "{s}");
    assert!(s.contains("gamma unused (global observer)"), "{s}");
    assert!(
        s.contains("high gain: the sweep stays below the knee returned"),
        "{s}"
    );
    assert!(!s.contains("not certified"), "{s}");
    assert!(s.contains("<- knee") && s.contains(" inf "), "{s}");
}

/// A certified design whose noise claim cannot be verified says why: the
/// global three-tank design at α = 0.9 (gains near 1.6e7) has no `noise`
/// key; its report's note, its text and its C header give the reason and
/// what gets a bound (`noise = min` at this α, which certifies one).
#[test]
fn a_certified_design_without_a_noise_bound_says_why() {
    let model = "examples/three_tank.qpv";
    let out = qpv(&["design", model, "--json", "-"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let doc: Value = serde_json::from_slice(&out.stdout).expect("json");
    let d = &doc["designs"][0];
    assert_eq!(d["verdict"], "certified", "{d}");
    assert!(d.get("noise").map_or(true, Value::is_null), "{d}");
    let notes: Vec<&str> = d["notes"]
        .as_array()
        .expect("notes")
        .iter()
        .filter_map(Value::as_str)
        .filter(|n| n.starts_with("no noise bound is certified: "))
        .collect();
    assert_eq!(notes.len(), 1, "one reason: {d}");
    assert!(
        notes[0].contains("independent eigenvalue check fails")
            && notes[0].contains("`noise = min` at this alpha"),
        "{}",
        notes[0]
    );

    let out = qpv(&["design", model]);
    let s = text(&out);
    assert!(
        s.contains("  noise: none certified: the smallest sigma"),
        "{s}"
    );
    assert_eq!(
        s.matches("no noise bound is certified").count(),
        0,
        "said once: {s}"
    );

    let dir = tmp("three_tank_c");
    let out = qpv(&["codegen", model, "--out", dir.to_str().expect("utf-8")]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let h = std::fs::read_to_string(dir.join("three_tank.h")).expect("header");
    assert!(
        h.contains("noise: none certified: the smallest sigma")
            && h.contains("`noise = min` at this alpha"),
        "{h}"
    );

    // What the note advises gets one.
    let out = qpv(&[
        "design", model, "--alpha", "0.9", "--noise", "min", "--json", "-",
    ]);
    let doc: Value = serde_json::from_slice(&out.stdout).expect("json");
    assert!(doc["designs"][0]["noise"]["sigma"].is_f64(), "{doc}");
}
