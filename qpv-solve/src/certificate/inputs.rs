//! The checks on a certificate's input (shapes, finiteness, α, γ, the
//! sample period, the cube slacks) and on the data alone: (S4) and P ⊂ F.

use super::margins::DataCheck;
use super::{sampled, RateCheck, Witness};
use crate::conditions::cube::CubeSlacks;
use crate::conditions::{rate_combos, ConditionSet};
use crate::model::validate;
use crate::vocab::{Candidate, Family};
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{Mode, PolytopicModel, StateBound};
use std::collections::BTreeMap;

/// The generators of the model's zonotope region, if the slacks fit them.
pub(super) fn cube_input_errors(
    model: &PolytopicModel,
    c: &CubeSlacks,
) -> Result<Vec<DVector<f64>>, String> {
    let Some(gens) = model.region.zonotope_generators() else {
        return Err("cube slacks given, but the region is not a box or zonotope".into());
    };
    let (nx, r, nc) = (model.nx(), gens.len(), rate_combos(model).len());
    let shape_ok = |v: &Vec<Vec<DMatrix<f64>>>| {
        v.len() == nc
            && v.iter().all(|per| {
                per.len() == r
                    && per
                        .iter()
                        .all(|m| m.shape() == (nx, nx) && m.iter().all(|x| x.is_finite()))
            })
    };
    if !shape_ok(&c.y) || !shape_ok(&c.x) {
        return Err(format!(
            "cube slacks: expected {nc} × {r} symmetric {nx} × {nx} matrices Y and X (rate combinations × generators), with finite entries"
        ));
    }
    if c.d.len() != r || !c.d.iter().all(|v| v.is_finite()) {
        return Err(format!("cube slacks: expected {r} finite entries of D"));
    }
    Ok(gens)
}

pub(super) fn input_errors(
    model: &PolytopicModel,
    set: ConditionSet,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> Vec<String> {
    let nx = model.nx();
    let ny = model.ny();
    let mut errs = Vec::new();
    if let Err(e) = validate(model) {
        errs.push(format!("model: {e}"));
        return errs;
    }
    if p.shape() != (nx, nx) {
        errs.push(format!("P is {:?}, expected ({nx}, {nx})", p.shape()));
    }
    if gammas.len() != model.nv() {
        errs.push(format!(
            "{} gains given, the model has {} vertices",
            gammas.len(),
            model.nv()
        ));
    }
    for (i, g) in gammas.iter().enumerate() {
        if g.shape() != (nx, ny) {
            errs.push(format!(
                "gain {} has the wrong shape (expected {nx} × {ny})",
                i + 1
            ));
        }
    }
    if !p.iter().all(|v| v.is_finite()) || !gammas.iter().all(|g| g.iter().all(|v| v.is_finite())) {
        errs.push("non-finite entries in P or the gains".into());
    }
    if !(alpha.is_finite() && alpha > 0.0) {
        errs.push(format!("α = {alpha} is not a positive finite number"));
    }
    // The caller's condition set decides, as in the check itself: paper
    // mode has no global observer.
    let global = super::units::is_global(model, set.mode());
    let gamma_ok = gamma.is_finite() && gamma > 0.0 && gamma < 1.0;
    if !(global || gamma_ok) {
        errs.push(format!("γ = {gamma} is not in (0, 1)"));
    }
    errs
}

/// The data checks (S4) and P ⊂ F at this γ (empty without Q).
pub fn data_checks(model: &PolytopicModel, mode: Mode, gamma: f64) -> BTreeMap<String, DataCheck> {
    let mut out = BTreeMap::new();
    let StateBound::Given(q) = &model.state_bound else {
        return out;
    };
    let set = ConditionSet::from_mode(mode);
    let s4 = model
        .region
        .facets
        .iter()
        .map(|a| gamma * gamma * a.dot(&(q * a)))
        .fold(f64::NEG_INFINITY, f64::max);
    let s4_desc = match set {
        ConditionSet::Sound => "(S4) max_k γ² a_kᵀ Q a_k ≤ 1: the state bound F lies in P/γ",
        ConditionSet::Paper => {
            "(15)/(S4) max_k γ² a_kᵀ Q a_k ≤ 1: assumed by the paper, not enforced by (13),(14),(26)"
        }
    };
    let s4 = DataCheck::at_most(s4, 1.0, set.requires_s4(), s4_desc);
    out.insert(Family::S4.name().to_string(), s4);
    let inf = match q.clone().cholesky() {
        Some(ch) => model
            .region
            .vertices
            .iter()
            .map(|x| x.dot(&ch.solve(x)))
            .fold(f64::NEG_INFINITY, f64::max),
        None => f64::INFINITY,
    };
    let desc = "max_i x_(i)ᵀ Q⁻¹ x_(i) ≤ 1: the region P lies in the state bound F (Assumption 2)";
    out.insert(
        Family::RegionInF.name().to_string(),
        DataCheck::at_most(inf, 1.0, false, desc),
    );
    out
}

/// The input errors of a check (shapes, finiteness, α, γ, the sample
/// period, the cube slacks), and the cube's generators when they fit.
pub(super) fn check_inputs(
    model: &PolytopicModel,
    set: ConditionSet,
    at: &Candidate,
    w: &Witness,
    rate: RateCheck<'_>,
) -> (Vec<String>, Vec<DVector<f64>>) {
    let mut errs = input_errors(model, set, at.alpha, at.gamma, w.p, w.gammas);
    if let RateCheck::Sampled(h) = rate {
        errs.extend(sampled::input_errors(set, at.alpha, h));
    }
    let gens = match rate {
        RateCheck::Cube(c) if errs.is_empty() => match cube_input_errors(model, c) {
            Ok(g) => g,
            Err(e) => {
                errs.push(e);
                Vec::new()
            }
        },
        _ => Vec::new(),
    };
    (errs, gens)
}
