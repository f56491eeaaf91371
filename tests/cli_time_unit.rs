//! `time = hours;`: a model written in hours is designed, checked and
//! exported with every rate, step and sample period said in hours, and
//! its report says which unit they are in.

use crate::common::{json_stdout, qpv, text, tmp};

const MODEL: &str = "examples/chemostat.qpv";

#[test]
fn a_model_in_hours_is_reported_in_hours() {
    let out = qpv(&["design", MODEL, "--json", "-"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let doc = json_stdout(&out);
    let d = &doc["designs"][0];
    assert_eq!(d["time_unit"], "hours", "{d}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("Euler step <= "), "{err}");
    let step = err.split("Euler step <= ").nth(1).unwrap_or_default();
    let step = step.split_whitespace().nth(1).unwrap_or_default();
    assert_eq!(step, "h", "the certified step is in hours: {err}");
    assert!(!err.contains("per second"), "{err}");
}

#[test]
fn a_sampled_design_in_hours_names_its_period_in_hours_everywhere() {
    let report = tmp("time-unit", "chemostat_sampled.json");
    let report_s = report.to_str().expect("utf-8 path");
    let out = qpv(&[
        "design", MODEL, "--sample", "0.01", "--alpha", "0.1", "--json", report_s,
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let t = text(&out);
    assert!(
        t.contains("h = 1e-2 h (100 per hour)") && t.contains("alpha = 0.100000 per hour"),
        "{t}"
    );
    assert!(!t.contains("Hz") && !t.contains("per second"), "{t}");
    // the check recomputes it on the model, in the model's unit
    let out = qpv(&["check", MODEL, "--gains", report_s]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(
        text(&out).contains("sampled at h = 1e-2 h (100 per hour)"),
        "{}",
        text(&out)
    );
    // the C header says hours, not seconds
    let dir = tmp("time-unit", "c");
    let out = qpv(&[
        "codegen",
        MODEL,
        "--gains",
        report_s,
        "--out",
        dir.to_str().expect("utf-8 path"),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let header = std::fs::read_to_string(dir.join("chemostat.h")).expect("the header");
    assert!(
        header.contains("certified at, hours: h = 1e-2 h (100 per hour)"),
        "{header}"
    );
    assert!(!header.contains("seconds"), "{header}");
}
