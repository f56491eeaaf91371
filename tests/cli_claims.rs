//! Never a wrong claim (docs/schema.md, "What a report may claim"): `check` and `simulate` re-check a
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

/// `qpv check` of a cube report re-checks the report's slack inequalities,
/// never the vertex pairs: per θ-vertex 4r + 1 rate conditions (paper
/// example: 4 θ-vertices, r = 3 generators, so 52 instead of 4 · 8² = 256
/// pairs), and for the region's vertices the two conditions on D instead
/// of the 8 vertices.
#[test]
fn check_of_a_cube_report_takes_the_slack_path() {
    let report = paper_cube();
    let out = qpv(&[
        "check",
        "examples/paper.qpv",
        "--gains",
        s(&report),
        "--json",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let j = common::json_stdout(&out);
    let fam = &j["families"];
    assert_eq!(fam["S5"]["count"], 4 * (4 * 3 + 1), "{fam}");
    assert_eq!(fam["S2"]["count"], 2, "{fam}");
    let s2 = fam["S2"]["worst_at"].as_str().expect("S2 worst_at");
    assert!(s2 == "D ⪰ GᵀPG" || s2 == "trace D ≤ 1", "{fam}");
    let s5 = fam["S5"]["worst_at"].as_str().expect("S5 worst_at");
    assert!(
        s5.contains(" Y k=") || s5.contains(" X k=") || s5.contains("F0 + ΣY + ΣX"),
        "{fam}"
    );
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

#[cfg(unix)] // symlinks and hard links
#[test]
fn json_output_never_overwrites_an_input() {
    let dir = tmp("same-file");
    std::fs::create_dir_all(&dir).expect("dir");
    let model = dir.join("m.qpv");
    let text_before = std::fs::read_to_string("examples/lotka_volterra.qpv").expect("model");
    std::fs::write(&model, &text_before).expect("write");
    let link = dir.join("link.qpv");
    let hard = dir.join("hard.qpv");
    let _ = std::fs::remove_file(&link);
    let _ = std::fs::remove_file(&hard);
    std::os::unix::fs::symlink(&model, &link).expect("symlink");
    std::fs::hard_link(&model, &hard).expect("hard link");
    let dotted = dir.join(".").join("m.qpv");
    for out_path in [&model, &dotted, &link, &hard] {
        let out = qpv(&["design", s(&model), "--json", s(out_path)]);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{t}");
        assert!(t.contains("the same file as the input"), "{t}");
        assert_eq!(std::fs::read_to_string(&model).expect("model"), text_before);
    }
    // check: the gains file is an input too.
    let report = design(
        "same-file-gains.json",
        &[
            "examples/lotka_volterra.qpv",
            "--alpha",
            "1",
            "--gamma",
            "0.3",
        ],
    );
    let before = std::fs::read_to_string(&report).expect("report");
    let out = qpv(&[
        "check",
        "examples/lotka_volterra.qpv",
        "--gains",
        s(&report),
        "--json",
        s(&report),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert_eq!(std::fs::read_to_string(&report).expect("report"), before);
    // vertices: the model.
    let out = qpv(&["vertices", s(&model), "--json", s(&link)]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert_eq!(std::fs::read_to_string(&model).expect("model"), text_before);
}

#[cfg(unix)] // symlinks and hard links
#[test]
fn json_reports_are_written_atomically_through_a_symlink() {
    let dir = tmp("atomic");
    std::fs::create_dir_all(&dir).expect("dir");
    let target = dir.join("report.json");
    let link = dir.join("latest.json");
    std::fs::write(&target, "old").expect("write");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&target, &link).expect("symlink");
    let out = qpv(&["vertices", "examples/paper.qpv", "--json", s(&link)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    // The link stays a link, its target holds the whole new document, and
    // no temporary file is left behind.
    assert!(std::fs::symlink_metadata(&link)
        .expect("link")
        .file_type()
        .is_symlink());
    assert_eq!(read(&target)["command"], "vertices");
    let names: Vec<String> = std::fs::read_dir(&dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
}

#[test]
fn output_paths_are_checked_before_the_work() {
    // tradeoff --plot FILE: refused before the sweep. The 12-state chain's
    // α = max design would itself be refused as too large: the --plot
    // error comes first, so nothing was solved.
    let (model, _) = chain(12);
    let file = tmp("plot-is-a-file");
    std::fs::write(&file, "x").expect("write");
    let json = tmp("tradeoff-never.json");
    let _ = std::fs::remove_file(&json);
    let out = qpv(&[
        "tradeoff",
        s(&model),
        "--plot",
        s(&file),
        "--json",
        s(&json),
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("--plot") && t.contains("not a directory"), "{t}");
    assert!(!t.contains("too large"), "{t}");
    // --json into a directory that does not exist, or onto a directory.
    let missing = tmp("no-such-dir").join("out.json");
    for target in [s(&missing), s(&std::env::temp_dir())] {
        let out = qpv(&["design", s(&model), "--json", target]);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{t}");
        assert!(t.contains("--json"), "{t}");
        assert!(!t.contains("too large"), "{t}");
    }
    // simulate --plot DIR whose CSV would overwrite its own --input-csv.
    let dir = tmp("plot-over-input");
    std::fs::create_dir_all(&dir).expect("dir");
    let csv = dir.join("trajectories.csv");
    std::fs::write(&csv, "t,s\n0,1\n1,1\n").expect("csv");
    let report = design(
        "plot-over-input.json",
        &[
            "examples/lotka_volterra.qpv",
            "--alpha",
            "1",
            "--gamma",
            "0.3",
        ],
    );
    let out = qpv(&[
        "simulate",
        "examples/lotka_volterra.qpv",
        "--design",
        s(&report),
        "--input-csv",
        s(&csv),
        "--plot",
        s(&dir),
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("the same file as the input"), "{t}");
    assert_eq!(
        std::fs::read_to_string(&csv).expect("csv"),
        "t,s\n0,1\n1,1\n"
    );
}

/// The Lotka–Volterra example's certified design (s ∈ [0.8, 1.2]).
fn lotka_volterra() -> PathBuf {
    design(
        "lv.json",
        &[
            "examples/lotka_volterra.qpv",
            "--alpha",
            "1",
            "--gamma",
            "0.3",
        ],
    )
}

fn simulate_lv(extra: &[&str]) -> (Option<i32>, String) {
    let report = lotka_volterra();
    let mut args = vec![
        "simulate",
        "examples/lotka_volterra.qpv",
        "--design",
        s(&report),
    ];
    args.extend_from_slice(extra);
    let out = qpv(&args);
    (out.status.code(), text(&out))
}

#[test]
fn a_parameter_outside_theta_or_given_twice_is_bad_input() {
    // s = 100 used to be clamped in the plant while the CSV recorded 100.
    let (code, t) = simulate_lv(&["--param", "s=100"]);
    assert_eq!(code, Some(2), "{t}");
    assert!(
        t.contains("--param s=100") && t.contains("outside Θ") && t.contains("[0.8, 1.2]"),
        "{t}"
    );
    assert!(!t.contains("certified"), "{t}");
    // Leaving Θ later in the run: named with the time.
    let (code, t) = simulate_lv(&["--param", "s=1+t", "--t-end", "1"]);
    assert_eq!(code, Some(2), "{t}");
    assert!(t.contains("at t = 0.2"), "{t}");
    // A repeated --param used to keep the last silently; a CSV column and
    // a flag for the same name too.
    let (code, t) = simulate_lv(&["--param", "s=1", "--param", "s=0.9"]);
    assert_eq!(code, Some(2), "{t}");
    assert!(
        t.contains("given twice") && t.contains("--param s=1"),
        "{t}"
    );
    let csv = tmp("s.csv");
    std::fs::write(&csv, "t,s\n0,1\n1,1.1\n").expect("csv");
    let (code, t) = simulate_lv(&["--input-csv", s(&csv), "--param", "s=0.9"]);
    assert_eq!(code, Some(2), "{t}");
    assert!(
        t.contains("given twice") && t.contains("--input-csv"),
        "{t}"
    );
    // A table column outside Θ.
    std::fs::write(&csv, "t,s\n0,1\n1,1.5\n").expect("csv");
    let (code, t) = simulate_lv(&["--input-csv", s(&csv)]);
    assert_eq!(code, Some(2), "{t}");
    assert!(t.contains("outside Θ"), "{t}");
    // Inside Θ: runs, certified.
    let (code, t) = simulate_lv(&["--param", "s=1+0.2*sin(t)"]);
    assert_eq!(code, Some(0), "{t}");
}

#[test]
fn a_signal_that_is_not_a_finite_number_is_bad_input() {
    // Used to end as "diverged" or "LEAVES the envelope (up to inf
    // times)", exit 1: it is the input that is wrong.
    for (param, when) in [("s=0/0", "NaN at t = 0"), ("s=1/t", "inf at t = 0")] {
        let (code, t) = simulate_lv(&["--param", param]);
        assert_eq!(code, Some(2), "{t}");
        assert!(t.contains(param) && t.contains(when), "{t}");
    }
    // An input that overflows: exp(1000 t) is inf from t ≈ 0.71.
    let model = tmp("forced.qpv");
    std::fs::write(
        &model,
        "model forced {\n  state x;\n  input u;\n  output y;\n  der x = -x + u;\n  \
         out y = x;\n  region box(1);\n  state_bound Q = [4];\n}\n",
    )
    .expect("model");
    let gains = write(
        "forced.json",
        &serde_json::json!({"P": [[1.0]], "L": [[[1.0]]], "alpha": 1.0, "gamma": 0.5}),
    );
    let out = qpv(&[
        "simulate",
        s(&model),
        "--design",
        s(&gains),
        "--input",
        "u=exp(1000*t)",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("--input u=exp(1000*t)") && t.contains("u(t) is inf at t = 0.71"),
        "{t}"
    );
}

#[test]
fn negative_flag_values_are_refused_with_the_real_reason() {
    // Used to be "unexpected argument '-1'" from the argument parser.
    let report = lotka_volterra();
    let lv = "examples/lotka_volterra.qpv";
    for (args, want) in [
        (
            vec!["design", lv, "--alpha", "-1"],
            "--alpha \"-1\": expected a positive number",
        ),
        (
            vec!["design", lv, "--gamma", "-0.5"],
            "--gamma \"-0.5\": expected a number in (0, 1)",
        ),
        (
            vec!["simulate", lv, "--design", s(&report), "--dt", "-1"],
            "--dt -1: expected a positive number",
        ),
        (
            vec!["simulate", lv, "--design", s(&report), "--t-end", "-1"],
            "--t-end -1: expected a non-negative number",
        ),
        (
            vec!["simulate", lv, "--design", s(&report), "--every", "-1"],
            "--every -1: expected a positive number",
        ),
        (
            vec!["simulate", lv, "--design", s(&report), "--noise", "-1"],
            "--noise -1: expected a non-negative amplitude",
        ),
    ] {
        let out = qpv(&args);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {t}");
        assert!(t.contains(want), "{args:?}: {t}");
    }
}

#[test]
fn reports_need_their_gains_keys_only() {
    let report = lotka_volterra();
    let doc = read(&report);
    // Without `schema`: says so, not "missing field `P`".
    let mut unversioned = doc.clone();
    unversioned
        .as_object_mut()
        .expect("object")
        .remove("schema");
    let file = write("no-schema.json", &unversioned);
    let out = qpv(&["check", "examples/lotka_volterra.qpv", "--gains", s(&file)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("\"schema\": \"qpv/1\""), "{t}");
    assert!(!t.contains("missing field"), "{t}");
    // An unknown state_bound.split is refused, not ignored.
    let mut odd = doc.clone();
    odd["designs"][0]["state_bound"]["split"] = Value::from("diagonal");
    let file = write("odd-split.json", &odd);
    let out = qpv(&["check", "examples/lotka_volterra.qpv", "--gains", s(&file)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("`state_bound.split` is \"diagonal\""), "{t}");
    // simulate needs what check needs: no `Gamma`, no `mode`, no verdict.
    let mut lean = doc.clone();
    let d = lean["designs"][0].as_object_mut().expect("design");
    for key in ["Gamma", "mode", "verdict", "margins", "summary", "search"] {
        d.remove(key);
    }
    let file = write("lean.json", &lean);
    let out = qpv(&[
        "simulate",
        "examples/lotka_volterra.qpv",
        "--design",
        s(&file),
        "--t-end",
        "0.5",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("certified (independent re-check"), "{t}");
}

#[test]
fn byte_order_marks_are_skipped_and_line_ends_of_every_kind_are_lines() {
    let bom = "\u{FEFF}";
    let model = tmp("bom.qpv");
    let src = std::fs::read_to_string("examples/lotka_volterra.qpv").expect("model");
    std::fs::write(&model, format!("{bom}{src}")).expect("write");
    let report = lotka_volterra();
    let gains = tmp("bom.json");
    std::fs::write(
        &gains,
        format!("{bom}{}", std::fs::read_to_string(&report).unwrap()),
    )
    .expect("write");
    let out = qpv(&["check", s(&model), "--gains", s(&gains)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    // A CSV with a byte-order mark and old Mac (CR) line ends.
    let csv = tmp("bom-cr.csv");
    std::fs::write(&csv, format!("{bom}t,s\r0,1\r1,1.1\r")).expect("csv");
    let out = qpv(&[
        "simulate",
        s(&model),
        "--design",
        s(&gains),
        "--input-csv",
        s(&csv),
        "--t-end",
        "0.5",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("signals given: parameter s"), "{t}");
    // A model with CR line ends: the error is at its line (4), not line 1.
    let cr = tmp("cr.qpv");
    std::fs::write(
        &cr,
        "model a {\r  state x;\r  output y;\r  der x = -x + foo;\r  out y = x;\r}\r",
    )
    .expect("write");
    let out = qpv(&["vertices", s(&cr)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("cr.qpv:4:16"), "{t}");
    // A NUL byte is named as such.
    let nul = tmp("nul.qpv");
    std::fs::write(&nul, "model a {\n  state x;\n\0 output y;\n}\n").expect("write");
    let out = qpv(&["vertices", s(&nul)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("nul.qpv:3:1") && t.contains("U+0000 (NUL)"),
        "{t}"
    );
}

#[test]
fn tiny_and_huge_numbers_are_printed_in_scientific_form() {
    let report = lotka_volterra();
    let out = qpv(&[
        "check",
        "examples/lotka_volterra.qpv",
        "--gains",
        s(&report),
        "--alpha",
        "1e-320",
    ]);
    let t = text(&out);
    assert!(t.contains("alpha = 1e-320"), "{t}");
    assert!(!t.contains("0000000000"), "{t}");
    let out = qpv(&[
        "simulate",
        "examples/lotka_volterra.qpv",
        "--design",
        s(&report),
        "--t-end",
        "1e308",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("--t-end 1e308"), "{t}");
    assert!(!t.contains("0000000000"), "{t}");
}

#[test]
fn an_endless_input_csv_is_refused() {
    // /dev/zero used to be read to the end: 24 GB resident, then killed.
    let (code, t) = simulate_lv(&["--input-csv", "/dev/zero"]);
    assert_eq!(code, Some(2), "{t}");
    assert!(t.contains("larger than 64 MiB"), "{t}");
}

#[test]
fn only_the_chosen_design_of_a_report_is_read() {
    // The report is parsed straight into the gains of the design used (a
    // 61 MiB report used to peak at 3 GB as JSON values): another design
    // of the file is skipped unread, even one whose P is not a matrix.
    let report = lotka_volterra();
    let mut doc = read(&report);
    let good = doc["designs"][0].clone();
    let mut broken = good.clone();
    broken["P"] = Value::from("not a matrix");
    // The older form of the verdict (two booleans) still counts.
    broken.as_object_mut().expect("design").remove("verdict");
    broken["certifies"] = Value::from(false);
    broken["feasible"] = Value::from(false);
    doc["designs"] = Value::from(vec![broken, good]);
    let file = write("two-designs.json", &doc);
    let out = qpv(&["check", "examples/lotka_volterra.qpv", "--gains", s(&file)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("using report 2"), "{t}");
}

#[test]
fn a_csv_beyond_its_size_limit_is_refused_before_the_run() {
    // 1e8 steps with a row each: about 22 GiB of CSV (19 GB in the probe).
    let dir = tmp("csv-cap");
    let (code, t) = simulate_lv(&[
        "--t-end",
        "1000",
        "--dt",
        "1e-5",
        "--every",
        "1e-5",
        "--plot",
        s(&dir),
    ]);
    assert_eq!(code, Some(2), "{t}");
    assert!(t.contains("at most 1 GiB") && t.contains("--every"), "{t}");
    assert!(!dir.join("trajectories.csv").exists());
}

/// splitmix64: the fuzz test's seeded generator.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

/// JSON pointers of every number under `v` (at `at`).
fn numbers(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Number(_) => out.push(at),
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                numbers(x, format!("{at}/{i}"), out);
            }
        }
        Value::Object(o) => {
            for (k, x) in o {
                numbers(x, format!("{at}/{k}"), out);
            }
        }
        _ => {}
    }
}

/// Multiplies every number under `v` by `f`.
fn scale(v: &mut Value, f: f64) {
    match v {
        Value::Number(n) => *v = Value::from(n.as_f64().unwrap_or(0.0) * f),
        Value::Array(a) => a.iter_mut().for_each(|x| scale(x, f)),
        Value::Object(o) => o.values_mut().for_each(|x| scale(x, f)),
        _ => {}
    }
}

/// One random mutation of the design object `d` (every numeric field,
/// every slack; scaling, swapping, removal), described in words.
fn mutate(d: &mut Value, rng: &mut Rng) -> String {
    const KEYS: [&str; 14] = [
        "P",
        "L",
        "alpha",
        "gamma",
        "cube",
        "skew",
        "state_bound",
        "noise",
        "sampling",
        "margins",
        "data_checks",
        "Gamma",
        "gain_norms",
        "mode",
    ];
    let present: Vec<&str> = KEYS.into_iter().filter(|k| d.get(*k).is_some()).collect();
    let key = *rng.pick(&present);
    let mut leaves = Vec::new();
    numbers(&d[key], format!("/{key}"), &mut leaves);
    let factors = [-1.0, 0.0, 1e-4, 0.5, 0.9, 1.0 + 1e-9, 1.1, 2.0, 1e4];
    let specials = [0.0, 1e308, -1e308, 5e-324, 1e-300];
    match rng.below(7) {
        0 | 1 if !leaves.is_empty() => {
            let at = rng.pick(&leaves).clone();
            let x = d.pointer(&at).and_then(Value::as_f64).unwrap_or(0.0);
            let f = *rng.pick(&factors);
            *d.pointer_mut(&at).expect("leaf") = Value::from(x * f);
            format!("{at} × {f}")
        }
        2 if !leaves.is_empty() => {
            let at = rng.pick(&leaves).clone();
            let v = *rng.pick(&specials);
            *d.pointer_mut(&at).expect("leaf") = Value::from(v);
            format!("{at} = {v:e}")
        }
        3 => {
            let f = *rng.pick(&factors);
            scale(&mut d[key], f);
            format!("/{key} scaled by {f}")
        }
        4 if leaves.len() > 1 => {
            let (a, b) = (rng.pick(&leaves).clone(), rng.pick(&leaves).clone());
            let va = d.pointer(&a).cloned().expect("leaf");
            let vb = d.pointer(&b).cloned().expect("leaf");
            *d.pointer_mut(&a).expect("leaf") = vb;
            *d.pointer_mut(&b).expect("leaf") = va;
            format!("{a} swapped with {b}")
        }
        5 => {
            // Swap two entries of an array (two vertices' gains, two
            // generators' slacks, two rows), or two keys' values.
            match d[key].as_array_mut() {
                Some(a) if a.len() > 1 => {
                    let n = a.len();
                    let (i, j) = (rng.below(n), rng.below(n));
                    a.swap(i, j);
                    format!("/{key}: entries {i} and {j} swapped")
                }
                _ => {
                    let other = *rng.pick(&present);
                    let (va, vb) = (d[key].clone(), d[other].clone());
                    d[key] = vb;
                    d[other] = va;
                    format!("/{key} swapped with /{other}")
                }
            }
        }
        _ => {
            d.as_object_mut().expect("design").remove(key);
            format!("/{key} removed")
        }
    }
}

/// Whether an independent sampling of V' + αV on the plant as written
/// (not the observer model the report's slacks build) falsifies P, L_l at
/// (α, γ): the counterexample, if any.
fn falsified(model: &str, d: &Value, alpha: f64, gamma: f64) -> Option<String> {
    use qpv::solve::report::rows_to_matrix;
    let src = std::fs::read_to_string(model).expect("model");
    let plant = qpv::dsl::parse(&src).expect("model").remove(0).polytopic();
    let rows = |v: &Value| -> Vec<Vec<f64>> {
        serde_json::from_value(v.clone()).expect("rows (the command accepted them)")
    };
    let p = rows_to_matrix(&rows(&d["P"]));
    let l: Vec<_> = d["L"]
        .as_array()
        .expect("L")
        .iter()
        .map(|m| rows_to_matrix(&rows(m)))
        .collect();
    let f = qpv::solve::falsify::falsify(&plant, &p, &l, alpha, gamma, 3000, 11)
        .expect("the sampler runs on gains the certificate accepted");
    (!f.passed()).then(|| format!("{:?}", f.worst))
}

#[test]
fn fuzzed_reports_never_claim_what_sampling_falsifies() {
    let bases = [
        (
            "examples/paper.qpv",
            design(
                "fuzz-paper.json",
                &["examples/paper.qpv", "--alpha", "10", "--gamma", "0.1889"],
            ),
        ),
        ("examples/paper.qpv", paper_cube()),
        ("examples/lotka_volterra.qpv", lotka_volterra()),
    ];
    let mut rng = Rng(24);
    let (mut claims, mut cases) = (0, 0);
    for (model, report) in &bases {
        let doc = read(report);
        let base = &doc["designs"][0];
        let alpha = base["alpha"].as_f64().expect("alpha");
        let gamma = base["gamma"].as_f64().expect("gamma");
        assert!(
            falsified(model, base, alpha, gamma).is_none(),
            "{model}: the base design"
        );
        // The sampler bites: the same gains at 100 α are falsified.
        assert!(
            falsified(model, base, 100.0 * alpha, gamma).is_some(),
            "{model}: 100 α"
        );
        for case in 0..30 {
            let mut m = doc.clone();
            let what = mutate(&mut m["designs"][0], &mut rng);
            let file = write(&format!("fuzz-{case}.json"), &m);
            let d = &m["designs"][0];
            cases += 1;
            let out = qpv(&["check", model, "--gains", s(&file), "--json", "-"]);
            let check_claims = out.status.code() == Some(0);
            if check_claims {
                let j = common::json_stdout(&out);
                assert_eq!(j["verdict"], "certified", "{what}");
                let (a, g) = (common::num(&j, "alpha"), common::num(&j, "gamma"));
                if let Some(cx) = falsified(model, d, a, g) {
                    panic!("{model} {what}: check certified α = {a}, γ = {g}; sampling found {cx}");
                }
                claims += 1;
            }
            let out = qpv(&["simulate", model, "--design", s(&file), "--t-end", "0.05"]);
            let t = text(&out);
            if t.contains("certified (independent re-check on this model)") {
                let (a, g) = (num_at(d, "alpha"), num_at(d, "gamma"));
                if let Some(cx) = falsified(model, d, a, g) {
                    panic!(
                        "{model} {what}: simulate claimed α = {a}, γ = {g}; sampling found {cx}"
                    );
                }
                assert!(
                    check_claims,
                    "{model} {what}: simulate claims what check does not: {t}"
                );
            }
        }
    }
    // The mutations are not all fatal: some certified reports remain (the
    // claims checked above), and most cases are refused or not certified.
    eprintln!("fuzz: {claims} of {cases} mutated reports certified by check, none falsified");
    assert!(claims > 0 && claims < cases, "{claims} of {cases}");
}

fn num_at(d: &Value, key: &str) -> f64 {
    d[key].as_f64().unwrap_or_else(|| panic!("{key} in {d}"))
}

/// A report with `poles` (docs/method.md §18): `design` prints the pole
/// note, `check` and `simulate` re-check the regions from P and L (family
/// D), and a gain moved out of the disk is NOT certified.
#[test]
fn check_and_simulate_recheck_the_pole_regions() {
    let model = tmp("tank_poles.qpv");
    let text_model = include_str!("../examples/three_tank.qpv").replace(
        "design { alpha = 0.9; }",
        "design { alpha = 0.09; poles = disk(centre = -3, radius = 3); }",
    );
    std::fs::write(&model, text_model).expect("write model");
    let report = tmp("tank_poles.json");
    let out = qpv(&["design", s(&model), "--json", s(&report)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("pole regions disk(centre = -3, radius = 3): certified"),
        "{t}"
    );
    let doc = read(&report);
    assert_eq!(doc["designs"][0]["poles"][0]["region"], "disk");
    assert!(doc["designs"][0]["margins"]["D"].as_f64().expect("D") > 0.0);
    let out = qpv(&["check", s(&model), "--gains", s(&report)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    // x3's gain at vertex 6 raised by 20: its mode leaves the disk.
    let mut doc = read(&report);
    let g = &mut doc["designs"][0]["L"][5][2][0];
    *g = Value::from(g.as_f64().expect("gain") + 20.0);
    let forged = write("tank_poles_forged.json", &doc);
    let out = qpv(&["check", s(&model), "--gains", s(&forged)]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("NOT certified") && t.contains("disk"), "{t}");
    let out = qpv(&["simulate", s(&model), "--design", s(&forged)]);
    let t = text(&out);
    assert!(t.contains("NOT certified"), "{t}");
}
