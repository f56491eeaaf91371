//! The verdict of a continuous run (`qpv simulate` without `--sample`),
//! beside the sampled run's ([`crate::analysis::sampled::SampledCheck`]):
//! what the run is compared with, what it found, and whether it violates
//! what is certified.
//!
//! A claim is made only when the report certifies *and* the independent
//! re-check on the model as it is now passes ([`not_certified_reason`]).
//! Then, without noise, ‖e(t)‖ is compared with the certified envelope
//! √cond(P) ‖e(0)‖ e^{−αt/2} (as RK4 at the run's step resolves it); with
//! noise of amplitude ν ≤ ν_max, with the certified noise bound
//! ([`NoiseEnvelope`]). Neither is compared below the arithmetic's floor
//! ([`arithmetic_floor`]). The certificate assumes e(0) in the region and
//! x(t) in F = {xᵀQ⁻¹x ≤ 1}: outside them a run above the bound is no
//! violation.

use crate::analysis::envelope::{arithmetic_floor, envelope_factor, resolved_decay, NoiseEnvelope};
use crate::analysis::trajectory::{below_from, Row, SETTLED};
use crate::report::Design;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{PolytopicModel, StateBound};

/// Relative slack of the envelope comparison (RK4 and rounding errors).
const ENVELOPE_SLACK: f64 = 1e-6;

/// Relative slack of the noise-bound comparison (RK4 error of a run whose
/// input jumps at every step).
const NOISE_SLACK: f64 = 1e-4;

/// Why `design` makes no claim on `obs` (the observer model built from the
/// model as it is now), or `None` if it does: its own verdict (`claims`,
/// the report's `certifies`) may only withdraw a claim; a claim is made
/// only when the independent re-check ([`Design::recheck_on`], the one
/// `qpv check` runs) passes.
pub fn not_certified_reason(
    design: &Design,
    claims: Option<bool>,
    obs: &PolytopicModel,
) -> Option<String> {
    if design.mode == qpv_dsl::Mode::Paper {
        return Some("the report is a paper-mode reproduction, which certifies nothing".into());
    }
    if claims == Some(false) {
        return Some("the report does not certify (its verdict is not `certified`)".into());
    }
    let cert = design.recheck_on(obs);
    if cert.passed {
        return None;
    }
    let mut why: Vec<String> = cert.input_errors.clone();
    why.extend(
        cert.families
            .iter()
            .filter(|f| !f.passed)
            .map(|f| format!("{} (margin {:.3e} at {})", f.name, f.margin, f.worst_at)),
    );
    why.extend(
        cert.data_checks
            .iter()
            .filter(|(_, c)| c.required && !c.passed)
            .map(|(k, c)| format!("{k} ({:.4} > {})", c.value, c.bound)),
    );
    Some(format!(
        "the independent certificate fails on the model as it is now: {}",
        why.join(", ")
    ))
}

/// A continuous run against what is certified: built before the run
/// ([`ContinuousCheck::new`]), shown every row ([`ContinuousCheck::see`]),
/// judged after it ([`ContinuousCheck::violated`]).
#[derive(Debug, Clone)]
pub struct ContinuousCheck {
    /// √cond(P) and α of the certified envelope, when a claim is made and
    /// the run has no noise.
    pub envelope: Option<(f64, f64)>,
    /// The certified bound on ‖e(t)‖ under noise, when a claim is made, the
    /// design carries a noise bound and ν ≤ ν_max.
    pub noise_bound: Option<NoiseEnvelope>,
    /// Whether e(0) lies in the region (a_kᵀ e(0) ≤ 1 on every facet).
    pub e0_inside: bool,
    /// ‖e(0)‖, from the first row.
    pub e0: f64,
    /// First time and worst ratio ‖e‖/envelope above it.
    pub envelope_exceeded: Option<(f64, f64)>,
    /// First time and worst ratio ‖e‖/(certified noise bound) above it.
    pub noise_exceeded: Option<(f64, f64)>,
    /// First time and largest xᵀQ⁻¹x above 1.
    pub left_f: Option<(f64, f64)>,
    /// First time and the parameter (0-based) whose θ left its interval Θ
    /// (a parameter tied to the plant's state, [`crate::simulate::Signal::State`],
    /// is only known as the run goes): the plant is then outside the box
    /// the design was certified for.
    pub left_theta: Option<(f64, usize)>,
    /// The time from which ‖e‖ < [`SETTLED`] (as the run goes on).
    pub below_from: Option<f64>,
    /// When the run produced a non-finite value (the caller sets it).
    pub diverged_at: Option<f64>,
    /// √cond(P) and α of the design, for the floor of every comparison;
    /// None if P is not positive definite.
    resolution: Option<(f64, f64)>,
    /// Q⁻¹ of the observer model's state bound F, when there is one.
    q_inv: Option<DMatrix<f64>>,
    /// Θ: the interval of every parameter.
    theta_box: Vec<(f64, f64)>,
    /// The run's RK4 step.
    dt: f64,
    /// Rows seen.
    rows: usize,
    /// The largest |x_i| or |x̂_i| so far: the scale of the run's rounding.
    scale: f64,
}

