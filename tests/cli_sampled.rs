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
    // the horizon from the design's rate, said (no --t-end given)
    assert!(s.contains("default time grid: --t-end "), "{s}");
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
            vec!["--sample", "1e-3", "--conditions", "cube"],
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
        Plant {
            file: "examples/varying_output.qpv",
            edits: &[("input  u;", "input  u in [-0.1, 0.1];")],
            h: 1e-2,
            alpha: 0.6,
            gamma: 0.3344,
            t_end: 10.0,
        },
        Plant {
            file: "examples/paper_equations.qpv",
            edits: &[],
            h: 1e-3,
            alpha: 10.0,
            gamma: 0.18898,
            t_end: 2.0,
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

/// One example plant for `qpv simulate --sample` through the command line:
/// the file, text edits, the design point (α, γ) and period h, the run's
/// length and initial plant state.
struct CliPlant {
    file: &'static str,
    edits: &'static [(&'static str, &'static str)],
    alpha: &'static str,
    /// None: no γ (the global observer has none).
    gamma: Option<&'static str>,
    h: &'static str,
    t_end: &'static str,
    x0: &'static str,
}

/// `qpv design --sample h` then `qpv simulate --sample h` on `plant`:
/// returns the design's continuous bound (report) and the simulation's text.
fn cli_sampled_run(tag: &str, plant: &CliPlant) -> (Value, String) {
    let mut src = std::fs::read_to_string(plant.file).unwrap();
    for (from, to) in plant.edits {
        assert!(src.contains(from), "{}: {from}", plant.file);
        src = src.replace(from, to);
    }
    let file = tmp(&format!("{tag}.qpv"));
    std::fs::write(&file, src).unwrap();
    let report = tmp(&format!("{tag}.json"));
    let mut args = vec![
        "design",
        file.to_str().unwrap(),
        "--alpha",
        plant.alpha,
        "--sample",
        plant.h,
        "--json",
        report.to_str().unwrap(),
    ];
    if let Some(g) = plant.gamma {
        args.extend(["--gamma", g]);
    }
    let out = qpv(&args);
    let s = text(&out);
    assert_eq!(out.status.code(), Some(0), "{tag}: {s}");
    assert!(s.contains("continuous plant sampled at h:"), "{tag}: {s}");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let bound = v["designs"][0]["sample"]["continuous_bound"].clone();
    let sim = qpv(&[
        "simulate",
        file.to_str().unwrap(),
        "--design",
        report.to_str().unwrap(),
        "--sample",
        plant.h,
        "--t-end",
        plant.t_end,
        "--x0",
        plant.x0,
    ]);
    let s = text(&sim);
    assert_eq!(sim.status.code(), Some(0), "{tag}: {s}");
    (bound, s)
}

/// The acceptance test of docs/method.md §16 on the example plants the
/// bound newly covers, through `qpv design --sample` and `qpv simulate
/// --sample`: derived scheduling variables (arrhenius_reactor, spacecraft;
/// the reactor once more with its temperature moving at a declared rate
/// and a cover of it, which exercises the interval gradient of the
/// Arrhenius functions and the piecewise boxes), inputs given ranges
/// (pmsm, as the example now declares them) and the global observer of an
/// LPV plant with a declared operating envelope (three_tank). Each design
/// reports a bound that holds, and each run starts in the certified set,
/// keeps every premise (no warning) and stays inside the recomputed bound
/// at every sample, with the largest ratio printed below 1.
#[test]
fn the_continuous_plant_stays_inside_the_bound_on_the_newly_covered_examples() {
    let plants = [
        CliPlant {
            file: "examples/arrhenius_reactor.qpv",
            edits: &[],
            alpha: "15",
            gamma: Some("0.6"),
            h: "1e-4",
            t_end: "0.5",
            x0: "0.25,0.25",
        },
        CliPlant {
            file: "examples/arrhenius_reactor.qpv",
            edits: &[
                ("param  T in [390, 420];", "param  T in [390, 420] rate 95;"),
                ("    design {", "    cover T into 2;\n    design {"),
            ],
            alpha: "15",
            gamma: Some("0.6"),
            h: "1e-4",
            t_end: "0.5",
            x0: "0.25,0.25",
        },
        CliPlant {
            file: "examples/spacecraft.qpv",
            edits: &[],
            alpha: "0.02",
            gamma: Some("0.5"),
            h: "0.1",
            t_end: "100",
            x0: "0.025,0.025,0.025",
        },
        CliPlant {
            file: "examples/pmsm.qpv",
            edits: &[],
            alpha: "150",
            gamma: Some("0.5"),
            h: "1e-5",
            t_end: "0.02",
            x0: "2.5,2.5,50",
        },
        CliPlant {
            file: "examples/three_tank.qpv",
            edits: &[
                ("input  q; ", "input  q in [0, 1];"),
                (
                    "    design { alpha = 0.9; }",
                    "    state_bound Q = [4, 0, 0; 0, 4, 0; 0, 0, 4];\n    design { alpha = 0.9; }",
                ),
            ],
            alpha: "0.1",
            gamma: None,
            h: "1e-2",
            t_end: "20",
            x0: "1,1,1",
        },
    ];
    for (k, plant) in plants.iter().enumerate() {
        let tag = format!("new{k}");
        let (bound, s) = cli_sampled_run(&tag, plant);
        let holds = bound["invariant"] == Value::Bool(true) || bound["global"] == Value::Bool(true);
        assert!(
            holds && bound["delta"].as_f64().unwrap() > 0.0,
            "{tag} {}: {bound}",
            plant.file
        );
        assert!(
            s.contains("continuous-plant bound (recomputed)"),
            "{tag}: {s}"
        );
        for broken in [
            "leaves the state bound F",
            "leaves its declared range",
            "faster than its declared rate",
            "outside the certified set",
        ] {
            assert!(!s.contains(broken), "{tag}: {s}");
        }
        let key = "the error stays inside the certified bound (largest sqrt V(e_k) / bound_k = ";
        let at = s.find(key).unwrap_or_else(|| panic!("{tag}: {s}")) + key.len();
        let ratio: f64 = s[at..].split(')').next().unwrap().parse().unwrap();
        assert!(ratio > 0.0 && ratio <= 1.0, "{tag}: {ratio}\n{s}");
    }
}

/// A declared rate of a parameter that enters only through derived
/// variables (the reactor's temperature inside the Arrhenius functions)
/// adds its term to the bound on |x''|, which grows with the rate.
#[test]
fn a_rate_on_a_derived_variables_parameter_enters_the_bound() {
    let src = std::fs::read_to_string("examples/arrhenius_reactor.qpv").unwrap();
    let model = |rate: &str| {
        let text = src.replace(
            "param  T in [390, 420];",
            &format!("param  T in [390, 420]{rate};"),
        );
        qpv::dsl::parse(&text).unwrap()[0].polytopic()
    };
    let held = model("");
    let p = nalgebra::DMatrix::from_row_slice(2, 2, &[1.5625, -0.4375, -0.4375, 1.5625]);
    let accel = |m: &qpv::dsl::PolytopicModel| {
        qpv::solve::report::continuous::continuous_bound(m, 15.0, 1e-4, &p)
            .unwrap()
            .accel
    };
    let (a0, a1, a2) = (
        accel(&held),
        accel(&model(" rate 10")),
        accel(&model(" rate 20")),
    );
    assert!(a1 > a0 && a2 > a1, "{a0} {a1} {a2}");
}

/// The global observer of an LPV plant without a declared state bound:
/// certified at h, no continuous-plant bound, and the note says what to add.
#[test]
fn the_global_observer_without_a_state_bound_says_what_to_add() {
    let out = qpv(&[
        "design",
        "examples/three_tank.qpv",
        "--alpha",
        "0.1",
        "--sample",
        "1e-2",
    ]);
    let s = text(&out);
    assert_eq!(out.status.code(), Some(0), "{s}");
    assert!(s.contains("CERTIFIED, GLOBAL at h = 1e-2 s"), "{s}");
    assert!(
        s.contains("no bound for the continuous plant sampled at h (the global observer (LPV plant) needs no state bound")
            && s.contains("`state_bound Q = [...];`"),
        "{s}"
    );
}

/// The manipulator (a cover of q2 into 4 pieces, derived cos, sin, 1/det M):
/// its example design is `conditions = cube`, which a sampled design
/// refuses, and the full sampled family (8192 blocks) takes minutes per
/// solve. Its continuous cube gains are checked at h = 10 µs on the full
/// discrete family instead (`qpv check --sample`: the cube slacks do not
/// apply at a sample period), and `qpv simulate --sample` runs the
/// continuous plant against them inside the bound computed with the cover's
/// piecewise boxes.
#[test]
fn the_manipulator_with_a_cover_stays_inside_the_bound_at_its_sample_period() {
    let report = tmp("manipulator.json");
    let out = qpv(&[
        "design",
        "examples/manipulator.qpv",
        "--json",
        report.to_str().unwrap(),
    ]);
    let s = text(&out);
    assert_eq!(out.status.code(), Some(0), "{s}");
    let check = qpv(&[
        "check",
        "examples/manipulator.qpv",
        "--gains",
        report.to_str().unwrap(),
        "--sample",
        "1e-5",
    ]);
    let s = text(&check);
    assert_eq!(check.status.code(), Some(0), "{s}");
    assert!(
        s.contains("S5d") && s.contains("8192 conditions: pass"),
        "{s}"
    );
    assert!(
        s.contains("continuous plant sampled at h (recomputed)")
            && s.contains("the certified set stays invariant"),
        "{s}"
    );
    simulate_inside(
        "examples/manipulator.qpv",
        &report,
        ["1e-5", "0.1", "0.25,0.25,0.035,0.035"],
    );
}

/// `qpv simulate FILE --design REPORT --sample H --t-end T --x0 X0`
/// (`[H, T, X0]`) exits 0 with the recomputed continuous-plant bound, its
/// premises kept, and the error inside the bound.
fn simulate_inside(file: &str, report: &std::path::Path, [h, t_end, x0]: [&str; 3]) {
    let sim = qpv(&[
        "simulate",
        file,
        "--design",
        report.to_str().unwrap(),
        "--sample",
        h,
        "--t-end",
        t_end,
        "--x0",
        x0,
    ]);
    let s = text(&sim);
    assert_eq!(sim.status.code(), Some(0), "{file}: {s}");
    assert!(s.contains("continuous-plant bound (recomputed)"), "{s}");
    for broken in [
        "leaves the state bound F",
        "leaves its declared range",
        "faster than its declared rate",
        "outside the certified set",
    ] {
        assert!(!s.contains(broken), "{file}: {s}");
    }
    assert!(
        s.contains("the error stays inside the certified bound"),
        "{file}: {s}"
    );
}

/// The elastic arm (4 states, 16 θ-vertices: its `alpha = max` search
/// takes about 40 s, so a fixed α = 5, γ = 0.09 here, decoupled): its
/// continuous gains at h = 0.2 ms certify the discrete family up to their
/// capacity there (α = 4.85), and `qpv simulate --sample` runs the
/// continuous plant against them inside the bound computed from the
/// example's declared torque ranges.
#[test]
fn the_elastic_arm_stays_inside_the_bound_at_its_sample_period() {
    let report = tmp("elastic_arm.json");
    let out = qpv(&[
        "design",
        "examples/elastic_arm.qpv",
        "--alpha",
        "5",
        "--gamma",
        "0.09",
        "--json",
        report.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    simulate_inside(
        "examples/elastic_arm.qpv",
        &report,
        ["2e-4", "1", "0.05,0.05,0.3,0.3"],
    );
}

/// `qpv simulate --sample H --noise NU`: the noise-optimal paper design at
/// h = 1 ms, the continuous plant with measurement noise on the sampled
/// outputs, compared with the recursion with noise (σ recomputed from the
/// gains); above ν_c, and for gains with no discrete noise bound, nothing
/// is compared and the output says why.
#[test]
fn a_sampled_run_with_noise_stays_inside_the_bound_with_noise() {
    let report = tmp("paper_noise_sampled.json");
    let out = qpv(&[
        "design",
        "examples/paper.qpv",
        "--alpha",
        "5",
        "--gamma",
        "0.18898",
        "--noise",
        "min",
        "--sample",
        "1e-3",
        "--json",
        report.to_str().unwrap(),
    ]);
    let s = text(&out);
    assert_eq!(out.status.code(), Some(0), "{s}");
    assert!(s.contains("with noise of amplitude nu <="), "{s}");
    let sim = |nu: &str| {
        qpv(&[
            "simulate",
            "examples/paper.qpv",
            "--design",
            report.to_str().unwrap(),
            "--sample",
            "1e-3",
            "--noise",
            nu,
            "--t-end",
            "2",
        ])
    };
    let run = sim("0.08");
    let s = text(&run);
    assert_eq!(run.status.code(), Some(0), "{s}");
    assert!(s.contains("with noise (recomputed: sigma ="), "{s}");
    assert!(
        s.contains("the error stays inside the certified bound"),
        "{s}"
    );
    let run = sim("0.2");
    let s = text(&run);
    assert_eq!(run.status.code(), Some(0), "{s}");
    assert!(
        s.contains("is above nu_c") && s.contains("nothing is compared"),
        "{s}"
    );
    assert!(!s.contains("stays inside the certified bound"), "{s}");
}

/// The decoupled discrete family (2p blocks per combination in place of
/// p²): sufficient for the full one, which the certificate re-checks, and
/// on Lotka–Volterra and Lorenz within 1 % of the full family's α at
/// h = 1 ms; `qpv check --sample` passes on its report.
#[test]
fn the_decoupled_discrete_family_certifies_close_to_the_full_one() {
    for file in ["examples/lotka_volterra.qpv", "examples/lorenz.qpv"] {
        let mut alpha = Vec::new();
        for conditions in ["full", "decoupled"] {
            let report = tmp(&format!("decoupled_sampled_{conditions}.json"));
            let out = qpv(&[
                "design",
                file,
                "--sample",
                "1e-3",
                "--alpha",
                "max",
                "--within",
                "0",
                "--conditions",
                conditions,
                "--json",
                report.to_str().unwrap(),
            ]);
            assert_eq!(
                out.status.code(),
                Some(0),
                "{file} {conditions}: {}",
                text(&out)
            );
            let doc: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
            let d = &doc["designs"][0];
            assert_eq!(d["verdict"], "certified", "{file} {conditions}");
            assert_eq!(d["conditions"], conditions, "{file}");
            alpha.push(d["alpha"].as_f64().unwrap());
            let check = qpv(&["check", file, "--gains", report.to_str().unwrap()]);
            assert_eq!(
                check.status.code(),
                Some(0),
                "{file} {conditions}: {}",
                text(&check)
            );
        }
        assert!(
            alpha[1] >= 0.99 * alpha[0],
            "{file}: decoupled α {} against full α {}",
            alpha[1],
            alpha[0]
        );
    }
}
