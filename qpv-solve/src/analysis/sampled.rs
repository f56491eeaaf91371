//! The continuous plant against the observer stepped at the sample period
//! (docs/method.md §16, "The real plant is continuous"; `qpv simulate
//! --sample H`).
//!
//! The plant follows its ODE, integrated by classical RK4 at h/`substeps`
//! (at least 20 substeps); the observer runs the generated code's step
//! x̂_{k+1} = x̂_k + h f̂(x̂_k, y_k, u_k, θ_k) on the samples y_k = h(x(t_k)),
//! u_k = u(t_k), θ_k = θ(t_k) (zero-order hold). A parameter or an input
//! without a declared `rate` is held over each step in the plant too (the
//! assumption the continuous-plant bound is computed under); one with a
//! rate follows its signal. [`check_sampled_run`] compares √V(e_k) with the
//! certified recursion b_{k+1} = ρ b_k + δ, b_0 = √V(e_0), ρ = √(1 − hα),
//! its limit δ/(1 − ρ) the ultimate bound, with α and δ recomputed from the
//! model and the gains ([`crate::report::continuous::sampled_claim`]).

use crate::analysis::continuous::{q_inv_of, record, see_f};
use crate::analysis::integrate::{euler, Rk4};
use crate::analysis::rhs::Frozen;
use crate::analysis::scenario::check_run;
use crate::analysis::simulate::{MeasurementNoise, Scenario, SimError, MAX_STEPS};
use crate::analysis::trajectory::error_norm;
use crate::report::continuous::{bound_model, sampled_claim, SampledClaim};
use crate::report::Design;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::PolytopicModel;

/// The fewest RK4 substeps per sample period (the plant at h/20 or finer).
pub const MIN_SUBSTEPS: usize = 20;

/// Relative slack of the comparison with the certified recursion (RK4's own
/// error at h/20 and rounding).
pub(crate) const BOUND_SLACK: f64 = 1e-6;

/// How the continuous plant and the sampled observer are run.
#[derive(Debug, Clone)]
pub struct SampledRun {
    /// The sample period h of the observer.
    pub h: f64,
    /// RK4 substeps of the plant per period (at least [`MIN_SUBSTEPS`]).
    pub substeps: usize,
    /// Per declared parameter: held at θ(t_k) over each step in the plant
    /// (no declared rate) or following its signal.
    pub hold_params: Vec<bool>,
    /// Per input: held at u(t_k) over each step in the plant, or not.
    pub hold_inputs: Vec<bool>,
    /// Measurement noise on the sampled outputs (a new vector of norm ν at
    /// every sample), or none. With it the run is compared with the bound
    /// with noise (docs/method.md §16, "Noise and the continuous plant").
    pub noise: Option<MeasurementNoise>,
}

impl SampledRun {
    /// The run at period `h` with [`MIN_SUBSTEPS`]: parameters and inputs
    /// without a declared rate in `model` are held over each step.
    pub fn for_model(model: &PolytopicModel, h: f64) -> SampledRun {
        SampledRun {
            h,
            substeps: MIN_SUBSTEPS,
            hold_params: model.params.iter().map(|p| p.rate.is_none()).collect(),
            hold_inputs: (0..model.nu())
                .map(|j| model.input_rates.get(j).copied().flatten().is_none())
                .collect(),
            noise: None,
        }
    }
}

/// One instant of a sampled run: every plant substep, and `sample` set at
/// the sample instants t_k = kh (after the observer's state is x̂_k).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SampledRow<'a> {
    /// Time.
    pub(crate) t: f64,
    /// True at t_k = kh.
    pub(crate) sample: bool,
    /// Plant state x(t).
    pub(crate) x: &'a [f64],
    /// The observer's state x̂_k (held between samples).
    pub(crate) xhat: &'a [f64],
    /// θ(t) as the plant sees it.
    pub(crate) theta: &'a [f64],
    /// u(t) as the plant sees it.
    pub(crate) u: &'a [f64],
}

