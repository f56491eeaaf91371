//! Records the optimisation level this proc-macro crate is compiled with
//! (cargo's `OPT_LEVEL` for the profile that builds it), so that `qpv!` can
//! warn when its solves run unoptimised inside rustc.

fn main() {
    let level = std::env::var("OPT_LEVEL").unwrap_or_default();
    println!("cargo:rustc-env=QPV_MACROS_OPT_LEVEL={level}");
    println!("cargo:rerun-if-changed=build.rs");
}
