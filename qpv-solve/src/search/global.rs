//! The global observer of an LPV plant ([`crate::model::ObserverKind::Global`],
//! docs/method.md §17): its fixed-α retry in the model's own units, its
//! α = max searched twice, and the knee of its α–gain curve. Its request
//! (γ fixed and unused, the full family) and its balanced units (pilot
//! solves) are the setup's ([`super::setup`]); the regional driver
//! ([`super::driver`]) runs its searches.

use super::design_plain;
use super::driver::design_plain_with;
use crate::error::SolveError;
use crate::report::{Design, Note, SearchStep};
use crate::settings::Settings;
use qpv_dsl::{AlphaSpec, DesignRequest, PolytopicModel};
use std::time::Instant;

/// The global observer's design ([`super::design_with_progress`] for an
/// LPV plant in sound mode, [`crate::model::ObserverKind::Global`]): a fixed α solved in
/// the pilots' balanced units and, if that does not certify, once more in
/// the model's own; α = max searched twice (the second time in the units
/// of the first result's P) and, unless the request already limits the
/// gain, the knee of the α–gain curve ([`knee`]).
pub(super) fn design(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
) -> Result<Design, SolveError> {
    if request.alpha != AlphaSpec::Max {
        let first = design_plain_with(model, request, settings, progress, None)?;
        if first.certifies() {
            return Ok(first);
        }
        // The units the pilots balanced by need not suit the request (near
        // the plant's own decay the gain-objective pilot's P is
        // degenerate): once more in the model's own units (D = I).
        let own = nalgebra::DMatrix::identity(model.nx(), model.nx());
        let mut second = design_plain_with(model, request, settings, progress, Some(&own))?;
        if !second.certifies() {
            return Ok(first);
        }
        second
            .notes
            .0
            .retain(|n| !matches!(n, Note::BalancedUnits { .. }));
        second.notes.push(format!(
            "the design in the pilots' balanced units did not certify ({} solver calls); solved again in the model's own units",
            first.search.len()
        ));
        return Ok(second);
    }
    // The global α = max: the units the first search balanced by (a pilot
    // at a small α) need not suit its result, so the search runs once
    // more in the units of the P it certified, and the better design is
    // kept.
    let t0 = Instant::now();
    let first = design_plain_with(model, request, settings, progress, None)?;
    if !first.certifies() {
        return Ok(first);
    }
    let hint = first.p_matrix();
    let second = design_plain_with(model, request, settings, progress, Some(&hint))?;
    let (n1, n2) = (first.search.len(), second.search.len());
    // The search log holds every solver call of the request: the other
    // search's calls first, then the kept one's.
    let (mut out, other) = if second.certifies() && second.alpha >= first.alpha {
        (second, first)
    } else {
        (first, second)
    };
    out.search.splice(0..0, other.search);
    out.notes.push(format!(
        "global α = max: searched twice, the second time in the units of the first result's P ({n1} + {n2} solver calls, all in the search log)"
    ));
    // A gain bound, a pole region (a disk bounds the gain) or a sample
    // period (h‖LC‖ must stay small) already limit the gain.
    let limited = request.max_gain.is_some() || !request.poles.is_empty();
    if request.within > 0.0 && !limited && request.sample.is_none() {
        out = knee(model, request, settings, progress, out)?;
    }
    out.seconds_total = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// Bisection steps in ln α for the global knee.
const KNEE_STEPS: usize = 8;

/// The practical α = max of the global observer (docs/method.md §17, "High
/// gain and the knee"): an observable LPV plant reaches any α with large
/// enough gains, so its α–gain curve has no supremum of its own and the
/// search stops where the numerics do. With g(α) the largest gain of the
/// smallest-gain design at α and α_ref = α_t/KNEE_FACTOR² (a rate a hundred
/// times slower), the design at α_t is *high gain* if g(α_t) >
/// KNEE_FACTOR³·g(α_ref) (faster than linear growth over those two decades:
/// the high-gain regime), g(α_ref) taken at least ‖A_l‖₂/‖C_l‖₂. Then the design returned is the knee: the fastest
/// α in [α_ref, α_t] with g(α) ≤ KNEE_FACTOR·g(α_ref), by bisection in ln α.
/// Otherwise `design` is returned unchanged.
fn knee(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    progress: &mut dyn FnMut(&SearchStep),
    design: Design,
) -> Result<Design, SolveError> {
    use super::practical::KNEE_FACTOR;
    let (Some(mut info), true) = (design.practical.clone(), design.certifies()) else {
        return Ok(design);
    };
    let gain = Design::max_gain_norm;
    let mut solves = 0;
    let mut log = design.search.clone();
    let mut at = |a: f64| -> Result<Option<Design>, SolveError> {
        let fixed = DesignRequest {
            alpha: AlphaSpec::Fixed(a),
            ..request.clone()
        };
        let d = design_plain(model, &fixed, settings, progress)?;
        solves += d.search.len();
        log.extend(d.search.iter().cloned());
        Ok(d.certifies().then_some(d))
    };
    let (alpha_t, g_t) = (design.alpha, gain(&design));
    let alpha_ref = alpha_t / KNEE_FACTOR.powi(2);
    let Some(reference) = at(alpha_ref)? else {
        return Ok(Design {
            search: log,
            ..design
        });
    };
    // Not below a gain of the plant's own size, ‖A_l‖₂/‖C_l‖₂: a reference
    // in the gain-free range (α below the plant's own decay) says nothing.
    let own = model.vertices.iter().map(|v| {
        let c = crate::linalg::norm2(&v.c);
        crate::linalg::norm2(&v.a) / c.max(f64::MIN_POSITIVE)
    });
    let g_ref = gain(&reference).max(own.fold(0.0, f64::max));
    if g_t <= KNEE_FACTOR.powi(3) * g_ref {
        return Ok(Design {
            search: log,
            ..design
        });
    }
    let (mut lo, mut hi, mut knee) = (alpha_ref, alpha_t, reference);
    for _ in 0..KNEE_STEPS {
        let mid = (lo * hi).sqrt();
        match at(mid)? {
            Some(d) if gain(&d) <= KNEE_FACTOR * g_ref => {
                lo = mid;
                knee = d;
            }
            _ => hi = mid,
        }
    }
    info.high_gain = true;
    info.solves += solves;
    // The α = max search's notes, but the units the returned design was
    // solved in are its own.
    let units = |n: &Note| matches!(n, Note::BalancedUnits { .. });
    let mut notes = design.notes.clone();
    notes.0.retain(|n| !units(n));
    notes
        .0
        .extend(knee.notes.0.iter().filter(|n| units(n)).cloned());
    notes.push(format!(
        "high gain: the global observer reaches α = {alpha_t:.6} only with max ‖L_l‖₂ = {g_t:.4e}, {:.1e} times the gain at α = {alpha_ref:.6} ({g_ref:.4e}); returned the knee of the α–gain curve, the fastest α with at most {KNEE_FACTOR} times that gain: α = {:.6}, max ‖L_l‖₂ = {:.4e} ({solves} more solver calls). On an LPV plant any α is reachable with gain enough: `max_gain = G` or a sample period sets the real limit (docs/method.md §17)",
        g_t / g_ref.max(f64::MIN_POSITIVE),
        knee.alpha,
        gain(&knee)
    ));
    let mut out = knee;
    // every solver call of the request, in the order made
    out.search = log;
    out.summary = format!(
        "{} (high gain: the knee of the α–gain curve, α_sup = {:.6})",
        out.summary, info.alpha_sup
    );
    out.practical = Some(info);
    out.notes = notes;
    Ok(out)
}
