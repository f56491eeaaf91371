//! `max_gain = G` past the SDP's own bound. The problem imposes
//! ‖Γ̂_l‖₂ ≤ G·λ with P̂ ⪰ λI ([`crate::lmi::Problem::with_max_gain`]),
//! which is sufficient for ‖L_l‖₂ = ‖P⁻¹Γ_l‖₂ ≤ G but loose wherever P is
//! ill-conditioned: designs whose actual gains meet G can lie beyond it.
//! The walk here solves the same conditions *without* that constraint,
//! minimising the gain ([`Ctx::min_gain_at`]), and accepts a point only
//! when the independent certificate passes with ‖L_l‖₂ ≤ G among its
//! required checks: for a fixed α, the smallest-gain design at α; for
//! α = max, the fastest α at which the smallest-gain design meets G, by
//! bisection in ln α between the bounded search's α (or the α floor) and
//! the unbounded supremum. The caller keeps whichever certified design is
//! faster.

use super::attempt::Point;
use super::practical::max_gain;
use super::Ctx;
use crate::error::SolveError;
use crate::lmi::Problem;
use crate::report::SearchStep;
use crate::settings::Settings;
use crate::vocab::{Candidate, Phase};
use qpv_dsl::{AlphaSpec, DesignRequest, PolytopicModel};

/// The walk's relative tolerance in α.
const WALK_TOL: f64 = 1e-2;

/// The most bisection steps of the walk.
const WALK_STEPS: usize = 14;

/// What the walk found.
pub(super) struct Walk {
    /// The fastest certified design with every ‖L_l‖₂ ≤ G, if any.
    pub point: Option<Point>,
    /// The smallest gain certified without the bound at the slowest α the
    /// walk tried, with that α (what a failure note may state).
    pub smallest: Option<(f64, f64)>,
    /// The walk's solves, for the design's search log.
    pub steps: Vec<SearchStep>,
}

/// The walk for `request` (its `max_gain` is `bound`) at `gamma` on
/// `model` and `free`, the request's problem without the gain constraint;
/// for α = max from the certified α `from` (the bounded search's, or None).
pub(super) fn walk(
    (model, free): (&PolytopicModel, Problem<'_>),
    request: &DesignRequest,
    settings: &Settings,
    (bound, gamma): (f64, f64),
    from: Option<f64>,
) -> Result<Walk, SolveError> {
    let mut quiet = |_: &SearchStep| {};
    let mut ctx = Ctx::new(model, request.mode, settings, free, &mut quiet);
    ctx.sample = request.sample;
    let mut out = Walk {
        point: None,
        smallest: None,
        steps: Vec::new(),
    };
    match request.alpha {
        AlphaSpec::Fixed(a) => out.point = meeting(&mut ctx, (gamma, bound), a, None, &mut out)?,
        AlphaSpec::Max => {
            let tol = settings.coarse_tol();
            let Some(sup) = ctx.alpha_max(gamma, None, tol, Phase::GainWalk)? else {
                out.steps = std::mem::take(&mut ctx.steps);
                return Ok(out);
            };
            let mut hi = sup.alpha * (1.0 - WALK_TOL);
            let mut lo = from.unwrap_or(settings.alpha_floor).min(hi);
            if let Some(p) = meeting(&mut ctx, (gamma, bound), hi, Some(&sup), &mut out)? {
                out.point = Some(p);
            } else {
                if from.is_none() {
                    out.point = meeting(&mut ctx, (gamma, bound), lo, Some(&sup), &mut out)?;
                    if out.point.is_none() {
                        out.steps = std::mem::take(&mut ctx.steps);
                        return Ok(out);
                    }
                }
                for _ in 0..WALK_STEPS {
                    if hi <= lo * (1.0 + WALK_TOL) {
                        break;
                    }
                    let mid = (lo * hi).sqrt();
                    match meeting(&mut ctx, (gamma, bound), mid, Some(&sup), &mut out)? {
                        Some(p) => {
                            lo = mid;
                            out.point = Some(p);
                        }
                        None => hi = mid,
                    }
                }
            }
        }
    }
    out.steps = std::mem::take(&mut ctx.steps);
    Ok(out)
}

/// The smallest-gain design at (`a`, γ) of `ctx`'s conditions (no gain
/// constraint in the problem), kept if the certificate passes with its
/// gain check ‖L_l‖₂ ≤ `bound` required; `out.smallest` records the gain
/// found at the slowest α tried.
fn meeting(
    ctx: &mut Ctx,
    (gamma, bound): (f64, f64),
    a: f64,
    seed: Option<&Point>,
    out: &mut Walk,
) -> Result<Option<Point>, SolveError> {
    ctx.max_gain = None;
    let mut p = ctx.min_gain_at(Candidate::new(a, gamma), seed.map(|s| &s.p))?;
    // The surrogate bounds the gain, it is not the gain: where its design
    // misses G, the default regularised objective's may not.
    if p.as_ref().map_or(true, |p| max_gain(p) > bound) {
        let cand = crate::vocab::Candidate::new(a, gamma);
        let solve = super::attempt::Solve::Lmi(crate::lmi::Objective::Gains, None);
        let at = ctx.attempt(cand, solve, Phase::GainWalk)?;
        if let Some(q) = at.point.filter(|_| at.certified) {
            if p.as_ref().map_or(true, |p| max_gain(&q) < max_gain(p)) {
                p = Some(q);
            }
        }
    }
    ctx.max_gain = Some(bound);
    if let Some(p) = &p {
        if out.smallest.map_or(true, |(sa, _)| a < sa) {
            out.smallest = Some((a, max_gain(p)));
        }
    }
    Ok(p.and_then(|mut p| {
        p.cert = ctx.certify(p.at(), &p.p, &p.l, p.cube.as_ref());
        p.cert.passed.then_some(p)
    }))
}
