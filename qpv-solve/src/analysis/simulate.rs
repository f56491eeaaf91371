//! Simulation of the plant and the observer (docs/method.md): plant and
//! observer integrated together by RK4 ([`simulate`], [`simulate_each`]),
//! with optional measurement noise. The pieces live beside it and are
//! re-exported here: the input checks ([`SimError`]), the reference
//! right-hand sides ([`plant_derivative`], [`observer_derivative`]), the
//! scenarios ([`Scenario`]), the trajectory and its CSV ([`Trajectory`]),
//! the certified envelopes ([`envelope_factor`], [`NoiseEnvelope`]) and the
//! run's verdict ([`ContinuousCheck`]).
//!
//! The plant is
//!
//! ```text
//! x' = A(θ) x + N(θ, x) x + B(θ) u,      y = C x + M(x) x,
//! ```
//!
//! with A(θ) = Σ_l μ_l(θ) A_l (likewise N_k, B), row k of N(θ, x) x equal to
//! xᵀ N_k(θ) x and row k of M(x) x equal to xᵀ M_k x. The observer is
//! docs/method.md §2:
//!
//! ```text
//! x̂' = A(θ) x̂ + N(θ, x̂) x̂ + B(θ) u + L(θ) [ y − C x̂ − M(x̂) x̂ ],   L(θ) = Σ_l μ_l(θ) L_l.
//! ```
//!
//! Vectors are taken as slices and returned as `Vec<f64>`. Every function
//! checks dimensions and finiteness of the model and the gains and returns a
//! [`SimError`] instead of panicking.
//!
//! ```
//! use nalgebra::DMatrix;
//! use qpv_solve::simulate::{simulate, Scenario};
//!
//! let src = "model decay {
//!     state x1, x2;  output y;  param th in [0, 1];
//!     der x1 = -(1 + th)*x1 + x2;
//!     der x2 = -x2 + x1*x2;
//!     out y = x1;
//!     region box(0.1);
//! }";
//! let model = qpv_dsl::parse(src)?.remove(0).polytopic();
//! // one gain L_l (nx × ny) per vertex
//! let gains = vec![DMatrix::from_row_slice(2, 1, &[2.0, 0.5]); model.nv()];
//! let traj = simulate(&model, &gains, &Scenario::default_for(&model))?;
//! assert_eq!(traj.diverged_at, None);
//! assert!(traj.error_norm.last() < traj.error_norm.first());
//!
//! let mut csv = Vec::new();
//! traj.write_csv(&model, &mut csv)?;
//! assert!(csv.starts_with(b"t,x1,x2,xhat1,xhat2,th,y,mu1,mu2,error_norm"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub use crate::analysis::checks::SimError;
pub use crate::analysis::continuous::ContinuousCheck;
pub use crate::analysis::envelope::{envelope_factor, NoiseEnvelope};
pub use crate::analysis::rhs::{observer_derivative, plant_derivative, plant_output};
pub use crate::analysis::scenario::{Scenario, Signal, MAX_STEPS};
pub use crate::analysis::trajectory::{Row, Trajectory, TrajectoryCsv, SETTLED};

use crate::analysis::integrate::Rk4;
use crate::analysis::rhs::Frozen;
use crate::analysis::scenario::check_run;
use crate::analysis::trajectory::{error_norm, recorded};
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// Plant and observer stacked as one ODE z = (x, x̂), with reusable buffers
/// (the RK4 run here and the Euler run, [`crate::analysis::euler`]).
pub(crate) struct Closed<'a> {
    model: &'a PolytopicModel,
    gains: &'a [DMatrix<f64>],
    scenario: &'a Scenario,
    frozen: Frozen,
    theta: Vec<f64>,
    u: Vec<f64>,
    y: Vec<f64>,
    yhat: Vec<f64>,
    /// Measurement noise added to y over the current step, if any.
    v: Option<Vec<f64>>,
}

impl<'a> Closed<'a> {
    pub(crate) fn new(
        model: &'a PolytopicModel,
        gains: &'a [DMatrix<f64>],
        scenario: &'a Scenario,
    ) -> Self {
        Closed {
            model,
            gains,
            scenario,
            frozen: Frozen::new(model),
            theta: vec![0.0; model.ntheta()],
            u: vec![0.0; model.nu()],
            y: vec![0.0; model.ny()],
            yhat: vec![0.0; model.ny()],
            v: None,
        }
    }

    /// dz = f(t, z); false if θ(t) or u(t) is not finite.
    pub(crate) fn rhs(&mut self, t: f64, z: &[f64], dz: &mut [f64]) -> bool {
        let nx = self.model.nx();
        self.scenario.theta_into(t, &z[..nx], &mut self.theta);
        self.scenario.u_into(t, &mut self.u);
        if self.theta.iter().chain(&self.u).any(|v| !v.is_finite()) {
            return false;
        }
        self.frozen.set(self.model, self.gains, &self.theta);
        let (x, xhat) = z.split_at(nx);
        let (dx, dxhat) = dz.split_at_mut(nx);
        self.frozen.plant(x, &self.u, dx);
        // the observer, eq. (9), fed the measurement y + v
        self.frozen.output(x, &mut self.y);
        if let Some(v) = &self.v {
            for (y, v) in self.y.iter_mut().zip(v) {
                *y += v;
            }
        }
        let io = (&mut self.y[..], &mut self.yhat[..]);
        self.frozen.observer((xhat, &self.u), io, dxhat);
        true
    }

