//! The one-dimensional search behind every search over a scalar: the γ
//! search of α (`search::gamma`), the noise-optimal design's γ, the
//! practical design's γ and the state bound's box size h (docs/method.md
//! §11, the α and γ search; §9, `state_bound auto`).
//!
//! A function x ↦ f(x) (None: nothing at x, e.g. nothing certified) is
//! maximised ([`Line::maximise`]) or minimised ([`Line::minimise`]):
//!
//! 1. every point of a grid is evaluated (from its top or its bottom);
//! 2. the grid may be extended below its lowest point, a grid step at a
//!    time, while that point is the best and the value still grows;
//! 3. the best local maximum of the grid values (or every one within reach
//!    of the best) is refined by golden-section steps inside the bracket of
//!    its two grid neighbours, in x or in ln x ([`Scale`]);
//! 4. if the point below the best found nothing (a cliff), a walk may step
//!    down from the best point: a step that finds more is taken (the next
//!    one longer), one that finds nothing is halved, one that finds less
//!    ends the walk.
//!
//! Each x is evaluated at most once; a goal value and a stop predicate end
//! the search early. The function is only seen through its values, so the
//! search is tested on functions with known extrema.

/// Most evaluations of a refinement: this many times its planned ones...
const EXTRA_REFINE: usize = 3;
/// ... while the last `GAIN_WINDOW` evaluations ...
const GAIN_WINDOW: usize = 2;
/// ... raised the best by more than this (relative); also the walk's
/// smallest step (1 − this).
const REFINE_GAIN: f64 = 0.005;
/// The walk's first step: x × this.
const WALK_STEP: f64 = 0.9;
/// 2 − φ: where a golden-section probe falls in the larger side.
const W: f64 = 0.381_966_011_250_105_1;

/// The coordinate the grid is spaced in and the golden-section steps are
/// taken in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// x itself.
    Linear,
    /// ln x (x > 0).
    Log,
}

impl Scale {
    fn to(self, x: f64) -> f64 {
        match self {
            Scale::Linear => x,
            Scale::Log => x.ln(),
        }
    }

    fn from(self, u: f64) -> f64 {
        match self {
            Scale::Linear => u,
            Scale::Log => u.exp(),
        }
    }

    /// `n` (at least 2) points evenly spaced in this scale from `lo` to
    /// `hi`, ascending; the last is `hi` exactly.
    pub fn grid(self, lo: f64, hi: f64, n: usize) -> Vec<f64> {
        let n = n.max(2);
        let (a, b) = (self.to(lo), self.to(hi));
        (0..n)
            .map(|k| {
                if k + 1 == n {
                    hi
                } else {
                    self.from(a + (b - a) * k as f64 / (n - 1) as f64)
                }
            })
            .collect()
    }

    /// The grid point one step (`x1` − `x0`, in this scale) below `x0`.
    fn step_below(self, x0: f64, x1: f64) -> f64 {
        match self {
            Scale::Linear => x0 - (x1 - x0),
            Scale::Log => x0 / (x1 / x0).max(1.0 + 1e-9),
        }
    }
}

/// Which stage of the search an evaluation belongs to (for the caller's
/// record of its solves).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// The grid and its extension.
    Grid,
    /// A golden-section refinement.
    Refine,
    /// The walk below a cliff.
    Walk,
}

/// Which local maxima of the grid values are refined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Peaks {
    /// The best one only.
    Best,
    /// Every one with f ≥ reach · best (a positive objective).
    Within(f64),
}

