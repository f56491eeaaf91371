//! The reports stay as they were: every example's design but the elastic
//! arm's (slow), and one case of each design family (sampled, noise, cube,
//! decoupled, skew slack, `max_gain`, pole regions, the global observer,
//! paper mode), compared key by key with the JSON written before the
//! engine was reorganised
//! (a reorganisation changes where code lives, never what a design says).
//!
//! Timings (keys naming seconds, durations in notes) are left out; numbers
//! agree to 1e-6 relative (the solver's arithmetic is the same; the BLAS
//! kernels may round differently on another CPU). `QPV_BLESS=1` rewrites
//! the files (only when a change of output is intended, and said so in the
//! commit).

use super::cli_docs::doc_numbers::number_len;
use super::common::qpv;
use serde_json::Value;
use std::path::PathBuf;

/// (file name, arguments after `design`): the cases compared.
const CASES: &[(&str, &[&str])] = &[
    ("arrhenius_reactor", &["examples/arrhenius_reactor.qpv"]),
    ("lorenz", &["examples/lorenz.qpv"]),
    ("lotka_volterra", &["examples/lotka_volterra.qpv"]),
    ("manipulator", &["examples/manipulator.qpv"]),
    ("paper", &["examples/paper.qpv"]),
    ("paper_auto", &["examples/paper_auto.qpv"]),
    ("paper_equations", &["examples/paper_equations.qpv"]),
    ("pmsm", &["examples/pmsm.qpv"]),
    ("sir", &["examples/sir.qpv"]),
    ("spacecraft", &["examples/spacecraft.qpv"]),
    ("three_tank", &["examples/three_tank.qpv"]),
    ("van_de_vusse", &["examples/van_de_vusse.qpv"]),
    ("varying_output", &["examples/varying_output.qpv"]),
    ("paper_sampled", &["tests/fixtures/paper_sampled.qpv"]),
    (
        "paper_noise",
        &[
            "examples/paper.qpv",
            "--model",
            "paper_example",
            "--noise",
            "min",
            "--alpha",
            "5",
            "--gamma",
            "0.18898",
        ],
    ),
    (
        "paper_cube",
        &[
            "examples/paper.qpv",
            "--conditions",
            "cube",
            "--alpha",
            "2",
            "--gamma",
            "0.18898",
        ],
    ),
    (
        "paper_cube_not_certified",
        &[
            "examples/paper.qpv",
            "--conditions",
            "cube",
            "--alpha",
            "5",
            "--gamma",
            "0.2",
        ],
    ),
    (
        "paper_decoupled",
        &[
            "examples/paper.qpv",
            "--conditions",
            "decoupled",
            "--alpha",
            "5",
        ],
    ),
    (
        "paper_skew",
        &[
            "examples/paper.qpv",
            "--split",
            "skew_slack",
            "--alpha",
            "5",
            "--gamma",
            "0.18898",
        ],
    ),
    (
        "paper_max_gain",
        &["examples/paper.qpv", "--max-gain", "30"],
    ),
    (
        "paper_region_cost",
        &["examples/paper.qpv", "--alpha", "5", "--region-cost"],
    ),
    (
        "paper_mode",
        &[
            "examples/paper.qpv",
            "--mode",
            "paper",
            "--alpha",
            "10",
            "--gamma",
            "0.4",
        ],
    ),
    (
        "paper_sampled_max",
        &[
            "examples/paper.qpv",
            "--sample",
            "1e-3",
            "--gamma",
            "0.18898",
        ],
    ),
    (
        "paper_noise_sampled",
        &[
            "examples/paper.qpv",
            "--noise",
            "min",
            "--alpha",
            "5",
            "--gamma",
            "0.18898",
            "--sample",
            "1e-3",
        ],
    ),
    (
        "three_tank_noise",
        &[
            "examples/three_tank.qpv",
            "--noise",
            "min",
            "--alpha",
            "0.5",
        ],
    ),
    (
        "three_tank_noise_sampled",
        &[
            "examples/three_tank.qpv",
            "--noise",
            "min",
            "--alpha",
            "0.5",
            "--sample",
            "1e-2",
        ],
    ),
    ("paper_sector", &["tests/fixtures/golden/paper_sector.qpv"]),
    (
        "tank_lpv_poles",
        &["tests/fixtures/golden/tank_lpv_poles.qpv"],
    ),
    (
        "three_tank_max_gain",
        &[
            "examples/three_tank.qpv",
            "--alpha",
            "max",
            "--max-gain",
            "100",
        ],
    ),
    (
        "three_tank_sampled",
        &[
            "examples/three_tank.qpv",
            "--alpha",
            "0.09",
            "--sample",
            "1e-2",
        ],
    ),
];

fn golden(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/golden")
        .join(format!("{name}.json"))
}

