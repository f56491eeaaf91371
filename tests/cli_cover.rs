//! The cover of the parameter box through the command line: the manipulator
//! example (`cover q2 into ...`) is listed piece by piece by `qpv vertices`,
//! designed and certified on every vertex of every piece by `qpv design`,
//! re-certified by `qpv check` and simulated by `qpv simulate`.

use crate::common;
use common::{json_stdout, qpv, text, tmp};

const MODEL: &str = "examples/manipulator.qpv";

#[test]
fn vertices_lists_the_pieces_and_their_ranges() {
    let out = qpv(&["vertices", MODEL, "--json", "-"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let j = json_stdout(&out);
    let cover = &j["cover"];
    let axes = cover["parameters"].as_array().expect("cover parameters");
    assert_eq!(axes.len(), 1);
    assert_eq!(axes[0]["name"], "q2");
    let n = axes[0]["pieces"].as_u64().expect("pieces") as usize;
    assert!(n > 1);
    let breaks = axes[0]["breaks"].as_array().expect("breaks");
    assert_eq!(breaks.len(), n + 1);
    assert_eq!(breaks[0], 0.2);
    assert_eq!(breaks[n], 2.0);
    let pieces = cover["pieces"].as_array().expect("pieces");
    assert_eq!(pieces.len(), n);
    let total = j["vertex_count"]["total"].as_u64().expect("total") as usize;
    assert_eq!(j["vertex_count"]["pieces"].as_u64(), Some(n as u64));
    assert_eq!(j["vertices"].as_array().map(Vec::len), Some(total));
    let per = total / n;
    assert_eq!(per, 8, "2^3 corners of (cos q2, sin q2, 1/det M) per piece");
    let whole = j["derived"].as_array().expect("derived");
    for (k, p) in pieces.iter().enumerate() {
        assert_eq!(
            p["vertices"],
            serde_json::json!([k * per + 1, (k + 1) * per])
        );
        // every piece's φ range lies inside (or at the rounding of) the
        // whole box's and is thinner
        for (d, w) in p["derived"].as_array().expect("ranges").iter().zip(whole) {
            let (lo, hi) = (d["lo"].as_f64().unwrap(), d["hi"].as_f64().unwrap());
            let (wlo, whi) = (w["lo"].as_f64().unwrap(), w["hi"].as_f64().unwrap());
            assert!(lo < hi && hi - lo < whi - wlo, "{d} vs {w}");
            assert!(lo >= wlo - 1e-12 * wlo.abs().max(1.0), "{d} vs {w}");
            assert!(hi <= whi + 1e-12 * whi.abs().max(1.0), "{d} vs {w}");
        }
    }
    let t = text(&qpv(&["vertices", MODEL]));
    assert!(t.contains("cover: q2 into"), "{t}");
    assert!(t.contains(&format!("piece {n} (q2 ∈ [")), "{t}");
    assert!(t.contains("of piece 2:"), "{t}");
}

#[test]
fn the_covered_manipulator_is_designed_checked_and_simulated() {
    let report = tmp("cover", "manipulator.json");
    let r = report.to_str().expect("utf-8 path");
    let out = qpv(&["design", MODEL, "--json", r]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(text(&out).contains("CERTIFIED"), "{}", text(&out));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report written"))
            .expect("json");
    let d = &doc["designs"][0];
    assert_eq!(d["verdict"], "certified");
    let v = json_stdout(&qpv(&["vertices", MODEL, "--json", "-"]));
    assert_eq!(
        d["L"].as_array().map(Vec::len),
        v["vertex_count"]["total"].as_u64().map(|n| n as usize),
        "one gain per vertex of every piece"
    );
    let ok = qpv(&["check", MODEL, "--gains", r]);
    assert_eq!(ok.status.code(), Some(0), "{}", text(&ok));
    let sim = qpv(&["simulate", MODEL, "--design", r, "--t-end", "1"]);
    assert_eq!(sim.status.code(), Some(0), "{}", text(&sim));
}

#[test]
fn the_vertex_count_warning_names_the_cover() {
    let text16 = std::fs::read_to_string(MODEL)
        .expect("the example")
        .replace("cover q2 into 4;", "cover q2 into 16;");
    let file = tmp("cover", "manipulator16.qpv");
    std::fs::write(&file, text16).expect("write");
    let f = file.to_str().expect("utf-8 path");
    let j = json_stdout(&qpv(&["vertices", f, "--json", "-"]));
    assert_eq!(j["vertex_count"]["total"], 128);
    assert_eq!(j["vertex_count"]["pieces"], 16);
    let w = j["vertex_count"]["warning"]
        .as_str()
        .expect("a warning above 64");
    assert!(
        w.contains("128 vertices") && w.contains("its 16 pieces"),
        "{w}"
    );
    let bad = std::fs::read_to_string(MODEL)
        .expect("the example")
        .replace("cover q2 into 4;", "cover q2 into 65;");
    let file = tmp("cover", "manipulator65.qpv");
    std::fs::write(&file, bad).expect("write");
    let out = qpv(&["vertices", file.to_str().expect("utf-8 path")]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out).contains("65 pieces: at most 64"),
        "{}",
        text(&out)
    );
}
