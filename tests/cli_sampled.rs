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
    assert!(
        s.contains("continuous plant sampled at h (recomputed)") && s.contains("lim sup |e_k| <="),
        "{s}"
    );

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
    assert!(
        s.contains("at this h the gains satisfy the discrete family up to alpha = "),
        "{s}"
    );

    // The continuous plant against the observer stepped at 1 kHz: the
    // bound is recomputed, the run stays inside it (exit 0).
    let sim = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        report.to_str().unwrap(),
        "--sample",
        "1e-3",
        "--scenario",
        "paper",
    ]);
    let s = text(&sim);
    assert_eq!(sim.status.code(), Some(0), "{s}");
    assert!(s.contains("the continuous plant by RK4 at h/20"), "{s}");
    assert!(s.contains("continuous-plant bound (recomputed)"), "{s}");
    assert!(
        s.contains("the error stays inside the certified bound"),
        "{s}"
    );
    assert!(s.contains("held over each step in the plant too"), "{s}");
    let bad = qpv(&[
        "simulate",
        "examples/paper.qpv",
        "--design",
        report.to_str().unwrap(),
        "--sample",
        "1e-3",
        "--plot",
        tmp("plots").to_str().unwrap(),
    ]);
    assert_eq!(bad.status.code(), Some(2), "{}", text(&bad));
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
    ] {
        let mut all = vec!["design", "examples/paper.qpv", "--gamma", "0.1889"];
        all.extend(args.iter().copied());
        let out = qpv(&all);
        let s = text(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {s}");
        assert!(s.contains(want), "{args:?}: {s}");
    }
}

/// One example plant for the sampled-data simulation: the file, text edits
/// (input ranges and rates the bound needs), the sample period and a
/// design point (α, γ) certified there.
struct Plant {
    file: &'static str,
    edits: &'static [(&'static str, &'static str)],
    h: f64,
    alpha: f64,
    gamma: f64,
    t_end: f64,
}

/// Designs `plant` at its sample period (library path, one solve), runs
/// the continuous plant (RK4 at h/20) against the observer stepped at h
/// on the default scenario (x(0) half a region vertex, x̂(0) = 0) and
/// returns the verdict.
fn sampled_run(plant: &Plant) -> qpv::solve::analysis::sampled::SampledCheck {
    use qpv::dsl::{AlphaSpec, GammaSpec, Mode};
    use qpv::solve::analysis::sampled::{check_sampled_run, SampledRun};
    let mut text = std::fs::read_to_string(plant.file).unwrap();
    for (from, to) in plant.edits {
        assert!(text.contains(from), "{}: {from}", plant.file);
        text = text.replace(from, to);
    }
    let models = qpv::dsl::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", plant.file));
    let poly = models[0].polytopic();
    let mut req = qpv::solve::request(
        AlphaSpec::Fixed(plant.alpha),
        GammaSpec::Fixed(plant.gamma),
        Mode::Sound,
    );
    req.sample = Some(plant.h);
    let d = qpv::solve::design(&poly, &req, &qpv::solve::Settings::default()).unwrap();
    assert!(d.certifies(), "{}: {:?}", plant.file, d.notes);
    let mut sc = qpv::solve::simulate::Scenario::default_for(&poly);
    sc.t_end = plant.t_end;
    // Half a region vertex: inside the certified set, and the plant stays
    // in F over the run (from a vertex itself some plants leave it).
    sc.x0.iter_mut().for_each(|v| *v *= 0.5);
    let run = SampledRun::for_model(&poly, plant.h);
    let c = check_sampled_run(&poly, &d, &sc, &run).unwrap();
    assert!(c.claim.certificate.passed, "{}", plant.file);
    c
}

/// The acceptance test of docs/method.md §16 ("The real plant is
/// continuous"): on every example plant whose sampled design has a
/// continuous-plant bound (multi-affine in θ, no cover, inputs with a
/// declared range), the continuous plant against the observer stepped at h
/// starts in the certified set, keeps its premises (x in F, θ and u in
/// range and rate) and never leaves √V(e_k) ≤ ρ^k √V(e_0) + δ(1 − ρ^k)/(1 − ρ),
/// every figure recomputed from the model and the gains; the paper example
/// once more with θ moving continuously at declared rates.
#[test]
fn the_continuous_plant_stays_inside_the_sampled_bound_on_every_example() {
    let plants = [
        Plant {
            file: "examples/paper.qpv",
            edits: &[],
            h: 1e-3,
            alpha: 10.0,
            gamma: 0.18898,
            t_end: 2.0,
        },
        Plant {
            file: "examples/paper.qpv",
            edits: &[
                ("th1 in [0, 1];", "th1 in [0, 1] rate 3.2;"),
                ("th2 in [0, 1];", "th2 in [0, 1] rate 4.8;"),
            ],
            h: 1e-3,
            alpha: 10.0,
            gamma: 0.18898,
            t_end: 2.0,
        },
        Plant {
            file: "examples/paper_auto.qpv",
            edits: &[],
            h: 1e-3,
            alpha: 12.0,
            gamma: 0.2066,
            t_end: 1.0,
        },
        Plant {
            file: "examples/lorenz.qpv",
            edits: &[],
            h: 1e-3,
            alpha: 5.0,
            gamma: 0.1996,
            t_end: 2.0,
        },
        Plant {
            file: "examples/lotka_volterra.qpv",
            edits: &[],
            h: 1e-3,
            alpha: 1.9,
            gamma: 0.3133,
            t_end: 2.0,
        },
        Plant {
            file: "examples/sir.qpv",
            edits: &[("input  b;", "input  b in [-0.1, 0.1];")],
            h: 1e-3,
            alpha: 0.037,
            gamma: 0.1176,
            t_end: 2.0,
        },
        Plant {
            file: "examples/van_de_vusse.qpv",
            edits: &[("input  u;", "input  u in [-4.3, 5.8];")],
            h: 1e-3,
            alpha: 600.0,
            gamma: 0.068,
            t_end: 0.05,
        },
    ];
    for plant in &plants {
        let c = sampled_run(plant);
        let b = c
            .claim
            .bound
            .as_ref()
            .unwrap_or_else(|w| panic!("{}: {w}", plant.file));
        assert!(b.invariant && b.delta > 0.0, "{}: {b:?}", plant.file);
        assert!(
            c.v0_sqrt <= 1.0,
            "{}: e(0) outside the certified set",
            plant.file
        );
        assert!(
            c.left_f.is_none() && c.left_theta.is_none() && c.rate_exceeded.is_none(),
            "{}: premises {c:?}",
            plant.file
        );
        assert!(c.diverged_at.is_none() && c.samples > 10, "{}", plant.file);
        assert!(
            c.exceeded.is_none() && !c.violated(),
            "{}: {:?} (worst {})",
            plant.file,
            c.exceeded,
            c.worst_ratio
        );
        assert!(
            c.worst_ratio <= 1.0 + 1e-6,
            "{}: {}",
            plant.file,
            c.worst_ratio
        );
    }
}