/// Checks the run's input; returns the number of samples.
fn samples_of(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    scenario: &Scenario,
    run: &SampledRun,
) -> Result<usize, SimError> {
    check_run(model, gains, scenario)?;
    let h = run.h;
    if !(h.is_finite() && h > 0.0) {
        return Err(SimError::Argument(format!("sample period h = {h}")));
    }
    if run.substeps < MIN_SUBSTEPS
        || run.hold_params.len() != scenario.theta.len()
        || run.hold_inputs.len() != scenario.u.len()
    {
        return Err(SimError::Argument(format!(
            "substeps {} (at least {MIN_SUBSTEPS}), one hold flag per parameter and input",
            run.substeps
        )));
    }
    if !(scenario.t_end.is_finite() && scenario.t_end >= 0.0) {
        return Err(SimError::TimeGrid(format!("t_end = {}", scenario.t_end)));
    }
    let samples = (scenario.t_end / h - 1e-9).ceil().max(0.0);
    if samples * run.substeps as f64 > MAX_STEPS as f64 {
        return Err(SimError::TimeGrid(format!(
            "{samples} samples × {} substeps (at most {MAX_STEPS} steps)",
            run.substeps
        )));
    }
    Ok(samples as usize)
}

/// The plant's side of a step: its signals (held or following the
/// scenario) and the RK4 buffers.
struct Plant<'a> {
    model: &'a PolytopicModel,
    scenario: &'a Scenario,
    run: &'a SampledRun,
    frozen: Frozen,
    rk4: Rk4,
}

/// θ(t) and u(t) as the plant sees them (held ones at their samples).
fn signals(
    sc: &Scenario,
    run: &SampledRun,
    (t, x): (f64, &[f64]),
    th_k: &[f64],
    u_k: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let at = |held: &[bool], sampled: &[f64], signals: &[crate::analysis::simulate::Signal]| {
        (0..sampled.len())
            .map(|i| {
                if held[i] {
                    sampled[i]
                } else {
                    signals[i].value(t, x)
                }
            })
            .collect()
    };
    (
        at(&run.hold_params, th_k, &sc.theta),
        at(&run.hold_inputs, u_k, &sc.u),
    )
}

impl Plant<'_> {
    /// One classical RK4 step of length dt from (t, x); false if a signal
    /// was not finite (x unchanged then).
    fn rk4(&mut self, t: f64, dt: f64, x: &mut [f64], th_k: &[f64], u_k: &[f64]) -> bool {
        let (model, sc, run, frozen) = (self.model, self.scenario, self.run, &mut self.frozen);
        let mut f = |t: f64, x: &[f64], out: &mut [f64]| {
            let (th, u) = signals(sc, run, (t, x), th_k, u_k);
            if th.iter().chain(&u).any(|v| !v.is_finite()) {
                return false;
            }
            frozen.set(model, &[], &th);
            frozen.plant(x, &u, out);
            true
        };
        self.rk4.step(&mut f, (t, dt, t + dt), x)
    }
}

/// The observer's step on the samples (the generated `step`):
/// x̂ ← x̂ + h (f(x̂, u_k, θ_k) + L(θ_k)(y_k − ŷ_k)).
fn observer_step(
    frozen: &mut Frozen,
    (model, gains): (&PolytopicModel, &[DMatrix<f64>]),
    (x, xh): (&[f64], &mut [f64]),
    (th_k, u_k, h): (&[f64], &[f64], f64),
    v: &[f64],
) {
    let (mut y, mut yh) = (vec![0.0; model.ny()], vec![0.0; model.ny()]);
    let mut dxh = vec![0.0; model.nx()];
    frozen.set(model, gains, th_k);
    frozen.output(x, &mut y);
    // The measurement y_k + v_k against the observer's output.
    for (a, vi) in y.iter_mut().zip(v) {
        *a += vi;
    }
    frozen.observer((xh, u_k), (&mut y, &mut yh), &mut dxh);
    euler(xh, h, &dxh);
}

