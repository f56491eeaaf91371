//! The practical `alpha = max` (docs/method.md, "The practical α = max"):
//! the α search finds the certified supremum α_sup; the design returned is
//! the one of smallest gain certified at α_t = (1 − within)·α_sup, since the
//! last fraction of α is often bought with gains 10⁴ times larger.
//!
//! * Gain objective: [`Objective::MinGain`] minimises κ with
//!   ‖L_l‖₂ ≤ ‖Γ_l‖₂/λ_min(P) ≤ κ (a convex surrogate of max_l ‖L_l‖₂),
//!   at α_t, at every γ where the α search certified α ≥ α_t (at most
//!   [`MAX_CANDIDATES`] of them), then [`REFINE`] golden-section steps in
//!   ln γ between the best one's neighbours. Every point is certified like
//!   any other; the gain reported is the reported L's, not κ. At the best
//!   γ and at the supremum's, the default regularised objective is solved
//!   too, and the smallest actual gain kept (the surrogate bounds the gain;
//!   it is not the gain). Where the regularised design wins (the surrogate
//!   is loose), the surrogate is reweighted by the best point's P for at
//!   most [`REWEIGHT_ROUNDS`] rounds. Where P is too ill-conditioned for the
//!   solves' default margin, the min-gain solves are repeated with the
//!   margin cut by [`MARGIN_CUTS`].
//! * High gain: when the γ search reached α_sup by its walk below a cliff
//!   (α rising only as γ falls) and the design at α_t (or, if none
//!   certified, the fastest point) has more than [`KNEE_FACTOR`] times the
//!   smallest gain at the walk's start, the supremum is approached only as
//!   ‖L‖ → ∞. The design returned is then the *knee*: the fastest walk
//!   point whose certified design (the α search's point there) has at most
//!   [`KNEE_FACTOR`] times the gain of the walk's starting point, or the
//!   smallest-gain design at (1 − within) of its α if one certifies with a
//!   smaller gain.

use super::attempt::Attempt;
use super::{Ctx, Point, Solve};
use crate::backend::Status;
use crate::error::SolveError;
use crate::line_search::Line;
use crate::lmi::Objective;
use crate::report::Practical;
use crate::vocab::{Candidate, Phase};
use nalgebra::DMatrix;

/// Most γ values at which the smallest-gain design is solved before the
/// refinement.
pub const MAX_CANDIDATES: usize = 10;
/// Golden-section steps in ln γ around the best candidate.
pub const REFINE: usize = 3;
/// The knee: the fastest point of the walk whose gain is within this factor
/// of the gain at the walk's start (and the high-gain test's threshold).
pub const KNEE_FACTOR: f64 = 10.0;
/// The γ search's walk below a cliff stops (practical α = max only) once a
/// point's gain exceeds this factor times the gain at the walk's start: α
/// is still rising there only because ‖L‖ → ∞.
pub const WALK_GAIN_LIMIT: f64 = 100.0;
/// The factors by which the min-gain solves' relative margin is cut, in
/// turn, where the design's P is too ill-conditioned to carry the default
/// one (docs/method.md §11a, "Margin"): the margins are absolute in the
/// solver's normalised coordinates (P̂ ⪰ εI, rate blocks ⪯ −εκI with P̂ of
/// order 1 at the region's vertices), so a P whose eigenvalues span more
/// than about 1/ε has no room for them in its weak direction.
pub const MARGIN_CUTS: [f64; 2] = [1e-2, 1e-4];
/// Most rounds of the reweighted gain surrogate, run where the regularised
/// design beat the surrogate's (docs/method.md §11a, "The gain objective").
pub const REWEIGHT_ROUNDS: usize = 3;

/// What the α search saw, for the practical design: every certified
/// (γ, α) it found, sorted by γ, and its walk below a cliff.
pub(super) struct Trace {
    /// Certified (γ, α) pairs, ascending in γ.
    pub samples: Vec<(f64, f64)>,
    /// The walk ended with α still rising.
    pub still_rising: bool,
    /// The α search's certified point at each point of the walk, in order.
    pub walk_points: Vec<Point>,
}