/// A plant with an input: the continuous-plant bound needs the input's
/// range (`input u in [lo, hi]`), and takes its rate when declared. The
/// design and `qpv check --sample` print the bound with the range and say
/// why there is none without it.
#[test]
fn the_continuous_bound_with_inputs_needs_their_range() {
    let src = std::fs::read_to_string("examples/van_de_vusse.qpv").unwrap();
    let ranged = tmp("vdv_ranged.qpv");
    std::fs::write(
        &ranged,
        src.replace("input  u;", "input  u in [-4.3, 5.8] rate 50;"),
    )
    .unwrap();
    let report = tmp("vdv_1khz.json");
    let out = qpv(&[
        "design",
        ranged.to_str().unwrap(),
        "--alpha",
        "600",
        "--gamma",
        "0.068",
        "--sample",
        "1e-3",
        "--json",
        report.to_str().unwrap(),
    ]);
    let s = text(&out);
    assert_eq!(out.status.code(), Some(0), "{s}");
    assert!(
        s.contains("continuous plant sampled at h: Euler truncation error"),
        "{s}"
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let b = &v["designs"][0]["sample"]["continuous_bound"];
    assert_eq!(b["rates_declared"], Value::Bool(false), "{b}"); // th has no rate
    let with_range = b["accel"].as_f64().unwrap();

    let check = qpv(&[
        "check",
        ranged.to_str().unwrap(),
        "--gains",
        report.to_str().unwrap(),
    ]);
    let s = text(&check);
    assert_eq!(check.status.code(), Some(0), "{s}");
    assert!(
        s.contains("continuous plant sampled at h (recomputed)"),
        "{s}"
    );
    // The same gains on the example as written (no range on u): certified,
    // and no continuous-plant bound, with the reason.
    let check = qpv(&[
        "check",
        "examples/van_de_vusse.qpv",
        "--gains",
        report.to_str().unwrap(),
    ]);
    let s = text(&check);
    assert_eq!(check.status.code(), Some(0), "{s}");
    assert!(
        s.contains("no bound (input(s) u declare no range (`input u in [lo, hi];`)"),
        "{s}"
    );
    // A rate on the input adds its B u' term: the bound on |x''| grows.
    let rated = tmp("vdv_rated.qpv");
    std::fs::write(
        &rated,
        src.replace("input  u;", "input  u in [-4.3, 5.8] rate 50;")
            .replace("param  th in [30, 40];", "param  th in [30, 40] rate 50;"),
    )
    .unwrap();
    let models = qpv::dsl::parse(&std::fs::read_to_string(&rated).unwrap()).unwrap();
    let d: qpv::solve::Design = serde_json::from_value(v["designs"][0].clone()).unwrap();
    let b = qpv::solve::report::continuous::continuous_bound(
        &models[0].polytopic(),
        d.alpha,
        1e-3,
        &d.p_matrix(),
    )
    .unwrap();
    assert!(
        b.rates_declared && b.accel > with_range,
        "{b:?} vs {with_range}"
    );
}

/// `--sample` with `--noise min`: the discrete noise claim, its σ and the
/// S5d certificate; σ at 1 kHz lies within 1 % of the continuous design's
/// at the same (α, γ) (the h → 0 limit, docs/method.md §16).
#[test]
fn noise_min_at_a_sample_period() {
    let sigma_of = |extra: &[&str]| -> (String, f64) {
        let report = tmp(&format!("noise{}.json", extra.len()));
        let mut args = vec![
            "design",
            "examples/paper.qpv",
            "--alpha",
            "5",
            "--gamma",
            "0.18898",
            "--noise",
            "min",
            "--json",
            report.to_str().unwrap(),
        ];
        args.extend(extra);
        let out = qpv(&args);
        let s = text(&out);
        assert_eq!(out.status.code(), Some(0), "{s}");
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (s, v["designs"][0]["noise"]["sigma"].as_f64().unwrap())
    };
    let (s, sampled) = sigma_of(&["--sample", "1e-3"]);
    assert!(s.contains("CERTIFIED at h = 1e-3 s (1 kHz)"), "{s}");
    assert!(
        s.contains("V(e_k+1) - (1 - h alpha) V(e_k) <= h sigma (|v_k|^2 + |w_k|^2)"),
        "{s}"
    );
    let (_, continuous) = sigma_of(&[]);
    assert!(
        (sampled / continuous - 1.0).abs() < 0.01,
        "{sampled} vs {continuous}"
    );
}