/// Runs the continuous plant (RK4 at h/substeps) against the observer
/// stepped at h, handing every substep's row to `each` (false stops the
/// run). Returns the time a non-finite value appeared, if one did.
pub(crate) fn simulate_sampled_each(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    scenario: &Scenario,
    run: &SampledRun,
    each: &mut dyn FnMut(&SampledRow<'_>) -> bool,
) -> Result<Option<f64>, SimError> {
    let samples = samples_of(model, gains, scenario, run)?;
    let (nx, h) = (model.nx(), run.h);
    let dt = h / run.substeps as f64;
    let mut frozen = Frozen::new(model);
    let mut plant = Plant {
        model,
        scenario,
        run,
        frozen: Frozen::new(model),
        rk4: Rk4::new(nx),
    };
    let mut x = scenario.x0.clone();
    let mut xh = scenario.xhat0.clone();
    let mut noise = run.noise.clone();
    for k in 0..=samples {
        let tk = k as f64 * h;
        let th_k: Vec<f64> = scenario.theta.iter().map(|s| s.value(tk, &x)).collect();
        let u_k: Vec<f64> = scenario.u.iter().map(|s| s.at(tk)).collect();
        let all = th_k.iter().chain(&u_k).chain(&x).chain(&xh);
        if all.clone().any(|v| !v.is_finite()) {
            return Ok(Some(tk));
        }
        let row = SampledRow {
            t: tk,
            sample: true,
            x: &x,
            xhat: &xh,
            theta: &th_k,
            u: &u_k,
        };
        if !each(&row) || k == samples {
            return Ok(None);
        }
        let v = noise
            .as_mut()
            .map(|n| n.sample(model.ny()))
            .unwrap_or_default();
        observer_step(
            &mut frozen,
            (model, gains),
            (&x, &mut xh),
            (&th_k, &u_k, h),
            &v,
        );
        // The plant over [t_k, t_k + h]: RK4 at h/substeps.
        for n in 0..run.substeps {
            let t = tk + n as f64 * dt;
            if !plant.rk4(t, dt, &mut x, &th_k, &u_k) {
                return Ok(Some(t));
            }
            if x.iter().any(|v| !v.is_finite()) {
                return Ok(Some(t + dt));
            }
            if n + 1 < run.substeps {
                let (theta, inputs) = signals(scenario, run, (t + dt, &x), &th_k, &u_k);
                let row = SampledRow {
                    t: t + dt,
                    sample: false,
                    x: &x,
                    xhat: &xh,
                    theta: &theta,
                    u: &inputs,
                };
                if !each(&row) {
                    return Ok(None);
                }
            }
        }
    }
    Ok(None)
}

/// The noise of a sampled run and what bounds it (see
/// [`SampledCheck::noise`]).
#[derive(Debug, Clone, Copy)]
pub struct NoiseInRun {
    /// The amplitude ν of the run's noise.
    pub amplitude: f64,
    /// σ of V(e_k+1) − (1 − hα)V(e_k) ≤ hσ|v_k|², recomputed (None: the
    /// gains certify no discrete noise bound at this h and α).
    pub sigma: Option<f64>,
    /// ν_c = √(((1 − δ)² − ρ²)/(hσ)) (∞ for the global observer).
    pub amplitude_max: f64,
}

/// The verdict of a sampled run against the certified bound.
#[derive(Debug, Clone)]
pub struct SampledCheck {
    /// What the gains certify at h, recomputed ([`sampled_claim`]).
    pub claim: SampledClaim,
    /// √V(e_0) = b_0: the run starts in the certified set when ≤ 1.
    pub v0_sqrt: f64,
    /// Samples compared.
    pub samples: usize,
    /// The largest √V(e_k) / b_k over the samples k ≥ 1 (≤ 1 + slack:
    /// inside; b_0 = √V(e_0) makes k = 0 exactly 1).
    pub worst_ratio: f64,
    /// The first sample time √V(e_k) exceeded b_k, and the largest ratio.
    pub exceeded: Option<(f64, f64)>,
    /// The first sample time from which √V(e_k) stays within the ultimate
    /// bound δ/(1 − ρ) to the end of the run (None: not by the end).
    pub entered_at: Option<f64>,
    /// The first time the plant left F (xᵀQ⁻¹x > 1, at any substep), and
    /// the largest xᵀQ⁻¹x: the bound assumes x(t) ∈ F.
    pub left_f: Option<(f64, f64)>,
    /// The first time a parameter left Θ or an input its declared range.
    pub left_theta: Option<f64>,
    /// A parameter or input that moved faster than its declared rate (a
    /// finite difference over one substep above it): name, time, slope.
    pub rate_exceeded: Option<(String, f64, f64)>,
    /// ‖e‖ at the last sample.
    pub last_error: f64,
    /// When the simulation produced a non-finite value.
    pub diverged_at: Option<f64>,
    /// With measurement noise of amplitude ν: the discrete noise claim's σ
    /// at this h recomputed from the gains (None: not certified), and the
    /// largest ν keeping the certified set invariant, ν_c.
    pub noise: Option<NoiseInRun>,
    /// Why the claim was withdrawn ([`SampledCheck::withdraw`]), if it was.
    pub withdrawn: Option<String>,
}

impl SampledCheck {
    /// Withdraws the claim (a report whose own verdict is short of
    /// certified): the run is reported, nothing is compared with a bound.
    pub fn withdraw(&mut self, why: &str) {
        self.withdrawn = Some(why.to_string());
    }

    /// The run violates the certified bound although its premises held:
    /// certified, bound computed and invariant, e(0) in {V ≤ 1}, x in F,
    /// θ in Θ, and √V(e_k) above b_k (or the run diverged).
    pub fn violated(&self) -> bool {
        if self.withdrawn.is_some() {
            return false;
        }
        let bound = self.claim.bound.as_ref().ok();
        let premises = bound.is_some_and(|b| b.holds())
            && (self.v0_sqrt <= 1.0 || bound.is_some_and(|b| b.global))
            && self.left_f.is_none()
            && self.left_theta.is_none()
            && self.rate_exceeded.is_none();
        premises && (self.exceeded.is_some() || self.diverged_at.is_some())
    }
}

/// Runs [`simulate_sampled_each`] with `design`'s gains on the plant
/// `model` (the observer model of the design, [`Design::observer_model`])
/// and compares √V(e_k) with the certified recursion, every figure
/// recomputed from the model and the gains ([`sampled_claim`]). Rate
/// premises (a parameter faster than its declared rate) are the caller's:
/// the run follows the scenario's signals.
pub fn check_sampled_run(
    model: &PolytopicModel,
    design: &Design,
    scenario: &Scenario,
    run: &SampledRun,
) -> Result<SampledCheck, SimError> {
    let obs = design
        .observer_model(model)
        .map_err(|e| SimError::Model(e.to_string()))?;
    let claim = sampled_claim(model, design, run.h);
    let p = design.p_matrix();
    if p.shape() != (obs.nx(), obs.nx()) {
        return Err(SimError::Shape {
            what: "P".into(),
            expected: (obs.nx(), obs.nx()),
            got: p.shape(),
        });
    }
    let gains = design.l_matrices();
    let mut rec = match &claim.bound {
        Ok(b) => Recursion {
            rho: (1.0 - run.h * claim.alpha).sqrt(),
            delta: b.delta,
            ultimate: b.ultimate_v_sqrt,
            bound: f64::NAN,
            noise2: 0.0,
            scale: 0.0,
            floor: 0.0,
        },
        Err(_) => Recursion {
            rho: f64::NAN,
            delta: f64::NAN,
            ultimate: f64::NAN,
            bound: f64::NAN,
            noise2: 0.0,
            scale: 0.0,
            floor: 0.0,
        },
    };
    let v_sqrt = |x: &[f64], xh: &[f64]| {
        let e = DVector::from_iterator(x.len(), x.iter().zip(xh).map(|(a, b)| a - b));
        e.dot(&(&p * &e)).max(0.0).sqrt()
    };
    let mut out = SampledCheck {
        claim,
        v0_sqrt: v_sqrt(&scenario.x0, &scenario.xhat0),
        samples: 0,
        worst_ratio: 0.0,
        exceeded: None,
        entered_at: None,
        left_f: None,
        left_theta: None,
        rate_exceeded: None,
        last_error: f64::NAN,
        diverged_at: None,
        noise: None,
        withdrawn: None,
    };
    out.noise = run.noise.as_ref().map(|n| {
        let ni = noise_in_run(&obs, design, &out.claim, n, (&p, &gains));
        rec.add_noise(&ni, (run.h, out.claim.alpha));
        ni
    });
    rec.bound = out.v0_sqrt;
    let p_top = ((&p + p.transpose()) * 0.5)
        .symmetric_eigenvalues()
        .max()
        .max(0.0);
    // x is checked against the Q the bound assumes (for the global
    // observer, the plant's declared operating envelope).
    let envelope = bound_model(model, design).unwrap_or_else(|_| obs.clone());
    let mut premises = Premises::of(&envelope, run);
    let mut each = |r: &SampledRow<'_>| {
        premises.see(r, &mut out);
        if r.sample {
            out.last_error = error_norm(r.x, r.xhat);
            // The arithmetic's resolution in √V: never a violation below it.
            let here = r.x.iter().chain(r.xhat).fold(0.0f64, |m, v| m.max(v.abs()));
            rec.scale = rec.scale.max(here);
            rec.floor = p_top.sqrt()
                * crate::analysis::envelope::arithmetic_floor(
                    1.0,
                    out.claim.alpha,
                    run.h,
                    rec.scale,
                );
            rec.sample(r.t, v_sqrt(r.x, r.xhat), &mut out);
        }
        true
    };
    out.diverged_at = simulate_sampled_each(&obs, &gains, scenario, run, &mut each)?;
    Ok(out)
}

