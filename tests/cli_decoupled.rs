//! `qpv design --conditions full|decoupled --split as_written|symmetric`
//! (docs/method.md §7, §8): the flags reach the design and its report.

use crate::common;
use common::qpv;

fn design_json(extra: &[&str]) -> (serde_json::Value, String) {
    let mut args = vec![
        "design",
        "examples/paper.qpv",
        "--alpha",
        "max",
        "--gamma",
        "0.1889",
    ];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--json", "-"]);
    let out = qpv(&args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("JSON report on stdout");
    assert_eq!(json["designs"].as_array().map(Vec::len), Some(1));
    (json["designs"][0].clone(), stderr)
}

#[test]
fn conditions_and_split_flags_reach_the_report() {
    let (full, _) = design_json(&["--split", "as_written", "--conditions", "full"]);
    let (dec, text) = design_json(&["--split", "as_written", "--conditions", "decoupled"]);
    assert_eq!(full["conditions"], "full");
    assert_eq!(dec["conditions"], "decoupled");
    assert_eq!(dec["split"], "as_written");
    assert!(
        text.contains("split = as_written, conditions = decoupled"),
        "{text}"
    );
    assert_eq!(dec["certifies"], true);
    let (af, ad) = (
        full["alpha"].as_f64().unwrap(),
        dec["alpha"].as_f64().unwrap(),
    );
    // No loss on the paper example (α_max ≈ 10.60 as written), to the
    // search tolerance.
    assert!(ad <= af * 1.001 && ad >= af * 0.999, "{ad} vs {af}");
    // The default split in sound mode is symmetric.
    let (sym, _) = design_json(&["--conditions", "decoupled"]);
    assert_eq!(sym["split"], "symmetric");
    assert!(sym["alpha"].as_f64().unwrap() > af);
}

#[test]
fn bad_flag_values_are_rejected() {
    for (flag, value, want) in [
        (
            "--conditions",
            "partial",
            "expected `full`, `decoupled`, `cube` or `auto`",
        ),
        (
            "--split",
            "skew",
            "expected `as_written`, `symmetric` or `skew_slack`",
        ),
    ] {
        let out = qpv(&["design", "examples/paper.qpv", flag, value]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_ne!(out.status.code(), Some(0));
        assert!(stderr.contains(want) && stderr.contains(value), "{stderr}");
    }
}

#[test]
fn split_skew_slack_reports_the_slack_and_check_uses_it() {
    let report = common::tmp("decoupled", "skew.json");
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "max",
        "--gamma",
        "0.1889",
        "--split",
        "skew_slack",
        "--json",
        report.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let v = &doc["designs"][0];
    assert_eq!(v["split"], "skew_slack");
    assert_eq!(v["skew"].as_array().map(Vec::len), Some(4));
    assert!(v["alpha"].as_f64().unwrap() > 13.0);
    let out = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        report.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(text.contains("all conditions hold"), "{text}");
}
