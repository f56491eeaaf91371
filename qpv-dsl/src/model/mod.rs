//! AST → validated [`Model`], one pipeline step per module: the names and
//! dimensions a model declares (`names`), its matrices from matrix literals
//! or equations (`matrices`), the convergence region (`region`), the state
//! bound (`state_bound`), the design requests (`design`) and the checks
//! that need the whole model (`validate`). The builder (`build`) runs them
//! in that order.

mod build;
mod cover;
mod derived;
mod design;
mod matrices;
mod measured;
mod names;
mod nonlinear;
mod poles;
mod region;
mod state_bound;
mod validate;

pub(crate) use build::build;
pub use design::{
    AlphaSpec, Clash, Conditions, DesignRequest, Float, GammaSpec, Mode, NoiseObjective,
    OutputFilter, OutputRoute, Split,
};
pub use names::{Param, MAX_DIM, MAX_PARAMS};
pub use poles::PoleRegion;
pub use state_bound::StateBound;
pub use validate::{MAX_COEFFICIENT, MAX_SCHEDULING};

use crate::diagnostic::{Span, Warning};
use crate::expr::bits;
use crate::expr::PolyMatrix;
use crate::region::Region;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

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
    /// The declared range [lo, hi] of each input (`input u in [lo, hi];`),
    /// `None` where none was declared (the f32 error floor needs them).
    pub input_ranges: Vec<Option<(f64, f64)>>,
    /// `input u rate r`: the bound |u_k'| ≤ r of each input (None: not
    /// declared), in input order.
    pub input_rates: Vec<Option<f64>>,
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
    /// Process disturbance names w_1..w_nw (may be empty).
    pub disturbances: Vec<String>,
    /// B_w(θ), nx × nw: x' = ... + B_w(θ)w.
    pub b_w: PolyMatrix,
    /// The outputs measured with noise (`noise y1, y2;`), as indices into
    /// `outputs`; `None`: every output (y_meas = y + v).
    pub noise_outputs: Option<Vec<usize>>,
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
    /// The derived scheduling variables φ_j(θ) (functions of the parameters
    /// that are not multi-affine), in order of first use. Bit `ntheta() + j`
    /// of a term mask of the matrices is φ_j; empty for a model whose
    /// entries are multi-affine in θ.
    pub derived: Vec<crate::sched::Derived>,
    /// The piecewise cover of the parameter box (`cover q2 into 4;`), with
    /// the ranges of the derived variables on every piece; `None`: the
    /// vertices are the corners of the one box of (θ, φ).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cover: Option<crate::cover::Cover>,
    /// The unit of the model's time (`time = hours;`; seconds by default):
    /// every rate, step and period of its designs is in this unit.
    #[serde(
        skip_serializing_if = "crate::time_unit::TimeUnit::is_seconds",
        default
    )]
    pub time_unit: crate::time_unit::TimeUnit,
    /// The nonlinear terms of unmeasured states in the `der` equations
    /// (a state inside a function, a denominator, or a term of degree three
    /// or more), kept as written ([`crate::jacobian`]); the right-hand side
    /// is A(θ)x + N(θ,x)x + B(θ)u + f(x, θ) with f their sum per row.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub nonlinear: Vec<crate::jacobian::NonlinearTerm>,
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