/// How a search runs (module doc); [`Line::default`] is a plain grid
/// with no refinement in ln x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// The coordinate of the golden-section steps (and the grid's
    /// extension).
    pub scale: Scale,
    /// The grid is evaluated from its top (true) or its bottom.
    pub descending: bool,
    /// Most grid steps added below the grid while its lowest point is the
    /// best and the value still grows (step 2; 0: none).
    pub extend: usize,
    /// Golden-section evaluations per refined local maximum (0: none).
    pub refine: usize,
    /// A refinement may take up to three times `refine`
    /// evaluations while its last two raised the best by more than 0.5 %
    /// (sharp peaks; a positive objective).
    pub extra: bool,
    /// Which local maxima are refined.
    pub peaks: Peaks,
    /// The lower end of the bracket of a local maximum at the grid's lowest
    /// point (None: that point itself).
    pub below: Option<f64>,
    /// The upper end of the bracket of a local maximum at the grid's
    /// highest point (None: that point itself).
    pub above: Option<f64>,
    /// The refinement ignores the grid point's value and starts at the
    /// bracket's golden point (the classic two-point start), instead of
    /// probing the larger side of the grid point.
    pub probe_first: bool,
    /// A refinement stops when its bracket is narrower than this (in the
    /// scale's coordinate).
    pub min_width: f64,
    /// The search stops once the best value reaches this.
    pub goal: Option<f64>,
    /// Most evaluations of the walk below a cliff (step 4; 0: no walk).
    pub walk: usize,
}

impl Default for Line {
    fn default() -> Self {
        Line {
            scale: Scale::Log,
            descending: false,
            extend: 0,
            refine: 0,
            extra: false,
            peaks: Peaks::Best,
            below: None,
            above: None,
            probe_first: false,
            min_width: 1e-6,
            goal: None,
            walk: 0,
        }
    }
}

/// A local maximum of the grid values (for a minimiser: a local minimum),
/// after its refinement if it had one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    /// Where the best value of its refinement lies.
    pub x: f64,
    /// That value.
    pub f: f64,
    /// Whether it was refined.
    pub refined: bool,
}

/// What a search found.
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    /// The best (x, f) evaluated (the lowest x among equal values); None
    /// when nothing was found anywhere.
    pub best: Option<(f64, f64)>,
    /// Every evaluation (x, f), ascending in x.
    pub samples: Vec<(f64, Option<f64>)>,
    /// The grid as evaluated, ascending (its extension included; a grid
    /// cut short by the goal or the stop predicate ends where it stopped).
    pub grid: Vec<f64>,
    /// The local maxima of the grid values, best first.
    pub peaks: Vec<Peak>,
    /// The walk below a cliff: its start, then every point it took (empty
    /// when there was no walk).
    pub walk: Vec<(f64, f64)>,
    /// Evaluations the walk made.
    pub walked: usize,
    /// The walk ended with the value still rising (by its evaluation limit
    /// or the stop predicate, not because the value fell).
    pub still_rising: bool,
}

/// The value memoised at x (relative tolerance 1e-12): Some(None) when x
/// was evaluated and found nothing.
fn find(samples: &[(f64, Option<f64>)], x: f64) -> Option<Option<f64>> {
    samples
        .iter()
        .find(|(s, _)| (s - x).abs() <= 1e-12 * x.abs())
        .map(|&(_, f)| f)
}

/// Orders "nothing" below every value.
fn rank(f: Option<f64>) -> f64 {
    f.unwrap_or(f64::NEG_INFINITY)
}

/// The evaluations of one search: memoised, sorted by x, with the goal
/// and the stop predicate.
struct Run<'a, E> {
    samples: Vec<(f64, Option<f64>)>,
    eval: &'a mut dyn FnMut(f64, Stage) -> Result<Option<f64>, E>,
    stop: &'a dyn Fn() -> bool,
    goal: Option<f64>,
}

impl<E> Run<'_, E> {
    fn value(&mut self, x: f64, stage: Stage) -> Result<Option<f64>, E> {
        if let Some(f) = find(&self.samples, x) {
            return Ok(f);
        }
        let f = (self.eval)(x, stage)?;
        let k = self.samples.partition_point(|&(s, _)| s < x);
        self.samples.insert(k, (x, f));
        Ok(f)
    }

    fn best(&self) -> Option<(f64, f64)> {
        self.samples
            .iter()
            .filter_map(|&(x, f)| f.map(|f| (x, f)))
            .fold(None, |b, p| match b {
                Some((_, bf)) if p.1 <= bf => b,
                _ => Some(p),
            })
    }

    /// The goal is reached or the caller says stop: no more evaluations.
    fn done(&self) -> bool {
        let reached = match (self.goal, self.best()) {
            (Some(g), Some((_, f))) => f >= g,
            _ => false,
        };
        reached || (self.stop)()
    }
}

