//! Clarabel's solver, instantiated for `f64` in this crate and nowhere else.
//!
//! Clarabel is generic over its float type, so its whole interior-point
//! method (setup, KKT factorisation, the PSD cones' scaling, the iteration)
//! is compiled by whichever crate first calls `DefaultSolver::<f64>::new`
//! and `solve`. Called from qpv-solve, that code would be compiled into
//! qpv-solve and again (unoptimised) into every test or bench that drives
//! Clarabel directly. Behind the one
//! non-generic [`solve`] below it is compiled once, optimised, in parallel
//! with the crates that do not need it.
//!
//! [`clarabel`] is re-exported so that callers name the same types (CSC
//! matrices, cones, settings, statuses).

pub use clarabel;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultInfo, DefaultSettings, DefaultSolution, DefaultSolver, IPSolver, SolverError,
    SupportedConeT,
};
use clarabel::timers::Timers;

/// One problem in Clarabel's standard form: minimise ½xᵀPx + qᵀx subject to
/// Ax + s = b, s in `cones` (the rows of `A` in the order of the cones).
#[derive(Debug, Clone)]
pub struct Sdp {
    /// Quadratic cost (upper triangle).
    pub p: CscMatrix<f64>,
    /// Linear cost.
    pub q: Vec<f64>,
    /// Constraint matrix.
    pub a: CscMatrix<f64>,
    /// Constraint right-hand side.
    pub b: Vec<f64>,
    /// Cones, in row order.
    pub cones: Vec<SupportedConeT<f64>>,
}

/// Everything a finished solve leaves: the solution (status, primal and
/// dual points, objective, iterations, Clarabel's solve time), the solver's
/// information (including the KKT solver's fill) and its timers.
#[derive(Debug)]
pub struct Solved {
    /// Status, points and objective values.
    pub solution: DefaultSolution<f64>,
    /// Residuals, the linear solver's name and sizes, and the like.
    pub info: DefaultInfo<f64>,
    /// Clarabel's internal timers (setup, factorisation, iterations).
    pub timers: Option<Timers>,
}

/// What a solve reports after each of its iterations, for a progress
/// display ([`solve_observed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iteration {
    /// The iteration's number (from 1).
    pub number: u32,
    /// The relative duality gap.
    pub gap_rel: f64,
    /// The primal residual.
    pub res_primal: f64,
    /// The dual residual.
    pub res_dual: f64,
}

/// [`solve`], calling `observe` after every iteration (a plain function:
/// the solver holds it for the whole solve). Observing changes nothing in
/// the iteration.
pub fn solve_observed(
    sdp: Sdp,
    settings: DefaultSettings<f64>,
    observe: fn(&Iteration),
) -> Result<Solved, SolverError> {
    run(sdp, settings, Some(observe))
}

/// Sets Clarabel up on `sdp` and solves it. The problem data are dropped
/// once the solver holds its own (scaled) copy, so the peak memory is one
/// copy, not two. An error is a setup error (inconsistent dimensions or
/// settings); every outcome of the iteration itself is a status in
/// [`Solved::solution`].
pub fn solve(sdp: Sdp, settings: DefaultSettings<f64>) -> Result<Solved, SolverError> {
    run(sdp, settings, None)
}

/// [`solve`] with an optional observer of every iteration.
fn run(
    sdp: Sdp,
    settings: DefaultSettings<f64>,
    observe: Option<fn(&Iteration)>,
) -> Result<Solved, SolverError> {
    let mut solver = DefaultSolver::new(&sdp.p, &sdp.q, &sdp.a, &sdp.b, &sdp.cones, settings)?;
    drop(sdp);
    if let Some(observe) = observe {
        // Clarabel's termination callback runs after every iteration; it
        // never asks to stop (false).
        solver.set_termination_callback(move |info: &DefaultInfo<f64>| {
            observe(&Iteration {
                number: info.iterations,
                gap_rel: info.gap_rel,
                res_primal: info.res_primal,
                res_dual: info.res_dual,
            });
            false
        });
    }
    solver.solve();
    Ok(Solved {
        solution: solver.solution,
        info: solver.info,
        timers: solver.timers,
    })
}