/// The premises of the bound along a run: x in F, θ and u in their
/// ranges, and the signals the plant follows within their declared rates.
struct Premises {
    q_inv: Option<DMatrix<f64>>,
    ranges: Vec<Option<(f64, f64)>>,
    rates: Vec<Option<f64>>,
    names: Vec<String>,
    prev: Option<(f64, Vec<f64>)>,
}

impl Premises {
    fn of(obs: &PolytopicModel, run: &SampledRun) -> Premises {
        let q_inv = q_inv_of(obs);
        let input = |j: usize| {
            (
                obs.input_rates.get(j).copied().flatten(),
                run.hold_inputs[j],
            )
        };
        Premises {
            q_inv,
            ranges: obs
                .params
                .iter()
                .map(|p| Some((p.lo, p.hi)))
                .chain((0..obs.nu()).map(|j| obs.input_ranges.get(j).copied().flatten()))
                .collect(),
            // Held signals have no rate to keep.
            rates: obs
                .params
                .iter()
                .zip(&run.hold_params)
                .map(|(p, &held)| if held { None } else { p.rate })
                .chain((0..obs.nu()).map(|j| match input(j) {
                    (_, true) => None,
                    (rate, false) => rate,
                }))
                .collect(),
            names: obs
                .params
                .iter()
                .map(|p| p.name.clone())
                .chain(obs.inputs.iter().cloned())
                .collect(),
            prev: None,
        }
    }

