//! qpv: certified gain-scheduled observers for quadratic parameter-varying
//! (QPV) systems.
//!
//! * [`dsl`] — the model language: text → [`dsl::Model`] → [`dsl::PolytopicModel`].
//! * [`solve`] — LMI synthesis with Clarabel, α/γ search, the independent
//!   certificate, simulation and falsification.
//! * [`qpv!`] — the build-time macro: parse, solve, certify and emit an
//!   unrolled `no_std` observer.
//! * `plot` (feature `plot`, part of the default `cli`) — SVG line charts of
//!   simulated trajectories (used by the `qpv` command line and the paper
//!   example).
//!
//! Features: `cli` (default) builds the `qpv` command line and implies `plot`
//! and `pure-lapack`; `pure-lapack` links pure-Rust BLAS/LAPACK symbols for
//! SDP solves at run time. A library user who only needs `qpv!`, the
//! certificate and simulation depends on qpv with `default-features = false`
//! (and adds `pure-lapack` to run [`solve::design`] in the program).
//!
//! ```
//! # #[cfg(feature = "pure-lapack")] {
//! let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper.qpv")).unwrap();
//! let model = &qpv::dsl::parse(&src).unwrap()[0];
//! let poly = model.polytopic();
//! let design = qpv::solve::design(&poly, &model.designs[1], &Default::default()).unwrap();
//! assert!(design.certifies());
//! # }
//! ```

pub use qpv_dsl as dsl;
pub use qpv_solve as solve;

#[cfg(feature = "plot")]
pub mod plot;

