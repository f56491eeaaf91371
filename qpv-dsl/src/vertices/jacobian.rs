//! The polytopic model's side of the nonlinear terms of unmeasured states
//! ([`crate::jacobian`]): the terms of a model with their global bound, the
//! set S of the regional observer, and the expansion of the vertices by the
//! Jacobian box.

use super::{PolytopicModel, Vertex};
use crate::jacobian::{entries_on, global_entries, Jacobian, JacobianBound, MAX_JACOBIAN_DIMS};
use nalgebra::DMatrix;

/// The nonlinear terms of `model` with their global bound (if every
/// entry has one), unexpanded; `None` for a model without such terms.
pub(crate) fn of_model(model: &crate::model::Model) -> Option<Jacobian> {
    if model.nonlinear.is_empty() {
        return None;
    }
    let params: Vec<String> = model.params.iter().map(|p| p.name.clone()).collect();
    let theta: Vec<(f64, f64)> = model.params.iter().map(|p| (p.lo, p.hi)).collect();
    let mut j = Jacobian {
        terms: model.nonlinear.clone(),
        global: None,
        on_set: false,
        bound: None,
    };
    j.global = global_entries(&j.rows(model.nx()), &model.states, &params, &theta);
    Some(j)
}

/// The box of states S the bound must hold on for the regional observer
/// at `gamma`: x ∈ F (|x_k| ≤ √Q_kk) and e ∈ E ⊂ P̃ = P/γ (|e_k| ≤
/// max_i |x_(i),k|/γ), so every point x − t e (t ∈ [0, 1]) of the segment
/// [x̂, x] lies in the box |z_k| ≤ √Q_kk + max_i |x_(i),k|/γ (outward
/// rounded). `None` without a given state bound or region.
pub fn s_box(model: &PolytopicModel, gamma: f64) -> Option<Vec<(f64, f64)>> {
    let crate::model::StateBound::Given(q) = &model.state_bound else {
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
    pub fn theta_vertices(&self) -> Vec<Vertex> {
        match self.jacobian.as_ref().and_then(|j| j.bound.as_ref()) {
            Some(b) => {
                let q = b.dims.len();
                b.base_a
                    .iter()
                    .enumerate()
                    .map(|(l, a)| Vertex {
                        a: a.clone(),
                        ..self.vertices[l << q].clone()
                    })
                    .collect()
            }
            None => self.vertices.clone(),
        }
    }

    /// Whether the nonlinear terms need the set S (some Jacobian entry has
    /// no global bound): then the observer is regional and the bound
    /// depends on γ.
    pub fn jacobian_needs_set(&self) -> bool {
        self.jacobian
            .as_ref()
            .is_some_and(|j| j.global.is_none() || j.on_set)
    }

    /// The same model with its nonlinear terms bounded on the set S even
    /// where a global bound exists (a narrower box, for the regional
    /// observer at a fixed γ), its vertices back to the θ-vertices until
    /// [`Self::with_jacobian`] expands them at that γ. Unchanged without
    /// nonlinear terms.
    pub fn with_jacobian_on_set(&self) -> PolytopicModel {
        let mut out = self.clone();
        if let Some(j) = &mut out.jacobian {
            out.vertices = self.theta_vertices();
            let q = self.gain_shift();
            if q > 0 && !out.noise.b_w.is_empty() {
                out.noise.b_w = out.noise.b_w.iter().step_by(1 << q).cloned().collect();
            }
            j.on_set = true;
            j.bound = None;
        }
        out
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
        base.vertices = self.theta_vertices();
        let q0 = self.gain_shift();
        if q0 > 0 && !base.noise.b_w.is_empty() {
            base.noise.b_w = base.noise.b_w.iter().step_by(1 << q0).cloned().collect();
        }
        let params: Vec<String> = self.params.iter().map(|p| p.name.clone()).collect();
        let theta: Vec<(f64, f64)> = self.params.iter().map(|p| (p.lo, p.hi)).collect();
        let rows = jac.rows(self.nx());
        let global = global_entries(&rows, &self.states, &params, &theta).filter(|_| !jac.on_set);
        let (entries, state_box, set, gamma) = match global {
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
            on_set: jac.on_set,
            bound: Some(JacobianBound {
                set,
                state_box,
                gamma,
                entries,
                dims,
                mid,
                base_a: base.vertices.iter().map(|v| v.a.clone()).collect(),
            }),
        });
        Ok(out)
    }
}
