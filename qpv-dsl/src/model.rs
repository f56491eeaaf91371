//! The typed model: names, dimensions, symbolic θ-polynomial matrices, the
//! convergence region, the state bound and the design requests of one
//! `model NAME { ... }` block, after validation.

use crate::diagnostic::{Span, Warning};
use crate::expr::PolyMatrix;
use crate::region::Region;
use serde::Serialize;

/// A bounded scheduling parameter `param NAME in [lo, hi];`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Param {
    /// The parameter's name as declared.
    pub name: String,
    /// Lower bound of θ_i.
    pub lo: f64,
    /// Upper bound of θ_i (strictly greater than `lo`).
    pub hi: f64,
    /// Where it was declared.
    pub span: Span,
}

/// Which set of LMI conditions a design uses (spec §5 / §6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// The sound conditions (S1)-(S5): the default, and the only mode that certifies.
    #[default]
    Sound,
    /// The paper's printed conditions (13), (14), (26): reproduction only.
    Paper,
}

/// The convergence rate requested by a design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AlphaSpec {
    /// A fixed decay rate α > 0.
    Fixed(f64),
    /// The largest certifiable α (bisection).
    Max,
}

/// The region scaling γ requested by a design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GammaSpec {
    /// A fixed γ in (0, 1).
    Fixed(f64),
    /// Search γ over (0, min(1, γ_max)] maximising α.
    Search,
}

/// One `design { ... }` request of a model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignRequest {
    /// Requested decay rate.
    pub alpha: AlphaSpec,
    /// Requested region scaling.
    pub gamma: GammaSpec,
    /// Condition set.
    pub mode: Mode,
    /// The `design` block in the source, for errors about this request.
    pub span: Span,
}

/// The set F = {x : xᵀ Q⁻¹ x ≤ 1} known to contain the state trajectory.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum StateBound {
    /// No `state_bound` given.
    None,
    /// `state_bound Q = [...]`: a symmetric positive definite Q (nx × nx).
    Given(nalgebra::DMatrix<f64>),
}

/// One validated `model` block with symbolic θ-dependent matrices.
///
/// Matrices are over the declared parameters (bit i of a term mask = i-th
/// entry of `params`). `n` has one nx × nx matrix per state and `m` one per
/// output; row k of N(θ,x)x is xᵀ N_k(θ) x, with N_k as written (no
/// symmetrisation).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Model {
    /// The model's name.
    pub name: String,
    /// Where the model block starts (its name).
    pub span: Span,
    /// State names x_1..x_nx.
    pub states: Vec<String>,
    /// Input names u_1..u_nu (may be empty).
    pub inputs: Vec<String>,
    /// Output names y_1..y_ny.
    pub outputs: Vec<String>,
    /// Declared parameters in declaration order.
    pub params: Vec<Param>,
    /// A(θ), nx × nx.
    pub a: PolyMatrix,
    /// N_k(θ), nx matrices of nx × nx.
    pub n: Vec<PolyMatrix>,
    /// B(θ), nx × nu.
    pub b: PolyMatrix,
    /// C(θ), ny × nx.
    pub c: PolyMatrix,
    /// M_k(θ), ny matrices of nx × nx.
    pub m: Vec<PolyMatrix>,
    /// The convergence region P, in both representations.
    pub region: Region,
    /// The state bound F.
    pub state_bound: StateBound,
    /// Design requests in source order.
    pub designs: Vec<DesignRequest>,
    /// Non-fatal remarks found while building the model.
    pub warnings: Vec<Warning>,
}

impl Model {
    /// Number of states.
    pub fn nx(&self) -> usize {
        self.states.len()
    }
    /// Number of inputs.
    pub fn nu(&self) -> usize {
        self.inputs.len()
    }
    /// Number of outputs.
    pub fn ny(&self) -> usize {
        self.outputs.len()
    }
    /// Number of declared parameters.
    pub fn ntheta(&self) -> usize {
        self.params.len()
    }
}
