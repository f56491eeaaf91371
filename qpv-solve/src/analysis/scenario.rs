//! What a run is driven by: the signals θ(t) and u(t), the initial states
//! and the time grid ([`Scenario`]), with the ready-made scenarios.

use crate::analysis::checks::{check_gains, check_len, check_model, SimError};
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;
use std::f64::consts::PI;
use std::fmt;
use std::sync::Arc;

/// Largest number of RK4 steps of one run
/// ([`crate::analysis::simulate::simulate_each`] hands every step out and
/// keeps none, so memory does not grow with the run).
pub const MAX_STEPS: usize = 100_000_000;

/// A scalar signal of time: one component of θ(t) or u(t).
#[derive(Clone)]
pub enum Signal {
    /// A constant value.
    Constant(f64),
    /// offset + amplitude · sin(omega · t + phase).
    Sin {
        /// Mean value.
        offset: f64,
        /// Amplitude.
        amplitude: f64,
        /// Angular frequency in rad/s.
        omega: f64,
        /// Phase in rad.
        phase: f64,
    },
    /// offset + amplitude · cos(omega · t + phase).
    Cos {
        /// Mean value.
        offset: f64,
        /// Amplitude.
        amplitude: f64,
        /// Angular frequency in rad/s.
        omega: f64,
        /// Phase in rad.
        phase: f64,
    },
    /// Any function of time.
    Custom(Arc<dyn Fn(f64) -> f64 + Send + Sync>),
    /// The plant's state k (0-based) as it runs: a parameter fed with a
    /// measured state (`param p in [lo, hi]` scheduling a term of degree 3
    /// on a measured factor), so that the run simulates the plant as
    /// written rather than a prescribed p(t). Only a parameter can be tied
    /// to a state; its value is [`Signal::value`]'s.
    State(usize),
    /// The plant's output cᵀx as the run goes (the row c, one entry per
    /// state): a parameter computed from a measured output (`param p =
    /// y1`), tied to it by [`Scenario::default_for`] and
    /// [`Scenario::paper`].
    Output(Vec<f64>),
}

impl Signal {
    /// A signal given by a closure.
    pub fn custom(f: impl Fn(f64) -> f64 + Send + Sync + 'static) -> Self {
        Signal::Custom(Arc::new(f))
    }

    /// The signal's value at time `t` and plant state `x` (only
    /// [`Signal::State`] reads `x`; a state index outside `x` is NaN).
    pub fn value(&self, t: f64, x: &[f64]) -> f64 {
        match self {
            Signal::State(k) => x.get(*k).copied().unwrap_or(f64::NAN),
            Signal::Output(c) if c.len() == x.len() => c.iter().zip(x).map(|(a, b)| a * b).sum(),
            Signal::Output(_) => f64::NAN,
            other => other.at(t),
        }
    }

    /// The signal's value at time `t` (NaN for [`Signal::State`], which
    /// needs the plant's state: [`Signal::value`]).
    pub fn at(&self, t: f64) -> f64 {
        match self {
            Signal::State(_) | Signal::Output(_) => f64::NAN,
            Signal::Constant(c) => *c,
            Signal::Sin {
                offset,
                amplitude,
                omega,
                phase,
            } => offset + amplitude * (omega * t + phase).sin(),
            Signal::Cos {
                offset,
                amplitude,
                omega,
                phase,
            } => offset + amplitude * (omega * t + phase).cos(),
            Signal::Custom(f) => f(t),
        }
    }
}

impl fmt::Debug for Signal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Signal::Constant(c) => write!(f, "Constant({c})"),
            Signal::Sin {
                offset,
                amplitude,
                omega,
                phase,
            } => write!(f, "{offset} + {amplitude}·sin({omega}·t + {phase})"),
            Signal::Cos {
                offset,
                amplitude,
                omega,
                phase,
            } => write!(f, "{offset} + {amplitude}·cos({omega}·t + {phase})"),
            Signal::Custom(_) => write!(f, "Custom(..)"),
            Signal::State(k) => write!(f, "x{}(t)", k + 1),
            Signal::Output(c) => write!(f, "{c:?}·x(t)"),
        }
    }
}

/// A simulation scenario: θ(t), u(t), initial states and the time grid.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// θ_i(t), one signal per declared parameter.
    pub theta: Vec<Signal>,
    /// u_j(t), one signal per input.
    pub u: Vec<Signal>,
    /// Plant initial state x(0).
    pub x0: Vec<f64>,
    /// Observer initial state x̂(0).
    pub xhat0: Vec<f64>,
    /// Final time (≥ 0).
    pub t_end: f64,
    /// RK4 step (> 0); the last step is shortened to end exactly at `t_end`.
    pub dt: f64,
}

