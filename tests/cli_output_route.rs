//! θ-varying output maps through the command line (issue: θ-dependent C(θ),
//! M_k(θ)): the example `examples/varying_output.qpv` (catch = effort ×
//! stock) designed by the double-sum relaxation and by the output
//! post-filter, the JSON report's `output_route`, and bad `output_route`
//! values.

use crate::common;
use common::qpv;
use std::path::PathBuf;
use std::process::Output;

const EXAMPLE: &str = "examples/varying_output.qpv";
const NX: usize = 2;
const NY: usize = 1;

fn tmp(name: &str) -> PathBuf {
    common::tmp("route", name)
}

fn example_text() -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(EXAMPLE);
    std::fs::read_to_string(path).expect("the example is readable")
}

/// The example with its design blocks replaced by `designs` (one line).
fn example_with(name: &str, designs: &str) -> PathBuf {
    let text: String = example_text()
        .lines()
        .filter(|l| !l.trim_start().starts_with("design {"))
        .collect::<Vec<_>>()
        .join("\n");
    let end = text.rfind('}').expect("the model block closes");
    let body = format!("{}    {designs}\n}}\n", &text[..end]);
    let path = tmp(name);
    std::fs::write(&path, body).expect("write");
    path
}

fn design_json(file: &str) -> (Output, serde_json::Value) {
    design_json_args(&["design", file, "--json", "-"])
}

fn design_json_args(args: &[&str]) -> (Output, serde_json::Value) {
    let out = qpv(args);
    let json = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not exactly one JSON document ({e}):\n{}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )
    });
    (out, json)
}

fn rows(v: &serde_json::Value) -> usize {
    v.as_array().map_or(0, Vec::len)
}

/// `L` has one matrix per θ-vertex, each `n` rows of NY; `P` is n × n.
fn assert_shapes(d: &serde_json::Value, n: usize) {
    let l = d["L"].as_array().expect("L is an array of matrices");
    assert_eq!(l.len(), 2, "two θ-vertices (E = 0.1, 0.3)");
    for lv in l {
        assert_eq!(rows(lv), n, "L_l has {n} rows: {lv}");
        assert!(lv.as_array().unwrap().iter().all(|r| rows(r) == NY));
    }
    assert_eq!(rows(&d["P"]), n, "P is {n} × {n}");
    assert!(d["P"].as_array().unwrap().iter().all(|r| rows(r) == n));
}

/// The example's three design blocks as written, at a fixed γ = 0.3 near
/// the searched optimum of each (0.29-0.33): the routes and the report's
/// shapes are what is tested here; the γ search is tested in the solver's
/// tests (one search on the pole-5 filter design takes about 840 solves).
#[test]
fn the_example_certifies_by_both_routes() {
    let text = example_text();
    assert_eq!(text.matches("gamma = search;").count(), 3, "three searches");
    let path = tmp("fixed_gamma.qpv");
    std::fs::write(&path, text.replace("gamma = search;", "gamma = 0.3;")).expect("write");
    let (out, j) = design_json(path.to_str().unwrap());
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let reports = j["designs"]
        .as_array()
        .expect("three design blocks: an array");
    assert_eq!(reports.len(), 3);
    for d in reports {
        assert_eq!(d["verdict"], "certified", "{}", d["summary"]);
        assert_eq!(d["output_route"]["output_varies"], true);
    }

    // 1. double sum: the plant's own states, N² = 4 rate combinations
    let ds = &reports[0];
    assert_eq!(ds["output_route"]["route"], "double_sum");
    assert_eq!(ds["output_route"]["combinations"], 4);
    assert_eq!(rows(&ds["output_route"]["states"]), NX);
    assert_shapes(ds, NX);
    let a_ds = ds["alpha"].as_f64().unwrap();
    assert!(a_ds > 0.65, "double-sum α = {a_ds} (measured 0.683)");

    // 2., 3. filter: one filter state per output, single sum
    for (d, pole) in [(&reports[1], 50.0), (&reports[2], 5.0)] {
        let r = &d["output_route"];
        assert_eq!(r["route"], "filter");
        assert_eq!(r["combinations"], 2);
        assert_eq!(r["filter"]["pole"].as_f64(), Some(pole));
        assert_eq!(r["filter"]["gain"].as_f64(), Some(pole), "unit DC gain");
        let states: Vec<&str> = r["states"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s.as_str().unwrap())
            .collect();
        assert_eq!(states.len(), NX + NY);
        assert_eq!(&states[..NX], ["e1", "e2"]);
        assert_shapes(d, NX + NY);
        assert!(d["alpha"].as_f64().unwrap() > 0.2, "{}", d["alpha"]);
    }
    let a_f50 = reports[1]["alpha"].as_f64().unwrap();
    assert!(
        a_f50 > 0.6,
        "filter(pole = 50) α = {a_f50} (measured 0.676)"
    );
}

