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

use crate::analysis::simulate::{check_gains, check_model, Frozen, Scenario, SimError, MAX_STEPS};
use crate::report::continuous::{sampled_claim, SampledClaim};
use crate::report::Design;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{PolytopicModel, StateBound};

/// The fewest RK4 substeps per sample period (the plant at h/20 or finer).
pub const MIN_SUBSTEPS: usize = 20;

/// Relative slack of the comparison with the certified recursion (RK4's own
/// error at h/20 and rounding).
pub const BOUND_SLACK: f64 = 1e-6;

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
        }
    }
}

/// One instant of a sampled run: every plant substep, and `sample` set at
/// the sample instants t_k = kh (after the observer's state is x̂_k).
#[derive(Debug, Clone, Copy)]
pub struct SampledRow<'a> {
    /// Time.
    pub t: f64,
    /// True at t_k = kh.
    pub sample: bool,
    /// Plant state x(t).
    pub x: &'a [f64],
    /// The observer's state x̂_k (held between samples).
    pub xhat: &'a [f64],
    /// θ(t) as the plant sees it.
    pub theta: &'a [f64],
    /// u(t) as the plant sees it.
    pub u: &'a [f64],
}

/// Runs the continuous plant (RK4 at h/substeps) against the observer
/// stepped at h, handing every substep's row to `each` (false stops the
/// run). Returns the time a non-finite value appeared, if one did.
pub fn simulate_sampled_each(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    scenario: &Scenario,
    run: &SampledRun,
    each: &mut dyn FnMut(&SampledRow<'_>) -> bool,
) -> Result<Option<f64>, SimError> {
    check_model(model)?;
    check_gains(model, gains)?;
    let (nx, ny) = (model.nx(), model.ny());
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
    if scenario.theta.len() != model.ntheta() || scenario.u.len() != model.nu() {
        return Err(SimError::Length {
            what: "scenario theta / u".into(),
            expected: model.ntheta() + model.nu(),
            got: scenario.theta.len() + scenario.u.len(),
        });
    }
    for (what, v) in [("x0", &scenario.x0), ("xhat0", &scenario.xhat0)] {
        if v.len() != nx || v.iter().any(|x| !x.is_finite()) {
            return Err(SimError::Length {
                what: what.into(),
                expected: nx,
                got: v.len(),
            });
        }
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
    let samples = samples as usize;
    let dt = h / run.substeps as f64;
    let mut frozen = Frozen::new(model);
    let mut x = scenario.x0.clone();
    let mut xh = scenario.xhat0.clone();
    let (mut y, mut yh, mut dxh) = (vec![0.0; ny], vec![0.0; ny], vec![0.0; nx]);
    let mut th = vec![0.0; model.ntheta()];
    let mut u = vec![0.0; model.nu()];
    let mut stages = [vec![0.0; nx], vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]];
    let mut tmp = vec![0.0; nx];
    for k in 0..=samples {
        let tk = k as f64 * h;
        let th_k: Vec<f64> = scenario.theta.iter().map(|s| s.at(tk)).collect();
        let u_k: Vec<f64> = scenario.u.iter().map(|s| s.at(tk)).collect();
        if th_k
            .iter()
            .chain(&u_k)
            .chain(&x)
            .chain(&xh)
            .any(|v| !v.is_finite())
        {
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
        // The observer's step on the samples (the generated `step`).
        frozen.set(model, gains, &th_k);
        frozen.output(&x, &mut y);
        frozen.output(&xh, &mut yh);
        for (a, b) in y.iter_mut().zip(&yh) {
            *a -= b;
        }
        frozen.drift(&xh, &mut dxh);
        frozen.add_input(&u_k, &mut dxh);
        frozen.add_gain(&y, &mut dxh);
        for (v, d) in xh.iter_mut().zip(&dxh) {
            *v += h * d;
        }
        // The plant over [t_k, t_k + h]: RK4 at h/substeps.
        let mut rhs = |t: f64, x: &[f64], out: &mut [f64]| -> bool {
            for (i, s) in scenario.theta.iter().enumerate() {
                th[i] = if run.hold_params[i] { th_k[i] } else { s.at(t) };
            }
            for (j, s) in scenario.u.iter().enumerate() {
                u[j] = if run.hold_inputs[j] { u_k[j] } else { s.at(t) };
            }
            if th.iter().chain(&u).any(|v| !v.is_finite()) {
                return false;
            }
            frozen.set(model, &[], &th);
            frozen.drift(x, out);
            frozen.add_input(&u, out);
            true
        };
        for n in 0..run.substeps {
            let t = tk + n as f64 * dt;
            let [k1, k2, k3, k4] = &mut stages;
            let mut ok = rhs(t, &x, k1);
            axpy(&mut tmp, &x, 0.5 * dt, k1);
            ok = ok && rhs(t + 0.5 * dt, &tmp, k2);
            axpy(&mut tmp, &x, 0.5 * dt, k2);
            ok = ok && rhs(t + 0.5 * dt, &tmp, k3);
            axpy(&mut tmp, &x, dt, k3);
            ok = ok && rhs(t + dt, &tmp, k4);
            if !ok {
                return Ok(Some(t));
            }
            for i in 0..nx {
                x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            if x.iter().any(|v| !v.is_finite()) {
                return Ok(Some(t + dt));
            }
            if n + 1 < run.substeps {
                let theta: Vec<f64> = (0..th_k.len())
                    .map(|i| {
                        if run.hold_params[i] {
                            th_k[i]
                        } else {
                            scenario.theta[i].at(t + dt)
                        }
                    })
                    .collect();
                let inputs: Vec<f64> = (0..u_k.len())
                    .map(|j| {
                        if run.hold_inputs[j] {
                            u_k[j]
                        } else {
                            scenario.u[j].at(t + dt)
                        }
                    })
                    .collect();
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

/// dst = x + c·k.
fn axpy(dst: &mut [f64], x: &[f64], c: f64, k: &[f64]) {
    for ((d, xi), ki) in dst.iter_mut().zip(x).zip(k) {
        *d = xi + c * ki;
    }
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
}

impl SampledCheck {
    /// The run violates the certified bound although its premises held:
    /// certified, bound computed and invariant, e(0) in {V ≤ 1}, x in F,
    /// θ in Θ, and √V(e_k) above b_k (or the run diverged).
    pub fn violated(&self) -> bool {
        let premises = self.claim.bound.as_ref().is_ok_and(|b| b.invariant)
            && self.v0_sqrt <= 1.0
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
    let q_inv = match &obs.state_bound {
        StateBound::Given(q) => q.clone().try_inverse(),
        _ => None,
    };
    let gains = design.l_matrices();
    let (rho, delta, ult) = match &claim.bound {
        Ok(b) => (
            (1.0 - run.h * claim.alpha).sqrt(),
            b.delta,
            b.ultimate_v_sqrt,
        ),
        Err(_) => (f64::NAN, f64::NAN, f64::NAN),
    };
    let v_sqrt = |x: &[f64], xh: &[f64]| {
        let e = DVector::from_iterator(x.len(), x.iter().zip(xh).map(|(a, b)| a - b));
        e.dot(&(&p * &e)).max(0.0).sqrt()
    };
    let mut out = SampledCheck {
        claim: claim.clone(),
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
    };
    let mut bound = out.v0_sqrt;
    // The declared rates of the signals the plant follows (held ones: none).
    let rates: Vec<Option<f64>> = obs
        .params
        .iter()
        .zip(&run.hold_params)
        .map(|(p, &held)| if held { None } else { p.rate })
        .chain((0..obs.nu()).map(|j| {
            let rate = obs.input_rates.get(j).copied().flatten();
            if run.hold_inputs.get(j).copied().unwrap_or(true) {
                None
            } else {
                rate
            }
        }))
        .collect();
    let names: Vec<String> = obs
        .params
        .iter()
        .map(|p| p.name.clone())
        .chain(obs.inputs.iter().cloned())
        .collect();
    let mut prev: Option<(f64, Vec<f64>)> = None;
    let mut each = |r: &SampledRow<'_>| {
        if let Some(qi) = &q_inv {
            let xs = DVector::from_column_slice(r.x);
            let s = xs.dot(&(qi * &xs));
            if s > 1.0 + 1e-9 {
                let f = out.left_f.get_or_insert((r.t, s));
                f.1 = f.1.max(s);
            }
        }
        let ranges = obs
            .params
            .iter()
            .map(|p| Some((p.lo, p.hi)))
            .chain((0..obs.nu()).map(|j| obs.input_ranges.get(j).copied().flatten()));
        let now: Vec<f64> = r.theta.iter().chain(r.u).copied().collect();
        let outside = ranges
            .zip(&now)
            .any(|(b, &v)| b.is_some_and(|(lo, hi)| v < lo - 1e-12 || v > hi + 1e-12));
        if outside && out.left_theta.is_none() {
            out.left_theta = Some(r.t);
        }
        if let Some((t0, before)) = &prev {
            let dt = r.t - t0;
            for (i, (a, b)) in before.iter().zip(&now).enumerate() {
                let slope = (b - a).abs() / dt;
                if rates[i].is_some_and(|rate| dt > 0.0 && slope > rate * (1.0 + 1e-6))
                    && out.rate_exceeded.is_none()
                {
                    out.rate_exceeded = Some((names[i].clone(), r.t, slope));
                }
            }
        }
        prev = Some((r.t, now));
        if !r.sample {
            return true;
        }
        if out.samples > 0 {
            bound = rho * bound + delta;
        }
        out.samples += 1;
        let v = v_sqrt(r.x, r.xhat);
        out.last_error =
            r.x.iter()
                .zip(r.xhat)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
        if bound.is_finite() {
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
            if v > bound * (1.0 + BOUND_SLACK) + 1e-300 {
                let e = out.exceeded.get_or_insert((r.t, ratio));
                e.1 = e.1.max(ratio);
            }
            if v <= ult * (1.0 + BOUND_SLACK) {
                out.entered_at.get_or_insert(r.t);
            } else {
                out.entered_at = None;
            }
        }
        true
    };
    let diverged = simulate_sampled_each(&obs, &gains, scenario, run, &mut each)?;
    out.diverged_at = diverged;
    Ok(out)
}
