//! The output routes of a design: how a θ-dependent output map
//! C(θ), M_k(θ) is handled, and the augmentation of the plant by an output
//! post-filter (Remark 3 of the method, docs/method.md).
//!
//! * **Double sum** (`output_route = double_sum`, the default): the model is
//!   designed as it is; with a θ-dependent output map the rate family is the
//!   relaxation of [`crate::conditions::Combo`] (Tuan et al. 2001).
//! * **Filter** (`output_route = filter(pole = a, gain = b)`): every output is
//!   filtered, x_{y,k}' = −a x_{y,k} + b y_k, and the observer is designed
//!   for the augmented plant z = (x, x_y) with the measurement ỹ = x_y:
//!
//! ```text
//!     A_z(θ) = [ A(θ)     0   ]    N_{z,k} = [ N_k  0 ]  (k ≤ nx),   [ b·M_k  0 ]  (filter row k)
//!              [ b C(θ)  −a I ]              [ 0    0 ]              [ 0      0 ]
//!     B_z = [B; 0],   C_z = [0 I],   M_z = 0.
//! ```
//!
//!   The output matrix is constant, so the single sum applies; the
//!   θ-dependence of C and M_k has moved into the state equation.
//!
//! **Region and state bound of the augmented plant (stated and checked).**
//! The observer runs the filter itself, so it knows x_y exactly and starts
//! its estimate there: e_y(0) = 0. The convergence region is therefore
//! extended as P × {0} for the initial errors (vertices (x_(i), 0)) and as
//! the cylinder P × R^ny for the set that must contain E and F (facets
//! (a_k, 0)). This is exact for the conditions, because nothing in the rate
//! LMIs depends on the filter coordinates of e or x: rows(N_z, e) and
//! rowsHe(N_z, x) only read the plant part (the filter blocks of N_z are
//! zero). Hence (S2) is imposed at (x_(i), 0), (S3) only on the plant facets
//! (E ⊂ P̃ × R^ny), (S4) reads only the plant block of Q, and (S5) at the
//! plant vertices. The state bound is F × R^ny; for the record, and for the
//! simulation check, the filter states are also bounded: with
//! x_y(0) = 0 and x ∈ F, |x_{y,k}(t)| ≤ h_k = |b|/a · ȳ_k, where
//! ȳ_k = max_l (‖Q^{1/2} c_{k,l}‖ + ‖Q^{1/2} sym(M_{k,l}) Q^{1/2}‖₂) bounds
//! |y_k| over F × Θ (a norm of a convex combination is at most the largest
//! norm at a vertex). The augmented Q is blockdiag(Q, diag(h_k²)); only its
//! plant block enters a condition.

use crate::error::SolveError;
use crate::linalg::sqrtm;
use crate::model::{is_double_sum, validate};
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{OutputFilter, OutputRoute, PolytopicModel, Region, StateBound, Vertex};
use serde::{Deserialize, Serialize};

/// The output route a design used, for reports and for rebuilding the
/// observer's model ([`crate::Design::observer_model`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputRouteInfo {
    /// "double_sum" or "filter".
    pub route: String,
    /// Whether the model's C or M_k depend on θ.
    pub output_varies: bool,
    /// The filter x_{y,k}' = −pole·x_{y,k} + gain·y_k (filter route only).
    pub filter: Option<FilterInfo>,
    /// The observer's state names: the plant's, then (filter route) one
    /// filter state per output.
    pub states: Vec<String>,
    /// Number of rate combinations per region-vertex pair: N (single sum,
    /// constant output map) or N² (double sum).
    pub combinations: usize,
}

/// The output post-filter of a filter-route design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FilterInfo {
    /// a: the filter pole is −a.
    pub pole: f64,
    /// b: the filter's input gain.
    pub gain: f64,
    /// h_k: |x_{y,k}(t)| ≤ h_k for x(t) ∈ F and x_y(0) = 0 (empty without a
    /// state bound Q). Informational: no condition depends on it.
    pub bound: Vec<f64>,
}

impl OutputRouteInfo {
    /// The route as the DSL's [`OutputRoute`].
    pub fn output_route(&self) -> OutputRoute {
        match &self.filter {
            Some(f) => OutputRoute::Filter(OutputFilter {
                pole: f.pole,
                gain: f.gain,
            }),
            None => OutputRoute::DoubleSum,
        }
    }
}

/// The name of the filter state of output `y`.
pub(crate) fn filter_state_name(y: &str) -> String {
    format!("{y}_filt")
}

/// Checks the filter's numbers (the DSL checks them too; this guards
/// programmatic callers).
fn check_filter(f: &OutputFilter) -> Result<(), SolveError> {
    if !(f.pole.is_finite() && f.pole > 0.0 && f.gain.is_finite() && f.gain != 0.0) {
        return Err(SolveError::Dimensions(format!(
            "output filter: pole must be positive and gain nonzero (got pole = {}, gain = {})",
            f.pole, f.gain
        )));
    }
    Ok(())
}

/// h_k = |b|/a · max_l (‖Q^{1/2} c_{k,l}‖ + ‖Q^{1/2} sym(M_{k,l}) Q^{1/2}‖₂):
/// bounds of the filter states for x(t) ∈ F = {xᵀQ⁻¹x ≤ 1}, θ ∈ Θ and
/// x_y(0) = 0 (see the module doc).
pub fn filter_bound(model: &PolytopicModel, q: &DMatrix<f64>, f: &OutputFilter) -> Vec<f64> {
    let r = sqrtm(q);
    (0..model.ny())
        .map(|k| {
            let ybar = model
                .vertices
                .iter()
                .map(|v| {
                    let c: DVector<f64> = v.c.row(k).transpose();
                    let lin = (&r * c).norm();
                    let ms = (&v.m[k] + v.m[k].transpose()) * 0.5;
                    let quad = (&r * ms * &r)
                        .symmetric_eigenvalues()
                        .iter()
                        .fold(0.0f64, |a, x| a.max(x.abs()));
                    lin + quad
                })
                .fold(0.0, f64::max);
            f.gain.abs() / f.pole * ybar
        })
        .collect()
}

