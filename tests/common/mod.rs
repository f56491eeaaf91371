//! Helpers shared by the command-line tests (the `cli` test binary:
//! tests/cli.rs and its `cli_*` modules).

use std::path::PathBuf;
use std::process::{Command, Output};

/// Runs the `qpv` binary of this build from the package root.
pub fn qpv(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qpv"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the qpv binary runs")
}

/// A path `name` in a temporary directory of this test process, `tag`
/// keeping the test files apart.
pub fn tmp(tag: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("qpv-cli-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

/// stdout and stderr of a run, as one text for messages and searches.
pub fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// stdout parsed as exactly one JSON document (`--json -`).
pub fn json_stdout(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not exactly one JSON document ({e}):\n{}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// The number at `key` of a JSON object (panics with the object if absent).
pub fn num(v: &serde_json::Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {v}"))
}