/// The report without what varies from run to run: keys naming seconds,
/// and durations in the notes' text (a number followed by " s").
fn normalise(v: &Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .filter(|(k, _)| !k.contains("seconds"))
                .map(|(k, v)| (k.clone(), normalise(v)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.iter().map(normalise).collect()),
        Value::String(s) => Value::String(mask_durations(s)),
        other => other.clone(),
    }
}

/// `s` with every number that is followed by " s" (a duration) replaced by `#`.
fn mask_durations(s: &str) -> String {
    let tokens = tokens(s);
    let mut out = String::new();
    for (i, t) in tokens.iter().enumerate() {
        let next = tokens.get(i + 1).map(|t| t.text.as_str()).unwrap_or("");
        let duration = next == " s"
            || next.starts_with(" s ")
            || next.starts_with(" s,")
            || next.starts_with(" s;")
            || next.starts_with(" s)")
            || next.starts_with(" s.");
        if t.number.is_some() && duration {
            out.push('#');
        } else {
            out.push_str(&t.text);
        }
    }
    out
}

/// A piece of a string: a number (its value) or the text between numbers.
struct Token {
    text: String,
    number: Option<f64>,
}

/// Splits `s` into numbers (as the docs check reads them,
/// [`number_len`]) and the text between them.
fn tokens(s: &str) -> Vec<Token> {
    let b = s.as_bytes();
    let mut out: Vec<Token> = Vec::new();
    let mut i = 0;
    let mut text = String::new();
    while i < b.len() {
        if b[i].is_ascii_digit() {
            // the docs check's scanner: digits, a fraction, an exponent
            let start = i;
            i += number_len(&s[i..]).max(1);
            let lit = &s[start..i];
            if !text.is_empty() {
                out.push(Token {
                    text: std::mem::take(&mut text),
                    number: None,
                });
            }
            out.push(Token {
                text: lit.to_string(),
                number: lit.parse().ok(),
            });
        } else {
            let ch = s[i..].chars().next().expect("a char");
            text.push(ch);
            i += ch.len_utf8();
        }
    }
    if !text.is_empty() {
        out.push(Token { text, number: None });
    }
    out
}

fn close(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= 1e-6 * a.abs().max(b.abs()) + 1e-12
}

/// The differences between `was` and `now` (path: was → now).
fn diff(was: &Value, now: &Value, path: &str, out: &mut Vec<String>) {
    match (was, now) {
        (Value::Object(a), Value::Object(b)) => {
            for k in a.keys().chain(b.keys().filter(|k| !a.contains_key(*k))) {
                let p = format!("{path}.{k}");
                match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => diff(x, y, &p, out),
                    (x, y) => out.push(format!("{p}: {x:?} → {y:?}")),
                }
            }
        }
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                diff(x, y, &format!("{path}[{i}]"), out);
            }
        }
        (Value::Number(a), Value::Number(b)) => {
            let (x, y) = (
                a.as_f64().unwrap_or(f64::NAN),
                b.as_f64().unwrap_or(f64::NAN),
            );
            if !close(x, y) {
                out.push(format!("{path}: {x:e} → {y:e}"));
            }
        }
        (Value::String(a), Value::String(b)) => {
            let (ta, tb) = (tokens(a), tokens(b));
            let same = ta.len() == tb.len()
                && ta.iter().zip(&tb).all(|(x, y)| match (x.number, y.number) {
                    (Some(p), Some(q)) => close(p, q),
                    _ => x.text == y.text,
                });
            if !same {
                out.push(format!("{path}:\n  was {a}\n  now {b}"));
            }
        }
        (a, b) if a == b => {}
        (a, b) => out.push(format!("{path}: {a} → {b}")),
    }
}

#[test]
fn every_report_is_as_it_was_before_the_reorganisation() {
    let bless = std::env::var_os("QPV_BLESS").is_some();
    let mut failures = Vec::new();
    for (name, args) in CASES {
        let mut all = vec!["design"];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--json", "-"]);
        let out = qpv(&all);
        let now: Value = match serde_json::from_slice(&out.stdout) {
            Ok(v) => normalise(&v),
            Err(e) => {
                failures.push(format!(
                    "{name}: no report ({e}): {}",
                    String::from_utf8_lossy(&out.stderr)
                ));
                continue;
            }
        };
        let path = golden(name);
        if bless {
            let text = serde_json::to_string_pretty(&now).expect("json") + "\n";
            std::fs::write(&path, text).expect("write the golden report");
            continue;
        }
        let was: Value = serde_json::from_str(
            &std::fs::read_to_string(&path)
                .unwrap_or_else(|e| panic!("{}: {e} (QPV_BLESS=1 writes it)", path.display())),
        )
        .expect("the golden report is JSON");
        let mut d = Vec::new();
        diff(&was, &now, name, &mut d);
        if !d.is_empty() {
            failures.push(d.join("\n"));
        }
    }
    assert!(
        failures.is_empty(),
        "reports changed:\n{}",
        failures.join("\n")
    );
}
