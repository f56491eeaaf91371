//! LMI synthesis with Clarabel, independent certification and simulation of
//! QPV observers: `PolytopicModel` + design request → certified `Design`.
//!
//! * [`design`] / [`design_with_progress`]: fixed (α, γ), α = max at fixed
//!   γ, or a γ search maximising α ([`search`] documents the algorithms);
//!   returns a [`Design`] that is `feasible` only if the independent
//!   [`check`] passed, and `certifies` only in sound mode.
//! * [`check`]: recomputes every condition — sound (S1)-(S5) or the paper's
//!   printed (13), (14), (26) — from P and L_l with nalgebra eigenvalues and
//!   reports the worst margin per family (positive = satisfied) plus the
//!   data checks (S4) and P ⊂ F; usable on externally supplied gains.
//! * [`state_bound`]: `state_bound auto` — computes Q (an invariant
//!   ellipsoid containing the region inside a box h·B, maximising γ_max of
//!   (S4), h searched) and checks it independently; [`design`] resolves it
//!   first and reports it in [`Design::state_bound`].
//! * [`output_filter`]: the output routes for a θ-dependent C(θ), M_k(θ):
//!   the double-sum relaxation, or the output post-filter augmentation
//!   (spec §3, Remark 3) with its region and state-bound extension.
//! * [`skew_slack`]: an experiment (issue 6 §2, optional) — alternating
//!   solves over a skew-symmetric slack K_k (N_k + K_k is the same plant)
//!   and what it buys (bench `skew_slack`).
//! * [`noise`]: the certified noise bound σ of V' + αV ≤ σ(|w|² + |v|²)
//!   (reported on every certified sound design as `noise`), the
//!   noise-optimal design ([`noise::design_noise`]) and the rate–noise
//!   trade-off ([`noise::tradeoff`]); [`sampling`]: the largest Euler step
//!   that keeps V contracting and an RK4 step estimate (`sampling`).
//! * [`sdp`]: the LMIs assembled directly into Clarabel's standard form
//!   (PSD triangle cones, no modelling layer); [`conditions`]: the condition
//!   sets and the one place where the two modes differ.
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
//! use qpv_solve::{check, design, request, Settings};
//!
//! let model = qpv_solve::conditions::reference::paper_model();
//! let req = request(AlphaSpec::Fixed(10.0), GammaSpec::Fixed(0.1889), Mode::Sound);
//! let d = design(&model, &req, &Settings::default()).unwrap();
//! assert!(d.feasible && d.certifies);
//! // Anyone can re-check the gains without the solver:
//! let c = check(&model, d.mode, d.alpha, d.gamma, &d.p_matrix(), &d.l_matrices());
//! assert!(c.passed);
//! println!("{}", d.to_json());
//! ```

#[cfg(feature = "pure-lapack")]
pub mod lapack;

pub mod certificate;
pub mod conditions;
pub mod falsify;
pub mod noise;
pub mod output_filter;
pub mod report;
pub mod sampling;
pub mod sdp;
pub mod search;
pub mod simulate;
pub mod skew_slack;
pub mod state_bound;
pub mod svec;

pub use certificate::{check, Certificate, FamilyMargin};
pub use report::{DataCheck, Design, SearchStep, SolverInfo, Status};
pub use search::{design, design_with_progress, request, Settings, SolveError};
