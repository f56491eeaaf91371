//! What the region costs a QPV plant (docs/method.md §18, "The cost of the
//! region"): the α the linear part of the plant alone certifies (every N_k
//! and M_k dropped: an LPV plant, designed by the global observer of §17,
//! with no region, state bound or γ) next to the certified QPV α.

use super::design_plain;
use crate::error::SolveError;
use crate::report::Design;
use crate::settings::Settings;
use qpv_dsl::{AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, PolytopicModel, Split};

/// The relative tolerance of the linear part's α search (a comparison
/// figure, not a design: 1 % is enough).
const TOLERANCE: f64 = 1e-2;

/// The plant with every N_k and M_k set to zero at every θ-vertex.
pub fn linear_part(model: &PolytopicModel) -> PolytopicModel {
    let mut lin = model.clone();
    for v in &mut lin.vertices {
        v.n.iter_mut()
            .chain(v.m.iter_mut())
            .for_each(|m| m.fill(0.0));
    }
    lin
}

/// With [`Settings::region_cost`], for a certified continuous-time sound
/// design of a QPV plant: the
/// largest α the linear part certifies globally (`alpha = max` with
/// `within = 0` at a 1 % tolerance, no gain bound or pole regions), stored
/// in `d.linear_part_alpha`, and the same with the design's largest gain
/// as `max_gain` in `d.linear_part_alpha_at_gain`, with a note comparing
/// them with the design's α.
/// Nothing for LPV plants, uncertified or sampled designs, paper mode.
pub(super) fn attach(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    d: &mut Design,
) -> Result<(), SolveError> {
    let applies = settings.region_cost
        && d.certifies()
        && !d.global
        && request.mode == Mode::Sound
        && request.sample.is_none()
        && !model.is_lpv();
    if !applies {
        return Ok(());
    }
    let lin = linear_part(model);
    let req = DesignRequest {
        alpha: AlphaSpec::Max,
        gamma: GammaSpec::Search,
        split: Split::Symmetric,
        conditions: Conditions::Auto,
        within: 0.0,
        max_gain: None,
        poles: Vec::new(),
        ..request.clone()
    };
    let coarse = Settings {
        bisection_rel_tol: TOLERANCE,
        ..settings.clone()
    };
    let lin_d = design_plain(&lin, &req, &coarse, &mut |_| {})?;
    d.linear_part_alpha = lin_d.certifies().then_some(lin_d.alpha);
    // The same with the QPV design's largest gain as a bound: the linear
    // part's α is often reached only with unbounded gains.
    let gain = d.max_gain_norm();
    if gain.is_finite() && gain > 0.0 {
        let bounded = DesignRequest {
            max_gain: Some(gain),
            ..req
        };
        let b = design_plain(&lin, &bounded, &coarse, &mut |_| {})?;
        d.linear_part_alpha_at_gain = b.certifies().then_some(b.alpha);
    }
    let cap = |a: f64| {
        if a >= settings.alpha_cap * (1.0 - 1e-3) {
            " (the search's cap)"
        } else {
            ""
        }
    };
    let mut note = match d.linear_part_alpha {
        Some(a) => format!(
            "region cost: the linear part alone (N_k = M_k = 0, the global observer of docs/method.md §17) certifies α = {a:.6}{}; this QPV design certifies α = {:.6} ({:.1} % of it) on its region",
            cap(a),
            d.alpha,
            100.0 * d.alpha / a
        ),
        None => "region cost: the linear part alone (N_k = M_k = 0) certifies no α > 0 globally".to_string(),
    };
    if let Some(a) = d.linear_part_alpha_at_gain {
        note.push_str(&format!(
            "; with its gains bounded by this design's max ‖L_l‖₂ = {gain:.4e}, α = {a:.6} ({:.1} %)",
            100.0 * d.alpha / a
        ));
    }
    d.notes.push(note);
    Ok(())
}