impl Line {
    /// Maximises `eval` (None: nothing at x) over the grid `grid`
    /// (ascending, at least two points) as the module doc describes;
    /// `stop` is asked before every evaluation.
    pub fn maximise<E>(
        &self,
        grid: &[f64],
        eval: &mut dyn FnMut(f64, Stage) -> Result<Option<f64>, E>,
        stop: &dyn Fn() -> bool,
    ) -> Result<Found, E> {
        let mut run = Run {
            samples: Vec::new(),
            eval,
            stop,
            goal: self.goal,
        };
        let grid = self.grid(grid, &mut run)?;
        let mut peaks = self.refine_peaks(&grid, &mut run)?;
        let before = run.best();
        let walk = match before {
            Some(b) if self.walk > 0 => self.walk_down(b, &mut run)?,
            _ => Walk::default(),
        };
        let best = run.best();
        if let (Some(b), Some(now)) = (before, best) {
            if walk.evals > 0 && now.1 > b.1 {
                // The walk moved the best local maximum: it ends where the
                // walk ended (a refined x may differ from the sample's by
                // rounding in the scale's coordinate).
                if let Some(m) = peaks.iter_mut().find(|m| (m.x - b.0).abs() <= 1e-9 * b.0) {
                    (m.x, m.f) = now;
                }
                peaks.sort_by(|x, y| y.f.total_cmp(&x.f));
            }
        }
        Ok(Found {
            best,
            samples: run.samples,
            grid,
            peaks,
            walk: walk.path,
            walked: walk.evals,
            still_rising: walk.rising,
        })
    }

    /// Minimises `eval` as [`Line::maximise`] maximises −`eval`; the values
    /// found are `eval`'s own (the peaks are its local minima). `goal` and
    /// `extra` are for maximisers only.
    pub fn minimise<E>(
        &self,
        grid: &[f64],
        eval: &mut dyn FnMut(f64, Stage) -> Result<Option<f64>, E>,
        stop: &dyn Fn() -> bool,
    ) -> Result<Found, E> {
        let mut neg = |x: f64, s: Stage| eval(x, s).map(|f| f.map(|v| -v));
        let mut out = self.maximise(grid, &mut neg, stop)?;
        out.best = out.best.map(|(x, f)| (x, -f));
        for s in &mut out.samples {
            s.1 = s.1.map(|v| -v);
        }
        for p in &mut out.peaks {
            p.f = -p.f;
        }
        for w in &mut out.walk {
            w.1 = -w.1;
        }
        Ok(out)
    }

    /// Steps 1 and 2: the grid's values, then its extension downwards.
    /// Returns the grid as evaluated.
    fn grid<E>(&self, grid: &[f64], run: &mut Run<'_, E>) -> Result<Vec<f64>, E> {
        let order: Vec<f64> = if self.descending {
            grid.iter().rev().copied().collect()
        } else {
            grid.to_vec()
        };
        let mut done: Vec<f64> = Vec::with_capacity(grid.len());
        for x in order {
            if run.done() {
                break;
            }
            run.value(x, Stage::Grid)?;
            done.push(x);
        }
        done.sort_by(f64::total_cmp);
        if done.len() < grid.len() || grid.len() < 2 {
            return Ok(done);
        }
        let mut grid = done;
        for _ in 0..self.extend {
            let Some((bx, bf)) = run.best() else {
                break;
            };
            if bx > grid[0] || run.done() {
                break;
            }
            let x = self.scale.step_below(grid[0], grid[1]);
            let f = run.value(x, Stage::Grid)?;
            grid.insert(0, x);
            if rank(f) <= bf {
                break;
            }
        }
        Ok(grid)
    }

