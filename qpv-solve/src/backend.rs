//! The SDP solver (Clarabel) as this crate sees it: the interpreted
//! [`Status`], the solver settings derived from [`Settings`], and the
//! BLAS/LAPACK symbols its PSD cones need.

use crate::settings::Settings;
use clarabel::solver::{DefaultSettings, SolverStatus};
use serde::{Deserialize, Serialize};

/// The outcome of one call to the SDP solver, as this crate interprets it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Clarabel reported `Solved`: a numerical point was returned. It is only
    /// *accepted* if the independent certificate passes as well.
    Solved,
    /// Clarabel returned a (full-accuracy) certificate of primal
    /// infeasibility: the LMIs with their margins have no solution.
    Infeasible,
    /// Anything else (AlmostSolved, AlmostPrimalInfeasible,
    /// InsufficientProgress, MaxIterations, MaxTime, NumericalError, …):
    /// neither a solution nor a proof of infeasibility. Never counted as
    /// feasible, never counted as infeasible; listed in the report.
    Unknown,
    /// No solve was run (e.g. a search that stopped before any step).
    NotRun,
}

impl Status {
    /// Short lowercase name ("solved", "infeasible", "unknown", "not run").
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Solved => "solved",
            Status::Infeasible => "infeasible",
            Status::Unknown => "unknown",
            Status::NotRun => "not run",
        }
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Only a full-accuracy primal-infeasibility certificate counts as infeasible.
pub fn interpret(s: SolverStatus) -> Status {
    match s {
        SolverStatus::Solved => Status::Solved,
        SolverStatus::PrimalInfeasible => Status::Infeasible,
        SolverStatus::Unsolved => Status::NotRun,
        _ => Status::Unknown,
    }
}

/// Clarabel settings from ours. Chordal decomposition is off: every rate
/// block is dense, and splitting the sparse region blocks of box regions
/// only adds cones (measured 10 % slower per iteration on the paper example).
pub fn clarabel_settings(s: &Settings) -> DefaultSettings<f64> {
    DefaultSettings {
        chordal_decomposition_enable: false,
        max_iter: s.max_iter,
        time_limit: s.time_limit,
        verbose: s.verbose,
        tol_gap_abs: s.tol_gap_abs,
        tol_gap_rel: s.tol_gap_rel,
        tol_feas: s.tol_feas,
        tol_infeas_abs: s.tol_infeas_abs,
        tol_infeas_rel: s.tol_infeas_rel,
        ..DefaultSettings::default()
    }
}

/// Makes sure the BLAS/LAPACK symbols Clarabel's PSD cones call are linked.
#[inline]
pub fn ensure_lapack() {
    #[cfg(feature = "pure-lapack")]
    crate::lapack::ensure_linked();
}
