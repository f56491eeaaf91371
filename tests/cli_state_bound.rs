//! `state_bound auto` through the command line: `qpv design`
//! computes and reports Q, and `qpv check` re-checks the report with it.

use crate::common;
use common::qpv;

#[test]
fn paper_auto_design_reports_the_bound_and_check_uses_it() {
    let report = common::tmp("auto", "auto.json");
    let out = qpv(&[
        "design",
        "examples/paper_auto.qpv",
        "--json",
        report.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("state bound: computed (state_bound auto)"),
        "{text}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let d = &json["designs"][0];
    let sb = &d["state_bound"];
    assert_eq!(sb["source"], "auto");
    assert_eq!(sb["Q"].as_array().map(Vec::len), Some(3));
    assert_eq!(sb["check"]["passed"], true);
    let gmax = sb["gamma_max"].as_f64().unwrap();
    let h = sb["h"].as_f64().unwrap();
    // γ_max of the paper's Q is 0.18898; the computed bound must do better
    assert!(gmax > 0.25 && h > 0.02, "γ_max {gmax}, h {h}");
    assert_eq!(d["verdict"], "certified");
    // the goal for the paper example with the computed bound
    assert!(d["alpha"].as_f64().unwrap() >= 11.3, "{}", d["alpha"]);

    // qpv check re-certifies the report with its Q ...
    let ok = qpv(&[
        "check",
        "examples/paper_auto.qpv",
        "--gains",
        report.to_str().unwrap(),
    ]);
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stdout)
    );
    // ... and refuses gains without one (exit 2, says what is missing)
    let mut stripped = d.clone();
    stripped.as_object_mut().unwrap().remove("state_bound");
    let bare = common::tmp("auto", "bare.json");
    std::fs::write(&bare, serde_json::to_string(&stripped).unwrap()).unwrap();
    let err = qpv(&[
        "check",
        "examples/paper_auto.qpv",
        "--gains",
        bare.to_str().unwrap(),
    ]);
    assert_eq!(err.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&err.stderr).contains("state_bound.Q"));
}

/// `state_bound auto` that finds no invariant ellipsoid (an unstable plant)
/// is an outcome of the solver, not bad input: exit 1, and the JSON report
/// lists the request among its `failures`.
#[test]
fn state_bound_auto_that_finds_nothing_exits_1() {
    let model = common::tmp("auto", "unstable.qpv");
    std::fs::write(
        &model,
        "model unstable {\n    state x1, x2;\n    output y1;\n    param th in [0, 1];\n    \
         A = [ 1 + th, 0 ; 0, 1 ];\n    N1 = [ 0, 0 ; 0, 0.1 ];\n    N2 = 0;\n    C = [ 1, 0 ];\n    \
         region box(0.1);\n    state_bound auto;\n    design { alpha = 1; gamma = 0.5; }\n}\n",
    )
    .unwrap();
    let out = qpv(&["design", model.to_str().unwrap(), "--json", "-"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("no invariant ellipsoid"), "{err}");
    assert!(err.contains("NOT CERTIFIED"), "{err}");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["designs"], serde_json::json!([]));
    assert_eq!(json["failures"][0]["request"], 1);
    assert!(json["failures"][0]["reason"]
        .as_str()
        .unwrap()
        .contains("no invariant ellipsoid"));
}

/// A report whose `state_bound auto` Q was tampered with (shrunk 100×: the
/// region no longer inside F) is not certified by `qpv check`: exit 1 and
/// the reason; the untouched report still exits 0.
#[test]
fn check_refuses_a_tampered_state_bound() {
    let report = common::tmp("auto_tamper", "report.json");
    let out = qpv(&[
        "design",
        "examples/paper_auto.qpv",
        "--alpha",
        "5",
        "--gamma",
        "0.15",
        "--json",
        report.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&report).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let d = &mut json["designs"][0];
    let ok = qpv(&[
        "check",
        "examples/paper_auto.qpv",
        "--gains",
        report.to_str().unwrap(),
    ]);
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stdout)
    );
    for row in d["state_bound"]["Q"].as_array_mut().unwrap() {
        for v in row.as_array_mut().unwrap() {
            *v = serde_json::json!(v.as_f64().unwrap() * 0.01);
        }
    }
    let tampered = common::tmp("auto_tamper", "tampered.json");
    std::fs::write(&tampered, serde_json::to_string(&json).unwrap()).unwrap();
    let bad = qpv(&[
        "check",
        "examples/paper_auto.qpv",
        "--gains",
        tampered.to_str().unwrap(),
    ]);
    assert_eq!(bad.status.code(), Some(1));
    let text = String::from_utf8_lossy(&bad.stdout);
    assert!(
        text.contains("region is not inside F") && text.contains("NOT certified"),
        "{text}"
    );
}
