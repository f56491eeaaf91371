//! The tests of qpv-dsl, one module per file (the library has no unit tests
//! of its own: they would be a second optimised build of it).
//!
//! Every file next to this one is a module of this single test binary, so
//! the crate's tests link once instead of once per file. A new test file
//! must be added to the list below; `every_test_file_is_a_module` fails if
//! one is missing.
//!
//! The binary is the test target `dsl` of the root package (its
//! Cargo.toml), not of qpv-dsl: a test target of qpv-dsl would be compiled
//! at opt-level 3 like the library (the dev profile optimises the package
//! as a whole), while this test code needs no optimisation; it calls the
//! optimised library. Run one file's tests with
//! `cargo test --test dsl FILE::`.

mod errors;
mod fuzz;
mod limits;
mod measured;
mod noise;
mod nonlinear;
mod options;
mod paper;
mod poles;
mod region;
mod region_basic;
mod sched_gradient;
mod sched_range;
mod soundness;
mod syntax;
mod time_unit;

/// Test files that are not listed above would silently not run: refuse them.
#[test]
fn every_test_file_is_a_module() {
    let root = include_str!("it.rs");
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("qpv-dsl/tests");
    let mut missing = Vec::new();
    for entry in std::fs::read_dir(&dir).expect("the tests directory") {
        let name = entry.expect("a directory entry").file_name();
        let name = name.to_string_lossy();
        if name.ends_with(".rs") && name != "it.rs" {
            let line = format!("mod {};", name.trim_end_matches(".rs"));
            if !root.lines().any(|l| l == line) {
                missing.push(name.into_owned());
            }
        }
    }
    assert!(
        missing.is_empty(),
        "tests/{missing:?} not declared as modules in tests/it.rs"
    );
}
