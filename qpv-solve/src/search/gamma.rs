//! The γ search's strategy, apart from the solver: which γ to evaluate,
//! in which order, and which local maxima to refine.
//!
//! α_max(γ) need not be unimodal (docs/method.md, the search section), so
//! the search does not trust one bracket:
//!
//! 1. a logarithmic grid of [`GammaPlan::grid`] points over
//!    [γ_hi / span, γ_hi], visited from the top; every point gets an
//!    *exact* value (the α search to a coarse relative tolerance, so a point
//!    is never ranked, kept or discarded on an estimate);
//! 2. if the lowest grid point is the best, the grid is extended downwards
//!    (a grid step at a time, at most [`MAX_EXTENSION`] steps) while α still
//!    grows;
//! 3. every local maximum of the grid values that is within reach of the
//!    best (α ≥ reach · best) is refined by golden-section steps in ln γ
//!    inside the bracket of its two grid neighbours; local maxima out of
//!    reach are recorded, not refined;
//! 4. if the best point's lower neighbour certified nothing (a cliff:
//!    α_max(γ) often grows as γ falls until the solver's search from
//!    scratch fails, while a solve seeded by the best point's P still
//!    certifies a little further down), the search walks down from the best
//!    point in steps of ln γ: a step that certifies more is taken (and the
//!    next one made longer), one that certifies nothing is halved (a longer
//!    step after a success may probe below a γ that already failed: seeds
//!    have changed since), one that certifies less ends the walk (the peak
//!    is behind it), as does a step below 0.5 % in γ or
//!    [`MAX_CONTINUATION`] evaluations.
//!
//! The caller then solves the best γ to the full tolerance. The search is
//! [`crate::line_search`]'s, configured here; [`maximise`] only sees a
//! function γ ↦ α (0 when nothing certifies), so it is tested on functions
//! with known maxima.

use crate::line_search::{Line, Peaks, Scale, Stage};
use crate::report::{GammaSearchInfo, LocalMax};
use crate::settings::Settings;
use crate::vocab::Phase;

/// Most extra grid steps below γ_hi / span when α still grows there.
pub const MAX_EXTENSION: usize = 6;

/// Most evaluations of the continuation below a cliff (step 4 of the
/// search), so that a plant whose α grows without end as γ falls stops.
pub const MAX_CONTINUATION: usize = 30;

/// The range and effort of one γ search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GammaPlan {
    /// Lowest grid point.
    pub lo: f64,
    /// Highest grid point (γ_hi).
    pub hi: f64,
    /// Number of grid points (at least 2).
    pub points: usize,
    /// Golden-section evaluations per refined local maximum.
    pub refine: usize,
    /// Local maxima with α ≥ reach · best are refined.
    pub reach: f64,
}

impl GammaPlan {
    /// The plan of [`Settings`] ([`Settings::gamma_grid`],
    /// [`Settings::gamma_span`], [`Settings::gamma_refine`],
    /// [`Settings::gamma_reach`]) below `hi`.
    pub fn from_settings(hi: f64, settings: &Settings) -> GammaPlan {
        GammaPlan {
            lo: hi / settings.gamma_span.max(1.0),
            hi,
            points: settings.gamma_grid.max(2),
            refine: settings.gamma_refine,
            reach: settings.gamma_reach.clamp(0.0, 1.0),
        }
    }

    /// The grid, ascending: `points` values log-spaced from `lo` to `hi`.
    pub fn grid(&self) -> Vec<f64> {
        Scale::Log.grid(self.lo, self.hi, self.points)
    }

    /// The search of the module doc: top down, extended downwards,
    /// every local maximum within reach refined (with extra steps on
    /// sharp peaks), then the walk below a cliff.
    fn line(&self) -> Line {
        Line {
            scale: Scale::Log,
            descending: true,
            extend: MAX_EXTENSION,
            refine: self.refine,
            extra: true,
            peaks: Peaks::Within(self.reach),
            walk: MAX_CONTINUATION,
            ..Line::default()
        }
    }
}

/// What [`maximise`] found: the best γ and its α (both 0 when nothing
/// certified anywhere), and the statement of what was searched.
#[derive(Debug, Clone, PartialEq)]
pub struct GammaOutcome {
    /// The γ of the best value.
    pub gamma: f64,
    /// The best value (α at `gamma`, to the evaluation's tolerance).
    pub alpha: f64,
    /// The searched range, point counts and local maxima.
    pub info: GammaSearchInfo,
    /// The walk below a cliff (step 4): the best point before it, then
    /// every point it took, in order (empty when there was no walk).
    pub walk: Vec<(f64, f64)>,
    /// The walk ended with α still rising (by its evaluation or step
    /// limit, not because α fell): the supremum lies at smaller γ still.
    pub still_rising: bool,
}

/// Maximises γ ↦ `eval(γ, phase)` over the plan (module doc). `eval`
/// returns the largest certified α at γ (0 if none); each γ is evaluated
/// at most once.
pub fn maximise<E>(
    plan: &GammaPlan,
    eval: &mut dyn FnMut(f64, Phase) -> Result<f64, E>,
) -> Result<GammaOutcome, E> {
    maximise_until(plan, eval, &|| false)
}

/// [`maximise`], with a walk below a cliff (step 4) that also ends when
/// `stop` says so (checked before each of its evaluations): the practical
/// α = max ends it once the gains have exploded.
pub(crate) fn maximise_until<E>(
    plan: &GammaPlan,
    eval: &mut dyn FnMut(f64, Phase) -> Result<f64, E>,
    stop: &dyn Fn() -> bool,
) -> Result<GammaOutcome, E> {
    let mut alpha_at = |g: f64, stage: Stage| {
        let phase = match stage {
            Stage::Grid => Phase::Grid,
            Stage::Refine => Phase::Refine,
            Stage::Walk => Phase::Continue,
        };
        eval(g, phase).map(|a| (a > 0.0).then_some(a))
    };
    let found = plan.line().maximise(&plan.grid(), &mut alpha_at, stop)?;
    let (gamma, alpha) = found.best.unwrap_or((0.0, 0.0));
    Ok(GammaOutcome {
        gamma,
        alpha,
        info: GammaSearchInfo {
            gamma_lo: found.grid[0].min(gamma),
            gamma_hi: plan.hi,
            grid_points: found.grid.len(),
            points: found.samples.len(),
            solves: 0,
            local_maxima: found
                .peaks
                .iter()
                .map(|m| LocalMax {
                    gamma: m.x,
                    alpha: m.f,
                    refined: m.refined,
                })
                .collect(),
            continued: found.walked,
        },
        walk: found.walk,
        still_rising: found.still_rising,
    })
}
