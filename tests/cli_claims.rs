//! Never a wrong claim (issue 24): `check` and `simulate` re-check a
//! report's claim on one path (`Design::recheck`, with its cube slacks and
//! its size guard); outputs never overwrite inputs and are checked before
//! the work; flag values and signals are bad input when they are, with
//! the place and the reason.

use crate::common;

use common::{qpv, text};
use serde_json::Value;
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    common::tmp("claims", name)
}

fn s(p: &std::path::Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Designs `args` into the report `name` (exit 0 required) and returns it.
fn design(name: &str, args: &[&str]) -> PathBuf {
    let report = tmp(name);
    let mut all = vec!["design"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--json", s(&report)]);
    let out = qpv(&all);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    report
}

fn read(path: &std::path::Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("json")
}

fn write(name: &str, doc: &Value) -> PathBuf {
    let path = tmp(name);
    std::fs::write(&path, doc.to_string()).expect("write");
    path
}

/// The paper example's cube design at a fixed point (certified, one solve).
fn paper_cube() -> PathBuf {
    design(
        "cube.json",
        &[
            "examples/paper.qpv",
            "--alpha",
            "1",
            "--gamma",
            "0.1",
            "--conditions",
            "cube",
        ],
    )
}

#[test]
fn check_and_simulate_recheck_the_cube_slacks_alike() {
    let report = paper_cube();
    let out = qpv(&["check", "examples/paper.qpv", "--gains", s(&report)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    // D negated: the slack inequality D ⪰ GᵀPG fails. `check` used to
    // ignore the slacks (exit 0) while `simulate` said NOT certified.
    let mut doc = read(&report);
    let d = &mut doc["designs"][0]["cube"]["D"];
    *d = Value::from(
        d.as_array()
            .expect("D")
            .iter()
            .map(|v| -v.as_f64().expect("number"))
            .collect::<Vec<_>>(),
    );
    let forged = write("cube_negated_d.json", &doc);
    let out = qpv(&["check", "examples/paper.qpv", "--gains", s(&forged)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("D ⪰ GᵀPG") && t.contains("NOT certified"), "{t}");
    let out = qpv(&["simulate", "examples/paper.qpv", "--design", s(&forged)]);
    let t = text(&out);
    assert!(t.contains("NOT certified") && t.contains("D ⪰ GᵀPG"), "{t}");
}

/// A chain of `n` decoupled states observed through x1, over box(0.1)
/// (2^n region vertices), with the gains P = I, L = 0.
fn chain(n: usize) -> (PathBuf, PathBuf) {
    let states: Vec<String> = (1..=n).map(|i| format!("x{i}")).collect();
    let ders: String = states
        .iter()
        .map(|x| format!("  der {x} = -{x};\n"))
        .collect();
    let model = tmp(&format!("chain{n}.qpv"));
    std::fs::write(
        &model,
        format!(
            "model chain {{\n  state {};\n  output y;\n{ders}  out y = x1;\n  region box(0.1);\n}}\n",
            states.join(", ")
        ),
    )
    .expect("write");
    let eye: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    let gains = serde_json::json!({
        "P": eye, "L": [vec![vec![0.0]; n]], "alpha": 0.5, "gamma": 0.5
    });
    (model, write(&format!("chain{n}.json"), &gains))
}

#[test]
fn check_refuses_a_recheck_beyond_the_certificate_budget() {
    // 4096 region vertices: 1.7e7 vertex-pair blocks, four times the
    // certificate's budget. Refused at once, with the reason and what
    // would fit (a cube report's slacks), instead of minutes of work.
    let (model, gains) = chain(12);
    for args in [
        vec!["check", s(&model), "--gains", s(&gains)],
        vec![
            "simulate",
            s(&model),
            "--design",
            s(&gains),
            "--t-end",
            "0.01",
        ],
    ] {
        let out = qpv(&args);
        let t = text(&out);
        assert!(t.contains("too large to re-check"), "{t}");
        assert!(t.contains("cube"), "{t}");
        assert!(!t.contains("=> certified"), "{t}");
    }
}