impl ContinuousCheck {
    /// The check of a run of `design`'s gains on `obs` (its observer
    /// model) from e(0) = `e0` at RK4 step `dt`, with measurement noise of
    /// amplitude `noise` (≥ 0) or none; `certified`: a claim is made
    /// ([`not_certified_reason`] is `None`).
    pub fn new(
        design: &Design,
        obs: &PolytopicModel,
        certified: bool,
        e0: &[f64],
        (noise, dt): (Option<f64>, f64),
    ) -> Self {
        let p = design.p_matrix();
        let resolution = envelope_factor(&p).map(|k| (k, design.alpha));
        let noise_bound = match (noise, &design.noise) {
            (Some(nu), Some(nb)) if certified && nu <= nb.max_amplitude => {
                NoiseEnvelope::new(&p, e0, design.alpha, nb, nu)
            }
            _ => None,
        };
        ContinuousCheck {
            envelope: resolution.filter(|_| certified && noise.is_none()),
            noise_bound,
            e0_inside: obs.region.facets.iter().all(|a| {
                let s: f64 = a.iter().zip(e0).map(|(a, e)| a * e).sum();
                s <= 1.0 + 1e-9
            }),
            e0: 0.0,
            envelope_exceeded: None,
            noise_exceeded: None,
            left_f: None,
            left_theta: None,
            below_from: None,
            diverged_at: None,
            resolution,
            q_inv: q_inv_of(obs),
            theta_box: obs.params.iter().map(|p| (p.lo, p.hi)).collect(),
            dt,
            rows: 0,
            scale: 0.0,
        }
    }

    /// Compares row `r` with the claim and its premises.
    pub fn see(&mut self, r: &Row<'_>) {
        let err = r.error_norm;
        if self.rows == 0 {
            self.e0 = err;
        }
        self.rows += 1;
        see_f(&self.q_inv, (r.t, r.x), &mut self.left_f);
        if self.left_theta.is_none() {
            let out = |(v, &(lo, hi)): (&f64, &(f64, f64))| {
                let tol = 1e-12 * lo.abs().max(hi.abs()).max(hi - lo);
                !(lo - tol..=hi + tol).contains(v)
            };
            let first = r.theta.iter().zip(&self.theta_box).position(out);
            self.left_theta = first.map(|i| (r.t, i));
        }
        let here = r.x.iter().chain(r.xhat).fold(0.0f64, |m, v| m.max(v.abs()));
        self.scale = self.scale.max(here);
        let floor = self.resolution.map_or(0.0, |(kf, alpha)| {
            arithmetic_floor(kf, alpha, self.dt, self.scale)
        });
        if let Some((kf, alpha)) = self.envelope {
            let env = kf * self.e0 * resolved_decay(alpha, self.dt, r.t);
            if err > env * (1.0 + ENVELOPE_SLACK) + floor {
                record(&mut self.envelope_exceeded, r.t, err / env);
            }
        }
        if let Some(b) = &self.noise_bound {
            let bound = b.at(r.t);
            if err > bound * (1.0 + NOISE_SLACK) + floor {
                record(&mut self.noise_exceeded, r.t, err / bound);
            }
        }
        self.below_from = below_from(self.below_from, r.t, err, SETTLED);
    }

    /// The run left the certified envelope or noise bound although e(0)
    /// was in the region, x stayed in F and θ in Θ.
    pub fn violated(&self) -> bool {
        (self.envelope_exceeded.is_some() || self.noise_exceeded.is_some())
            && self.e0_inside
            && self.left_f.is_none()
            && self.left_theta.is_none()
    }

    /// The run failed: it diverged, or [`ContinuousCheck::violated`].
    pub fn failed(&self) -> bool {
        self.diverged_at.is_some() || self.violated()
    }
}

/// Q⁻¹ of `model`'s state bound F, when it has one.
pub(crate) fn q_inv_of(model: &PolytopicModel) -> Option<DMatrix<f64>> {
    match &model.state_bound {
        StateBound::Given(q) if q.nrows() == model.nx() => q.clone().try_inverse(),
        _ => None,
    }
}

/// Records in `left_f` the time `t` and xᵀQ⁻¹x if x lies outside
/// F = {xᵀQ⁻¹x ≤ 1} (`q_inv` = Q⁻¹; none: nothing is checked).
pub(crate) fn see_f(
    q_inv: &Option<DMatrix<f64>>,
    (t, x): (f64, &[f64]),
    left_f: &mut Option<(f64, f64)>,
) {
    if let Some(qi) = q_inv {
        let xs = DVector::from_column_slice(x);
        let s = xs.dot(&(qi * &xs));
        if s > 1.0 + 1e-9 {
            record(left_f, t, s);
        }
    }
}

/// Keeps the first time of an event and its largest value.
pub(crate) fn record(slot: &mut Option<(f64, f64)>, t: f64, v: f64) {
    let e = slot.get_or_insert((t, v));
    e.1 = e.1.max(v);
}