impl Trace {
    /// The trace of an α search at one fixed γ.
    pub fn at_fixed_gamma(gamma: f64, alpha: f64) -> Trace {
        Trace {
            samples: vec![(gamma, alpha)],
            still_rising: false,
            walk_points: Vec::new(),
        }
    }
}

/// The practical design: its point (None if no smallest-gain design
/// certified, then the fastest point stands), what the report says about
/// it, and the notes.
pub(super) struct Outcome {
    pub point: Option<Point>,
    pub info: Practical,
    pub notes: Vec<String>,
}

/// max_l ‖L_l‖₂ of a point.
pub(super) fn max_gain(p: &Point) -> f64 {
    p.l.iter().map(crate::linalg::norm2).fold(0.0, f64::max)
}

impl Ctx<'_, '_> {
    /// The certified smallest-gain design at (α, γ), if any. From scratch
    /// (P̂ ⪰ I) first; if that does not certify and a certified point's P
    /// is given (`seed`), normalised by its shape (P̂ ⪰ P_seed/λ_min, see
    /// [`Objective::MinGain`]), where the solver's scratch problem is
    /// badly scaled (the elastic arm at small γ). Near the supremum the
    /// conditions may also leave less room than the solves' default margin
    /// (the max-margin optimum t̂ below `Settings::margin_rel`): then the
    /// margin is measured (one max-margin solve) and the solve repeated
    /// with half of it. Where P must be too ill-conditioned to carry the
    /// margin at all (the max-margin solve, which keeps P̂ ⪰ εI, finds no
    /// room), the solve is repeated with the margin cut by
    /// [`MARGIN_CUTS`] (docs/method.md §11a, "Margin"). The certificate is
    /// the same either way.
    pub(super) fn min_gain_at(
        &mut self,
        cand: Candidate,
        seed: Option<&DMatrix<f64>>,
    ) -> Result<Option<Point>, SolveError> {
        if let Some(m) = self.margin_cut {
            // A cut margin was needed at another γ: start with it there.
            if let Some(p) = self.min_gain_with_margin(cand, seed, m)? {
                return Ok(Some(p));
            }
        }
        let at = self.attempt(cand, Solve::Lmi(Objective::MinGain, None), Phase::Practical)?;
        if at.certified {
            return Ok(at.point);
        }
        if seed.is_some() {
            let at = self.attempt(cand, Solve::Lmi(Objective::MinGain, seed), Phase::Practical)?;
            if at.certified {
                return Ok(at.point);
            }
        }
        let room = self.attempt(
            cand,
            Solve::Lmi(Objective::MaxMargin, None),
            Phase::Practical,
        )?;
        let t = room.margin;
        let eps = self.settings.margin_rel;
        if t.is_finite() && t > 0.0 && t < eps {
            return self.min_gain_with_margin(cand, seed, 0.5 * t);
        }
        if t.is_finite() && t >= eps {
            // Room enough for the default margin: the failure is not it.
            return Ok(None);
        }
        self.min_gain_margin_cuts(cand, seed)
    }

    /// The min-gain solve at `cand` with the margin cut by each factor of
    /// [`MARGIN_CUTS`] in turn, while the cut one is still infeasible (a
    /// point that fails the certificate does not improve with less margin).
    /// Records the margin of a point that certifies in `self.margin_cut`.
    fn min_gain_margin_cuts(
        &mut self,
        cand: Candidate,
        seed: Option<&DMatrix<f64>>,
    ) -> Result<Option<Point>, SolveError> {
        for f in MARGIN_CUTS {
            let m = f * self.settings.margin_rel;
            let at = self.min_gain_attempt_with_margin(cand, seed, m)?;
            if at.certified {
                self.margin_cut = Some(self.margin_cut.map_or(m, |c| c.min(m)));
                return Ok(at.point);
            }
            if at.status != Status::Infeasible {
                break;
            }
        }
        Ok(None)
    }

