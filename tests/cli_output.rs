//! What the command line prints adds up: one meaning per count, no region
//! vertices for the global observer, numbers in one readable form, the
//! flags' overrides said, charts whose axes and legends hide no data.

use crate::common::{json_stdout, qpv, text, tmp};

/// A two-state LPV plant (every N_k zero): the global observer.
const TINY_LPV: &str = "model tiny_lpv {
    state x1, x2;
    output y;
    param r in [0.5, 1];
    der x1 = -r*x1 + x2;
    der x2 = -x2;
    out y = x1;
}
";

/// The number after `prefix` in `s`.
fn number_after(s: &str, prefix: &str) -> usize {
    let at = s
        .find(prefix)
        .unwrap_or_else(|| panic!("`{prefix}` not in:\n{s}"));
    s[at + prefix.len()..]
        .chars()
        .take_while(char::is_ascii_digit)
        .collect::<String>()
        .parse()
        .unwrap_or_else(|_| panic!("no number after `{prefix}` in:\n{s}"))
}

#[test]
fn the_solver_call_counts_of_a_global_alpha_max_add_up() {
    let model = tmp("output", "tiny_lpv.qpv");
    std::fs::write(&model, TINY_LPV).expect("model");
    let m = model.to_str().expect("utf-8 path");
    let out = qpv(&[
        "design", m, "--alpha", "max", "--within", "0", "--json", "-",
    ]);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(0), "{all}");
    let doc = json_stdout(&out);
    let d = &doc["designs"][0];
    let log = d["search"].as_array().expect("search log");
    let returned = log.iter().filter(|s| s["status"] == "solved").count();
    // the one count of solver calls: the text's, the note's sum, the log's
    assert_eq!(number_after(&all, "solver calls: "), log.len(), "{all}");
    assert_eq!(number_after(&all, "the search made "), log.len(), "{all}");
    let made = format!("the search made {} solver call(s), ", log.len());
    assert_eq!(number_after(&all, &made), returned, "{all}");
    let note = d["notes"]
        .as_array()
        .expect("notes")
        .iter()
        .filter_map(|n| n.as_str())
        .find(|n| n.contains("searched twice"))
        .unwrap_or_else(|| panic!("the two-search note: {d}"));
    let first = number_after(note, "P (");
    let second = number_after(note, &format!("P ({first} + "));
    assert_eq!(first + second, log.len(), "{note}");
    assert!(!all.contains(" solves"), "one word for one count:\n{all}");
}

#[test]
fn a_failed_design_counts_in_the_same_words() {
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "100",
        "--gamma",
        "0.4",
        "--json",
        "-",
    ]);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "{all}");
    let doc = json_stdout(&out);
    let d = &doc["designs"][0];
    let log = d["search"].as_array().expect("log");
    let rejected = log
        .iter()
        .filter(|s| s["status"] == "solved" && s["certified"] == false)
        .count();
    assert!(rejected > 0, "this request returns a point that fails: {d}");
    assert_eq!(number_after(&all, "solver calls: "), log.len(), "{all}");
    assert!(
        all.contains(&format!(
            "{rejected} point(s) returned by the solver failed the independent certificate"
        )),
        "{all}"
    );
    assert!(!all.contains("no attempt returned"), "{all}");
}

#[test]
fn check_of_a_global_design_names_no_region_vertices() {
    let report = tmp("output", "tank_sampled.json");
    let r = report.to_str().expect("utf-8 path");
    let out = qpv(&[
        "design",
        "examples/three_tank.qpv",
        "--alpha",
        "0.15",
        "--sample",
        "0.01",
        "--json",
        r,
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let out = qpv(&["check", "examples/three_tank.qpv", "--gains", r]);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(0), "{all}");
    assert!(all.contains("S5d"), "{all}");
    assert!(
        !all.contains(" i=") && !all.contains(" j="),
        "the global observer has no region vertices:\n{all}"
    );
}

#[test]
fn vertices_of_an_lpv_plant_says_there_is_no_region() {
    let out = qpv(&["vertices", "examples/three_tank.qpv"]);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(0), "{all}");
    assert!(!all.contains("0 vertices, 0 facets"), "{all}");
    assert!(all.contains("region: none"), "{all}");
    assert!(all.contains("global observer"), "{all}");
}

