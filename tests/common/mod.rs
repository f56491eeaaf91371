//! Helpers shared by the command-line tests (`tests/cli*.rs`).

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
#[allow(dead_code)] // not every test file writes files
pub fn tmp(tag: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("qpv-cli-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}