/// The plant augmented by the output post-filter (module doc): states
/// (x, x_y), measurement ỹ = x_y, region P × {0} / P × R^ny, state bound
/// blockdiag(Q, diag(h²)). The state bound must be given (resolve
/// `state_bound auto` first); a model without one stays without one.
pub fn augment(model: &PolytopicModel, f: &OutputFilter) -> Result<PolytopicModel, SolveError> {
    check_filter(f)?;
    validate(model)?;
    let (nx, ny) = (model.nx(), model.ny());
    let nz = nx + ny;
    let (a, b) = (f.pole, f.gain);
    let embed = |m: &DMatrix<f64>, scale: f64| {
        let mut z = DMatrix::zeros(nz, nz);
        z.view_mut((0, 0), (nx, nx)).copy_from(&(m * scale));
        z
    };
    let vertices = model
        .vertices
        .iter()
        .map(|v| {
            let mut az = DMatrix::zeros(nz, nz);
            az.view_mut((0, 0), (nx, nx)).copy_from(&v.a);
            az.view_mut((nx, 0), (ny, nx)).copy_from(&(&v.c * b));
            for k in 0..ny {
                az[(nx + k, nx + k)] = -a;
            }
            let n =
                v.n.iter()
                    .map(|nk| embed(nk, 1.0))
                    .chain(v.m.iter().map(|mk| embed(mk, b)))
                    .collect();
            let mut bz = DMatrix::zeros(nz, model.nu());
            bz.view_mut((0, 0), (nx, model.nu())).copy_from(&v.b);
            let mut cz = DMatrix::zeros(ny, nz);
            for k in 0..ny {
                cz[(k, nx + k)] = 1.0;
            }
            Vertex {
                theta: v.theta.clone(),
                a: az,
                n,
                b: bz,
                c: cz,
                m: vec![DMatrix::zeros(nz, nz); ny],
            }
        })
        .collect();
    let extend = |x: &DVector<f64>| {
        let mut z = DVector::zeros(nz);
        z.rows_mut(0, nx).copy_from(x);
        z
    };
    let region = Region {
        vertices: model.region.vertices.iter().map(extend).collect(),
        facets: model.region.facets.iter().map(extend).collect(),
        // A zonotope stays one with generators (g_k, 0), whose vertices are
        // the (x_(i), 0) above.
        generators: model
            .region
            .zonotope_generators()
            .map(|g| g.iter().map(extend).collect())
            .unwrap_or_default(),
    };
    let state_bound = match &model.state_bound {
        StateBound::Given(q) => {
            let h = filter_bound(model, q, f);
            let mut qz = DMatrix::zeros(nz, nz);
            qz.view_mut((0, 0), (nx, nx)).copy_from(q);
            for (k, hk) in h.iter().enumerate() {
                // A zero output row (h = 0) still needs a positive entry.
                qz[(nx + k, nx + k)] = (hk * hk).max(f64::MIN_POSITIVE);
            }
            StateBound::Given(qz)
        }
        StateBound::None => StateBound::None,
        StateBound::Auto { .. } => {
            return Err(SolveError::StateBoundInput(
                "the output filter needs the plant's state bound resolved first".into(),
            ))
        }
    };
    let mut states = model.states.clone();
    let filt: Vec<String> = model.outputs.iter().map(|y| filter_state_name(y)).collect();
    states.extend(filt.iter().cloned());
    Ok(PolytopicModel {
        name: model.name.clone(),
        states,
        inputs: model.inputs.clone(),
        input_rates: model.input_rates.clone(),
        input_ranges: model.input_ranges.clone(),
        outputs: filt,
        params: model.params.clone(),
        scheduling: model.scheduling.clone(),
        vertices,
        region,
        state_bound,
        designs: model.designs.clone(),
        noise: Default::default(),
        derived: model.derived.clone(),
        cover: model.cover.clone(),
        time_unit: model.time_unit,
        jacobian: None,
    })
}

/// The model the observer of `route` is designed for: `model` itself
/// (double sum) or its augmentation (filter), with the route's record.
/// `model`'s state bound must be given or absent (not `auto`).
pub fn apply(
    model: &PolytopicModel,
    route: &OutputRoute,
) -> Result<(PolytopicModel, OutputRouteInfo), SolveError> {
    let varies = model.output_varies();
    match route {
        OutputRoute::DoubleSum => {
            let info = OutputRouteInfo {
                route: "double_sum".into(),
                output_varies: varies,
                filter: None,
                states: model.states.clone(),
                combinations: combinations(model),
            };
            Ok((model.clone(), info))
        }
        OutputRoute::Filter(f) => {
            let z = augment(model, f)?;
            let bound = match &model.state_bound {
                StateBound::Given(q) => filter_bound(model, q, f),
                _ => Vec::new(),
            };
            let info = OutputRouteInfo {
                route: "filter".into(),
                output_varies: varies,
                filter: Some(FilterInfo {
                    pole: f.pole,
                    gain: f.gain,
                    bound,
                }),
                states: z.states.clone(),
                combinations: combinations(&z),
            };
            Ok((z, info))
        }
    }
}

fn combinations(model: &PolytopicModel) -> usize {
    if is_double_sum(model) {
        model.nv() * model.nv()
    } else {
        model.nv()
    }
}