#[test]
fn numbers_print_in_one_readable_form() {
    use qpv::dsl::fmt_sig;
    assert_eq!(fmt_sig(0.0, 5), "0");
    assert_eq!(fmt_sig(2.44140625e296, 4), "2.441e296");
    assert_eq!(fmt_sig(1e-300, 3), "1.00e-300");
    assert_eq!(fmt_sig(0.18898, 6), "0.188980");
    assert_eq!(fmt_sig(12.3949, 3), "12.4");
    let info = qpv::solve::GammaSearchInfo {
        gamma_lo: 0.0,
        gamma_hi: 0.18898,
        grid_points: 3,
        points: 4,
        solves: 9,
        local_maxima: Vec::new(),
        continued: 0,
    };
    let s = info.statement();
    assert!(s.contains("γ ∈ [0, 0.188980]"), "{s}");
    // a sample period far off the scale: its rate in exponent form
    for h in ["1e-300", "1e300"] {
        let out = qpv(&[
            "design",
            "examples/paper.qpv",
            "--alpha",
            "5",
            "--gamma",
            "0.18",
            "--sample",
            h,
        ]);
        let all = text(&out);
        let longest = all
            .split(|c: char| !c.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(longest < 20, "a {longest}-digit number:\n{all}");
        assert!(!all.contains("(0 Hz)"), "{all}");
    }
}

#[test]
fn the_output_says_what_the_flags_overrode_of_the_design_blocks() {
    let src = std::fs::read_to_string("examples/paper.qpv").expect("paper.qpv");
    let start = src.find("    design {").expect("a design block");
    let model = format!(
        "{}    design {{ alpha = max; max_gain = 50; split = as_written; }}\n}}\n",
        &src[..start]
    );
    let path = tmp("output", "paper_max_gain.qpv");
    std::fs::write(&path, model).expect("model");
    let m = path.to_str().expect("utf-8 path");
    // --alpha replaces the block: its max_gain and split are not used
    let out = qpv(&[
        "design", m, "--alpha", "5", "--gamma", "0.18", "--json", "-",
    ]);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(0), "{all}");
    for said in [
        "design block 1",
        "max_gain = 50 dropped",
        "split = as_written -> split = symmetric",
        "alpha = max -> alpha = 5",
    ] {
        assert!(all.contains(said), "`{said}` in:\n{all}");
    }
    let doc = json_stdout(&out);
    assert!(
        doc["designs"][0]["notes"]
            .as_array()
            .expect("notes")
            .iter()
            .any(|n| n
                .as_str()
                .is_some_and(|n| n.contains("max_gain = 50 dropped"))),
        "the note is in the report too: {doc}"
    );
    // an override flag on the block it runs: said too
    let out = qpv(&["design", m, "--split", "symmetric", "--within", "0.3"]);
    let all = text(&out);
    for said in [
        "command-line flags override design block 1",
        "split = as_written -> split = symmetric",
        "alpha = max -> alpha = max(within = 0.3)",
    ] {
        assert!(all.contains(said), "`{said}` in:\n{all}");
    }
    assert!(!all.contains("max_gain = 50 dropped"), "{all}");
}

#[test]
fn a_log_axis_starts_below_the_data_and_the_legend_beside_the_plot() {
    // the paper example's error ends at 1.008e-7: room below it
    let (lo, hi) = qpv::plot::y_range([1.008e-7, 0.03, 1.2].into_iter(), true);
    assert!(lo <= 1.008e-7 / 10f64.powf(0.25) && hi >= 1.2, "{lo} {hi}");
    let (lo, _) = qpv::plot::y_range([1e-7, 1.0].into_iter(), true);
    assert!(lo < 1e-7, "a decade value is not the floor itself: {lo}");
    let path = tmp("output", "legend.svg");
    let points: Vec<(f64, f64)> = (0..100)
        .map(|k| (k as f64 * 0.02, (-(k as f64) * 0.2).exp()))
        .collect();
    qpv::plot::line_chart(
        &path,
        "t",
        "e",
        &[qpv::plot::Series::new(
            "a long legend entry that would cover the curve",
            points,
            qpv::plot::PALETTE[0],
            false,
        )],
        true,
    )
    .expect("chart");
    let svg = std::fs::read_to_string(&path).expect("svg");
    let at = svg.find("a long legend entry").expect("the legend's text");
    let tag = &svg[svg[..at].rfind("<text").expect("its tag")..at];
    let x: f64 = tag
        .split("x=\"")
        .nth(1)
        .and_then(|r| r.split('"').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("x of {tag}"));
    assert!(
        x >= 900.0,
        "the legend stands right of the 900-px plot: {tag}"
    );
}
