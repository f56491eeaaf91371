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
//! assert!(design.feasible && design.certifies);
//! # }
//! ```

pub use qpv_dsl as dsl;
pub use qpv_macros::qpv;
pub use qpv_solve as solve;

#[cfg(feature = "plot")]
pub mod plot;
