//! Compile-fail tests of `qpv!`: one case per class of user mistake, each
//! `.stderr` showing that the error lands on the offending token.
//!
//! The cases call `qpv_macros::qpv!` (what `qpv::qpv!` re-exports) so that
//! trybuild's separate build needs only this crate and its dependencies,
//! not the facade's command-line and plotting crates.
//!
//! Regenerate the expected output with
//! `TRYBUILD=overwrite cargo test -p qpv-macros --test ui` and review the diff.

#[test]
fn ui() {
    // trybuild builds the macro without the workspace's profile, hence
    // unoptimised: the slow-solve warning would make the expected output
    // depend on the machine's speed.
    std::env::set_var("QPV_SLOW_SOLVE_WARNING", "off");
    // trybuild's cargo builds the whole dependency tree again in its own
    // target directory; without debug info that build is markedly cheaper
    // (the cases only need the compiler's messages).
    std::env::set_var("CARGO_PROFILE_DEV_DEBUG", "false");
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/*.rs");
}