    /// Records in `out` the first broken premise of row `r`.
    fn see(&mut self, r: &SampledRow<'_>, out: &mut SampledCheck) {
        see_f(&self.q_inv, (r.t, r.x), &mut out.left_f);
        let now: Vec<f64> = r.theta.iter().chain(r.u).copied().collect();
        let outside = self
            .ranges
            .iter()
            .zip(&now)
            .any(|(b, &v)| b.is_some_and(|(lo, hi)| v < lo - 1e-12 || v > hi + 1e-12));
        if outside && out.left_theta.is_none() {
            out.left_theta = Some(r.t);
        }
        if let Some((t0, before)) = &self.prev {
            let dt = r.t - t0;
            for (i, (a, b)) in before.iter().zip(&now).enumerate() {
                let slope = (b - a).abs() / dt;
                if self.rates[i].is_some_and(|rate| dt > 0.0 && slope > rate * (1.0 + 1e-6))
                    && out.rate_exceeded.is_none()
                {
                    out.rate_exceeded = Some((self.names[i].clone(), r.t, slope));
                }
            }
        }
        self.prev = Some((r.t, now));
    }
}

/// The certified recursion b_{k+1} = ρ b_k + δ and its limit.
struct Recursion {
    rho: f64,
    delta: f64,
    ultimate: f64,
    bound: f64,
    /// hσν²: the noise term of b_{k+1} = √(ρ²b_k² + hσν²) + δ.
    noise2: f64,
    /// The largest |x_i| or |x̂_i| so far, and the run's resolution in √V
    /// below which nothing is compared ([`crate::analysis::envelope::arithmetic_floor`]).
    scale: f64,
    floor: f64,
}

