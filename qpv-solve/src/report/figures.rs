//! The figures a certified design carries beside its gains: the noise bound
//! on the model's channels and the sampling figures, computed on its observer
//! model.

use crate::certificate::noise::noise_bound_or_why;
use crate::model::noise::NoiseChannels;
use crate::report::{Design, Note};
use qpv_dsl::PolytopicModel;

/// The channels to use on a design's observer model: `channels` as given
/// for the double-sum route, mapped through the filter for the filter route
/// ([`NoiseChannels::through_filter`]).
pub(crate) fn channels_on_observer(
    plant: &PolytopicModel,
    design: &Design,
    channels: &NoiseChannels,
) -> NoiseChannels {
    match design.output_route.as_ref().and_then(|r| r.filter.as_ref()) {
        Some(f) => channels.through_filter(plant.nx(), plant.ny(), plant.nv(), f.gain),
        None => channels.clone(),
    }
}

/// Adds the noise bound (on the model's channels,
/// [`NoiseChannels::from_model`]) and the
/// sampling figures ([`crate::certificate::sampling`]) to a certified sound-mode design,
/// computed on its observer model; leaves other designs untouched. Nothing
/// is added that its check did not pass; a missing noise bound is said
/// with its reason ([`Note::NoNoiseBound`], [`no_noise_bound`]).
pub fn attach(plant: &PolytopicModel, design: &mut Design) {
    if !design.certifies() {
        return;
    }
    let Ok(obs) = design.observer_model(plant) else {
        return;
    };
    // Both figures check every region-vertex pair; a cube design exists
    // to avoid that, so above the size the automatic choice solves
    // exactly they are left out (and said so).
    let pairs = obs.nv() * obs.region.vertices.len().pow(2);
    if design.conditions == qpv_dsl::Conditions::Cube
        && pairs > crate::model::size::AUTO_FULL_BLOCKS
    {
        design.notes.push(format!(
            "the noise bound and the sampling figures are not computed for this cube design: they check all {pairs} vertex-pair blocks"
        ));
        return;
    }
    let channels = channels_on_observer(plant, design, &NoiseChannels::from_model(plant));
    let (p, l) = (design.p_matrix(), design.l_matrices());
    // Why a certified design carries no noise bound is said once (the
    // figures are attached again when a design is baked or re-checked).
    design
        .notes
        .0
        .retain(|n| !matches!(n, Note::NoNoiseBound(_)));
    design.noise = match noise_bound_or_why(&obs, &channels, design.alpha, design.gamma, &p, &l) {
        Ok(nb) => Some(nb),
        Err(why) => {
            let note = Note::NoNoiseBound(why);
            if !design.notes.contains(&note) {
                design.notes.push(note);
            }
            None
        }
    };
    design.sampling =
        crate::certificate::sampling::sampling(&obs, design.alpha, design.gamma, &p, &l);
}

/// Why a certified design carries no noise bound, when its figures said
/// so ([`Note::NoNoiseBound`]; also read back from a report's notes).
pub fn no_noise_bound(design: &Design) -> Option<String> {
    if design.noise.is_some() {
        return None;
    }
    design.notes.iter().find_map(|n| match n {
        Note::NoNoiseBound(why) => Some(why.clone()),
        Note::Text(t) => t
            .strip_prefix("no noise bound is certified: ")
            .and_then(|rest| rest.strip_suffix(crate::report::NOISE_MIN_ADVICE))
            .and_then(|rest| rest.strip_suffix("; "))
            .map(str::to_string),
        _ => None,
    })
}
