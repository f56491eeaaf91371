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
    assert_eq!(dec["verdict"], "certified");
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

/// The ring plant x_k' = −x_k + 4 x_k x_{k+1}, y = x1, and gains file with
/// P = I, L = 0 at (α, γ) = (0.5, 0.4) whose skew slack has skew part
/// `c` and, when `sym`, a symmetric part of −2 that cancels N's symmetric
/// part: returns the `check` run.
fn check_ring_with_slack(tag: &str, c: f64, sym: bool) -> std::process::Output {
    let model = common::tmp("skew-forged", &format!("{tag}.qpv"));
    std::fs::write(
        &model,
        "model ring {\n  state x1, x2, x3;\n  output y;\n  der x1 = -x1 + 4*x1*x2;\n  \
         der x2 = -x2 + 4*x2*x3;\n  der x3 = -x3 + 4*x3*x1;\n  out y = x1;\n  region box(0.5);\n  \
         state_bound Q = [1, 0, 0; 0, 1, 0; 0, 0, 1];\n}\n",
    )
    .unwrap();
    let s = if sym { -2.0 } else { 0.0 };
    let skew = serde_json::json!([[
        [[0.0, s, 0.0], [s, 0.0, c], [0.0, -c, 0.0]],
        [[0.0, 0.0, -c], [0.0, 0.0, s], [c, s, 0.0]],
        [[0.0, c, s], [-c, 0.0, 0.0], [s, 0.0, 0.0]]
    ]]);
    let gains = serde_json::json!({
        "P": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        "L": [[[0.0], [0.0], [0.0]]],
        "alpha": 0.5,
        "gamma": 0.4,
        "mode": "sound",
        "split": "as_written",
        "skew": skew
    });
    let file = common::tmp("skew-forged", &format!("{tag}.json"));
    std::fs::write(&file, gains.to_string()).unwrap();
    qpv(&[
        "check",
        model.to_str().unwrap(),
        "--gains",
        file.to_str().unwrap(),
    ])
}

#[test]
fn a_forged_skew_slack_cannot_change_the_plant() {
    // A skew part of 2^43 used to hide the symmetric −2 from a tolerance
    // that grew with K; at x = 0, e = (−½, −½, −½) the true V' + αV is
    // 1.875 > 0, so nothing may be certified.
    let out = check_ring_with_slack("forged", 2f64.powi(43), true);
    let text = common::text(&out);
    assert_ne!(out.status.code(), Some(0), "{text}");
    assert!(!text.contains("all conditions hold"), "{text}");
    assert!(text.contains("not skew-symmetric"), "{text}");
    // The symmetric part alone, without a huge skew part, is refused too.
    let out = check_ring_with_slack("sym-only", 0.0, true);
    let text = common::text(&out);
    assert_ne!(out.status.code(), Some(0), "{text}");
    assert!(text.contains("not skew-symmetric"), "{text}");
    // A huge but exactly skew slack would round N away: refused by size.
    let out = check_ring_with_slack("huge", 2f64.powi(43), false);
    let text = common::text(&out);
    assert_ne!(out.status.code(), Some(0), "{text}");
    assert!(text.contains("too large"), "{text}");
    // A true skew slack of N's size is accepted (the check runs; these
    // gains need not certify).
    let out = check_ring_with_slack("honest", 1.0, false);
    let text = common::text(&out);
    assert!(!text.contains("skew slack K_"), "{text}");
    assert!(!text.contains("all conditions hold"), "{text}");
}