impl Scenario {
    /// The paper's scenario (docs/method.md): θ1(t) = 0.5 + 0.5 sin(4πt),
    /// θ2(t) = 0.5 + 0.5 cos(πt/5 + π/6), x(0) = (−0.02, −0.02, −0.02),
    /// x̂(0) = 0, u = 0, t_end = 2, dt = 1e-3.
    ///
    /// Sizes follow `model` (u has `model.nu()` zero signals); it is meant for
    /// the paper's example (nx = 3, two parameters), and [`crate::analysis::simulate::simulate`] reports
    /// a [`SimError`] if `model` does not fit.
    pub fn paper(model: &PolytopicModel) -> Self {
        Scenario {
            theta: vec![
                Signal::Sin {
                    offset: 0.5,
                    amplitude: 0.5,
                    omega: 4.0 * PI,
                    phase: 0.0,
                },
                Signal::Cos {
                    offset: 0.5,
                    amplitude: 0.5,
                    omega: PI / 5.0,
                    phase: PI / 6.0,
                },
            ],
            u: vec![Signal::Constant(0.0); model.nu()],
            x0: vec![-0.02; model.nx()],
            xhat0: vec![0.0; model.nx()],
            t_end: 2.0,
            dt: 1e-3,
        }
        .with_measured(model)
    }

    /// Every parameter computed from a measured output (`param p = y1`)
    /// tied to the plant's output ([`Signal::Output`]): the plant runs as
    /// written, and the parameter is what the deployed observer computes
    /// from the (noise-free) measurement.
    pub fn with_measured(mut self, model: &PolytopicModel) -> Self {
        for (s, p) in self.theta.iter_mut().zip(&model.params) {
            if let Some(m) = &p.measured {
                *s = Signal::Output(m.row.clone());
            }
        }
        self
    }

    /// A generic scenario for any model: x(0) = the first vertex of the
    /// convergence region (0 if the region has none), x̂(0) = 0, u = 0, and
    /// every θ_i sweeping its whole box, θ_i(t) = mid_i + half_i ·
    /// sin(2π f_i t) with f_i = 1 + i/2 Hz, t_end = 2, dt = 1e-3.
    pub fn default_for(model: &PolytopicModel) -> Self {
        let x0 = match model.region.vertices.first() {
            Some(v) if v.len() == model.nx() => v.iter().copied().collect(),
            _ => vec![0.0; model.nx()],
        };
        Scenario {
            theta: model
                .params
                .iter()
                .enumerate()
                .map(|(i, p)| Signal::Sin {
                    offset: 0.5 * (p.lo + p.hi),
                    amplitude: 0.5 * (p.hi - p.lo),
                    omega: 2.0 * PI * (1.0 + 0.5 * i as f64),
                    phase: 0.0,
                })
                .collect(),
            u: vec![Signal::Constant(0.0); model.nu()],
            x0,
            xhat0: vec![0.0; model.nx()],
            t_end: 2.0,
            dt: 1e-3,
        }
        .with_measured(model)
    }

    /// θ(t) at the plant's state `x` into `out`.
    pub(crate) fn theta_into(&self, t: f64, x: &[f64], out: &mut [f64]) {
        for (o, s) in out.iter_mut().zip(&self.theta) {
            *o = s.value(t, x);
        }
    }

    /// u(t) into `out`.
    pub(crate) fn u_into(&self, t: f64, out: &mut [f64]) {
        for (o, s) in out.iter_mut().zip(&self.u) {
            *o = s.at(t);
        }
    }

    /// Number of RK4 steps, checking the time grid (at most [`MAX_STEPS`]).
    pub(crate) fn steps(&self) -> Result<usize, SimError> {
        if !(self.t_end.is_finite() && self.t_end >= 0.0) {
            return Err(SimError::TimeGrid(format!("t_end = {}", self.t_end)));
        }
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(SimError::TimeGrid(format!("dt = {}", self.dt)));
        }
        // a tolerance so that t_end = 2, dt = 1e-3 gives 2000 steps, not 2001
        let n = (self.t_end / self.dt - 1e-9).ceil().max(0.0);
        if n > MAX_STEPS as f64 {
            return Err(SimError::TimeGrid(format!(
                "t_end / dt = {n} steps (at most {MAX_STEPS})"
            )));
        }
        Ok(n as usize)
    }
}

/// Checks a run's input: the model, the gains, x(0) and x̂(0) (finite, nx
/// entries) and one signal per parameter and input (the time grid is the
/// caller's: [`Scenario::steps`]).
pub(crate) fn check_run(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    scenario: &Scenario,
) -> Result<(), SimError> {
    check_model(model)?;
    check_gains(model, gains)?;
    check_len("x0", &scenario.x0, model.nx())?;
    check_len("xhat0", &scenario.xhat0, model.nx())?;
    for (what, got, expected) in [
        ("scenario theta", scenario.theta.len(), model.ntheta()),
        ("scenario u", scenario.u.len(), model.nu()),
    ] {
        if got != expected {
            return Err(SimError::Length {
                what: what.to_string(),
                expected,
                got,
            });
        }
    }
    Ok(())
}
