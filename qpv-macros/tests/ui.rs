//! Compile-fail tests of `qpv!`: one case per class of user mistake in
//! `tests/ui/*.rs`, each `.stderr` showing the compiler's message and that
//! it lands on the offending token.
//!
//! Each case is compiled by rustc directly (`--emit=metadata`: type-checked,
//! not code-generated) against the `qpv!` proc-macro that cargo built for
//! this test, so no dependency is compiled again. (trybuild, which this
//! harness replaces, builds the whole dependency tree a second time in its
//! own target directory with its own flags: about 120 s of a cold CI run on
//! two cores, for eight cases that take a second.) The cases call
//! `qpv_macros::qpv!`, what `qpv::qpv!` re-exports. The expected output is
//! the compiler's, with the closing "aborting due to" summary removed.
//!
//! Regenerate the expected output with
//! `QPV_UI=overwrite cargo test -p qpv-macros --test ui` and review the diff.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The `qpv!` proc-macro library cargo built beside this test binary (the
/// newest, if several profiles left several).
fn proc_macro_library() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    let deps = exe.parent().expect("the test binary's directory");
    let ext = std::env::consts::DLL_EXTENSION;
    let prefix = format!("{}qpv_macros-", std::env::consts::DLL_PREFIX);
    std::fs::read_dir(deps)
        .expect("the deps directory")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            name.starts_with(&prefix) && p.extension().is_some_and(|e| e == ext)
        })
        .max_by_key(|p| std::fs::metadata(p).and_then(|m| m.modified()).ok())
        .unwrap_or_else(|| panic!("no {prefix}*.{ext} in {}", deps.display()))
}

/// The compiler's messages, as a reader sees them, without the lines that
/// only count errors or point to `rustc --explain`.
fn normalise(stderr: &str) -> String {
    let kept: Vec<&str> = stderr
        .lines()
        .map(str::trim_end)
        .filter(|l| {
            !l.starts_with("error: aborting due to")
                && !l.starts_with("For more information about")
                && !l.starts_with("Some errors have detailed explanations")
        })
        .collect();
    kept.join("\n").trim().to_string() + "\n"
}

/// Compiles one case; its normalised stderr, or a description of why the
/// case is wrong in itself (it compiled).
fn compile_fail(macro_lib: &Path, case: &Path, out: &Path) -> Result<String, String> {
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let run = Command::new(rustc)
        .args([
            "--edition",
            "2021",
            "--crate-type",
            "bin",
            "--emit=metadata",
        ])
        .arg("--diagnostic-width=140")
        .arg("--color=never")
        .arg("--extern")
        .arg(format!("qpv_macros={}", macro_lib.display()))
        .arg("--out-dir")
        .arg(out)
        .arg(case)
        // The macro's "solve took long" note depends on the machine.
        .env("QPV_SLOW_SOLVE_WARNING", "off")
        .output()
        .expect("rustc runs");
    if run.status.success() {
        return Err(format!("{} compiled, but must fail", case.display()));
    }
    Ok(normalise(&String::from_utf8_lossy(&run.stderr)))
}

#[test]
fn ui() {
    let macro_lib = proc_macro_library();
    let overwrite = std::env::var_os("QPV_UI").is_some_and(|v| v == "overwrite");
    let out = std::env::temp_dir().join(format!("qpv-ui-{}", std::process::id()));
    std::fs::create_dir_all(&out).expect("a scratch directory");
    // Paths relative to the package, as the messages show them.
    let mut cases: Vec<PathBuf> = std::fs::read_dir("tests/ui")
        .expect("tests/ui")
        .filter_map(Result::ok)
        .map(|e| Path::new("tests/ui").join(e.file_name()))
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect();
    cases.sort();
    assert!(cases.len() >= 8, "the UI cases are missing: {cases:?}");
    let mut failures = Vec::new();
    for case in &cases {
        let expected_path = case.with_extension("stderr");
        let got = match compile_fail(&macro_lib, case, &out) {
            Ok(s) => s,
            Err(e) => {
                failures.push(e);
                continue;
            }
        };
        if overwrite {
            std::fs::write(&expected_path, &got).expect("write the expected output");
            continue;
        }
        let expected = std::fs::read_to_string(&expected_path)
            .map(|s| normalise(&s))
            .unwrap_or_default();
        if got != expected {
            failures.push(format!(
                "{}: the compiler's output differs from {}\n--- expected\n{expected}--- got\n{got}",
                case.display(),
                expected_path.display()
            ));
        }
    }
    let _ = std::fs::remove_dir_all(&out);
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}
