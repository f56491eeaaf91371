//! The C export (`qpv codegen --lang c`) against the Rust observer `qpv!`
//! generates from the same model and the same certified numbers.
//!
//! For the paper's example and the manipulator (scheduling functions and a
//! cover), the Rust module's P, L_l, α and γ go into a gains file, `qpv
//! codegen --gains` re-certifies them and writes the C, the system C
//! compiler builds it with `-std=c99 -Wall -Wextra -Werror -pedantic` (and
//! `-Wdouble-promotion -Wfloat-conversion` for `float`) together with a C
//! driver, and the driver steps the C observer (RK4 and Euler) through a
//! 2 s scenario whose measurements, inputs and θ(t) (leaving Θ at times,
//! to exercise the clamp) come from the generated Rust plant. The C
//! estimate must match the Rust observer's to 1e-12 of the state's scale
//! (f64); the C constants P and L_l must parse back to the Rust ones bit
//! for bit; the clamp counts must agree. With `float` the C observer must
//! stay within 1e-4 of the state's scale of the f64 Rust one: an empirical
//! tolerance, as no certified f32 rounding floor is computed yet.
//!
//! Without a C compiler (`$CC`, else `cc`) the tests say so on stderr and
//! pass, except under CI (`$CI` set), where they fail.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The C compiler, or None (after saying so loudly; a failure under CI).
fn c_compiler() -> Option<String> {
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let found = Command::new(&cc)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if found {
        return Some(cc);
    }
    let msg =
        format!("no C compiler found (tried `{cc}`; set $CC): the C export tests did NOT run");
    assert!(std::env::var_os("CI").is_none(), "{msg}");
    loud(&format!("SKIPPED: {msg}"));
    None
}