/// Fixed (α, γ) = (0.6, 0.3), one solve per design: every route certifies,
/// and the slow filter pays in gain (measured max ‖L_l‖₂: 42 double sum,
/// 64 pole 50, 511 pole 5): the observer must undo the filter's lag.
#[test]
fn a_slow_filter_costs_gain() {
    let fixed = "alpha = 0.6; gamma = 0.3;";
    let mut norms = Vec::new();
    for (name, route, kind, n) in [
        ("ds.qpv", "output_route = double_sum;", "double_sum", NX),
        ("fast.qpv", "output_route = filter;", "filter", NX + NY),
        (
            "slow.qpv",
            "output_route = filter(pole = 5);",
            "filter",
            NX + NY,
        ),
    ] {
        let file = example_with(name, &format!("design {{ {fixed} {route} }}"));
        let (out, doc) = design_json(file.to_str().unwrap());
        let d = &doc["designs"][0];
        assert_eq!(
            out.status.code(),
            Some(0),
            "{route}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(d["verdict"], "certified");
        assert_eq!(d["output_route"]["route"], kind);
        assert_shapes(d, n);
        let max = d["gain_norms"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .fold(0.0, f64::max);
        norms.push(max);
    }
    assert!(
        norms[2] > 5.0 * norms[0],
        "pole 5 needs far larger gains than the double sum: {norms:?}"
    );
}

#[test]
fn bad_output_routes_exit_2_with_a_positioned_message() {
    let cases = [
        (
            "design { output_route = kalman; }",
            "`output_route` must be `double_sum` or `filter`",
            "kalman",
        ),
        (
            "design { output_route = filter(pole = 0); }",
            "`pole` must be a positive number",
            "0",
        ),
        (
            "design { output_route = double_sum(pole = 1); }",
            "`double_sum` takes no options",
            "(pole = 1)",
        ),
        (
            "design { output_route = filter(gain = 0); }",
            "`gain` must be a nonzero number",
            "0",
        ),
    ];
    for (k, (design, message, token)) in cases.into_iter().enumerate() {
        let path = example_with(&format!("bad{k}.qpv"), design);
        let text = std::fs::read_to_string(&path).unwrap();
        // the design line is the last but one; its token's 1-based column
        let line_no = text.lines().count() - 1;
        let line = text.lines().nth(line_no - 1).unwrap();
        let col = line.rfind(token).expect("token on the design line") + 1;
        let out = qpv(&["design", path.to_str().unwrap(), "--json", "-"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{design}: {err}");
        assert!(out.stdout.is_empty(), "nothing on stdout for bad input");
        assert!(
            err.contains(&format!(":{line_no}:{col}: ")),
            "{design}: expected position {line_no}:{col} in {err}"
        );
        assert!(err.contains(message), "{design}: {err}");
        assert!(err.contains(line.trim()), "the line is quoted: {err}");
    }
}

/// `--output-route`, `--filter-pole`: one request from the flags; `qpv
/// check` re-certifies a filter report against the augmented plant.
#[test]
fn route_flags_override_and_check_recertifies_a_filter_design() {
    let report = tmp("f20.json");
    let report = report.to_str().unwrap();
    let out = qpv(&[
        "design",
        EXAMPLE,
        "--output-route",
        "filter",
        "--filter-pole",
        "20",
        "--alpha",
        "0.6",
        "--gamma",
        "0.3",
        "--json",
        report,
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    assert_eq!(
        doc["designs"].as_array().map(Vec::len),
        Some(1),
        "one request from the flags: one report"
    );
    let d = &doc["designs"][0];
    assert_eq!(d["verdict"], "certified");
    assert_eq!(d["output_route"]["route"], "filter");
    assert_eq!(d["output_route"]["filter"]["pole"].as_f64(), Some(20.0));
    assert_shapes(d, NX + NY);
    let check = qpv(&["check", EXAMPLE, "--gains", report]);
    assert_eq!(
        check.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&check.stdout)
    );

    let (out, doc) = design_json_args(&[
        "design",
        EXAMPLE,
        "--output-route",
        "double_sum",
        "--alpha",
        "0.6",
        "--gamma",
        "0.3",
        "--json",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(0));
    let d = &doc["designs"][0];
    assert_eq!(d["output_route"]["route"], "double_sum");
    assert_shapes(d, NX);

    for bad in [
        &["--output-route", "kalman"][..],
        &["--output-route", "double_sum", "--filter-pole", "3"][..],
        &["--filter-pole", "0"][..],
    ] {
        let mut args = vec!["design", EXAMPLE];
        args.extend_from_slice(bad);
        let out = qpv(&args);
        assert_eq!(out.status.code(), Some(2), "{bad:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(bad[0]), "{bad:?}: {err}");
    }
}
