//! Plants scheduled on a measured output, end to end through the command
//! line: Van der Pol and Duffing as a textbook writes them (examples/),
//! designed with `alpha = max`, re-checked, simulated as written from
//! initial errors across a box, exported as C that compiles under
//! `-std=c99 -Wall -Wextra -Werror -pedantic`; and the positioned errors
//! of what is still refused.

use crate::common::{self, qpv, text};
use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    common::tmp("measured", name)
}

/// Designs `example` into a JSON report and checks what the report says
/// about the measured parameter y1; returns the report's path.
fn design(example: &str) -> PathBuf {
    let report = tmp(&format!("{example}.json"));
    let path = format!("examples/{example}.qpv");
    let out = qpv(&["design", &path, "--json", report.to_str().expect("utf-8")]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("is scheduled on the measured output y1"),
        "the rewrite is reported: {t}"
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let d = &doc["designs"][0];
    assert_eq!(d["verdict"], "certified", "{d}");
    assert!(d["alpha"].as_f64().expect("alpha") > 0.0, "{d}");
    let check = &d["data_checks"]["measured_y1"];
    assert_eq!(check["passed"], true, "{check}");
    assert_eq!(check["required"], true, "{check}");
    let notes = d["notes"].to_string();
    assert!(
        notes.contains("computed from the measured output y1") && notes.contains("rewritten"),
        "{notes}"
    );
    report
}

/// `qpv check` on the report exits 0 (the measured check included).
fn recheck(example: &str, report: &Path) {
    let path = format!("examples/{example}.qpv");
    let out = qpv(&["check", &path, "--gains", report.to_str().expect("utf-8")]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(t.contains("measured_y1") && t.contains("pass"), "{t}");
}

/// `qpv simulate` from each x0 (x̂(0) = 0: e(0) = x0) with `extra` flags:
/// y1 follows the plant's output without `--param`, and the error stays
/// inside the certified envelope.
fn simulate(example: &str, report: &Path, x0s: &[&str], extra: &[&str]) {
    let path = format!("examples/{example}.qpv");
    for x0 in x0s {
        let mut args = vec![
            "simulate",
            &path,
            "--design",
            report.to_str().expect("utf-8"),
            "--x0",
            x0,
            "--t-end",
            "6",
        ];
        args.extend_from_slice(extra);
        let out = qpv(&args);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(0), "{t}");
        assert!(
            t.contains("parameter y1 is computed from the plant's output y1"),
            "{t}"
        );
        assert!(
            t.contains("stays inside the certified envelope"),
            "{x0}: {t}"
        );
        assert!(!t.contains("leaves its interval"), "{x0}: {t}");
    }
    // y1 is the plant's output: giving it is an error, not a silent override
    let out = qpv(&[
        "simulate",
        &path,
        "--design",
        report.to_str().expect("utf-8"),
        "--param",
        "y1=0.5",
    ]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("`y1` is computed from the measured output y1") && t.contains("cannot be given"),
        "{t}"
    );
}

/// The C export, with a driver that steps the observer without θ, compiled
/// under the strict flags (skipped without a C compiler, loudly).
fn export_c(example: &str, driver: &str) {
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".to_string());
    if !Command::new(&cc)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        assert!(std::env::var_os("CI").is_none(), "no C compiler");
        eprintln!("SKIPPED: no C compiler (`{cc}`): the C export of {example} was not compiled");
        return;
    }
    let out_dir = tmp(&format!("{example}-c"));
    let path = format!("examples/{example}.qpv");
    let run = qpv(&[
        "codegen",
        &path,
        "--lang",
        "c",
        "--out",
        out_dir.to_str().expect("utf-8"),
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run));
    let header = std::fs::read_to_string(out_dir.join(format!("{example}.h"))).expect("header");
    let up = example.to_uppercase();
    assert!(
        header.contains(&format!("#define {up}_NTHETA_IN 0")),
        "the steppers take no θ: {header}"
    );
    std::fs::write(out_dir.join("main.c"), driver).expect("driver");
    let exe = out_dir.join("main");
    let c = Command::new(&cc)
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"])
        .arg("-I")
        .arg(&out_dir)
        .arg(out_dir.join("main.c"))
        .arg(out_dir.join(format!("{example}.c")))
        .arg("-lm")
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("cc runs");
    assert!(
        c.status.success(),
        "the C does not compile:\n{}",
        String::from_utf8_lossy(&c.stderr)
    );
    let printed = Command::new(&exe).output().expect("runs");
    let printed = String::from_utf8_lossy(&printed.stdout);
    assert!(printed.trim() == "converged", "{printed}");
}

