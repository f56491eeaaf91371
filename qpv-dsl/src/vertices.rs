//! The polytopic model: matrices at the corners of the parameter box and the
//! multilinear weights μ_l(θ) (spec §3).

use crate::model::{DesignRequest, Param, StateBound};
use crate::region::Region;
use nalgebra::DMatrix;
use serde::Serialize;

/// The numeric data at one vertex l of the parameter box.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Vertex {
    /// The full parameter vector at this corner (parameters that generate no
    /// vertex are set to their midpoint; they appear in no matrix).
    pub theta: Vec<f64>,
    /// A_l.
    pub a: DMatrix<f64>,
    /// N_{k,l}, k = 1..nx.
    pub n: Vec<DMatrix<f64>>,
    /// B_l.
    pub b: DMatrix<f64>,
}

/// A model in polytopic form: A(θ) = Σ_l μ_l(θ) A_l exactly, constant C, M_k.
///
/// Vertex order: corners of the box of the *scheduling* parameters (those that
/// appear in some matrix), first declared parameter most significant, lo
/// before hi; so μ_1 = Π (hi_i − θ_i)/(hi_i − lo_i).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PolytopicModel {
    /// The model's name.
    pub name: String,
    /// State names.
    pub states: Vec<String>,
    /// Input names.
    pub inputs: Vec<String>,
    /// Output names.
    pub outputs: Vec<String>,
    /// All declared parameters.
    pub params: Vec<Param>,
    /// Indices into `params` of the parameters that generate vertices.
    pub scheduling: Vec<usize>,
    /// The 2^scheduling.len() vertices in the documented order.
    pub vertices: Vec<Vertex>,
    /// C, ny × nx (constant).
    pub c: DMatrix<f64>,
    /// M_k, ny matrices nx × nx (constant).
    pub m: Vec<DMatrix<f64>>,
    /// The convergence region.
    pub region: Region,
    /// The state bound F.
    pub state_bound: StateBound,
    /// Design requests.
    pub designs: Vec<DesignRequest>,
}

impl PolytopicModel {
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
    /// Number of declared parameters (length of a θ vector).
    pub fn ntheta(&self) -> usize {
        self.params.len()
    }
    /// Number of vertices.
    pub fn nv(&self) -> usize {
        self.vertices.len()
    }

    /// The weights μ_l(θ) for a full parameter vector `theta` (one entry per
    /// declared parameter). Each scheduling θ_i is clamped into [lo_i, hi_i]
    /// first, so the weights are always ≥ 0 and sum to 1.
    pub fn mu(&self, theta: &[f64]) -> Vec<f64> {
        let s = self.scheduling.len();
        let mut w = Vec::with_capacity(s);
        for &pi in &self.scheduling {
            let p = &self.params[pi];
            let t = theta.get(pi).copied().unwrap_or(p.lo);
            let t = if t.is_nan() { p.lo } else { t.clamp(p.lo, p.hi) };
            w.push((t - p.lo) / (p.hi - p.lo));
        }
        (0..1usize << s)
            .map(|l| {
                (0..s)
                    .map(|i| {
                        // bit (s-1-i) of l: first scheduling parameter most significant
                        if (l >> (s - 1 - i)) & 1 == 1 {
                            w[i]
                        } else {
                            1.0 - w[i]
                        }
                    })
                    .product()
            })
            .collect()
    }
}
