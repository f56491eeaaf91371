//! The plant's data as the conditions see it: validation, the region
//! radius, the (S4) γ range of a Q, the split of N_k and M_k.

use crate::error::SolveError;
use nalgebra::DMatrix;
use qpv_dsl::{PolytopicModel, Split, StateBound};

/// Whether the rate family of `model` is the double sum (its output map
/// depends on θ) rather than the single sum over θ-vertices.
pub fn is_double_sum(model: &PolytopicModel) -> bool {
    model.nv() > 1 && model.output_varies()
}

/// The model with the requested representation of N_k and M_k: as written
/// (borrowed, no copy), or symmetrised (N_{k,l} → (N_{k,l} + N_{k,l}ᵀ)/2,
/// M_k → (M_k + M_kᵀ)/2, by [`PolytopicModel::with_split`]).
/// Both describe the same plant (xᵀTx only sees the symmetric part of T),
/// so a certificate for either is a certificate for the plant; they differ
/// in the LMIs, through rows(N, e).
pub fn with_split(model: &PolytopicModel, split: Split) -> std::borrow::Cow<'_, PolytopicModel> {
    match split {
        Split::AsWritten => std::borrow::Cow::Borrowed(model),
        _ => std::borrow::Cow::Owned(model.with_split(split)),
    }
}

/// Largest Euclidean norm of a region vertex (ρ).
pub fn region_radius(model: &PolytopicModel) -> f64 {
    model
        .region
        .vertices
        .iter()
        .map(|x| x.norm())
        .fold(0.0, f64::max)
}

/// γ_max = 1 / max_k sqrt(a_kᵀ Q a_k) from (S4), if Q is given.
pub fn gamma_max(model: &PolytopicModel) -> Option<f64> {
    let StateBound::Given(q) = &model.state_bound else {
        return None;
    };
    Some(gamma_max_for(model, q))
}

/// γ_max = 1 / max_k sqrt(a_kᵀ Q a_k) of (S4) for a given Q (the state
/// bound of the model or a candidate one, e.g. a computed `state_bound auto`).
pub fn gamma_max_for(model: &PolytopicModel, q: &DMatrix<f64>) -> f64 {
    let worst = model
        .region
        .facets
        .iter()
        .map(|a| a.dot(&(q * a)))
        .fold(0.0, f64::max);
    1.0 / worst.sqrt()
}

/// Checks that the model data have consistent dimensions and a usable region.
pub fn validate(model: &PolytopicModel) -> Result<(), SolveError> {
    let nx = model.nx();
    let ny = model.ny();
    let bad = |s: String| Err(SolveError::Dimensions(s));
    if nx == 0 {
        return bad("the model has no state".into());
    }
    if ny == 0 {
        return bad("the model has no output".into());
    }
    if model.vertices.is_empty() {
        return Err(SolveError::NoVertices);
    }
    let lpv = model.is_lpv();
    if !lpv && (model.region.vertices.is_empty() || model.region.facets.is_empty()) {
        return Err(SolveError::EmptyRegion);
    }
    for (l, v) in model.vertices.iter().enumerate() {
        if v.c.shape() != (ny, nx) {
            return bad(format!(
                "C at vertex {} is {:?}, expected ({ny}, {nx})",
                l + 1,
                v.c.shape()
            ));
        }
        if v.m.len() != ny || v.m.iter().any(|m| m.shape() != (nx, nx)) {
            return bad(format!(
                "vertex {}: expected {ny} matrices M_k of {nx} × {nx}",
                l + 1
            ));
        }
        if v.a.shape() != (nx, nx) {
            return bad(format!("A at vertex {} is {:?}", l + 1, v.a.shape()));
        }
        if v.n.len() != nx || v.n.iter().any(|m| m.shape() != (nx, nx)) {
            return bad(format!(
                "vertex {}: expected {nx} matrices N_k of {nx} × {nx}",
                l + 1
            ));
        }
    }
    if model.region.vertices.iter().any(|x| x.len() != nx)
        || model.region.facets.iter().any(|a| a.len() != nx)
    {
        return bad(format!("region vertices and facets must have {nx} entries"));
    }
    if let StateBound::Given(q) = &model.state_bound {
        if q.shape() != (nx, nx) {
            return bad(format!("Q is {:?}, expected ({nx}, {nx})", q.shape()));
        }
    }
    let all_finite = model.vertices.iter().all(|v| {
        v.a.iter().all(|x| x.is_finite())
            && v.c.iter().all(|x| x.is_finite())
            && v.n
                .iter()
                .chain(&v.m)
                .all(|m| m.iter().all(|x| x.is_finite()))
    }) && model
        .region
        .vertices
        .iter()
        .all(|x| x.iter().all(|v| v.is_finite()))
        && model
            .region
            .facets
            .iter()
            .all(|x| x.iter().all(|v| v.is_finite()));
    if !all_finite {
        return bad("non-finite entries in the model data".into());
    }
    if !lpv && region_radius(model) <= 0.0 {
        return Err(SolveError::EmptyRegion);
    }
    Ok(())
}

/// Which observer a design builds. Decided once, from the plant and the
/// mode ([`ObserverKind::of`]), and carried as a value from there: a
/// design's setup, its report (`global`, [`crate::Design::kind`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObserverKind {
    /// The regional QPV observer: (S1)-(S5) on the region and the state
    /// bound, convergence for e(0) in the region.
    Regional,
    /// The global observer of an LPV plant (every N_k and M_k zero, sound
    /// mode): P ⪰ I and He{P A_l − Γ_l C_m} + αP ≺ 0 over the rate
    /// combinations, with no region, state bound or γ (docs/method.md, "The
    /// global observer"); paper mode keeps the printed conditions.
    Global,
}

impl ObserverKind {
    /// The observer a design of `mode` on `model` builds: the global one
    /// for an LPV plant ([`PolytopicModel::is_lpv`]) in sound mode.
    pub fn of(model: &PolytopicModel, mode: qpv_dsl::Mode) -> ObserverKind {
        if mode == qpv_dsl::Mode::Sound && model.is_lpv() {
            ObserverKind::Global
        } else {
            ObserverKind::Regional
        }
    }

    /// Whether this is the global observer.
    pub fn is_global(self) -> bool {
        self == ObserverKind::Global
    }
}

/// The model a global design is solved and analysed on: the plant with its
/// region replaced by the single point {0} and no state bound. Every
/// vertex-pair loop (rate family, noise, sampling) then visits exactly one
/// pair, whose nonlinear terms vanish, so it computes the linear block
/// He{P A_l − Γ_l C_m}; the region conditions are skipped by the global
/// assembly and certificate. Other models are returned unchanged.
pub fn global_model(model: &PolytopicModel) -> std::borrow::Cow<'_, PolytopicModel> {
    if !model.is_lpv() {
        return std::borrow::Cow::Borrowed(model);
    }
    let mut out = model.clone();
    out.region = qpv_dsl::Region {
        vertices: vec![nalgebra::DVector::zeros(model.nx())],
        facets: Vec::new(),
        generators: Vec::new(),
    };
    out.state_bound = StateBound::None;
    std::borrow::Cow::Owned(out)
}
