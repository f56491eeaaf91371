//! The numerical settings of a design, with documented defaults.

/// Numerical settings of a design. All fields have documented defaults
/// ([`Settings::default`]). Serialised with its field names (what `qpv!`
/// keys its cache by); serde_json writes the infinite `time_limit` (no
/// limit) as `null`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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
    /// Number of points of the γ search's logarithmic grid over
    /// [γ_hi / `gamma_span`, γ_hi]. Default 13 (four per decade).
    pub gamma_grid: usize,
    /// Ratio of the top to the bottom of the γ grid: α_max(γ) can peak far
    /// below γ_hi (on plants with strong nonlinear terms the best γ was
    /// found near γ_max / 20), and the grid is extended further down when
    /// its lowest point is still the best. Default 1000.
    pub gamma_span: f64,
    /// Golden-section evaluations in ln γ per refined local maximum of the
    /// γ grid (and in the noise search's γ refinement). Default 4.
    pub gamma_refine: usize,
    /// Local maxima of the γ grid with α ≥ `gamma_reach` · best are
    /// refined; lower ones are reported only. Default 0.5.
    pub gamma_reach: f64,
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
    /// Clarabel gap/feasibility tolerance of the α/γ search's max-margin
    /// solves (never tighter than the tolerances above). Their points are
    /// certified independently, so they need no more accuracy. Default 1e-5.
    pub search_tol: f64,
    /// Print Clarabel's iteration log. Default false.
    pub verbose: bool,
    /// Clarabel: the direct solver of the KKT system factorised at every
    /// interior-point iteration. Default [`KktSolver::default`].
    pub kkt_solver: KktSolver,
    /// After a certified continuous-time sound design of a QPV plant, also
    /// search the α its linear part alone certifies globally (two more
    /// α searches; `Design::linear_part_alpha`, docs/method.md §18).
    /// Default false (`qpv design --region-cost` sets it).
    pub region_cost: bool,
}

/// The sparse LDLᵀ solver Clarabel factorises its KKT systems with.
///
/// Without the `faer` feature only [`KktSolver::Qdldl`] exists. The enum is
/// `non_exhaustive` because the feature adds variants.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[non_exhaustive]
pub enum KktSolver {
    /// QDLDL: Clarabel's built-in simplicial, single-threaded LDLᵀ. Fast on
    /// small problems, slow once the factor has millions of nonzeros (cube
    /// conditions at nx ≥ 10).
    Qdldl,
    /// faer's supernodal LDLᵀ (dense kernels on the factor's supernodes) on
    /// `threads` threads: 0 = one per core (rayon's pool), 1 = sequential.
    #[cfg(feature = "faer")]
    Faer {
        /// Number of threads (0 = one per core).
        threads: u32,
    },
    /// Clarabel's own choice per problem: it orders the KKT system, counts
    /// the factorisation's operations and takes faer (one thread per core)
    /// when they exceed 40 per factor entry, where dense supernodes pay
    /// (the cube conditions: about 150), else QDLDL.
    #[cfg(feature = "faer")]
    Auto,
}

impl Default for KktSolver {
    /// QDLDL without the `faer` feature, [`KktSolver::Auto`] with it.
    fn default() -> Self {
        #[cfg(feature = "faer")]
        {
            KktSolver::Auto
        }
        #[cfg(not(feature = "faer"))]
        {
            KktSolver::Qdldl
        }
    }
}

impl Settings {
    /// The coarse relative tolerance of the diagnostic and secondary α
    /// searches (failure notes, fallbacks, the gain walk): ten times
    /// [`Settings::bisection_rel_tol`], at most 5 %.
    pub fn coarse_tol(&self) -> f64 {
        (10.0 * self.bisection_rel_tol).min(0.05)
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            margin_rel: 1e-5,
            bisection_rel_tol: 1e-3,
            gamma_grid: 13,
            gamma_span: 1000.0,
            gamma_refine: 4,
            gamma_reach: 0.5,
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
            search_tol: 1e-5,
            verbose: false,
            kkt_solver: KktSolver::default(),
            region_cost: false,
        }
    }
}
