//! The one builder of the observer's model: state bound → output route →
//! split → skew, from the plant as it is now.
//!
//! Every path that designs or re-checks gains goes through
//! [`ObserverModel::prepare`]: the design itself, [`crate::Design::observer_model`]
//! and [`crate::Design::recheck`], `qpv check` and the `qpv!` macro. For a
//! model with `state_bound auto`, the Q either is computed
//! ([`StateBoundClaim::Compute`]) or comes from a report, a gains file or the
//! macro's cache; such a Q is a *claim* ([`StateBoundClaim::Claimed`]) and is
//! verified against the model as it is now — symmetric, positive definite,
//! finite and sensibly scaled, the region inside F, F inside its box h·B and
//! invariant for the current plant ([`state_bound::check`]) — before
//! anything is checked with it. A refused claim is an error that says what
//! failed.

use crate::error::SolveError;
use crate::model::output_filter::{self, OutputRouteInfo};
use crate::model::skew::with_skew;
use crate::model::state_bound::{self, BoundCheck, StateBoundInfo};
use crate::model::{gamma_max_for, validate};
use crate::settings::Settings;
use crate::vocab::BoundSource;
use nalgebra::DMatrix;
use qpv_dsl::{DesignRequest, OutputRoute, PolytopicModel, Split, StateBound};

/// Largest condition number λ_max/λ_min accepted for a claimed Q: beyond
/// it the ellipsoid is numerically degenerate (a scaling problem, not a bound).
pub const MAX_Q_CONDITION: f64 = 1e12;

/// A Q for `state_bound auto` as a report carries it: Q, and the box size h
/// and split of N_k its invariance was certified with (if known).
#[derive(Debug, Clone, PartialEq)]
pub struct ClaimedBound {
    /// Q of F = {x : xᵀQ⁻¹x ≤ 1}.
    pub q: DMatrix<f64>,
    /// Box size h of h·B; if absent, the smallest box containing F is used.
    pub h: Option<f64>,
    /// Representation of N_k of the invariance check; if absent, both
    /// (written and symmetric, the same plant) are tried.
    pub split: Option<Split>,
}

/// How the builder obtains Q for a model with `state_bound auto` (a model
/// with a given Q or without a bound uses its own and ignores this).
#[derive(Debug, Clone, Copy)]
pub enum StateBoundClaim<'a> {
    /// Compute Q ([`state_bound::resolve`]), as a design does.
    Compute(&'a Settings),
    /// Verify a Q that a report claims, against the model as it is now.
    Claimed(&'a ClaimedBound),
}

/// What the observer is built with besides the plant: the output route,
/// the split of N_k and M_k, and the skew slack K_{k,l} (per θ-vertex, per k)
/// of a `split = skew_slack` design.
#[derive(Debug, Clone, Copy)]
pub struct ObserverOptions<'a> {
    /// Double sum or output post-filter.
    pub output_route: &'a OutputRoute,
    /// Representation of N_k, M_k in the conditions (the same plant).
    pub split: Split,
    /// The skew slack added to N_k after the split, if any.
    pub skew: Option<&'a [Vec<DMatrix<f64>>]>,
}

impl<'a> ObserverOptions<'a> {
    /// The route and split of a design request (no skew slack).
    pub fn for_request(request: &'a DesignRequest) -> Self {
        ObserverOptions {
            output_route: &request.output_route,
            split: request.split,
            skew: None,
        }
    }
}

/// The model the observer's P and L_l belong to, and how it was built.
#[derive(Debug, Clone)]
pub struct ObserverModel {
    /// The plant with its state bound resolved (Q given), before the output
    /// route and the split: what a design of the plant starts from.
    pub plant: PolytopicModel,
    /// The model the conditions are solved and certified on: `plant` after
    /// the output route, the split and the skew slack.
    pub model: PolytopicModel,
    /// The state bound used, for the report.
    pub state_bound: StateBoundInfo,
    /// The output route used, for the report.
    pub output_route: OutputRouteInfo,
}