#[test]
fn van_der_pol_as_written_certifies_checks_simulates_and_exports() {
    let report = design("van_der_pol");
    recheck("van_der_pol", &report);
    simulate(
        "van_der_pol",
        &report,
        &["2,0", "-1,1.5", "0.5,-2", "1,1"],
        &[],
    );
    // the plant as written (Euler substeps) against the C observer stepped
    // at 1 ms with y only
    let driver = "#include \"van_der_pol.h\"\n#include <stdio.h>\n#include <math.h>\n\
        int main(void) {\n\
        \x20   van_der_pol_observer o;\n    double x[2] = {2.0, 0.0};\n    int k, i;\n\
        \x20   van_der_pol_init(&o);\n\
        \x20   for (k = 0; k < 4000; k++) {\n\
        \x20       double y[1];\n        y[0] = x[0];\n\
        \x20       van_der_pol_step_rk4(&o, 1e-3, y, NULL, NULL);\n\
        \x20       for (i = 0; i < 100; i++) {\n\
        \x20           double d0 = x[1], d1 = x[1] - x[0] * x[0] * x[1] - x[0];\n\
        \x20           x[0] += 1e-5 * d0; x[1] += 1e-5 * d1;\n        }\n    }\n\
        \x20   {\n        const double *xh = van_der_pol_estimate(&o);\n\
        \x20       puts(fabs(x[0] - xh[0]) + fabs(x[1] - xh[1]) < 1e-2 && o.clamped == 0 ? \"converged\" : \"diverged\");\n    }\n\
        \x20   return 0;\n}\n";
    export_c("van_der_pol", driver);
    let out = qpv(&["vertices", "examples/van_der_pol.qpv"]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "{t}");
    assert!(
        t.contains("parameter `y1` is computed from the measured output y1")
            && t.contains("rewritten: `x1^2*x2` at 14:22 as `(y1^2)*x2`"),
        "{t}"
    );
}

#[test]
fn duffing_as_written_certifies_checks_simulates_and_exports() {
    let report = design("duffing");
    recheck("duffing", &report);
    simulate(
        "duffing",
        &report,
        &["1.5,0", "-1,1", "0,-1.5"],
        &["--input", "u=sin(1.2*t)"],
    );
    let driver = "#include \"duffing.h\"\n#include <stdio.h>\n#include <math.h>\n\
        int main(void) {\n\
        \x20   duffing_observer o;\n    double x[2] = {1.5, 0.0};\n    int k, i;\n\
        \x20   duffing_init(&o);\n\
        \x20   for (k = 0; k < 4000; k++) {\n\
        \x20       double y[1], u[1];\n        y[0] = x[0];\n        u[0] = sin(1.2 * k * 1e-3);\n\
        \x20       duffing_step_rk4(&o, 1e-3, y, u, NULL);\n\
        \x20       for (i = 0; i < 100; i++) {\n\
        \x20           double d0 = x[1], d1 = -0.3 * x[1] - x[0] - 0.5 * x[0] * x[0] * x[0] + u[0];\n\
        \x20           x[0] += 1e-5 * d0; x[1] += 1e-5 * d1;\n        }\n    }\n\
        \x20   {\n        const double *xh = duffing_estimate(&o);\n\
        \x20       puts(fabs(x[0] - xh[0]) + fabs(x[1] - xh[1]) < 1e-2 && o.clamped == 0 ? \"converged\" : \"diverged\");\n    }\n\
        \x20   return 0;\n}\n";
    export_c("duffing", driver);
}

/// What is still refused, positioned: a degree-3 term whose factors are
/// not measured; a measured factor whose interval cannot be derived (the
/// state bound is computed); a declared interval narrower than the output
/// over F.
#[test]
fn what_is_still_refused_is_a_positioned_error() {
    let cases = [
        (
            "model m { state x1, x2; output y; der x1 = x2; der x2 = -x1 - x1*x1*x2; out y = x1; \
             region box(0.5); state_bound auto; }",
            "1:63",
            "declare `param p = y in [lo, hi];`",
        ),
        (
            "model m { state x1, x2; output y; param p = y in [-1, 1]; der x1 = x2; \
             der x2 = -x1 - x1*x1*x2; out y = x1; state_bound Q = [4, 0; 0, 1]; }",
            "1:50",
            "does not cover the output `y` over the state bound F: y ranges over [-2, 2] there",
        ),
    ];
    for (i, (src, at, fragment)) in cases.iter().enumerate() {
        let path = tmp(&format!("refused{i}.qpv"));
        std::fs::write(&path, src).expect("model");
        let out = qpv(&["vertices", path.to_str().expect("utf-8")]);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{t}");
        assert!(t.contains(&format!("{}:{at}", path.display())), "{at}: {t}");
        assert!(t.contains(fragment), "{fragment}: {t}");
    }
}