    /// Hands the row for time `t` to `each` (θ(t) and u(t) are evaluated
    /// again for the row); `each`'s answer: whether the run goes on.
    pub(crate) fn emit(
        &mut self,
        t: f64,
        z: &[f64],
        each: &mut dyn FnMut(&Row<'_>) -> bool,
    ) -> bool {
        let nx = self.model.nx();
        self.scenario.theta_into(t, &z[..nx], &mut self.theta);
        self.scenario.u_into(t, &mut self.u);
        let mu = self.model.mu(&self.theta);
        each(&Row {
            t,
            x: &z[..nx],
            xhat: &z[nx..],
            theta: &self.theta,
            u: &self.u,
            mu: &mu,
            error_norm: error_norm(&z[..nx], &z[nx..]),
        })
    }
}

/// Bounded measurement noise for [`simulate_each`]: at every step a random
/// direction on the noisy outputs, scaled to the amplitude ν (the largest
/// a noise bound allows), zero on the other outputs, held over the step.
/// Seeded (splitmix64, the falsifier's generator), so a run is the same on
/// every platform.
#[derive(Debug, Clone)]
pub struct MeasurementNoise {
    rng: crate::analysis::rng::Rng,
    amplitude: f64,
    outputs: Vec<usize>,
}

impl MeasurementNoise {
    /// Noise of amplitude `amplitude` on the outputs `outputs` (indices),
    /// from `seed`.
    pub fn new(seed: u64, amplitude: f64, outputs: Vec<usize>) -> Self {
        MeasurementNoise {
            rng: crate::analysis::rng::Rng(seed ^ 0x9E37_79B9_7F4A_7C15),
            amplitude,
            outputs,
        }
    }

    /// The amplitude ν: every noise vector has Euclidean norm ν.
    pub fn amplitude(&self) -> f64 {
        self.amplitude
    }

    /// The indices of the outputs the noise enters.
    pub fn outputs(&self) -> &[usize] {
        &self.outputs
    }

    /// The next noise vector on all `ny` outputs: a direction uniform in
    /// the unit ball (by rejection), normalised and scaled to ν on the
    /// noisy outputs, zero on the others.
    pub fn sample(&mut self, ny: usize) -> Vec<f64> {
        let mut v = vec![0.0; ny];
        if self.outputs.is_empty() {
            return v;
        }
        let dir: Vec<f64> = loop {
            let d: Vec<f64> = (0..self.outputs.len())
                .map(|_| self.rng.uniform() * 2.0 - 1.0)
                .collect();
            let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n > 1e-3 && n <= 1.0 {
                break d.iter().map(|x| x / n).collect();
            }
        };
        for (k, &i) in self.outputs.iter().enumerate() {
            if i < ny {
                v[i] = self.amplitude * dir[k];
            }
        }
        v
    }
}

/// Simulates plant and observer (docs/method.md §2) with classical fixed-step RK4;
/// θ and u are sampled at the RK4 stage times and y = C x + M(x) x is taken
/// from the plant's stage state. Every step is recorded (at most
/// [`crate::analysis::trajectory::MAX_RECORDED_STEPS`]; [`simulate_each`] streams longer runs).
///
/// Returns an error for inconsistent input (sizes, non-finite data, time
/// grid). If the state or the estimate becomes non-finite, the simulation
/// stops and [`Trajectory::diverged_at`] says when.
pub fn simulate(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    scenario: &Scenario,
) -> Result<Trajectory, SimError> {
    // A bad grid is reported by simulate_each, after the model's checks.
    let steps = recorded(scenario.steps().unwrap_or(0))?;
    let mut traj = Trajectory::with_capacity(steps + 1);
    traj.diverged_at = simulate_each(model, gains, scenario, None, &mut |r| {
        traj.push(r);
        true
    })?;
    Ok(traj)
}

/// The run of [`simulate`], optionally with measurement noise (`noise`:
/// the observer is fed y + v, v drawn once per step and held over it),
/// each row handed to `each` instead of recorded, so memory does not grow
/// with the run (at most [`MAX_STEPS`] steps). `each` returns whether the
/// run goes on. Returns the time a non-finite value appeared (in x, x̂, θ
/// or u at an RK4 stage), if one did; the rows before it were handed out.
pub fn simulate_each(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    scenario: &Scenario,
    mut noise: Option<&mut MeasurementNoise>,
    each: &mut dyn FnMut(&Row<'_>) -> bool,
) -> Result<Option<f64>, SimError> {
    check_run(model, gains, scenario)?;
    let steps = scenario.steps()?;
    let mut sys = Closed::new(model, gains, scenario);
    let mut z: Vec<f64> = scenario.x0.iter().chain(&scenario.xhat0).copied().collect();
    let mut rk4 = Rk4::new(z.len());
    if !scenario
        .theta
        .iter()
        .all(|s| s.value(0.0, &scenario.x0).is_finite())
    {
        return Ok(Some(0.0));
    }
    if !sys.emit(0.0, &z, each) {
        return Ok(None);
    }
    for k in 0..steps {
        let t = k as f64 * scenario.dt;
        let t_next = if k + 1 == steps {
            scenario.t_end
        } else {
            (k + 1) as f64 * scenario.dt
        };
        if let Some(n) = noise.as_deref_mut() {
            sys.v = Some(n.sample(model.ny()));
        }
        let mut f = |t: f64, z: &[f64], dz: &mut [f64]| sys.rhs(t, z, dz);
        if !rk4.step(&mut f, (t, t_next - t, t_next), &mut z) {
            return Ok(Some(t));
        }
        let x = &z[..model.nx()];
        let theta_ok = scenario
            .theta
            .iter()
            .all(|s| s.value(t_next, x).is_finite());
        if !theta_ok || z.iter().any(|v| !v.is_finite()) {
            return Ok(Some(t_next));
        }
        if !sys.emit(t_next, &z, each) {
            return Ok(None);
        }
    }
    Ok(None)
}
