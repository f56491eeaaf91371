//! LMI synthesis with Clarabel, independent certification and simulation of
//! QPV observers: `PolytopicModel` + design request → certified `Design`.
//!
//! * [`design`] / [`design_with_progress`]: fixed (α, γ), α = max at fixed
//!   γ, or a γ search maximising α ([`search`] documents the algorithms);
//!   returns a [`Design`] whose `verdict` is `Certified` only if the
//!   independent [`check`] passed in sound mode (`Reproduction` in paper mode).
//! * [`check`]: recomputes every condition — sound (S1)-(S5) or the paper's
//!   printed (13), (14), (26) — from P and L_l with nalgebra eigenvalues and
//!   reports the worst margin per family (positive = satisfied) plus the
//!   data checks (S4) and P ⊂ F; usable on externally supplied gains.
//! * [`model`]: the observer's model: the state bound (given, or computed
//!   for `state_bound auto` by [`state_bound`]), the output route ([`output_filter`]: double sum or output
//!   post-filter), the split of N_k and M_k, and the skew slack
//!   ([`model::skew`]).
//! * [`lmi`]: the LMIs assembled directly into Clarabel's standard form
//!   (PSD triangle cones, no modelling layer); [`conditions`]: the condition
//!   sets and the one place where the two modes differ.
//! * Noise, in the folder of each layer: the channels
//!   ([`model::noise`]), the certified bound σ of V' + αV ≤ σ(|w|² + |v|²)
//!   and its check ([`certificate::noise`]; reported on every certified
//!   sound design as `noise`), the noise-optimal design and the rate–noise
//!   trade-off ([`search::noise`]) and the falsification of a noise claim
//!   ([`analysis::noise`]); [`certificate::sampling`]: the largest Euler
//!   step that keeps V contracting and an RK4 step estimate (`sampling`).
//!
//! # Layers
//!
//! The crate reads as its pipeline, in layers (listed once, in the
//! workspace README, and checked against the code by its layer test): a
//! module imports only from its own layer or those below it; the
//! certificate never imports the assembly, so its independence is a
//! structural fact.
//!
//! Conventions: N_k and M_k are used as represented in the model handed in
//! (a request's `split` may symmetrise them first); row k of rows(T, v) is vᵀT_k. Strict inequalities are
//! solved with margins relative to the data ([`Settings::margin_rel`]); the
//! default objective minimises Σ_l ‖Γ_l‖_F² (scaled), which keeps the gains
//! L_l = P⁻¹Γ_l moderate; ‖L_l‖₂ is reported. Only Clarabel's primal
//! infeasibility certificate counts as *infeasible*; any other non-solved
//! status is *unknown* ([`Status`]).
//!
//! ```no_run
//! use qpv_dsl::{AlphaSpec, GammaSpec, Mode};
//! use qpv_solve::certificate::Gains;
//! use qpv_solve::{check, design, request, Settings};
//!
//! let model = qpv_solve::conditions::reference::paper_model();
//! let req = request(AlphaSpec::Fixed(10.0), GammaSpec::Fixed(0.1889), Mode::Sound);
//! let d = design(&model, &req, &Settings::default()).unwrap();
//! assert!(d.certifies());
//! // Anyone can re-check the gains without the solver:
//! let (p, l) = (d.p_matrix(), d.l_matrices());
//! let c = check(&model, &Gains::new(&p, &l), &d.candidate(), d.mode);
//! assert!(c.passed);
//! println!("{}", d.to_json());
//! ```

/// The pure-Rust BLAS/LAPACK the PSD cones call (the `qpv-lapack` crate),
/// linked only with the `pure-lapack` feature.
#[cfg(feature = "pure-lapack")]
pub use qpv_lapack as lapack;

// Shared vocabulary.
pub mod backend;
pub(crate) mod error;
#[doc(hidden)]
pub mod fixtures;
pub mod linalg;
pub mod line_search;
pub(crate) mod settings;
pub mod vocab;
// Model preparation.
pub mod model;
// Condition families, their assembly into the SDP, and the certificate.
pub mod certificate;
pub mod conditions;
pub mod lmi;
// Search, report, analysis.
pub mod analysis;
pub mod export;
pub mod report;
pub mod search;

pub use analysis::{falsify, simulate};
pub use certificate::{check, Certificate, FamilyMargin};
pub use error::SolveError;
pub use linalg::svec;
pub use model::{output_filter, state_bound};
pub use report::{DataCheck, Design, GammaSearchInfo, LocalMax, SearchStep, SolverInfo, Status};
pub use search::{alpha_profile, design, design_with_progress, request, ProfilePoint};
pub use settings::{KktSolver, Settings};