impl ObserverModel {
    /// Builds the observer's model of `plant`: state bound (given, computed
    /// or a verified claim, see [`StateBoundClaim`]), then the output route,
    /// then the split, then the skew slack. Fails with the reason when the
    /// model is inconsistent, a claimed Q does not hold for the model as it
    /// is now, or the skew slack does not fit.
    pub fn prepare(
        plant: &PolytopicModel,
        options: &ObserverOptions<'_>,
        bound: StateBoundClaim<'_>,
    ) -> Result<ObserverModel, SolveError> {
        validate(plant)?;
        super::jacobian::refuse_unsupported(plant, options.output_route, options.skew.is_some())?;
        // An LPV plant written without a region: the global observer's
        // model (region {0}, whose one pair carries the linear block).
        let global = super::global_model(plant);
        let plant = if plant.region.is_none() {
            &*global
        } else {
            plant
        };
        let (resolved, state_bound) = match (&plant.state_bound, bound) {
            (StateBound::Auto { .. }, StateBoundClaim::Claimed(claim)) => {
                verify_claim(plant, claim)?
            }
            (_, StateBoundClaim::Compute(settings)) => state_bound::resolve(plant, settings)?,
            // A given Q (or none) is the model's own: nothing to compute.
            (_, StateBoundClaim::Claimed(_)) => state_bound::resolve(plant, &Settings::default())?,
        };
        let (routed, output_route) = output_filter::apply(&resolved, options.output_route)?;
        let split = routed.with_split(options.split);
        let model = match options.skew {
            Some(k) => {
                check_skew(&split, k)?;
                with_skew(&split, k)
            }
            None => split,
        };
        let model = super::jacobian::expand(model, None)?;
        Ok(ObserverModel {
            plant: resolved,
            model,
            state_bound,
            output_route,
        })
    }

    /// The observer's model with a skew slack K_{k,l} added to N_k (checked
    /// like the one of [`ObserverOptions::skew`]).
    pub fn with_skew(&self, k: &[Vec<DMatrix<f64>>]) -> Result<PolytopicModel, SolveError> {
        check_skew(&self.model, k)?;
        Ok(with_skew(&self.model, k))
    }
}

/// Largest size of a skew slack against N: beyond it, N + K loses N's
/// digits to rounding (ulp(K) ≈ ‖N‖), and the certificate would judge a
/// plant other than the model's.
const SKEW_SIZE_LIMIT: f64 = 1e6;

/// One skew-symmetric nx × nx matrix per state and θ-vertex. A slack read
/// from a file may change the representation of N_k, never the plant:
/// its symmetric part (which would change xᵀN_k x) must vanish to rounding
/// *judged against the size of N at that vertex*, not of K (a tolerance
/// that grows with K lets a huge skew part hide a symmetric part that
/// cancels N), and K may not be so large that N + K rounds N away.
fn check_skew(model: &PolytopicModel, k: &[Vec<DMatrix<f64>>]) -> Result<(), SolveError> {
    let n = model.nx();
    let shaped = k.len() == model.nv()
        && k.iter().all(|kl| {
            kl.len() == n
                && kl
                    .iter()
                    .all(|kk| kk.shape() == (n, n) && kk.iter().all(|v| v.is_finite()))
        });
    if !shaped {
        return Err(SolveError::Dimensions(format!(
            "the skew slack must hold one skew-symmetric {n}×{n} matrix of finite numbers per \
             state and θ-vertex"
        )));
    }
    for (l, (kl, v)) in k.iter().zip(&model.vertices).enumerate() {
        let nmax = v.n.iter().map(|m| m.amax()).fold(0.0, f64::max);
        for (s, kk) in kl.iter().enumerate() {
            let sym = ((kk + kk.transpose()) * 0.5).amax();
            if sym > 1e-12 * (1.0 + nmax) {
                return Err(SolveError::Dimensions(format!(
                    "the skew slack K_{} at θ-vertex {} is not skew-symmetric: its symmetric part \
                     (largest entry {sym:.3e}) would change the plant (N at this vertex has \
                     entries up to {nmax:.3e}); a slack may only change how N is written",
                    s + 1,
                    l + 1
                )));
            }
            if kk.amax() > SKEW_SIZE_LIMIT * (1.0 + nmax) {
                return Err(SolveError::Dimensions(format!(
                    "the skew slack K_{} at θ-vertex {} is too large (largest entry {:.3e}, N has \
                     entries up to {nmax:.3e}): N + K would lose N's digits to rounding",
                    s + 1,
                    l + 1,
                    kk.amax()
                )));
            }
        }
    }
    Ok(())
}

/// Refuses a claimed state bound with the reason.
fn refuse(what: String) -> SolveError {
    SolveError::StateBound(format!(
        "the given Q is refused for the model as it is now: {what}"
    ))
}