impl Model {
    /// The scheduling variables at `theta`: θ itself followed by the derived
    /// variables φ_j(θ) (θ as given, not clamped). Term masks of the
    /// matrices index this vector.
    pub fn extended(&self, theta: &[f64]) -> Vec<f64> {
        let mut v: Vec<f64> = (0..self.ntheta())
            .map(|i| theta.get(i).copied().unwrap_or(0.0))
            .collect();
        for d in &self.derived {
            let x = d.expr.eval(&v[..self.ntheta()]);
            v.push(x);
        }
        v
    }
    /// A(θ) at a full parameter vector (one entry per declared parameter).
    pub fn eval_a(&self, theta: &[f64]) -> DMatrix<f64> {
        self.a.eval(&self.extended(theta))
    }
    /// N_k(θ), k = 1..nx.
    pub fn eval_n(&self, theta: &[f64]) -> Vec<DMatrix<f64>> {
        let t = self.extended(theta);
        self.n.iter().map(|m| m.eval(&t)).collect()
    }
    /// B(θ).
    pub fn eval_b(&self, theta: &[f64]) -> DMatrix<f64> {
        self.b.eval(&self.extended(theta))
    }
    /// C(θ).
    pub fn eval_c(&self, theta: &[f64]) -> DMatrix<f64> {
        self.c.eval(&self.extended(theta))
    }
    /// M_k(θ), k = 1..ny.
    pub fn eval_m(&self, theta: &[f64]) -> Vec<DMatrix<f64>> {
        let t = self.extended(theta);
        self.m.iter().map(|m| m.eval(&t)).collect()
    }
    /// The right-hand side f(x, u, θ) = A(θ)x + N(θ,x)x + B(θ)u.
    pub fn rhs(&self, x: &DVector<f64>, u: &DVector<f64>, theta: &[f64]) -> DVector<f64> {
        let mut f = self.eval_a(theta) * x;
        if self.nu() > 0 {
            f += self.eval_b(theta) * u;
        }
        for (k, nk) in self.eval_n(theta).iter().enumerate() {
            f[k] += (x.transpose() * nk * x)[(0, 0)];
        }
        let mut v: Vec<f64> = x.iter().copied().collect();
        v.extend((0..self.ntheta()).map(|i| theta.get(i).copied().unwrap_or(0.0)));
        for t in &self.nonlinear {
            f[t.row] += t.expr.eval(&v);
        }
        f
    }
    /// The output h(x, θ) = C(θ) x + M(θ, x)x.
    pub fn output(&self, x: &DVector<f64>, theta: &[f64]) -> DVector<f64> {
        let mut y = self.eval_c(theta) * x;
        for (k, mk) in self.eval_m(theta).iter().enumerate() {
            y[k] += (x.transpose() * mk * x)[(0, 0)];
        }
        y
    }
    /// Indices of the parameters that appear in A, N_k, B, B_w, C or M_k (those
    /// that generate vertices), in declaration order.
    pub fn scheduling(&self) -> Vec<usize> {
        bits(self.param_mask() & low_bits(self.ntheta())).collect()
    }

    /// Bit mask of the parameters and derived variables that appear in some
    /// matrix.
    fn param_mask(&self) -> u64 {
        self.a.param_mask()
            | self.b.param_mask()
            | self.b_w.param_mask()
            | self.c.param_mask()
            | self
                .n
                .iter()
                .chain(&self.m)
                .fold(0, |m, p| m | p.param_mask())
    }

    /// Number of vertices of the polytopic model: 2^s corners (s scheduling
    /// parameters and derived variables) per piece of the cover, one piece
    /// without a cover.
    pub fn nv(&self) -> usize {
        let s = self.scheduling().len() + self.derived.len();
        self.cover.as_ref().map_or(1, |c| c.len()) << s
    }

    /// Whether the plant is LPV (every N_k and M_k is zero): its observer
    /// is global and needs no region or state bound.
    /// Nonlinear terms without a global Jacobian bound need the region.
    pub fn is_lpv(&self) -> bool {
        self.n.iter().chain(&self.m).all(PolyMatrix::is_zero)
            && (self.nonlinear.is_empty() || {
                let j = crate::jacobian::Jacobian {
                    terms: self.nonlinear.clone(),
                    global: None,
                    on_set: false,
                    bound: None,
                };
                let params: Vec<String> = self.params.iter().map(|p| p.name.clone()).collect();
                let theta: Vec<(f64, f64)> = self.params.iter().map(|p| (p.lo, p.hi)).collect();
                crate::jacobian::global_entries(&j.rows(self.nx()), &self.states, &params, &theta)
                    .is_some()
            })
    }

    /// Whether C or some M_k depends on θ (such a model is
    /// designed by the double-sum relaxation or an output post-filter).
    pub fn output_varies(&self) -> bool {
        self.c.param_mask() != 0 || self.m.iter().any(|p| p.param_mask() != 0)
    }
}

/// The mask of the first `n` bits.
pub(crate) fn low_bits(n: usize) -> u64 {
    if n >= 64 {
        u64::MAX
    } else {
        (1u64 << n) - 1
    }
}