    /// The min-gain solve at `cand` with the solves' relative margin `m`.
    fn min_gain_with_margin(
        &mut self,
        cand: Candidate,
        seed: Option<&DMatrix<f64>>,
        m: f64,
    ) -> Result<Option<Point>, SolveError> {
        let at = self.min_gain_attempt_with_margin(cand, seed, m)?;
        Ok(if at.certified { at.point } else { None })
    }

    /// One min-gain attempt at `cand` with the solves' relative margin `m`
    /// (the default restored after it, whatever its outcome).
    fn min_gain_attempt_with_margin(
        &mut self,
        cand: Candidate,
        seed: Option<&DMatrix<f64>>,
        m: f64,
    ) -> Result<Attempt, SolveError> {
        self.margin_rel = Some(m);
        let at = self.attempt(cand, Solve::Lmi(Objective::MinGain, seed), Phase::Practical);
        self.margin_rel = None;
        at
    }

    /// The practical design below the fastest certified point `sup` (module
    /// doc), from what the α search saw.
    pub(super) fn practical(
        &mut self,
        sup: &Point,
        within: f64,
        trace: &Trace,
    ) -> Result<Outcome, SolveError> {
        let n0 = self.steps.len();
        self.margin_cut = None;
        let a_t = (1.0 - within) * sup.alpha;
        let gain_sup = max_gain(sup);
        let cands = candidates(trace, sup.gamma, a_t);
        let mut best: Option<(Point, f64)> = None;
        // Every candidate, then golden-section steps in ln γ inside the
        // bracket of the best one's neighbours (a side without a neighbour
        // is not probed).
        let line = Line {
            refine: REFINE,
            min_width: 1e-3,
            ..Line::default()
        };
        line.minimise(
            &cands,
            &mut |g, _| self.try_gamma(Candidate::new(a_t, g), &sup.p, &mut best),
            &|| false,
        )?;
        // The surrogate bounds the gain, it is not the gain: the default
        // regularised objective (½ w Σ‖Γ̂_l‖²) at the same point sometimes
        // does better (and solves where the homogenised problem's scaling
        // fails): the smaller actual gain is kept. Where it does better,
        // the surrogate is loose, and the metric-normalised min-gain solve
        // is repeated from the best point's P (reweighting).
        if self.regularised_beats(a_t, sup.gamma, &mut best)? {
            self.reweight(a_t, &mut best)?;
        }
        let mut notes = Vec::new();
        if let Some(m) = self.margin_cut {
            notes.push(format!(
                "P is too ill-conditioned near α_sup for the solves' default margin ({:.0e}, absolute in the solver's normalised coordinates): min-gain solves that were infeasible with it were repeated with the margin cut to {m:.0e}; the certificate is the same",
                self.settings.margin_rel
            ));
        }
        let high_gain = self.knee(sup, within, trace, gain_sup, &mut best, &mut notes)?;
        let solves = self.steps.len() - n0;
        let capped = sup.alpha >= self.settings.alpha_cap * (1.0 - 1e-9);
        let of = if capped {
            "the search's cap"
        } else if self.walk_stopped {
            "the fastest point found (the walk to small γ stopped where the gains passed 100× its start; α rises further only as ‖L‖ → ∞)"
        } else {
            "the certified supremum"
        };
        match &best {
            Some((p, g)) => notes.insert(
                0,
                format!(
                    "alpha = max(within = {within}): α = {:.6} is {:.1} % of {of} α_sup = {:.6} (γ = {:.6}, max ‖L_l‖₂ = {gain_sup:.4e}); the smallest-gain design there has max ‖L_l‖₂ = {g:.4e} at γ = {:.6} ({solves} solver calls minimising κ with P ⪰ λ I, ‖Γ_l‖₂ ≤ κλ over {} values of γ)",
                    p.alpha,
                    100.0 * p.alpha / sup.alpha,
                    sup.alpha,
                    sup.gamma,
                    p.gamma,
                    cands.len()
                ),
            ),
            None => notes.push(format!(
                "alpha = max(within = {within}): no smallest-gain design certified at α = {a_t:.6} ({solves} solver calls); the fastest certified point is reported"
            )),
        }
        Ok(Outcome {
            point: best.map(|(p, _)| p),
            info: Practical {
                alpha_sup: sup.alpha,
                gamma_sup: sup.gamma,
                gain_sup,
                within,
                high_gain,
                solves,
                capped,
            },
            notes,
        })
    }