/// A line on the real stderr: the test harness captures `eprintln!` of a
/// passing test, not a direct write, so a skip is seen without
/// `--nocapture`.
fn loud(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// A fresh directory for one test.
fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("qpv-c-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Runs `qpv` from the package root; panics with its output on failure.
fn qpv(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_qpv"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the qpv binary runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(out.status.code(), Some(0), "qpv {args:?}:\n{text}");
    text
}

/// The C driver: prints P and L, then reads steps `h y.. u.. θ..` from
/// stdin and prints, after each, the RK4 and the Euler observer's x̂; at
/// the end both clamp counts.
fn driver(m: &str) -> String {
    let up = m.to_uppercase();
    format!(
        r#"#include "{m}.h"
#include <stdio.h>
#include <stdlib.h>

static {m}_real rd(void) {{
    char buf[64];
    if (scanf("%63s", buf) != 1) exit(3);
    return ({m}_real)strtod(buf, NULL);
}}

int main(void) {{
    {m}_observer rk, eu;
    {m}_real y[{up}_NY], u[{up}_NU + 1], th[{up}_NTHETA + 1];
    int i, j, k;
    for (i = 0; i < {up}_NZ; i++)
        for (j = 0; j < {up}_NZ; j++) printf("%.17g\n", (double){m}_P[i][j]);
    for (k = 0; k < {up}_NV; k++)
        for (i = 0; i < {up}_NZ; i++)
            for (j = 0; j < {up}_NY; j++) printf("%.17g\n", (double){m}_L[k][i][j]);
    {m}_init(&rk);
    {m}_init(&eu);
    for (;;) {{
        char buf[64];
        {m}_real h;
        const {m}_real *e;
        if (scanf("%63s", buf) != 1) break;
        h = ({m}_real)strtod(buf, NULL);
        for (i = 0; i < {up}_NY; i++) y[i] = rd();
        for (i = 0; i < {up}_NU; i++) u[i] = rd();
        for (i = 0; i < {up}_NTHETA; i++) th[i] = rd();
        {m}_step_rk4(&rk, h, y, u, th);
        {m}_step_euler(&eu, h, y, u, th);
        e = {m}_estimate(&rk);
        for (i = 0; i < {up}_NX; i++) printf("%.17g ", (double)e[i]);
        e = {m}_estimate(&eu);
        for (i = 0; i < {up}_NX; i++) printf("%.17g ", (double)e[i]);
        printf("\n");
    }}
    printf("clamped %lu %lu\n", rk.clamped, eu.clamped);
    return 0;
}}
"#
    )
}

/// The Cortex-M4F cross-compiler's flags (docs/embedded.md).
const M4F: [&str; 5] = [
    "-mcpu=cortex-m4",
    "-mthumb",
    "-mfloat-abi=hard",
    "-mfpu=fpv4-sp-d16",
    "-Os",
];

/// Where `arm-none-eabi-gcc` is installed (CI does not install it:
/// docs/embedded.md, "Cross-compiling for a Cortex-M4F"): cross-compiles
/// `<model>.c` in `out` with the warnings `warn` (and for f32 the
/// promotion warnings), prints the object's `.text` size, and for f32
/// asserts that `nm` finds no double-precision helper (`__aeabi_d*`).
/// Without the compiler it says so on stderr and checks nothing.
fn cortex_m4f(out: &Path, model: &str, float: &str, warn: &[&str]) {
    let gcc = std::env::var("ARM_CC").unwrap_or_else(|_| "arm-none-eabi-gcc".into());
    if !Command::new(&gcc)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        loud(&format!(
            "NOTE: {gcc} not found: the Cortex-M4F build of {model}.c ({float}) did not run \
             (apt-get install gcc-arm-none-eabi; docs/embedded.md)"
        ));
        return;
    }
    let obj = out.join(format!("{model}.m4f.o"));
    let mut c = Command::new(&gcc);
    c.args(M4F).args(warn);
    if float == "f32" {
        c.args(["-Wdouble-promotion", "-Wfloat-conversion"]);
    }
    let c = c
        .arg("-c")
        .arg(out.join(format!("{model}.c")))
        .arg("-o")
        .arg(&obj)
        .output()
        .expect("arm-none-eabi-gcc runs");
    assert!(
        c.status.success(),
        "{model}.c ({float}) does not cross-compile for the Cortex-M4F:\n{}",
        String::from_utf8_lossy(&c.stderr)
    );
    let tool = |name: &str| gcc.replace("gcc", name);
    let nm = Command::new(tool("nm"))
        .arg("-u")
        .arg(&obj)
        .output()
        .expect("arm-none-eabi-nm runs");
    let undefined = String::from_utf8_lossy(&nm.stdout).to_string();
    let helpers: Vec<&str> = undefined
        .split_whitespace()
        .filter(|s| s.starts_with("__aeabi_d"))
        .collect();
    let size = Command::new(tool("size"))
        .arg("-A")
        .arg(&obj)
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).to_string())
        .unwrap_or_default();
    let text = size
        .lines()
        .find(|l| l.starts_with(".text"))
        .and_then(|l| l.split_whitespace().nth(1))
        .unwrap_or("?")
        .to_string();
    eprintln!("Cortex-M4F {model}.c ({float}): .text {text} bytes, double helpers {helpers:?}");
    if float == "f32" {
        assert!(
            helpers.is_empty(),
            "the f32 object of {model} calls double-precision helpers: {helpers:?}"
        );
    }
}

/// Writes the gains file of a generated module's design.
fn gains_file(path: &Path, model: &str, alpha: f64, gamma: f64, p: String, l: String) {
    let text = format!(
        r#"{{"model": "{model}", "mode": "sound", "alpha": {alpha:e}, "gamma": {gamma:e}, "P": {p}, "L": {l}}}"#
    );
    std::fs::write(path, text).expect("gains file written");
}