/// σ of the discrete noise claim for the run's noise channels, recomputed
/// from the gains at the claim's (h, α), and ν_c.
fn noise_in_run(
    obs: &PolytopicModel,
    design: &Design,
    claim: &SampledClaim,
    n: &MeasurementNoise,
    (p, gains): (&DMatrix<f64>, &[DMatrix<f64>]),
) -> NoiseInRun {
    let channels = crate::model::noise::NoiseChannels {
        outputs: Some(n.outputs().to_vec()),
        b_w: None,
    };
    let sigma = crate::certificate::noise_sampled::SampledNoise {
        model: obs,
        channels: &channels,
        alpha: claim.alpha,
        gamma: design.gamma,
        h: claim.h,
    }
    .bound(p, gains)
    .map(|b| b.sigma);
    let amplitude_max = match (&claim.bound, sigma) {
        (Ok(b), Some(s)) => b.amplitude_limit((claim.h, claim.alpha), s),
        _ => 0.0,
    };
    NoiseInRun {
        amplitude: n.amplitude(),
        sigma,
        amplitude_max,
    }
}

impl Recursion {
    /// The noise term: b_{k+1} = √(ρ²b_k² + hσν²) + δ, ultimate bound
    /// δ/(1 − ρ) + ν√(σ/α) (docs/method.md §16). Without a certified σ, or
    /// above ν_c, there is no bound and nothing is compared.
    fn add_noise(&mut self, ni: &NoiseInRun, (h, alpha): (f64, f64)) {
        match ni.sigma {
            Some(s) if ni.amplitude <= ni.amplitude_max => {
                self.noise2 = h * s * ni.amplitude * ni.amplitude;
                self.ultimate += ni.amplitude * (s / alpha).sqrt();
            }
            _ => self.rho = f64::NAN,
        }
    }

    /// Compares √V(e_k) = `v` at sample time `t` with b_k (b_0 = √V(e_0)).
    fn sample(&mut self, t: f64, v: f64, out: &mut SampledCheck) {
        if out.samples > 0 {
            let b = self.rho * self.bound;
            self.bound = (b * b + self.noise2).sqrt() + self.delta;
        }
        out.samples += 1;
        let bound = self.bound;
        if !bound.is_finite() {
            return;
        }
        let ratio = if bound > 0.0 {
            v / bound
        } else if v > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        if out.samples > 1 {
            out.worst_ratio = out.worst_ratio.max(ratio);
        }
        if v > bound * (1.0 + BOUND_SLACK) + self.floor + 1e-300 {
            record(&mut out.exceeded, t, ratio);
        }
        if v <= self.ultimate * (1.0 + BOUND_SLACK) {
            out.entered_at.get_or_insert(t);
        } else {
            out.entered_at = None;
        }
    }
}