    /// The regularised design at the best γ of `best` and at the
    /// supremum's γ `gamma_sup`, kept in `best` if its actual gain is
    /// smaller; returns whether it was (the surrogate was loose there).
    fn regularised_beats(
        &mut self,
        a_t: f64,
        gamma_sup: f64,
        best: &mut Option<(Point, f64)>,
    ) -> Result<bool, SolveError> {
        let g_best = best.as_ref().map_or(gamma_sup, |(b, _)| b.gamma);
        let mut at_gammas = vec![g_best];
        if gamma_sup != g_best {
            at_gammas.push(gamma_sup);
        }
        let mut beats = false;
        for g in at_gammas {
            let solve = Solve::Lmi(Objective::Gains, None);
            let at = self.attempt(Candidate::new(a_t, g), solve, Phase::Practical)?;
            if let Some(p) = at.point.filter(|_| at.certified) {
                let gain = max_gain(&p);
                if best.as_ref().map_or(true, |(_, bg)| gain < *bg) {
                    beats = true;
                    *best = Some((p, gain));
                }
            }
        }
        Ok(beats)
    }

    /// Iterative reweighting of the gain surrogate (docs/method.md §11a,
    /// "The gain objective"): the min-gain solve normalised by the best
    /// point's P (P̂ ⪰ W = P/λ_min(P), ‖W^{-1/2}Γ̂_l‖₂ ≤ κ) at its γ, then
    /// by the new point's P, for at most [`REWEIGHT_ROUNDS`] rounds while
    /// a round lowers the actual certified gain by 1 % or more; the
    /// smallest actual gain is kept in `best`.
    fn reweight(&mut self, a_t: f64, best: &mut Option<(Point, f64)>) -> Result<(), SolveError> {
        let Some((start, _)) = best.as_ref() else {
            return Ok(());
        };
        let (gamma, mut w) = (start.gamma, start.p.clone());
        for _ in 0..REWEIGHT_ROUNDS {
            let solve = Solve::Lmi(Objective::MinGain, Some(&w));
            let at = self.attempt(Candidate::new(a_t, gamma), solve, Phase::Practical)?;
            let Some(p) = at.point.filter(|_| at.certified) else {
                break;
            };
            let (g, bg) = (max_gain(&p), best.as_ref().map_or(f64::INFINITY, |b| b.1));
            w = p.p.clone();
            if g < bg {
                *best = Some((p, g));
            }
            if g > 0.99 * bg {
                break;
            }
        }
        Ok(())
    }