/// Exports and compiles the C of `file` with the gains at `gains`, runs
/// the driver on `steps` (one line per step) and returns its output lines.
fn run_c(
    cc: &str,
    d: &Path,
    file: &str,
    model: &str,
    gains: &Path,
    float: &str,
    steps: &str,
) -> Vec<String> {
    let out = d.join(float);
    let text = qpv(&[
        "codegen",
        file,
        "--lang",
        "c",
        "--float",
        float,
        "--gains",
        gains.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(text.contains("certified"), "{text}");
    let source = std::fs::read_to_string(out.join(format!("{model}.c"))).expect("C source");
    assert!(!source.contains("malloc") && !source.contains("static int counter"));
    std::fs::write(out.join("driver.c"), driver(model)).expect("driver");
    let exe = out.join("driver");
    let mut flags = vec![
        "-std=c99",
        "-Wall",
        "-Wextra",
        "-Werror",
        "-pedantic",
        "-O2",
    ];
    if float == "f32" {
        flags.extend(["-Wdouble-promotion", "-Wfloat-conversion"]);
    }
    // the generated code alone, with every warning an error
    let obj = out.join(format!("{model}.o"));
    let c = Command::new(cc)
        .args(&flags)
        .arg("-c")
        .arg(out.join(format!("{model}.c")))
        .arg("-o")
        .arg(&obj)
        .output()
        .expect("cc runs");
    assert!(
        c.status.success(),
        "{model}.c ({float}) does not compile cleanly:\n{}",
        String::from_utf8_lossy(&c.stderr)
    );
    cortex_m4f(&out, model, float, &flags[..5]);
    let c = Command::new(cc)
        .args(["-std=c99", "-O2"])
        .arg(out.join("driver.c"))
        .arg(&obj)
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .expect("cc runs");
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
    // the steps from a file: a pipe written while the driver's output
    // fills the other pipe would deadlock
    let steps_file = out.join("steps.txt");
    std::fs::write(&steps_file, steps).expect("steps written");
    let out = Command::new(&exe)
        .stdin(std::fs::File::open(&steps_file).expect("steps file"))
        .output()
        .expect("driver runs");
    assert!(out.status.success(), "driver failed");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect()
}

/// Rust debug text of nested arrays as JSON (`[[1.0, 2.0], ...]` is both).
fn json<T: std::fmt::Debug>(v: &T) -> String {
    format!("{v:?}")
}

/// The Rust side of one comparison: the scenario and both observers.
macro_rules! compare {
    ($m:ident, $file:literal, $x0:expr, $theta:expr, $u:expr) => {{
        let Some(cc) = c_compiler() else { return };
        let name = stringify!($m);
        let d = dir(name);
        let gains = d.join("gains.json");
        gains_file(&gains, name, $m::ALPHA, $m::GAMMA, json(&$m::P), json(&$m::L));
        // the scenario: RK4 of the generated plant, h = 1 ms for 2 s
        let h = 1e-3;
        let mut x: [f64; $m::NX] = $x0;
        let mut rk = $m::Observer::new();
        let mut eu = $m::Observer::new();
        let mut steps = String::new();
        let mut rust = Vec::new();
        let mut scale = 0.0f64;
        for k in 0..2000 {
            let t = k as f64 * h;
            let theta: [f64; $m::NTHETA] = ($theta)(t);
            let u: [f64; $m::NU] = ($u)(t);
            let y = $m::plant::output(&x, &theta);
            steps.push_str(&format!("{h:e}"));
            for v in y.iter().chain(u.iter()).chain(theta.iter()) {
                steps.push_str(&format!(" {v:e}"));
            }
            steps.push('\n');
            rk.step_rk4(h, &y, &u, &theta);
            eu.step_euler(h, &y, &u, &theta);
            rust.push((rk.estimate(), eu.estimate()));
            scale = x.iter().fold(scale, |s, v| s.max(v.abs()));
            let f = |x: &[f64; $m::NX]| $m::plant::derivative(x, &u, &theta);
            let k1 = f(&x);
            let k2 = f(&core::array::from_fn(|i| x[i] + 0.5 * h * k1[i]));
            let k3 = f(&core::array::from_fn(|i| x[i] + 0.5 * h * k2[i]));
            let k4 = f(&core::array::from_fn(|i| x[i] + h * k3[i]));
            x = core::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        }
        assert!(rk.clamped() > 0, "the scenario leaves Θ at times");
        for (float, tol) in [("f64", 1e-12), ("f32", 1e-4)] {
            let lines = run_c(&cc, &d, $file, name, &gains, float, &steps);
            let (nz, ny, nv) = ($m::NZ, $m::NY, $m::NV);
            let consts: Vec<f64> = lines[..nz * nz + nv * nz * ny]
                .iter()
                .map(|l| l.parse().expect("a constant"))
                .collect();
            let rust_consts: Vec<f64> = $m::P
                .iter()
                .flatten()
                .chain($m::L.iter().flatten().flatten())
                .copied()
                .collect();
            for (c, r) in consts.iter().zip(&rust_consts) {
                let want = if float == "f32" { f64::from(*r as f32) } else { *r };
                assert_eq!(c.to_bits(), want.to_bits(), "{float}: constant {c} vs {want}");
            }
            let rows = &lines[nz * nz + nv * nz * ny..];
            assert_eq!(rows.len(), rust.len() + 1, "one line per step and the clamp counts");
            let mut worst = 0.0f64;
            for (row, (r_rk, r_eu)) in rows.iter().zip(&rust) {
                let c: Vec<f64> = row
                    .split_whitespace()
                    .map(|v| v.parse().expect("a number"))
                    .collect();
                for (cv, rv) in c.iter().zip(r_rk.iter().chain(r_eu.iter())) {
                    worst = worst.max((cv - rv).abs() / scale);
                }
            }
            eprintln!("{name} {float}: C vs Rust, worst difference {worst:.3e} of the state's scale {scale:.3e}");
            assert!(worst <= tol, "{name} {float}: C differs from Rust by {worst:e} of the state's scale");
            assert_eq!(
                rows.last().map(String::as_str),
                Some(format!("clamped {} {}", rk.clamped(), eu.clamped()).as_str())
            );
        }
    }};
}

#[test]
fn paper_example_c_matches_the_rust_observer() {
    use super::paper_sound;
    compare!(
        paper_sound,
        "tests/nostd/paper_sound.qpv",
        [0.01, -0.005, 0.004],
        |t: f64| [0.5 + 0.6 * (7.0 * t).sin(), 0.5 + 0.5 * (3.0 * t).cos()],
        |_t: f64| []
    );
}

#[test]
fn manipulator_c_matches_the_rust_observer() {
    use super::manipulator;
    compare!(
        manipulator,
        "examples/manipulator.qpv",
        [0.2, -0.1, 0.03, -0.02],
        |t: f64| [1.1 + 1.0 * (2.0 * t).sin()],
        |t: f64| [0.01 * (5.0 * t).sin(), -0.01 * (3.0 * t).cos()]
    );
}

#[test]
fn the_design_path_refuses_paper_mode_and_exports_the_sound_design() {
    let Some(cc) = c_compiler() else { return };
    let d = dir("design");
    let out = d.to_str().expect("utf-8");
    // examples/paper.qpv: block 1 is the paper-mode reproduction
    let bad = Command::new(env!("CARGO_BIN_EXE_qpv"))
        .args([
            "codegen",
            "examples/paper.qpv",
            "--design",
            "1",
            "--out",
            out,
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("qpv runs");
    let text = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{text}");
    assert!(
        text.contains("examples/paper.qpv:26: design block 1 is a paper-mode"),
        "{text}"
    );
    assert!(!d.join("paper_example.c").exists(), "nothing written");
    let text = qpv(&["codegen", "tests/nostd/paper_sound.qpv", "--out", out]);
    assert!(
        text.contains("solved and independently re-checked"),
        "{text}"
    );
    let source = std::fs::read_to_string(d.join("paper_sound.c")).expect("C source");
    let header = std::fs::read_to_string(d.join("paper_sound.h")).expect("C header");
    assert!(header.contains("typedef double paper_sound_real;"));
    assert!(
        header.contains("S1"),
        "the certificate's margins in the comment block"
    );
    assert!(source.contains("const paper_sound_real paper_sound_ALPHA = 10.0;"));
    assert!(
        !header.contains("ALPHA_SUP"),
        "a fixed α has no supremum estimate"
    );
    assert!(
        !source.contains("#include <math.h>"),
        "no libm without scheduling functions"
    );
    let c = Command::new(&cc)
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c"])
        .arg(d.join("paper_sound.c"))
        .arg("-o")
        .arg(d.join("p.o"))
        .output()
        .expect("cc runs");
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
}

/// The C driver of a sampled design: reads the start x̂(0) (NX numbers,
/// given to `<m>_init_at`), then samples `y.. u.. θ..` from stdin and
/// prints x̂ after each call of the certified `<m>_step`.
fn sampled_driver(m: &str) -> String {
    let up = m.to_uppercase();
    format!(
        r#"#include "{m}.h"
#include <stdio.h>
#include <stdlib.h>

int main(void) {{
    {m}_observer o;
    {m}_real y[{up}_NY], u[{up}_NU + 1], th[{up}_NTHETA + 1];
    {m}_real x0[{up}_NX];
    char buf[64];
    int i;
    printf("%.17g\n", (double){m}_SAMPLE_PERIOD);
    for (i = 0; i < {up}_NX; i++) {{
        if (scanf("%63s", buf) != 1) return 3;
        x0[i] = ({m}_real)strtod(buf, NULL);
    }}
    {m}_init_at(&o, x0);
    for (;;) {{
        const {m}_real *e;
        for (i = 0; i < {up}_NY; i++) {{
            if (scanf("%63s", buf) != 1) return 0;
            y[i] = ({m}_real)strtod(buf, NULL);
        }}
        for (i = 0; i < {up}_NU; i++) {{ if (scanf("%63s", buf) != 1) return 3; u[i] = ({m}_real)strtod(buf, NULL); }}
        for (i = 0; i < {up}_NTHETA; i++) {{ if (scanf("%63s", buf) != 1) return 3; th[i] = ({m}_real)strtod(buf, NULL); }}
        {m}_step(&o, y, u, th);
        e = {m}_estimate(&o);
        for (i = 0; i < {up}_NX; i++) printf("%.17g ", (double)e[i]);
        printf("\n");
    }}
}}
"#
    )
}

/// A `sample = h` design (docs/method.md §16) exported as C. The design path solves
/// and certifies it at h (the certificate block says so); from the baked
/// numbers of `qpv!` (a gains file with the report's `sample` key) the C
/// `<m>_step` matches the Rust `Observer::step`, in f64 and in f32 (whose
/// SAMPLE_PERIOD is the float nearest h, the period then certified).
#[test]
fn a_sampled_design_exports_its_period_and_certified_step() {
    use super::generated_sampled::paper_sampled as m;
    let Some(cc) = c_compiler() else { return };
    let d = dir("sampled");
    let file = "tests/fixtures/paper_sampled.qpv";
    let design_out = d.join("design");
    let text = qpv(&[
        "codegen",
        file,
        "--out",
        design_out.to_str().expect("utf-8"),
    ]);
    assert!(text.contains("certified at h = 1e-3 s (1 kHz)"), "{text}");
    let header = std::fs::read_to_string(design_out.join("paper_sampled.h")).expect("C header");
    assert!(
        header.contains(" * certified at h = 1e-3 s (1 kHz): paper_sampled_step"),
        "{header}"
    );
    assert!(
        header.contains("extern const paper_sampled_real paper_sampled_SAMPLE_PERIOD;"),
        "{header}"
    );
    assert!(header.contains(
        "void paper_sampled_step(paper_sampled_observer *o, const paper_sampled_real *y"
    ));
    assert!(
        header.contains("noise bound and Euler step figures: not computed for a sampled design")
    );
    assert!(
        header.contains("S5d") && !header.contains("  S5 "),
        "{header}"
    );

    let gains = d.join("gains.json");
    let sample = format!(
        r#""sample": {{"h": {h:e}, "alpha": {a:e}, "alpha_per_step": {s:e}, "decrease": {dec:e}}}"#,
        h = m::SAMPLE_PERIOD,
        a = m::ALPHA,
        s = m::SAMPLE_PERIOD * m::ALPHA,
        dec = 1.0 - m::SAMPLE_PERIOD * m::ALPHA
    );
    let text = format!(
        r#"{{"model": "paper_sampled", "mode": "sound", "alpha": {:e}, "gamma": {:e}, {sample}, "P": {}, "L": {}}}"#,
        m::ALPHA,
        m::GAMMA,
        json(&m::P),
        json(&m::L)
    );
    std::fs::write(&gains, text).expect("gains file written");
    // the scenario: the Euler plant from x(0) = (0.01, −0.005, 0.004), 1 s,
    // the observer from x̂(0) = 0
    let mut x = [0.01, -0.005, 0.004];
    let mut obs = m::Observer::new();
    let (mut steps, mut rust) = ("0 0 0\n".to_string(), Vec::new());
    for k in 0..1000 {
        let th = super::paper_theta(k as f64 * m::SAMPLE_PERIOD);
        let y = m::plant::output(&x, &th);
        for v in y.iter().chain(th.iter()) {
            steps.push_str(&format!("{v:e} "));
        }
        steps.push('\n');
        obs.step(&y, &[], &th);
        rust.push(obs.estimate());
        let f = m::plant::derivative(&x, &[], &th);
        x = core::array::from_fn(|i| x[i] + m::SAMPLE_PERIOD * f[i]);
    }
    for (float, tol, period) in [
        ("f64", 1e-12, m::SAMPLE_PERIOD),
        ("f32", 1e-4, f64::from(m::SAMPLE_PERIOD as f32)),
    ] {
        let out = d.join(float);
        let text = qpv(&[
            "codegen",
            file,
            "--float",
            float,
            "--gains",
            gains.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert!(text.contains("certified at h = "), "{text}");
        let exe = sampled_exe(&cc, &out);
        let lines = run_lines(&exe, &out, &steps);
        let h: f64 = lines[0].parse().expect("the period");
        assert_eq!(h.to_bits(), period.to_bits(), "{float}: SAMPLE_PERIOD {h}");
        assert_eq!(lines.len(), rust.len() + 1);
        let mut worst = 0.0f64;
        for (row, r) in lines[1..].iter().zip(&rust) {
            for (cv, rv) in row.split_whitespace().zip(r) {
                let cv: f64 = cv.parse().expect("a number");
                worst = worst.max((cv - rv).abs() / 0.01);
            }
        }
        assert!(
            worst <= tol,
            "{float}: C step differs from Rust step by {worst:e}"
        );
    }
}

/// Builds the sampled driver with the C export in `out`.
fn sampled_exe(cc: &str, out: &Path) -> PathBuf {
    std::fs::write(out.join("driver.c"), sampled_driver("paper_sampled")).expect("driver");
    let exe = out.join("driver");
    let c = Command::new(cc)
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-O2",
        ])
        .arg(out.join("driver.c"))
        .arg(out.join("paper_sampled.c"))
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .expect("cc runs");
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
    exe
}

/// Runs a driver with `input` on stdin (through a file: a pipe written
/// while the driver fills the other would deadlock); its output lines.
fn run_lines(exe: &Path, dir: &Path, input: &str) -> Vec<String> {
    let input_file = dir.join("input.txt");
    std::fs::write(&input_file, input).expect("input written");
    let run = Command::new(exe)
        .stdin(std::fs::File::open(&input_file).expect("input file"))
        .output()
        .expect("driver runs");
    assert!(run.status.success(), "driver failed");
    String::from_utf8_lossy(&run.stdout)
        .lines()
        .map(str::to_string)
        .collect()
}

/// The f32 export of a sampled design certifies a finite floor for its
/// `<m>_step` at the sample period (the recursion's rounding as a bounded
/// disturbance of the certified discrete contraction, docs/embedded.md),
/// the header declares it with `FLOAT_BITS` 32 and the rounding split, and
/// a run started at e(0) = 0 (`<m>_init_at`) against the Euler plant stays
/// at or below it at every step (the recursion keeps ρ_k ≤ ρ* from ρ_0 = 0).
#[test]
fn a_sampled_f32_export_certifies_a_floor_for_its_step() {
    use super::generated_sampled::paper_sampled as m;
    let Some(cc) = c_compiler() else { return };
    let d = dir("sampled-floor");
    let out = d.join("f32");
    let text = qpv(&[
        "codegen",
        "tests/fixtures/paper_sampled.qpv",
        "--float",
        "f32",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(text.contains("certified at h = "), "{text}");
    let header = std::fs::read_to_string(out.join("paper_sampled.h")).expect("C header");
    let source = std::fs::read_to_string(out.join("paper_sampled.c")).expect("C source");
    for item in [
        "#define PAPER_SAMPLED_FLOAT_BITS 32",
        "extern const paper_sampled_real paper_sampled_F32_STEP_FLOOR;",
        "extern const paper_sampled_real paper_sampled_F32_ROUNDING_D0, paper_sampled_F32_ROUNDING_D1;",
        "extern const paper_sampled_real paper_sampled_F32_RATE;",
        "void paper_sampled_init_at(paper_sampled_observer *o, const paper_sampled_real *x0);",
        "#ifndef PAPER_SAMPLED_NO_CERTIFICATE",
    ] {
        assert!(header.contains(item), "missing `{item}` in the header");
    }
    let value = |name: &str| -> f64 {
        let key = format!("const paper_sampled_real paper_sampled_{name} = ");
        let line = source
            .lines()
            .find(|l| l.starts_with(&key))
            .unwrap_or_else(|| panic!("no {name} in the source"));
        let v = line[key.len()..].trim_end_matches(';');
        if v == "INFINITY" {
            return f64::INFINITY;
        }
        v.trim_end_matches('f').parse().expect("a number")
    };
    let floor = value("F32_STEP_FLOOR");
    let (d1, rate, alpha) = (value("F32_ROUNDING_D1"), value("F32_RATE"), value("ALPHA"));
    assert!(floor.is_finite() && floor > 0.0, "F32_STEP_FLOOR = {floor}");
    assert!(floor < 1e-3, "a useful floor: {floor}");
    assert!(
        rate > 0.0 && rate <= alpha && (alpha - 2.0 * d1 - rate).abs() <= 1e-5 * alpha,
        "F32_RATE = {rate}, ALPHA = {alpha}, D1 = {d1}"
    );
    assert!(
        header.contains("f32 floor of paper_sampled_step at SAMPLE_PERIOD"),
        "the certificate block states the step's floor"
    );
    // the Euler plant (f64) from x(0), the f32 observer from x̂(0) = x(0)
    // exactly (an f32 value): 3 s at 1 kHz, θ sweeping Θ
    let h = f64::from(m::SAMPLE_PERIOD as f32);
    let mut x: [f64; 3] = [0.01, -0.005, 0.004].map(|v: f64| f64::from(v as f32));
    let mut input = format!("{:e} {:e} {:e}\n", x[0], x[1], x[2]);
    let mut plant = Vec::new();
    for k in 0..3000 {
        let th = super::paper_theta(k as f64 * h);
        let y = m::plant::output(&x, &th);
        for v in y.iter().chain(th.iter()) {
            input.push_str(&format!("{v:e} "));
        }
        input.push('\n');
        let f = m::plant::derivative(&x, &[], &th);
        x = core::array::from_fn(|i| x[i] + h * f[i]);
        plant.push(x);
    }
    // -D<M>_NO_CERTIFICATE compiles the certificate text out
    for (define, has) in [
        (None, true),
        (Some("-DPAPER_SAMPLED_NO_CERTIFICATE"), false),
    ] {
        let obj = out.join("cert.o");
        let mut c = Command::new(&cc);
        c.args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"]);
        c.args(["-Wdouble-promotion", "-Wfloat-conversion"]);
        c.args(define);
        let c = c
            .arg("-c")
            .arg(out.join("paper_sampled.c"))
            .arg("-o")
            .arg(&obj)
            .output()
            .expect("cc runs");
        assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
        let symbols = Command::new("nm").arg(&obj).output().expect("nm runs");
        let symbols = String::from_utf8_lossy(&symbols.stdout);
        assert_eq!(
            symbols.contains("paper_sampled_CERTIFICATE"),
            has,
            "{define:?}:\n{symbols}"
        );
    }
    let exe = sampled_exe(&cc, &out);
    let lines = run_lines(&exe, &out, &input);
    assert_eq!(lines.len(), plant.len() + 1);
    let mut worst = 0.0f64;
    for (row, x) in lines[1..].iter().zip(&plant) {
        let e2: f64 = row
            .split_whitespace()
            .zip(x)
            .map(|(v, xi)| (xi - v.parse::<f64>().expect("a number")).powi(2))
            .sum();
        worst = worst.max(e2.sqrt());
    }
    eprintln!("sampled f32 step: largest |x - x̂| {worst:.3e}, certified floor {floor:.3e}");
    assert!(
        worst <= floor,
        "|e| = {worst:e} above the certified floor {floor:e}"
    );
    // the observer does round: the run is not trivially exact
    assert!(worst > 0.0);
}

#[test]
fn an_uncertified_design_block_is_explained_as_qpv_explains_it() {
    // The paper's example with γ above the (S4) limit of its state bound:
    // `qpv codegen` writes nothing and says why in the library's words
    // (qpv_solve::export::explain), as `qpv!` does.
    let d = dir("explain");
    let text = include_str!("nostd/paper_sound.qpv").replace("gamma = 0.1889", "gamma = 0.4");
    assert!(
        text.contains("gamma = 0.4"),
        "the test edits the design block"
    );
    let model = d.join("too_wide.qpv");
    std::fs::write(&model, text).expect("model written");
    let out = Command::new(env!("CARGO_BIN_EXE_qpv"))
        .arg("codegen")
        .arg(&model)
        .arg("--out")
        .arg(&d)
        .output()
        .expect("qpv runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("design block 1 is not certified: failing: "),
        "{err}"
    );
    assert!(
        err.contains("this fails on the model's data alone: with this state bound, (S4) admits gamma up to 0.189 only"),
        "{err}"
    );
    assert!(err.contains("nothing written"), "{err}");
    assert!(!d.join("paper_sound.c").exists());
}

#[test]
fn an_alpha_max_design_exports_its_supremum_estimate() {
    // examples/lorenz.qpv: `alpha = max` (the practical design, 1 % below
    // the supremum estimate unless the gains force the knee).
    let Some(cc) = c_compiler() else { return };
    let d = dir("alpha-sup");
    let out = d.to_str().expect("utf-8");
    qpv(&["codegen", "examples/lorenz.qpv", "--out", out]);
    let source = std::fs::read_to_string(d.join("lorenz.c")).expect("C source");
    let header = std::fs::read_to_string(d.join("lorenz.h")).expect("C header");
    assert!(header.contains("extern const lorenz_real lorenz_ALPHA_SUP;"));
    assert!(header.contains("not a rate this design certifies"));
    let value = |name: &str| -> f64 {
        let key = format!("const lorenz_real lorenz_{name} = ");
        let line = source
            .lines()
            .find(|l| l.starts_with(&key))
            .unwrap_or_else(|| panic!("no {name} in the source"));
        line[key.len()..]
            .trim_end_matches(';')
            .parse()
            .expect("a number")
    };
    let (alpha, sup) = (value("ALPHA"), value("ALPHA_SUP"));
    assert!(
        alpha > 0.0 && alpha <= sup,
        "ALPHA = {alpha}, ALPHA_SUP = {sup}"
    );
    let c = Command::new(&cc)
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c"])
        .arg(d.join("lorenz.c"))
        .arg("-o")
        .arg(d.join("l.o"))
        .output()
        .expect("cc runs");
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
}
