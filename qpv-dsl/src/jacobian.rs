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
use crate::vertices::{PolytopicModel, Vertex};
use crate::StateBound;
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
    /// The θ-vertices before the expansion.
    #[serde(skip)]
    pub base: Vec<Vertex>,
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

/// The nonlinear terms of `model` with their global bound (if every
/// entry has one), unexpanded; `None` for a model without such terms.
pub fn of_model(model: &crate::Model) -> Option<Jacobian> {
    if model.nonlinear.is_empty() {
        return None;
    }
    let params: Vec<String> = model.params.iter().map(|p| p.name.clone()).collect();
    let theta: Vec<(f64, f64)> = model.params.iter().map(|p| (p.lo, p.hi)).collect();
    let mut j = Jacobian {
        terms: model.nonlinear.clone(),
        global: None,
        bound: None,
    };
    j.global = global_entries(&j.rows(model.nx()), &model.states, &params, &theta);
    Some(j)
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

/// The box of states S the bound must hold on for the regional observer
/// at `gamma`: x ∈ F (|x_k| ≤ √Q_kk) and e ∈ E ⊂ P̃ = P/γ (|e_k| ≤
/// max_i |x_(i),k|/γ), so every point x − t e (t ∈ [0, 1]) of the segment
/// [x̂, x] lies in the box |z_k| ≤ √Q_kk + max_i |x_(i),k|/γ (outward
/// rounded). `None` without a given state bound or region.
pub fn s_box(model: &PolytopicModel, gamma: f64) -> Option<Vec<(f64, f64)>> {
    let StateBound::Given(q) = &model.state_bound else {
        return None;
    };
    if model.region.vertices.is_empty() || gamma.is_nan() || gamma <= 0.0 {
        return None;
    }
    let up = |x: f64| x + x.abs() * 4.0 * f64::EPSILON + f64::MIN_POSITIVE;
    Some(
        (0..model.nx())
            .map(|k| {
                let e = model
                    .region
                    .vertices
                    .iter()
                    .map(|v| v[k].abs())
                    .fold(0.0, f64::max);
                let r = up(up(q[(k, k)].max(0.0).sqrt()) + up(e / gamma));
                (-r, r)
            })
            .collect(),
    )
}

impl PolytopicModel {
    /// The number of Jacobian vertex dimensions q: the vertices are the
    /// θ-vertices each repeated at 2^q corners (0 without nonlinear terms
    /// or before the expansion); vertices l and l' share their gain when
    /// l >> q == l' >> q.
    pub fn gain_shift(&self) -> usize {
        self.jacobian.as_ref().map_or(0, Jacobian::shift)
    }

    /// The θ-vertices (before any Jacobian expansion).
    pub fn theta_vertices(&self) -> &[Vertex] {
        match self.jacobian.as_ref().and_then(|j| j.bound.as_ref()) {
            Some(b) => &b.base,
            None => &self.vertices,
        }
    }

    /// Whether the nonlinear terms need the set S (some Jacobian entry has
    /// no global bound): then the observer is regional and the bound
    /// depends on γ.
    pub fn jacobian_needs_set(&self) -> bool {
        self.jacobian.as_ref().is_some_and(|j| j.global.is_none())
    }

    /// The model with its vertices expanded by the Jacobian box: the
    /// global bound when every entry has one, else the bound on the set S
    /// at `gamma` ([`s_box`]). The bound is recomputed from the terms
    /// (any earlier expansion is undone first). Unchanged without
    /// nonlinear terms. An error says why no bound exists.
    pub fn with_jacobian(&self, gamma: Option<f64>) -> Result<PolytopicModel, String> {
        let Some(jac) = &self.jacobian else {
            return Ok(self.clone());
        };
        let mut base = self.clone();
        base.vertices = self.theta_vertices().to_vec();
        let q0 = self.gain_shift();
        if q0 > 0 && !base.noise.b_w.is_empty() {
            base.noise.b_w = base.noise.b_w.iter().step_by(1 << q0).cloned().collect();
        }
        let params: Vec<String> = self.params.iter().map(|p| p.name.clone()).collect();
        let theta: Vec<(f64, f64)> = self.params.iter().map(|p| (p.lo, p.hi)).collect();
        let rows = jac.rows(self.nx());
        let (entries, state_box, set, gamma) =
            match global_entries(&rows, &self.states, &params, &theta) {
                Some(e) => (e, None, "all of R^nx (a global bound)".to_string(), None),
                None => {
                    let g = gamma.ok_or_else(|| {
                        "the Jacobian of the nonlinear terms has no global bound, and no γ was \
                         given for the set S"
                            .to_string()
                    })?;
                    let sb = s_box(&base, g).ok_or_else(|| {
                        "the Jacobian of the nonlinear terms has no global bound: the set S needs \
                         a region and a given state bound (`state_bound Q = [...]`)"
                            .to_string()
                    })?;
                    let e = entries_on(&rows, &self.states, &params, &sb, &theta)?;
                    let text: Vec<String> = sb.iter().map(|(_, r)| format!("{r:.6e}")).collect();
                    let set = format!(
                    "S = box hull of F ⊕ (−P/γ), γ = {g}: |z_k| ≤ √Q_kk + max_i |x_(i),k|/γ = [{}]",
                    text.join(", ")
                );
                    (e, Some(sb), set, Some(g))
                }
            };
        let dims: Vec<usize> = (0..entries.len())
            .filter(|&d| entries[d].lo < entries[d].hi)
            .collect();
        if dims.len() > MAX_JACOBIAN_DIMS {
            return Err(format!(
                "the nonlinear terms have {} non-constant Jacobian entries: at most \
                 {MAX_JACOBIAN_DIMS} vertex dimensions are supported",
                dims.len()
            ));
        }
        let nx = self.nx();
        let mut mid = DMatrix::zeros(nx, nx);
        for e in &entries {
            mid[(e.row, e.col)] += 0.5 * (e.lo + e.hi);
        }
        let q = dims.len();
        let mut vertices = Vec::with_capacity(base.vertices.len() << q);
        for v in &base.vertices {
            for c in 0..1usize << q {
                let mut h = DMatrix::zeros(nx, nx);
                for (k, e) in entries.iter().enumerate() {
                    let up = match dims.iter().position(|&d| d == k) {
                        Some(d) => (c >> (q - 1 - d)) & 1 == 1,
                        None => false,
                    };
                    h[(e.row, e.col)] += if up { e.hi } else { e.lo };
                }
                let mut w = v.clone();
                w.a = &v.a + h;
                vertices.push(w);
            }
        }
        let mut out = base.clone();
        out.vertices = vertices;
        if !base.noise.b_w.is_empty() {
            out.noise.b_w = base
                .noise
                .b_w
                .iter()
                .flat_map(|b| std::iter::repeat(b.clone()).take(1 << q))
                .collect();
        }
        out.jacobian = Some(Jacobian {
            terms: jac.terms.clone(),
            global: jac.global.clone(),
            bound: Some(JacobianBound {
                set,
                state_box,
                gamma,
                entries,
                dims,
                mid,
                base: base.vertices,
            }),
        });
        Ok(out)
    }
}
