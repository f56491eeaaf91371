//! Nonlinear terms of unmeasured states (bounded Jacobians): plants written
//! as physics writes them design and certify, `qpv check` re-certifies
//! their reports (and refuses gains that depend on the Jacobian corner),
//! simulations of the nonlinear plant and observer stay inside the
//! certified envelope, and their C export compiles.

use crate::common;

use common::{num, qpv, text};
use std::path::PathBuf;
use std::process::Command;
use std::sync::OnceLock;

fn tmp(name: &str) -> PathBuf {
    common::tmp("jacobian", name)
}

/// Designs `model` (its own design block) into a report, once per model;
/// asserts exit 0.
fn report(model: &str) -> PathBuf {
    static ARM: OnceLock<PathBuf> = OnceLock::new();
    static FRICTION: OnceLock<PathBuf> = OnceLock::new();
    static DUFFING: OnceLock<PathBuf> = OnceLock::new();
    let cell = match model {
        "flexible_joint" => &ARM,
        "friction_joint" => &FRICTION,
        _ => &DUFFING,
    };
    cell.get_or_init(|| {
        let out = tmp(&format!("{model}.json"));
        let run = qpv(&[
            "design",
            &format!("examples/{model}.qpv"),
            "--json",
            out.to_str().expect("utf-8"),
        ]);
        assert_eq!(run.status.code(), Some(0), "{}", text(&run));
        out
    })
    .clone()
}

fn design_json(model: &str) -> serde_json::Value {
    let s = std::fs::read_to_string(report(model)).expect("report");
    let doc: serde_json::Value = serde_json::from_str(&s).expect("json");
    doc["designs"][0].clone()
}

#[test]
fn the_flexible_joint_arm_as_written_certifies_with_alpha_max_at_the_gain_bound_and_sample() {
    let d = design_json("flexible_joint");
    assert_eq!(d["verdict"], "certified", "{d}");
    assert!(num(&d, "alpha") > 0.0, "{d}");
    // the arm's request: alpha = max; max_gain = 1e3; sample = 1e-3
    assert!(d["gain_norms"]
        .as_array()
        .expect("norms")
        .iter()
        .all(|g| g.as_f64().is_some_and(|g| g <= 1e3)));
    assert_eq!(
        d["L"].as_array().expect("L").len(),
        2,
        "two Jacobian corners"
    );
    assert_eq!(d["L"][0], d["L"][1], "one gain for both corners");
    let notes = d["notes"].to_string();
    assert!(
        notes.contains("d(der w1)/d(q1) ∈ [-2.000000e1, 2.000000e1]"),
        "{notes}"
    );
    assert!(notes.contains("a global bound"), "{notes}");
    assert!(notes.contains("1 robust vertex dimension"), "{notes}");
}

#[test]
fn qpv_check_recertifies_each_plants_report() {
    for m in ["flexible_joint", "friction_joint", "duffing_position"] {
        let r = report(m);
        let out = qpv(&[
            "check",
            &format!("examples/{m}.qpv"),
            "--gains",
            r.to_str().expect("utf-8"),
        ]);
        assert_eq!(out.status.code(), Some(0), "{m}: {}", text(&out));
    }
}

