//! The design driver: fixed (α, γ), α-bisection at fixed γ, and γ-search.
//! (in progress: API fixed, bodies being filled in)

use crate::report::{Design, SearchStep};
use qpv_dsl::{DesignRequest, PolytopicModel};

/// Numerical settings of a design. All fields have documented defaults
/// ([`Settings::default`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Relative margin ε_rel for the strict (and, for safety, the non-strict)
    /// inequalities. The LMIs are solved in scaled variables P̂ = P/s,
    /// Γ̂ = Γ/s (s = 1/ρ² in sound mode, ρ² in paper mode, ρ = largest
    /// vertex norm of the region), where every condition is O(1); there
    /// P̂ ⪰ ε_rel I, the region conditions hold with ε_rel to spare, and each
    /// rate LMI (S5)/(26) is ⪯ −ε_rel κ I with κ the Frobenius size of its
    /// data (γ(α + max‖A_l‖) + max‖nonlinear term‖). Default 1e-5.
    pub margin_rel: f64,
    /// Relative tolerance of the α bisection: stop when (hi − lo) ≤ tol · lo.
    /// Default 1e-3.
    pub bisection_rel_tol: f64,
    /// Number of points of the coarse γ grid (γ_hi·k/n, k = 1..n). Default 8.
    pub gamma_grid: usize,
    /// Golden-section refinement steps in γ after the grid. Default 8.
    pub gamma_refine: usize,
    /// Largest α the bisection will try. Default 1e6.
    pub alpha_cap: f64,
    /// Smallest α tried when looking for any feasible α (α must be > 0). Default 1e-4.
    pub alpha_floor: f64,
    /// Weight of the default objective ½·w·Σ_l ‖Γ̂_l‖_F² (scaled Γ̂), which
    /// keeps the gains moderate; 0 turns the final solve into a pure
    /// feasibility problem. Default 1.0.
    pub gain_weight: f64,
    /// Clarabel: maximum interior-point iterations. Default 200.
    pub max_iter: u32,
    /// Clarabel: time limit per solve, seconds (∞ = none). Default ∞.
    pub time_limit: f64,
    /// Clarabel: absolute / relative duality-gap tolerance. Default 1e-8 / 1e-8.
    pub tol_gap_abs: f64,
    /// See `tol_gap_abs`.
    pub tol_gap_rel: f64,
    /// Clarabel: feasibility tolerance. Default 1e-8.
    pub tol_feas: f64,
    /// Clarabel: infeasibility-certificate tolerances (abs / rel). Default 1e-8 / 1e-8.
    pub tol_infeas_abs: f64,
    /// See `tol_infeas_abs`.
    pub tol_infeas_rel: f64,
    /// Print Clarabel's iteration log. Default false.
    pub verbose: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            margin_rel: 1e-5,
            bisection_rel_tol: 1e-3,
            gamma_grid: 8,
            gamma_refine: 8,
            alpha_cap: 1e6,
            alpha_floor: 1e-4,
            gain_weight: 1.0,
            max_iter: 200,
            time_limit: f64::INFINITY,
            tol_gap_abs: 1e-8,
            tol_gap_rel: 1e-8,
            tol_feas: 1e-8,
            tol_infeas_abs: 1e-8,
            tol_infeas_rel: 1e-8,
            verbose: false,
        }
    }
}

/// Why a design could not even be attempted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// Sound mode needs the state bound F (Q) for (S4) and for the γ range.
    #[error("model `{0}` has no state_bound Q: sound mode needs it for (S4) and the γ range")]
    MissingStateBound(String),
    /// The convergence region has no vertices or no facets.
    #[error("the convergence region is empty (it needs vertices and facets)")]
    EmptyRegion,
    /// The model has no parameter vertex.
    #[error("the polytopic model has no vertices")]
    NoVertices,
    /// A fixed γ outside (0, 1).
    #[error("γ = {0} is not in (0, 1)")]
    BadGamma(f64),
    /// A fixed α that is not a positive finite number.
    #[error("α = {0} is not a positive finite number")]
    BadAlpha(f64),
    /// (S4) leaves no admissible γ: γ_max = 1/max_k sqrt(a_kᵀQa_k) is not positive/finite.
    #[error("no admissible γ: γ_max from (S4) is {0}")]
    NoGammaRange(f64),
    /// Inconsistent dimensions in the model data.
    #[error("inconsistent model data: {0}")]
    Dimensions(String),
    /// Clarabel refused the problem data (a bug here, reported as an error).
    #[error("solver setup failed: {0}")]
    Setup(String),
}

/// Runs the design requested: fixed (α, γ), α = max by bisection at fixed γ,
/// or a γ search maximising α. See [`design_with_progress`].
pub fn design(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
) -> Result<Design, SolveError> {
    design_with_progress(model, request, settings, &mut |_| {})
}

/// As [`design`], calling `progress` after every solve.
pub fn design_with_progress(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    let _ = (model, request, settings, progress);
    todo!("in progress")
}
