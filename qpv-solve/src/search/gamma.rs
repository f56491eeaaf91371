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
//! The caller then solves the best γ to the full tolerance. [`maximise`]
//! only sees a function γ ↦ α (0 when nothing certifies), so it is tested
//! on functions with known maxima.

use crate::report::{GammaSearchInfo, LocalMax};
use crate::settings::Settings;
use crate::vocab::Phase;

/// Most extra grid steps below γ_hi / span when α still grows there.
pub const MAX_EXTENSION: usize = 6;

/// A refinement may take up to this many times its planned evaluations...
const EXTRA_REFINE: usize = 3;
/// ... while the last `GAIN_WINDOW` evaluations ...
const GAIN_WINDOW: usize = 2;
/// ... raised the best by more than this (relative).
const REFINE_GAIN: f64 = 0.005;

/// The continuation's first step: γ × this.
const CONTINUATION_STEP: f64 = 0.9;
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
        let n = self.points.max(2);
        let (a, b) = (self.lo.ln(), self.hi.ln());
        (0..n)
            .map(|k| {
                if k + 1 == n {
                    self.hi
                } else {
                    (a + (b - a) * k as f64 / (n - 1) as f64).exp()
                }
            })
            .collect()
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

/// Evaluated points (γ, α), kept sorted by γ.
struct Samples(Vec<(f64, f64)>);

