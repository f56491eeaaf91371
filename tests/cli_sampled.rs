//! `--sample H` on the command line: a design certified at the sample
//! period (text and report), `qpv check` of its gains at that period and at
//! a period they do not survive, and the refusals.

use crate::common;

use common::{qpv, text};
use serde_json::Value;
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    common::tmp("sampled", name)
}

/// `qpv design --sample 1e-3`: "CERTIFIED at h = 1e-3 s (1 kHz)", the
/// report's `sample` key, and S5d in its margins; `qpv check` reads h from
/// the report and certifies; `--sample 0.05` on the same gains does not.
#[test]
fn design_and_check_at_a_sample_period() {
    let report = tmp("paper_1khz.json");
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "8",
        "--gamma",
        "0.1889",
        "--sample",
        "1e-3",
        "--json",
        report.to_str().unwrap(),
    ]);
    let s = text(&out);
    assert_eq!(out.status.code(), Some(0), "{s}");
    assert!(s.contains("CERTIFIED at h = 1e-3 s (1 kHz)"), "{s}");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let d = &v["designs"][0];
    assert_eq!(d["sample"]["h"].as_f64(), Some(1e-3), "{d}");
    let decrease = d["sample"]["decrease"].as_f64().unwrap();
    assert!((decrease - (1.0 - 1e-3 * 8.0)).abs() < 1e-12, "{decrease}");
    assert!(d["margins"]["S5d"].as_f64().unwrap() > 0.0, "{d}");
    assert!(d["margins"].get("S5").is_none(), "{d}");

    let check = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        report.to_str().unwrap(),
    ]);
    let s = text(&check);
    assert_eq!(check.status.code(), Some(0), "{s}");
    assert!(
        s.contains("sampled at h = 1e-3 s (1 kHz) (gains file)"),
        "{s}"
    );
    assert!(s.contains("S5d"), "{s}");

    let slow = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        report.to_str().unwrap(),
        "--sample",
        "0.05",
    ]);
    let s = text(&slow);
    assert_eq!(slow.status.code(), Some(1), "{s}");
    assert!(
        s.contains("sampled at h = 5e-2 s (20 Hz) (--sample)"),
        "{s}"
    );
    assert!(s.contains("NOT certified"), "{s}");
}

/// Bad periods and combinations are refused with the reason, exit 2.
#[test]
fn bad_sample_periods_are_refused() {
    for (args, want) in [
        (
            vec!["--sample", "-0.001"],
            "--sample -0.001: expected a positive sample period",
        ),
        (
            vec!["--sample", "0"],
            "--sample 0: expected a positive sample period",
        ),
        (
            vec!["--sample", "1e-3", "--conditions", "decoupled"],
            "--sample does not apply here",
        ),
        (
            vec!["--sample", "1e-3", "--alpha", "5", "--noise", "min"],
            "--sample with --noise min",
        ),
    ] {
        let mut all = vec!["design", "examples/paper.qpv", "--gamma", "0.1889"];
        all.extend(args.iter().copied());
        let out = qpv(&all);
        let s = text(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {s}");
        assert!(s.contains(want), "{args:?}: {s}");
    }
}
