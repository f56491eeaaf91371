//! Nonlinear terms of unmeasured states (docs/method.md, "Nonlinear terms
//! of unmeasured states"): the part f(x, θ) of the `der` equations that is
//! not affine-plus-quadratic in the states, kept as expressions, and the
//! interval bounds of its Jacobian that turn it into a robust vertex
//! dimension of the polytopic model.
//!
//! By the mean value theorem, row by row, f(x) − f(x̂) = H e with row i of
//! H the gradient of f_i at some point of the segment [x̂, x]. If every
//! entry obeys lo_ij ≤ ∂f_i/∂x_j ≤ hi_ij wherever that segment can lie, H
//! lies in the box of matrices whose non-constant entries sit at their
//! bounds. Each non-constant entry is one scalar vertex dimension: every
//! θ-vertex l is repeated at the 2^q corners H_v of that box (A_l + H_v),
//! all with the same gain, since H is not measured.
//!
//! A term's expression is a [`SchedExpr`] over the combined variables
//! (x_1..x_nx, θ_1..θ_np): `Param(i)` is the state i for i < nx and the
//! parameter i − nx after them.

use crate::diagnostic::Span;
use crate::sched::{gradient_hull, SchedExpr};
use nalgebra::DMatrix;
use serde::Serialize;

/// Most vertex dimensions (non-constant Jacobian entries) a model may add.
pub const MAX_JACOBIAN_DIMS: usize = 12;

/// Half-widths of the two boxes a global bound is tried on: an entry is
/// bounded globally when its enclosure is the same on both (a bound that
/// grows with the box is not a global one).
const GLOBAL_REACH: [f64; 2] = [1e60, 1e120];

/// One nonlinear term of a `der` equation, as written.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NonlinearTerm {
    /// The state equation it belongs to (0-based row of x').
    pub row: usize,
    /// The term over (x, θ), with its sign (serialized through `text`).
    #[serde(skip)]
    pub expr: SchedExpr,
    /// The term as written (with its sign).
    pub text: String,
    /// Where it is written.
    pub span: Span,
}

/// The bound of one Jacobian entry ∂f_row/∂x_col.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JacobianEntry {
    /// Row (the state equation), 0-based.
    pub row: usize,
    /// Column (the state differentiated by), 0-based.
    pub col: usize,
    /// `d(der w1)/d(q1)`.
    pub name: String,
    /// Lower bound (outward rounded).
    pub lo: f64,
    /// Upper bound (outward rounded).
    pub hi: f64,
}

/// The nonlinear terms of a model and, once the vertices carry them, the
/// bound they were expanded with.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Jacobian {
    /// The terms, in equation order.
    pub terms: Vec<NonlinearTerm>,
    /// The bounds on all of R^nx (× Θ), when every entry has one; `None`
    /// when some entry grows without bound (then the set S is needed).
    pub global: Option<Vec<JacobianEntry>>,
    /// Bound on the set S even where a global bound exists (a tighter box
    /// for a regional observer; [`crate::PolytopicModel::with_jacobian_on_set`]).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub on_set: bool,
    /// The bound the model's vertices are expanded with; `None` before.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bound: Option<JacobianBound>,
}

/// The Jacobian box a polytopic model's vertices carry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JacobianBound {
    /// The set the bound holds on, in words.
    pub set: String,
    /// The box of states the bound holds on (`None`: all of R^nx).
    pub state_box: Option<Vec<(f64, f64)>>,
    /// The γ of P̃ = P/γ the box was computed for (`None`: global).
    pub gamma: Option<f64>,
    /// Every entry that is not identically zero.
    pub entries: Vec<JacobianEntry>,
    /// Indices into `entries` of the non-constant ones: the vertex
    /// dimensions, first most significant in the vertex order.
    pub dims: Vec<usize>,
    /// The middle of the box, nx × nx (Σ_l μ_l A_l = A(θ) + mid).
    #[serde(skip)]
    pub mid: DMatrix<f64>,
    /// A_l of the θ-vertices before the expansion (the corners of vertex
    /// l differ from it in A only).
    #[serde(skip)]
    pub base_a: Vec<DMatrix<f64>>,
}

impl Jacobian {
    /// The number of vertex dimensions the bound adds (0 before expansion).
    pub fn shift(&self) -> usize {
        self.bound.as_ref().map_or(0, |b| b.dims.len())
    }

    /// f(x, θ), one entry per state: the sum of the terms of each row.
    pub fn eval(&self, nx: usize, x: &[f64], theta: &[f64]) -> Vec<f64> {
        let mut v: Vec<f64> = x.to_vec();
        v.extend_from_slice(theta);
        let mut out = vec![0.0; nx];
        for t in &self.terms {
            out[t.row] += t.expr.eval(&v);
        }
        out
    }

    /// The rows' sums f_i as expressions over (x, θ), `None` for a row
    /// without a term.
    pub fn rows(&self, nx: usize) -> Vec<Option<SchedExpr>> {
        (0..nx)
            .map(|i| {
                let t: Vec<(bool, SchedExpr)> = self
                    .terms
                    .iter()
                    .filter(|t| t.row == i)
                    .map(|t| (false, t.expr.clone()))
                    .collect();
                (!t.is_empty()).then_some(SchedExpr::Sum(t))
            })
            .collect()
    }
}

/// The names of the combined variables (x, θ) of a term.
pub fn var_names(states: &[String], params: &[String]) -> Vec<String> {
    states.iter().chain(params).cloned().collect()
}

/// The Jacobian entries of `rows` (f_i over (x, θ)) on the box `state_box`
/// of the states and `theta` of the parameters: interval gradients with
/// outward rounding, hulled over a grid of sub-boxes. Entries that are
/// identically zero are left out.
pub fn entries_on(
    rows: &[Option<SchedExpr>],
    states: &[String],
    params: &[String],
    state_box: &[(f64, f64)],
    theta: &[(f64, f64)],
) -> Result<Vec<JacobianEntry>, String> {
    let names = var_names(states, params);
    let mut b = state_box.to_vec();
    b.extend_from_slice(theta);
    let nx = states.len();
    let mut out = Vec::new();
    for (i, f) in rows.iter().enumerate() {
        let Some(f) = f else { continue };
        let g = gradient_hull(f, &b, &names)
            .map_err(|e| format!("the Jacobian of `der {}`: {e}", states[i]))?;
        for (j, &(lo, hi)) in g.iter().take(nx).enumerate() {
            if f.param_mask() & (1 << j) == 0 || (lo == 0.0 && hi == 0.0) {
                continue;
            }
            out.push(JacobianEntry {
                row: i,
                col: j,
                name: format!("d(der {})/d({})", states[i], states[j]),
                lo,
                hi,
            });
        }
    }
    Ok(out)
}

/// The global bounds of `rows`, if every entry has one (its enclosure is
/// the same on two boxes of very different size); `None` otherwise.
pub fn global_entries(
    rows: &[Option<SchedExpr>],
    states: &[String],
    params: &[String],
    theta: &[(f64, f64)],
) -> Option<Vec<JacobianEntry>> {
    let at = |r: f64| {
        let b = vec![(-r, r); states.len()];
        entries_on(rows, states, params, &b, theta).ok()
    };
    let small = at(GLOBAL_REACH[0])?;
    let large = at(GLOBAL_REACH[1])?;
    (small == large).then_some(small)
}