impl Samples {
    fn insert(&mut self, g: f64, a: f64) {
        let k = self.0.partition_point(|&(x, _)| x < g);
        self.0.insert(k, (g, a));
    }
    fn get(&self, g: f64) -> Option<f64> {
        self.0
            .iter()
            .find(|(x, _)| (x - g).abs() <= 1e-12 * g)
            .map(|&(_, a)| a)
    }
    fn best(&self) -> (f64, f64) {
        self.0
            .iter()
            .copied()
            .fold((0.0, 0.0), |b, p| if p.1 > b.1 { p } else { b })
    }
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
pub fn maximise_until<E>(
    plan: &GammaPlan,
    eval: &mut dyn FnMut(f64, Phase) -> Result<f64, E>,
    stop: &dyn Fn() -> bool,
) -> Result<GammaOutcome, E> {
    let mut samples = Samples(Vec::new());
    let mut value = |g: f64, phase: Phase, s: &mut Samples| -> Result<f64, E> {
        if let Some(a) = s.get(g) {
            return Ok(a);
        }
        let a = eval(g, phase)?;
        s.insert(g, a);
        Ok(a)
    };
    let mut grid = plan.grid();
    for &g in grid.iter().rev() {
        value(g, Phase::Grid, &mut samples)?;
    }
    // Extend downwards while the lowest point is the best and still rising.
    let step = (grid[1] / grid[0]).max(1.0 + 1e-9);
    for _ in 0..MAX_EXTENSION {
        let (bg, ba) = samples.best();
        if ba <= 0.0 || bg > grid[0] {
            break;
        }
        let g = grid[0] / step;
        let a = value(g, Phase::Grid, &mut samples)?;
        grid.insert(0, g);
        if a <= ba {
            break;
        }
    }
    let vals: Vec<f64> = grid
        .iter()
        .map(|&g| samples.get(g).unwrap_or(0.0))
        .collect();
    let best_grid = vals.iter().copied().fold(0.0, f64::max);
    // Local maxima of the grid values, best first.
    let mut peaks: Vec<usize> = (0..grid.len())
        .filter(|&k| {
            vals[k] > 0.0
                && (k == 0 || vals[k] >= vals[k - 1])
                && (k + 1 == grid.len() || vals[k] > vals[k + 1])
        })
        .collect();
    peaks.sort_by(|&a, &b| vals[b].total_cmp(&vals[a]));
    let mut local = Vec::new();
    for &k in &peaks {
        let refined = vals[k] >= plan.reach * best_grid && plan.refine > 0;
        let (mut g, mut a) = (grid[k], vals[k]);
        if refined {
            let lo = grid[k.saturating_sub(1)];
            let hi = grid[(k + 1).min(grid.len() - 1)];
            (g, a) = golden(lo, grid[k], hi, vals[k], plan.refine, &mut |x| {
                value(x, Phase::Refine, &mut samples)
            })?;
        }
        local.push(LocalMax {
            gamma: g,
            alpha: a,
            refined,
        });
    }
    let before = samples.best();
    let (continued, walk, still_rising) =
        continue_down(&mut samples, &mut |x, s| value(x, Phase::Continue, s), stop)?;
    let (gamma, alpha) = samples.best();
    if continued > 0 && alpha > before.1 {
        // The walk moved the best local maximum: report where it ended (the
        // refinement's γ may differ from the sample's by rounding in ln γ).
        if let Some(m) = local
            .iter_mut()
            .find(|m| (m.gamma - before.0).abs() <= 1e-9 * before.0)
        {
            (m.gamma, m.alpha) = (gamma, alpha);
        }
        local.sort_by(|x, y| y.alpha.total_cmp(&x.alpha));
    }
    Ok(GammaOutcome {
        gamma,
        alpha,
        info: GammaSearchInfo {
            gamma_lo: grid[0].min(gamma),
            gamma_hi: plan.hi,
            grid_points: grid.len(),
            points: samples.0.len(),
            solves: 0,
            local_maxima: local,
            continued,
        },
        walk,
        still_rising,
    })
}

/// The walk's evaluations, path and whether α was still rising at its end.
type Walk = (usize, Vec<(f64, f64)>, bool);

/// Step 4 of the search (module doc): from the best point, while the point
/// evaluated just below it certified nothing (or there is none), walks down
/// in ln γ. Returns the number of evaluations made (0 when the best point
/// is not at a cliff, or nothing certified anywhere), the walk's path (its
/// start, then every point taken) and whether it ended with α still
/// rising (not because α fell below a point).
fn continue_down<E>(
    samples: &mut Samples,
    value: &mut dyn FnMut(f64, &mut Samples) -> Result<f64, E>,
    stop: &dyn Fn() -> bool,
) -> Result<Walk, E> {
    let (mut g, mut a) = samples.best();
    let below = samples.0.iter().rev().find(|&&(x, _)| x < g).map(|p| p.1);
    if a <= 0.0 || below.is_some_and(|b| b > 0.0) {
        return Ok((0, Vec::new(), false));
    }
    let mut path = vec![(g, a)];
    let mut rho = CONTINUATION_STEP;
    let mut evals = 0;
    let mut rising = true;
    while evals < MAX_CONTINUATION && rho < 1.0 - REFINE_GAIN && !stop() {
        let x = g * rho;
        let ax = value(x, samples)?;
        evals += 1;
        if ax > a {
            (g, a) = (x, ax);
            path.push((g, a));
            // A longer step next, as long as steps certify.
            rho = rho.powf(1.25);
        } else if ax > 0.0 {
            rising = false;
            break; // α falls again below x: the peak lies behind.
        } else {
            rho = rho.sqrt();
        }
    }
    let rising = rising && path.len() > 1;
    Ok((evals, path, rising))
}

/// Golden-section steps in ln γ from the bracket lo ≤ mid ≤ hi (mid the
/// best so far, value `f_mid`): each evaluation probes the larger side of
/// mid at the golden ratio and shrinks the bracket. At least `evals`
/// evaluations, and up to [`EXTRA_REFINE`] times as many while the last
/// [`GAIN_WINDOW`] raised the best by more than [`REFINE_GAIN`] (sharp
/// peaks, as where α_max(γ) ∝ 1/γ ends abruptly at small γ). Returns the
/// best (γ, α) seen.
fn golden<E>(
    lo: f64,
    mid: f64,
    hi: f64,
    f_mid: f64,
    evals: usize,
    f: &mut dyn FnMut(f64) -> Result<f64, E>,
) -> Result<(f64, f64), E> {
    const W: f64 = 0.381_966_011_250_105_1; // 2 − φ
    let (mut a, mut b, mut c) = (lo.ln(), mid.ln(), hi.ln());
    let mut fb = f_mid;
    let mut history = vec![fb];
    for n in 0..evals * EXTRA_REFINE {
        if c - a < 1e-6 {
            break;
        }
        if n >= evals {
            let k = history.len();
            let old = history[k.saturating_sub(GAIN_WINDOW + 1)];
            if fb <= old * (1.0 + REFINE_GAIN) {
                break;
            }
        }
        let right = c - b >= b - a;
        let x = if right {
            b + W * (c - b)
        } else {
            b - W * (b - a)
        };
        let fx = f(x.exp())?;
        if fx > fb {
            // x is the new middle; b bounds it on one side.
            if right {
                a = b;
            } else {
                c = b;
            }
            b = x;
            fb = fx;
        } else if right {
            c = x;
        } else {
            a = x;
        }
        history.push(fb);
    }
    Ok((b.exp(), fb))
}
