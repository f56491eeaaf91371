//! The SDP solver (Clarabel) as this crate sees it: the interpreted
//! [`Status`], the solver settings derived from [`Settings`], and the
//! BLAS/LAPACK symbols its PSD cones need.

pub(crate) mod builder;

use crate::error::SolveError;
use crate::settings::{KktSolver, Settings};
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
pub(crate) fn interpret(s: SolverStatus) -> Status {
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
    let (direct_solve_method, max_threads) = match s.kkt_solver {
        KktSolver::Qdldl => ("qdldl", 0),
        #[cfg(feature = "faer")]
        KktSolver::Faer { threads } => ("faer", threads),
        #[cfg(feature = "faer")]
        KktSolver::Auto => ("auto", 0),
    };
    DefaultSettings {
        direct_solve_method: direct_solve_method.to_string(),
        max_threads,
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

/// One SDP in Clarabel's standard form (minimise ½xᵀPx + qᵀx subject to
/// Ax + s = b, s in the cones), as `qpv-clarabel` takes it.
pub use qpv_clarabel::Sdp;

/// What one solver call returned, read by the one rule of this crate.
#[derive(Debug, Clone)]
pub struct SdpRun {
    /// The interpreted status (only a full-accuracy infeasibility
    /// certificate is [`Status::Infeasible`]).
    pub status: Status,
    /// Clarabel's own status, for reports (`AlmostSolved`, `MaxIterations`…).
    pub detail: String,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Clarabel's solve time in seconds.
    pub solve_seconds: f64,
    /// The primal point, when the status can carry one (see [`has_point`])
    /// and every entry is finite. It is a *candidate*: nothing is feasible
    /// until the independent certificate says so.
    pub x: Option<Vec<f64>>,
}

/// The statuses whose primal point is worth handing to the certificate:
/// solved, almost solved, or stopped early (insufficient progress, iteration
/// or time limit) at an interior point. Infeasibility certificates, numerical
/// errors and unsolved problems carry none.
pub fn has_point(s: SolverStatus) -> bool {
    matches!(
        s,
        SolverStatus::Solved
            | SolverStatus::AlmostSolved
            | SolverStatus::InsufficientProgress
            | SolverStatus::MaxIterations
            | SolverStatus::MaxTime
    )
}

/// Runs Clarabel once on `sdp`: the only place in the crate that calls the
/// solver, so every caller reads its answer by the same rule.
/// The problem data are dropped once the solver holds its own copy
/// ([`qpv_clarabel::solve`]), so the peak memory is one copy, not two.
pub fn run_sdp(sdp: Sdp, settings: DefaultSettings<f64>) -> Result<SdpRun, SolveError> {
    ensure_lapack();
    let observed = ITERATION_HOOK.with(|h| h.borrow().is_some());
    let solved = match observed {
        true => qpv_clarabel::solve_observed(sdp, settings, forward_iteration),
        false => qpv_clarabel::solve(sdp, settings),
    }
    .map_err(|e| SolveError::Setup(format!("{e:?}")))?;
    let sol = solved.solution;
    let point = has_point(sol.status) && sol.x.iter().all(|v| v.is_finite());
    Ok(SdpRun {
        status: interpret(sol.status),
        detail: format!("{:?}", sol.status),
        iterations: sol.iterations,
        solve_seconds: sol.solve_time,
        x: point.then_some(sol.x),
    })
}

pub use qpv_clarabel::Iteration;

/// A function of every solver iteration on this thread
/// ([`with_iteration_progress`]).
type IterationHook = Box<dyn FnMut(&Iteration)>;

thread_local! {
    /// The hook of [`with_iteration_progress`] while it runs.
    static ITERATION_HOOK: std::cell::RefCell<Option<IterationHook>> =
        const { std::cell::RefCell::new(None) };
}

/// Hands one iteration to this thread's hook, if any.
fn forward_iteration(it: &Iteration) {
    ITERATION_HOOK.with(|h| {
        if let Ok(mut h) = h.try_borrow_mut() {
            if let Some(f) = h.as_mut() {
                f(it);
            }
        }
    });
}

/// Runs `f` with `hook` called after every iteration of every SDP solve
/// it makes on this thread (a progress display inside a long solve: a
/// search reports between solves, a solve of minutes says nothing else).
/// The hook sees the solver's progress only; it changes no result.
pub fn with_iteration_progress<R>(
    hook: impl FnMut(&Iteration) + 'static,
    f: impl FnOnce() -> R,
) -> R {
    let previous = ITERATION_HOOK.with(|h| h.borrow_mut().replace(Box::new(hook)));
    let out = f();
    ITERATION_HOOK.with(|h| *h.borrow_mut() = previous);
    out
}

/// Makes sure the BLAS/LAPACK symbols Clarabel's PSD cones call are linked.
#[inline]
pub fn ensure_lapack() {
    #[cfg(feature = "pure-lapack")]
    crate::lapack::ensure_linked();
}