    /// The knee of the α–gain curve (module doc): when α_sup was reached by
    /// the walk below a cliff and the design at the tolerance (`best`, or
    /// the fastest point `sup`) has more than [`KNEE_FACTOR`] times the gain
    /// at the walk's start, `best` becomes the fastest walk point within
    /// that factor, if it at least halves the gain. Returns whether it did;
    /// `notes` says why either way.
    fn knee(
        &mut self,
        sup: &Point,
        within: f64,
        trace: &Trace,
        gain_sup: f64,
        best: &mut Option<(Point, f64)>,
        notes: &mut Vec<String>,
    ) -> Result<bool, SolveError> {
        let mut high_gain = false;
        // The walk below a cliff took α up only by going to smaller γ, where
        // the gains grow: the α search's certified points along it are the
        // α–gain curve the knee is taken on (no solve needed; near the walk's
        // small γ the smallest-gain solves from scratch often fail where the
        // seeded α search certified).
        if let Some(start) = trace
            .walk_points
            .first()
            .filter(|_| trace.walk_points.len() > 1)
        {
            let g_ref = max_gain(start);
            let (b_gain, b_alpha) = best
                .as_ref()
                .map_or((gain_sup, sup.alpha), |(b, gb)| (*gb, b.alpha));
            if b_gain > KNEE_FACTOR * g_ref {
                let k = trace
                    .walk_points
                    .iter()
                    .rposition(|p| max_gain(p) <= KNEE_FACTOR * g_ref)
                    .unwrap_or(0);
                let on_curve = trace.walk_points[k].clone();
                let (ka, kg) = (on_curve.alpha, on_curve.gamma);
                // A smaller gain at the same point, if a smallest-gain solve
                // certifies within the tolerance below it.
                let knee = match self
                    .min_gain_at(Candidate::new((1.0 - within) * ka, kg), Some(&on_curve.p))?
                {
                    Some(p) if max_gain(&p) < max_gain(&on_curve) => p,
                    _ => on_curve,
                };
                let kg_gain = max_gain(&knee);
                // The knee only where it buys a real cut in gain.
                if kg_gain <= 0.5 * b_gain {
                    high_gain = true;
                    notes.push(format!(
                "high gain: the certified α {} (max ‖L_l‖₂ = {b_gain:.4e} at α = {b_alpha:.6}, against {g_ref:.4e} at α = {:.6}, γ = {:.6}, where the walk to small γ started): the supremum is approached only as ‖L‖ → ∞, so the design returned is the knee of the α–gain curve (the fastest point of the walk whose certified design has at most {KNEE_FACTOR}× the gain at its start: α = {ka:.6}, γ = {kg:.6}); `max_gain = G` or a sample period sets the real limit",
                if self.walk_stopped {
                    "was still rising where the walk stopped (a point's gain above 100× its start)"
                } else if trace.still_rising {
                    "still rises at the smallest γ searched"
                } else {
                    "rose only by walking to small γ"
                },
                start.alpha,
                start.gamma,
            ));
                    *best = Some((knee, kg_gain));
                } else {
                    notes.push(format!(
                    "the gains grow along the whole walk to small γ (max ‖L_l‖₂ = {g_ref:.4e} already at its start, α = {:.6}): no slower point of it has less than half the gain, so the design at the tolerance is kept; `max_gain = G` or a sample period sets the real limit",
                    start.alpha
                ));
                }
            }
        }
        Ok(high_gain)
    }

    /// The smallest-gain design at (α, γ): its gain (None if it did not
    /// certify), kept in `best` if smaller.
    fn try_gamma(
        &mut self,
        cand: Candidate,
        seed: &DMatrix<f64>,
        best: &mut Option<(Point, f64)>,
    ) -> Result<Option<f64>, SolveError> {
        Ok(self.min_gain_at(cand, Some(seed))?.map(|p| {
            let g = max_gain(&p);
            if best.as_ref().map_or(true, |(_, bg)| g < *bg) {
                *best = Some((p, g));
            }
            g
        }))
    }
}

/// The γ values to solve at: every γ where the search certified α ≥ α_t
/// and the supremum's γ, ascending, thinned evenly to [`MAX_CANDIDATES`]
/// (keeping both ends and the supremum's γ).
fn candidates(trace: &Trace, gamma_sup: f64, alpha_t: f64) -> Vec<f64> {
    let mut c: Vec<f64> = trace
        .samples
        .iter()
        .filter(|s| s.1 >= alpha_t)
        .map(|s| s.0)
        .chain([gamma_sup])
        .collect();
    c.sort_by(f64::total_cmp);
    c.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs());
    if c.len() > MAX_CANDIDATES {
        let k = c.len();
        let mut keep: Vec<f64> = (0..MAX_CANDIDATES - 1)
            .map(|i| c[i * (k - 1) / (MAX_CANDIDATES - 2)])
            .chain([gamma_sup])
            .collect();
        keep.sort_by(f64::total_cmp);
        keep.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs());
        c = keep;
    }
    c
}