/// Checks a claimed Q (shape, finite, symmetric, positive definite, not
/// badly scaled, a state count the invariance check takes) and returns
/// W = Q⁻¹, symmetrised.
fn claimed_metric(q: &DMatrix<f64>, nx: usize) -> Result<DMatrix<f64>, SolveError> {
    if q.shape() != (nx, nx) {
        return Err(refuse(format!(
            "Q is {:?}, expected ({nx}, {nx})",
            q.shape()
        )));
    }
    if !q.iter().all(|v| v.is_finite()) {
        return Err(refuse("Q has non-finite entries".into()));
    }
    let asym = (q - q.transpose()).norm();
    if asym > 1e-12 * q.norm() {
        return Err(refuse(format!(
            "Q is not symmetric (‖Q − Qᵀ‖_F = {asym:.3e})"
        )));
    }
    let eig = q.clone().symmetric_eigenvalues();
    let (lmin, lmax) = eig
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if lmin.is_nan() || lmin <= 0.0 {
        return Err(refuse(format!(
            "Q is not positive definite (smallest eigenvalue {lmin:.3e})"
        )));
    }
    if lmax / lmin > MAX_Q_CONDITION {
        return Err(refuse(format!(
            "Q is badly scaled (eigenvalues from {lmin:.3e} to {lmax:.3e}, condition number \
             {:.3e} > {MAX_Q_CONDITION:.0e})",
            lmax / lmin
        )));
    }
    if nx > state_bound::MAX_STATES {
        return Err(refuse(format!(
            "its invariance can be checked for at most {} states",
            state_bound::MAX_STATES
        )));
    }
    let Some(w) = q.clone().cholesky().map(|c| c.inverse()) else {
        return Err(refuse(
            "Q is not positive definite (no Cholesky factor)".into(),
        ));
    };
    Ok((&w + w.transpose()) * 0.5)
}

/// The refusal of a claimed Q whose state-bound check failed, naming every
/// part that failed.
fn refused_check(chk: &BoundCheck, h: f64) -> SolveError {
    let mut why = Vec::new();
    if chk.region.is_nan() || chk.region > 1.0 {
        why.push(format!(
            "the region is not inside F (max_i x_(i)ᵀ Q⁻¹ x_(i) = {:.4} > 1)",
            chk.region
        ));
    }
    if chk.in_box.is_nan() || chk.in_box > 1.0 {
        why.push(format!(
            "F is not inside its box h·B with h = {h:.4e} (max_j Q_jj/(h β_j)² = {:.4} > 1)",
            chk.in_box
        ));
    }
    if chk.invariance.is_nan() || chk.invariance >= 0.0 {
        why.push(format!(
            "F is not invariant for the plant (max λ(He{{W(A_l + rows(N_l, v))}})/‖W‖ = {:.3e} ≥ 0 on h·B)",
            chk.invariance
        ));
    }
    if why.is_empty() {
        why.push("the state-bound check failed".into());
    }
    refuse(why.join("; "))
}

/// Verifies a claimed Q for a `state_bound auto` model (module doc) and
/// returns the model with Q given and the report's record of it.
fn verify_claim(
    plant: &PolytopicModel,
    claim: &ClaimedBound,
) -> Result<(PolytopicModel, StateBoundInfo), SolveError> {
    let nx = plant.nx();
    let q = &claim.q;
    let w = claimed_metric(q, nx)?;
    let h = match claim.h {
        Some(h) => h,
        None => {
            // the smallest box h·B containing F (B scaled as the state-bound search does)
            let shape = state_bound::box_shape(plant);
            (0..nx)
                .map(|j| q[(j, j)].sqrt() / shape[j])
                .fold(0.0, f64::max)
                * (1.0 + 1e-9)
        }
    };
    let splits = match claim.split {
        Some(s) => vec![s],
        None => vec![Split::Symmetric, Split::AsWritten],
    };
    let mut checked: Option<(Split, BoundCheck)> = None;
    for split in splits {
        let chk = state_bound::check(&plant.with_split(split), &w, h);
        let better = checked
            .as_ref()
            .map_or(true, |(_, c)| chk.passed || chk.invariance < c.invariance);
        if better {
            checked = Some((split, chk));
        }
        if checked.as_ref().is_some_and(|(_, c)| c.passed) {
            break;
        }
    }
    let (split, chk) = checked.expect("at least one split is checked");
    if !chk.passed {
        return Err(refused_check(&chk, h));
    }
    let mut out = plant.clone();
    out.state_bound = StateBound::Given(q.clone());
    let info = StateBoundInfo {
        source: BoundSource::Auto,
        q: Some(crate::linalg::matrix_to_rows(q)),
        h: Some(h),
        h_fixed: false,
        gamma_max: Some(gamma_max_for(plant, q)),
        gamma_upper: None,
        split: Some(split),
        check: Some(chk),
        solves: 0,
        seconds: 0.0,
        notes: vec![
            "Q was given (not computed) and verified against the model: positive definite, the region inside F, F inside h·B and invariant".into(),
        ],
    };
    Ok((out, info))
}
