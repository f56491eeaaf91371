//! Compile-fail tests of `qpv!`: one case per class of user mistake, each
//! `.stderr` showing that the error lands on the offending token.
//!
//! Regenerate the expected output with `TRYBUILD=overwrite cargo test --test ui`
//! and review the diff.

#[test]
fn ui() {
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/*.rs");
}