/// Builds a certified observer at compile time from a QPV model.
///
/// ```ignore
/// qpv::qpv!(include "examples/paper.qpv");      // path relative to Cargo.toml
/// // or inline: qpv::qpv! { model plant { state x1, x2; ... design { ... } } }
///
/// let mut obs = paper_example::Observer::new();  // x̂(0) = 0
/// obs.step_rk4(1e-3, &y, &[], &theta);           // y, u, θ held over the step
/// let xhat = obs.estimate();
/// println!("{}", paper_example::CERTIFICATE);
/// ```
///
/// # Generated API (one module per model, named after it)
///
/// * constants `NX`, `NY`, `NU`, `NTHETA`, `NV`, `THETA_MIN`, `THETA_MAX`;
///   `ROUTE` (`"double_sum"` or `"filter"`), `NZ` (the design's state
///   size), `NS` (the observer's state size), `ALPHA`, `GAMMA`,
///   `P: [[f64; NZ]; NZ]`, `L: [[[f64; NY]; NZ]; NV]`, `CERTIFIES` and
///   `CERTIFICATE` (route, margins per condition family, solver status and
///   iterations; implements `Display`);
/// * `mu(&θ) -> [f64; NV]`, `gain(&θ) -> [[f64; NY]; NZ]`,
///   `clamp_theta(&θ) -> ([f64; NTHETA], bool)`;
/// * `Observer`: `new()`, `with_state(&x0)`, `from_state(&s)`, `state()`,
///   `derivative(&y, &u, &θ) -> [f64; NS]`, `step_euler(dt, &y, &u, &θ)`
///   (debug builds assert `dt ≤ MAX_STEP_EULER` when that is positive),
///   `step_rk4(dt, &y, &u, &θ)`, `estimate() -> [f64; NX]`, `clamped()`;
/// * `plant::derivative(&x, &u, &θ)`, `plant::output(&x, &θ)`.
///
/// # Output routes
///
/// `output_route = double_sum` (the default): the observer is
/// x̂' = A(θ)x̂ + N(θ,x̂)x̂ + B(θ)u + L(θ)[y − C(θ)x̂ − M(θ,x̂)x̂]; its state
/// is x̂ (`NZ = NS = NX`).
///
/// `output_route = filter(pole = a, gain = b)`: the design is for the plant
/// augmented by the output post-filter x_y' = −a x_y + b y (`NZ = NX + NY`,
/// plant states first; the design module also has `FILTER_POLE`,
/// `FILTER_GAIN`). The observer runs the filter on the measurement itself;
/// its state (`NS = NX + 2·NY`) is (x̂, x̂_y, x_y):
///
/// ```text
/// x̂'   = A(θ)x̂ + N(θ,x̂)x̂ + B(θ)u + L_x(θ)(x_y − x̂_y)
/// x̂_y' = −a x̂_y + b (C(θ)x̂ + M(θ,x̂)x̂) + L_y(θ)(x_y − x̂_y)
/// x_y'  = −a x_y + b y
/// ```
///
/// with L_x, L_y the first NX and last NY rows of L(θ). `new` and
/// `with_state` start x̂_y = x_y = 0, as the certificate assumes;
/// `estimate()` is x̂ only.
///
/// Everything is fully unrolled and constant-folded, uses `::core` only (it
/// builds in `#![no_std]` crates), never allocates and cannot panic.
///
/// # Several designs
///
/// Each `design { ... }` block of a model becomes a submodule `design1`,
/// `design2`, ... in source order. The first *certified* (sound-mode) design
/// is re-exported at the model level. A `mode = paper` design is solved and
/// checked against the paper's printed conditions, but those certify
/// nothing: its submodule records `ALPHA`, `GAMMA`, `CERTIFIES = false` and
/// the `CERTIFICATE`, with no gain and no observer. A model needs at least
/// one sound design.
///
/// # Run-time behaviour
///
/// θ outside Θ: `Observer`, `mu` and `gain` clamp each component into
/// [`THETA_MIN`, `THETA_MAX`] (NaN becomes the lower bound); the `step_*`
/// methods count such steps (`Observer::clamped`). The certificate only
/// covers θ ∈ Θ. The `plant` functions use θ as given. NaN in x, y or u
/// propagates into the result.
///
/// # Errors
///
/// Every error is one `compile_error!` on the offending token: syntax and
/// validation errors on the token the parser points at (for `include`, on
/// the string literal, with `file:line:column` in the message); a design
/// that is not certified on its `design` block, with the request, the
/// failing condition family with its margin and the best certified (α, γ)
/// (or, for a request that fails on the data alone, such as a γ above what
/// (S4) admits, that limit instead of a search). No uncertified gain is
/// ever baked.
///
/// # Build time
///
/// The SDP solve runs inside rustc, in the proc-macro and its dependencies
/// as built for the host: set `[profile.dev.build-override] opt-level = 3`
/// and `[profile.release.build-override] opt-level = 3` (the qpv workspace
/// does); unoptimised, an expansion is about 15 times slower, and one that
/// takes longer than a second says so in a compile-time warning (a
/// deprecation note naming these settings). Solved designs are cached (see
/// the `cache` module: `$QPV_CACHE_DIR`, else `$CARGO_TARGET_DIR/qpv-cache`,
/// else `target/qpv-cache` of the workspace; `QPV_CACHE=off` disables it);
/// a cache hit is re-certified before use. `QPV_DUMP_DIR=dir` writes the
/// generated code of each model to `dir/<model>.rs` for review.
///
/// # Dependencies
///
/// A crate that depends on `qpv` needs nothing else: the code generated for
/// a model with scheduling functions (`sin(q2)`, `1/(4 - m)`, ...) calls the
/// `no_std` math library `libm` through `qpv`'s own copy. (A `#![no_std]`
/// firmware crate that uses `qpv_macros::qpv!` directly, without the facade,
/// depends on `libm` itself.)
#[macro_export]
macro_rules! qpv {
    ($($model:tt)*) => {
        $crate::__private::qpv_with_libm! { ($crate::__private::libm) $($model)* }
    };
}

/// What the code generated by [`qpv!`] refers to through the facade; not
/// a public API.
#[doc(hidden)]
pub mod __private {
    pub use libm;
    pub use qpv_macros::qpv_with_libm;
}