    /// Step 3: the local maxima of the grid values, best first, refined as
    /// the field `peaks` says.
    fn refine_peaks<E>(&self, grid: &[f64], run: &mut Run<'_, E>) -> Result<Vec<Peak>, E> {
        let vals: Vec<Option<f64>> = grid
            .iter()
            .map(|&x| find(&run.samples, x).flatten())
            .collect();
        let v = |k: usize| rank(vals[k]);
        let best = vals
            .iter()
            .flatten()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        let n = grid.len();
        let mut at: Vec<usize> = (0..n)
            .filter(|&k| {
                vals[k].is_some() && (k == 0 || v(k) >= v(k - 1)) && (k + 1 == n || v(k) > v(k + 1))
            })
            .collect();
        at.sort_by(|&a, &b| v(b).total_cmp(&v(a)));
        let mut peaks = Vec::with_capacity(at.len());
        for (i, &k) in at.iter().enumerate() {
            let refined = self.refine > 0
                && !run.done()
                && match self.peaks {
                    Peaks::Best => i == 0,
                    Peaks::Within(reach) => v(k) >= reach * best,
                };
            let (mut x, mut f) = (grid[k], v(k));
            if refined {
                let lo = match k {
                    0 => self.below.unwrap_or(grid[0]),
                    _ => grid[k - 1],
                };
                let hi = match k + 1 == n {
                    true => self.above.unwrap_or(grid[n - 1]),
                    false => grid[k + 1],
                };
                (x, f) = self.golden(lo, (grid[k], v(k)), hi, run)?;
            }
            peaks.push(Peak { x, f, refined });
        }
        Ok(peaks)
    }

    /// Golden-section steps in the scale's coordinate from the bracket
    /// lo ≤ mid ≤ hi (mid the best so far, with its value; with
    /// `probe_first` the bracket's golden point replaces it): each
    /// evaluation probes the larger side of mid at the golden ratio and
    /// shrinks the bracket. `refine` evaluations, more with `extra`
    /// (field doc). Returns the best (x, f) of mid and the probes, f = −∞
    /// for nothing.
    fn golden<E>(
        &self,
        lo: f64,
        mid: (f64, f64),
        hi: f64,
        run: &mut Run<'_, E>,
    ) -> Result<(f64, f64), E> {
        let s = self.scale;
        let (mut a, mut c) = (s.to(lo), s.to(hi));
        let (mut b, mut fb) = (s.to(mid.0), mid.1);
        let mut n = 0;
        if self.probe_first && c - a >= self.min_width {
            b = a + W * (c - a);
            fb = rank(run.value(s.from(b), Stage::Refine)?);
            n = 1;
        }
        let cap = match self.extra {
            true => self.refine * EXTRA_REFINE,
            false => self.refine,
        };
        let mut history = vec![fb];
        while n < cap {
            if c - a < self.min_width || run.done() {
                break;
            }
            if n >= self.refine {
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
            let fx = rank(run.value(s.from(x), Stage::Refine)?);
            n += 1;
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
        // (With `probe_first` the grid point may still be the best.)
        Ok(if fb >= mid.1 { (s.from(b), fb) } else { mid })
    }

    /// Step 4 (module doc): from the best point `start`, while the point
    /// evaluated just below it found nothing (or there is none), walks
    /// down in steps x ↦ ρx (x > 0).
    fn walk_down<E>(&self, start: (f64, f64), run: &mut Run<'_, E>) -> Result<Walk, E> {
        let (mut x, mut f) = start;
        let below = run.samples.iter().rev().find(|&&(s, _)| s < x).map(|p| p.1);
        if below.is_some_and(|b| b.is_some()) {
            return Ok(Walk::default());
        }
        let mut path = vec![(x, f)];
        let mut rho = WALK_STEP;
        let mut evals = 0;
        let mut rising = true;
        while evals < self.walk && rho < 1.0 - REFINE_GAIN && !run.done() {
            let fx = run.value(x * rho, Stage::Walk)?;
            evals += 1;
            match fx {
                Some(v) if v > f => {
                    (x, f) = (x * rho, v);
                    path.push((x, f));
                    // A longer step next, as long as steps find more.
                    rho = rho.powf(1.25);
                }
                Some(_) => {
                    rising = false;
                    break; // the value falls again below: the peak lies behind.
                }
                None => rho = rho.sqrt(),
            }
        }
        let rising = rising && path.len() > 1;
        Ok(Walk {
            path,
            evals,
            rising,
        })
    }
}

/// The walk below a cliff: its path (its start, then every point taken),
/// its evaluations, and whether it ended with the value still rising.
#[derive(Default)]
struct Walk {
    path: Vec<(f64, f64)>,
    evals: usize,
    rising: bool,
}
