//! LMI synthesis with Clarabel, independent certification and simulation of
//! QPV observers: `PolytopicModel` + design request → certified `Design`.
//!
//! * [`design`] / [`design_with_progress`]: fixed (α, γ), α = max by
//!   bisection, or a γ search maximising α; returns a [`Design`] that is
//!   `feasible` only if the independent [`check`] passed.
//! * [`check`]: recomputes every condition (sound (S1)-(S5) or the paper's
//!   (13),(14),(26)) from P and L_l with nalgebra eigenvalues; usable on
//!   externally supplied gains.

#[cfg(feature = "pure-lapack")]
pub mod lapack;

pub mod certificate;
pub mod conditions;
pub mod falsify;
pub mod report;
pub mod sdp;
pub mod search;
pub mod simulate;
pub mod svec;

pub use certificate::{check, Certificate, FamilyMargin};
pub use report::{DataCheck, Design, SearchStep, SolverInfo, Status};
pub use search::{design, design_with_progress, Settings, SolveError};