#[test]
fn gains_that_depend_on_the_jacobian_corner_are_refused() {
    let s = std::fs::read_to_string(report("flexible_joint")).expect("report");
    let mut doc: serde_json::Value = serde_json::from_str(&s).expect("json");
    let l = &mut doc["designs"][0]["L"][1][0][0];
    *l = serde_json::json!(l.as_f64().expect("entry") * 1.001);
    let path = tmp("untied.json");
    std::fs::write(&path, doc.to_string()).expect("written");
    let out = qpv(&[
        "check",
        "examples/flexible_joint.qpv",
        "--gains",
        path.to_str().expect("utf-8"),
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(
        t.contains("may not depend on the unmeasured Jacobian corner"),
        "{t}"
    );
}

#[test]
fn the_duffing_cubic_is_bounded_on_the_set_s_at_a_fixed_gamma() {
    let d = design_json("duffing_position");
    assert_eq!(d["verdict"], "certified", "{d}");
    assert!(num(&d, "alpha") > 0.0, "{d}");
    let notes = d["notes"].to_string();
    assert!(notes.contains("box hull of F ⊕ (−P/γ)"), "{notes}");
    assert!(notes.contains("γ fixed at"), "{notes}");
    // Q = I, region box(0.5): γ = γ_max = 0.5 (less 1e-6), |z_k| ≤ 1 + 0.5/γ,
    // d(der x2)/d(x1) = -1.5 x1^2 ∈ [-6, 0] up to rounding
    let g = num(&d, "gamma");
    assert!((g - 0.5 * (1.0 - 1e-6)).abs() < 1e-12, "{g}");
    assert!(notes.contains("d(der x2)/d(x1) ∈ [-6.0000"), "{notes}");
}

/// Runs `qpv simulate` of `model` with its report from `x0` (the observer
/// starts at 0, so x0 is also the initial error) and asserts the run stays
/// in the certified envelope.
fn simulate_inside(model: &str, x0: &str, extra: &[&str]) {
    let r = report(model);
    let path = format!("examples/{model}.qpv");
    let mut args = vec![
        "simulate",
        &path,
        "--design",
        r.to_str().expect("utf-8"),
        "--x0",
        x0,
    ];
    args.extend_from_slice(extra);
    let out = qpv(&args);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{model} from {x0}: {t}");
    assert!(
        t.contains("the error stays inside the certified envelope"),
        "{model} from {x0}: {t}"
    );
}

#[test]
fn simulations_of_the_nonlinear_plants_stay_inside_the_certified_envelope() {
    for x0 in ["1.5,0,0,0", "-3,2,0,0", "0.3,-4,0.2,1", "3.1,0,-0.5,0"] {
        simulate_inside(
            "flexible_joint",
            x0,
            &["--t-end", "1", "--input", "u=0.8*sin(5*t)"],
        );
    }
    for x0 in ["0.5,3", "-0.2,-5", "1,0"] {
        simulate_inside(
            "friction_joint",
            x0,
            &["--t-end", "1", "--input", "u=0.3*sin(2*t)"],
        );
    }
    // the Duffing oscillator's region box(0.5) and its corners
    for x0 in ["0.5,0.5", "-0.5,0.5", "0.5,-0.5", "-0.5,-0.5", "0.25,0"] {
        simulate_inside("duffing_position", x0, &["--t-end", "5"]);
    }
}

/// Exports `model`'s design as C and compiles it with the strict flags.
fn c_compiles(model: &str, cc: &str) {
    let dir = tmp(&format!("c-{model}"));
    let run = qpv(&[
        "codegen",
        &format!("examples/{model}.qpv"),
        "--out",
        dir.to_str().expect("utf-8"),
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run));
    let src = dir.join(format!("{model}.c"));
    let c = Command::new(cc)
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c"])
        .arg(&src)
        .arg("-o")
        .arg(dir.join(format!("{model}.o")))
        .output()
        .expect("cc runs");
    assert!(
        c.status.success(),
        "{model}: the C does not compile:\n{}",
        String::from_utf8_lossy(&c.stderr)
    );
}

fn compiler() -> Option<String> {
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let ok = Command::new(&cc)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(std::env::var_os("CI").is_none(), "no C compiler `{cc}`");
        eprintln!("SKIPPED: no C compiler `{cc}`");
    }
    ok.then_some(cc)
}

#[test]
fn the_c_export_evaluates_the_terms_as_written_and_compiles() {
    let Some(cc) = compiler() else { return };
    for m in ["flexible_joint", "friction_joint", "duffing_position"] {
        c_compiles(m, &cc);
    }
    let code = std::fs::read_to_string(tmp("c-flexible_joint").join("flexible_joint.c"))
        .expect("C source");
    assert!(code.contains("#include <math.h>"), "math for sin");
    assert!(code.contains("sin(x0)"), "sin(q̂1) in the observer");
}

#[test]
fn qpv_vertices_shows_the_jacobian_dimension() {
    let out = qpv(&["vertices", "examples/flexible_joint.qpv"]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("d(der w1)/d(q1) = -20"), "{t}");
    assert!(t.contains("d(der w1)/d(q1) = 20"), "{t}");
    assert!(t.contains("der w1: -(mgl/Jl)*sin(q1)"), "{t}");
    assert!(
        t.contains("Jacobian bounded on all of R^nx (a global bound)"),
        "{t}"
    );
    // a bound on S: expanded at the γ a searching design fixes
    let out = qpv(&["vertices", "examples/duffing_position.qpv"]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("Jacobian bounded on S = box hull of F ⊕ (−P/γ)"),
        "{t}"
    );
    assert!(t.contains("1 robust vertex dimension(s)"), "{t}");
    assert!(t.contains("2 vertices"), "{t}");
}
