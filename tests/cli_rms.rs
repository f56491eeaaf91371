//! `qpv design --noise rms` on the paper example: the flags, the report's
//! `rms` key, `qpv check` accepting it and rejecting a forged bound, and
//! the refusals of incomplete requests (exit 2, naming the missing flag).

use crate::common;

use common::{qpv, text};
use serde_json::Value;

fn tmp(name: &str) -> std::path::PathBuf {
    common::tmp("rms", name)
}

#[test]
fn rms_design_reports_its_bound_and_check_rejects_a_forged_one() {
    let report = tmp("paper_rms.json");
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--gamma",
        "0.18898",
        "--noise",
        "rms",
        "--output-std",
        "4e-4",
        "--noise-period",
        "1e-3",
        "--json",
        report.to_str().expect("utf-8"),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(text(&out).contains("total RMS <="), "{}", text(&out));
    let mut v: Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let d = &v["designs"][0];
    assert_eq!(d["verdict"], "certified");
    let total = d["rms"]["total"].as_f64().expect("rms.total");
    assert!(total > 0.0 && total < 4e-4, "{total}");
    assert_eq!(d["rms"]["per_state"].as_array().map(Vec::len), Some(3));
    assert_eq!(
        d["rms"]["noise"]["output_std"],
        serde_json::json!([4e-4, 4e-4])
    );
    let check = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        report.to_str().unwrap(),
    ]);
    assert_eq!(check.status.code(), Some(0), "{}", text(&check));
    // The same gains with the RMS bound claimed 10 % lower: not certified.
    v["designs"][0]["rms"]["total"] = serde_json::json!(0.9 * total);
    let forged = tmp("paper_rms_forged.json");
    std::fs::write(&forged, serde_json::to_string(&v).unwrap()).unwrap();
    let check = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        forged.to_str().unwrap(),
    ]);
    assert_eq!(check.status.code(), Some(1), "{}", text(&check));
    assert!(text(&check).contains("rms"), "{}", text(&check));
}

#[test]
fn incomplete_rms_requests_exit_2_naming_the_flag() {
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--noise",
        "rms",
        "--noise-period",
        "1e-3",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("output_std"), "{}", text(&out));
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--noise",
        "rms",
        "--output-std",
        "1e-3",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("noise_period"), "{}", text(&out));
    let out = qpv(&["design", "examples/paper.qpv", "--output-std", "-1"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
}

#[test]
fn codegen_bakes_the_rms_bound_into_the_c_export() {
    let paper = std::fs::read_to_string("examples/paper.qpv").expect("paper.qpv");
    let start = paper.find("design {").expect("a design block");
    let model = format!(
        "{}design {{ gamma = 0.18898; noise = rms; output_std = 4e-4; noise_period = 1e-3; }}\n}}\n",
        &paper[..start]
    );
    let file = tmp("paper_rms.qpv");
    std::fs::write(&file, model).unwrap();
    let dir = tmp("paper_rms_c");
    let out = qpv(&[
        "codegen",
        file.to_str().unwrap(),
        "--lang",
        "c",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let h = std::fs::read_to_string(dir.join("paper_example.h")).expect("header");
    let c = std::fs::read_to_string(dir.join("paper_example.c")).expect("source");
    assert!(h.contains("paper_example_RMS_BOUND;"), "{h}");
    assert!(h.contains("paper_example_RMS_BOUND_PER_STATE[3]"), "{h}");
    let line = c
        .lines()
        .find(|l| l.contains("paper_example_RMS_BOUND ="))
        .expect("the bound's definition");
    let v: f64 = line
        .split('=')
        .nth(1)
        .and_then(|s| s.trim().trim_end_matches(';').parse().ok())
        .expect("a number");
    assert!(v > 0.0 && v < 4e-4, "{line}");
}
