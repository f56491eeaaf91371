//! Simulation of the plant and the observer (docs/method.md): the reference
//! right-hand sides, ready-made scenarios and a fixed-step RK4 integrator.
//!
//! The plant is
//!
//! ```text
//! x' = A(θ) x + N(θ, x) x + B(θ) u,      y = C x + M(x) x,
//! ```
//!
//! with A(θ) = Σ_l μ_l(θ) A_l (likewise N_k, B), row k of N(θ, x) x equal to
//! xᵀ N_k(θ) x and row k of M(x) x equal to xᵀ M_k x. The observer is
//! spec eq. (9):
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
//! traj.write_csv(&mut csv)?;
//! assert!(csv.starts_with(b"t,x1,x2,xhat1,xhat2,theta1,mu1,mu2,error_norm"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;
use serde::Serialize;
use std::f64::consts::PI;
use std::fmt;
use std::io::{self, Write};
use std::sync::Arc;

/// Largest number of RK4 steps of one run ([`simulate_each`] hands every
/// step out and keeps none, so memory does not grow with the run).
pub const MAX_STEPS: usize = 100_000_000;

/// Largest number of steps a recorded [`Trajectory`] holds ([`simulate`],
/// [`crate::analysis::euler::simulate_euler`]): every row stays in memory
/// (a few hundred bytes each), so a longer run streams through
/// [`simulate_each`].
pub const MAX_RECORDED_STEPS: usize = MAX_STEPS / 10;

/// Largest number of scheduling parameters accepted (2^20 vertices).
const MAX_SCHEDULING: usize = 20;

/// Why a simulation or falsification could not be run on its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A vector has the wrong number of entries.
    #[error("{what} has {got} entries, expected {expected}")]
    Length {
        /// Which vector.
        what: String,
        /// The length implied by the model.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// A matrix has the wrong shape.
    #[error("{what} is {}×{}, expected {}×{}", got.0, got.1, expected.0, expected.1)]
    Shape {
        /// Which matrix.
        what: String,
        /// The shape implied by the model (rows, columns).
        expected: (usize, usize),
        /// The shape given (rows, columns).
        got: (usize, usize),
    },
    /// An input contains NaN or an infinity.
    #[error("{what} must be finite")]
    NotFinite {
        /// Which input.
        what: String,
    },
    /// A matrix that must be symmetric positive definite is not.
    #[error("{what} is not symmetric positive definite")]
    NotPositiveDefinite {
        /// Which matrix.
        what: String,
    },
    /// The model's own data is inconsistent (vertex count, parameter box).
    #[error("inconsistent model: {0}")]
    Model(String),
    /// The time grid is unusable: t_end < 0, dt ≤ 0, non-finite, or too many steps.
    #[error("invalid time grid: {0}")]
    TimeGrid(String),
    /// Some other argument is out of its documented range.
    #[error("invalid argument: {0}")]
    Argument(String),
}

fn check_len(what: &str, v: &[f64], expected: usize) -> Result<(), SimError> {
    if v.len() != expected {
        return Err(SimError::Length {
            what: what.to_string(),
            expected,
            got: v.len(),
        });
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(SimError::NotFinite {
            what: what.to_string(),
        });
    }
    Ok(())
}

fn check_matrix(what: &str, m: &DMatrix<f64>, rows: usize, cols: usize) -> Result<(), SimError> {
    if m.shape() != (rows, cols) {
        return Err(SimError::Shape {
            what: what.to_string(),
            expected: (rows, cols),
            got: m.shape(),
        });
    }
    if m.iter().any(|x| !x.is_finite()) {
        return Err(SimError::NotFinite {
            what: what.to_string(),
        });
    }
    Ok(())
}

/// Checks that every matrix of `model` has the shape implied by its names,
/// that the vertex count matches the scheduling parameters and that every
/// parameter box is a finite, non-empty interval.
pub fn check_model(model: &PolytopicModel) -> Result<(), SimError> {
    let (nx, nu, ny) = (model.nx(), model.nu(), model.ny());
    for p in &model.params {
        if !(p.lo.is_finite() && p.hi.is_finite() && p.lo < p.hi) {
            return Err(SimError::Model(format!(
                "parameter {} has the box [{}, {}]",
                p.name, p.lo, p.hi
            )));
        }
    }
    // derived scheduling variables φ_j(θ) double the vertices like parameters
    let s = model.scheduling.len() + model.derived.len();
    if s > MAX_SCHEDULING {
        return Err(SimError::Model(format!(
            "{s} scheduling parameters (at most {MAX_SCHEDULING} supported)"
        )));
    }
    if let Some(&i) = model.scheduling.iter().find(|&&i| i >= model.ntheta()) {
        return Err(SimError::Model(format!(
            "scheduling index {i} but only {} parameters",
            model.ntheta()
        )));
    }
    // 2^s corners per piece of the cover (one piece without a cover)
    let pieces = model.pieces();
    if let Some(c) = &model.cover {
        if c.pieces.iter().any(|p| {
            p.theta.len() != model.ntheta()
                || p.phi.len() != model.derived.len()
                || !p.theta.iter().chain(&p.phi).all(|&(lo, hi)| lo < hi)
        }) {
            return Err(SimError::Model(
                "a piece of the cover has ranges that do not match the model".into(),
            ));
        }
    }
    if model.nv() != pieces << s {
        return Err(SimError::Model(format!(
            "{} vertices for {s} scheduling parameters and {pieces} piece(s) (expected {})",
            model.nv(),
            pieces << s
        )));
    }
    for (l, v) in model.vertices.iter().enumerate() {
        check_matrix(&format!("A_{}", l + 1), &v.a, nx, nx)?;
        check_matrix(&format!("B_{}", l + 1), &v.b, nx, nu)?;
        if v.n.len() != nx {
            return Err(SimError::Model(format!(
                "vertex {} has {} matrices N_k, expected {nx}",
                l + 1,
                v.n.len()
            )));
        }
        for (k, n) in v.n.iter().enumerate() {
            check_matrix(&format!("N_{},{}", k + 1, l + 1), n, nx, nx)?;
        }
    }
    for (l, v) in model.vertices.iter().enumerate() {
        check_matrix(&format!("C_{}", l + 1), &v.c, ny, nx)?;
        if v.m.len() != ny {
            return Err(SimError::Model(format!(
                "vertex {} has {} matrices M_k, expected one per output ({ny})",
                l + 1,
                v.m.len()
            )));
        }
        for (k, m) in v.m.iter().enumerate() {
            check_matrix(&format!("M_{},{}", k + 1, l + 1), m, nx, nx)?;
        }
    }
    Ok(())
}

/// Checks that there is one finite nx × ny gain L_l per vertex.
pub(crate) fn check_gains(model: &PolytopicModel, gains: &[DMatrix<f64>]) -> Result<(), SimError> {
    if gains.len() != model.nv() {
        return Err(SimError::Length {
            what: "gains".to_string(),
            expected: model.nv(),
            got: gains.len(),
        });
    }
    for (l, g) in gains.iter().enumerate() {
        check_matrix(&format!("L_{}", l + 1), g, model.nx(), model.ny())?;
    }
    Ok(())
}

/// xᵀ T x for a square matrix T.
fn quad(t: &DMatrix<f64>, x: &[f64]) -> f64 {
    let mut s = 0.0;
    for (j, xj) in x.iter().enumerate() {
        let mut col = 0.0;
        for (i, xi) in x.iter().enumerate() {
            col += xi * t[(i, j)];
        }
        s += col * xj;
    }
    s
}

/// out += T v.
fn add_mul(out: &mut [f64], t: &DMatrix<f64>, v: &[f64]) {
    for (j, vj) in v.iter().enumerate() {
        for (i, o) in out.iter_mut().enumerate() {
            *o += t[(i, j)] * vj;
        }
    }
}

/// dst += w · src (same shapes).
fn add_scaled(dst: &mut DMatrix<f64>, w: f64, src: &DMatrix<f64>) {
    for (d, s) in dst.iter_mut().zip(src.iter()) {
        *d += w * s;
    }
}

/// The model's matrices frozen at one θ: μ(θ), A(θ), N_k(θ), B(θ), C(θ),
/// M_k(θ) and, when gains are given, L(θ). Buffers are reused between calls.
#[derive(Debug, Clone)]
pub(crate) struct Frozen {
    pub(crate) mu: Vec<f64>,
    a: DMatrix<f64>,
    n: Vec<DMatrix<f64>>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    m: Vec<DMatrix<f64>>,
    l: DMatrix<f64>,
}

impl Frozen {
    /// Zero buffers sized for `model` (which must have passed [`check_model`]).
    pub(crate) fn new(model: &PolytopicModel) -> Self {
        let (nx, nu, ny) = (model.nx(), model.nu(), model.ny());
        Frozen {
            mu: vec![0.0; model.nv()],
            a: DMatrix::zeros(nx, nx),
            n: vec![DMatrix::zeros(nx, nx); nx],
            b: DMatrix::zeros(nx, nu),
            c: DMatrix::zeros(ny, nx),
            m: vec![DMatrix::zeros(nx, nx); ny],
            l: DMatrix::zeros(nx, ny),
        }
    }

    /// Sets every matrix to its value at `theta`: X(θ) = Σ_l μ_l(θ) X_l.
    /// With `gains` empty, L(θ) = 0.
    pub(crate) fn set(&mut self, model: &PolytopicModel, gains: &[DMatrix<f64>], theta: &[f64]) {
        self.mu = model.mu(theta);
        self.a.fill(0.0);
        self.b.fill(0.0);
        self.c.fill(0.0);
        self.l.fill(0.0);
        for n in self.n.iter_mut().chain(self.m.iter_mut()) {
            n.fill(0.0);
        }
        for (l, (v, &w)) in model.vertices.iter().zip(&self.mu).enumerate() {
            add_scaled(&mut self.a, w, &v.a);
            add_scaled(&mut self.b, w, &v.b);
            add_scaled(&mut self.c, w, &v.c);
            for (n, nl) in self.n.iter_mut().zip(&v.n) {
                add_scaled(n, w, nl);
            }
            for (m, ml) in self.m.iter_mut().zip(&v.m) {
                add_scaled(m, w, ml);
            }
            if let Some(g) = gains.get(l) {
                add_scaled(&mut self.l, w, g);
            }
        }
    }

    /// out = A(θ) x + N(θ, x) x: the drift without input.
    pub(crate) fn drift(&self, x: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        add_mul(out, &self.a, x);
        for (o, nk) in out.iter_mut().zip(&self.n) {
            *o += quad(nk, x);
        }
    }

    /// out += B(θ) u.
    pub(crate) fn add_input(&self, u: &[f64], out: &mut [f64]) {
        add_mul(out, &self.b, u);
    }

    /// out += L(θ) v.
    pub(crate) fn add_gain(&self, v: &[f64], out: &mut [f64]) {
        add_mul(out, &self.l, v);
    }

    /// out = C(θ) x + M(θ, x) x: the output map.
    pub(crate) fn output(&self, x: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        add_mul(out, &self.c, x);
        for (o, mk) in out.iter_mut().zip(&self.m) {
            *o += quad(mk, x);
        }
    }
}

/// The plant's right-hand side x' = A(θ) x + N(θ, x) x + B(θ) u.
///
/// `theta` has one entry per declared parameter; scheduling parameters are
/// clamped into their box (as [`PolytopicModel::mu`] does).
pub fn plant_derivative(
    model: &PolytopicModel,
    x: &[f64],
    u: &[f64],
    theta: &[f64],
) -> Result<Vec<f64>, SimError> {
    check_model(model)?;
    check_len("x", x, model.nx())?;
    check_len("u", u, model.nu())?;
    check_len("theta", theta, model.ntheta())?;
    let mut frozen = Frozen::new(model);
    frozen.set(model, &[], theta);
    let mut dx = vec![0.0; model.nx()];
    frozen.drift(x, &mut dx);
    frozen.add_input(u, &mut dx);
    Ok(dx)
}

/// The plant's output y = C(θ) x + M(θ, x) x (θ clamped into the box).
pub fn plant_output(
    model: &PolytopicModel,
    x: &[f64],
    theta: &[f64],
) -> Result<Vec<f64>, SimError> {
    check_model(model)?;
    check_len("x", x, model.nx())?;
    check_len("theta", theta, model.ntheta())?;
    let mut frozen = Frozen::new(model);
    frozen.set(model, &[], theta);
    let mut y = vec![0.0; model.ny()];
    frozen.output(x, &mut y);
    Ok(y)
}

/// The observer's right-hand side, spec eq. (9):
/// x̂' = A(θ) x̂ + N(θ, x̂) x̂ + B(θ) u + L(θ) [y − C(θ) x̂ − M(θ, x̂) x̂],
/// with L(θ) = Σ_l μ_l(θ) L_l and `gains[l]` = L_l (nx × ny, vertex order of
/// the model).
///
/// This is the reference implementation other code (generated observers) is
/// tested against.
pub fn observer_derivative(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    xhat: &[f64],
    y: &[f64],
    u: &[f64],
    theta: &[f64],
) -> Result<Vec<f64>, SimError> {
    check_model(model)?;
    check_gains(model, gains)?;
    check_len("xhat", xhat, model.nx())?;
    check_len("y", y, model.ny())?;
    check_len("u", u, model.nu())?;
    check_len("theta", theta, model.ntheta())?;
    let mut frozen = Frozen::new(model);
    frozen.set(model, gains, theta);
    let mut dxhat = vec![0.0; model.nx()];
    frozen.drift(xhat, &mut dxhat);
    frozen.add_input(u, &mut dxhat);
    // output error y − C x̂ − M(x̂) x̂
    let mut yhat = vec![0.0; model.ny()];
    frozen.output(xhat, &mut yhat);
    let innovation: Vec<f64> = y.iter().zip(&yhat).map(|(y, yh)| y - yh).collect();
    frozen.add_gain(&innovation, &mut dxhat);
    Ok(dxhat)
}

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
}

impl Signal {
    /// A signal given by a closure.
    pub fn custom(f: impl Fn(f64) -> f64 + Send + Sync + 'static) -> Self {
        Signal::Custom(Arc::new(f))
    }

    /// The signal's value at time `t`.
    pub fn at(&self, t: f64) -> f64 {
        match self {
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
    /// the paper's example (nx = 3, two parameters), and [`simulate`] reports
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
    }

    /// θ(t) into `out`.
    fn theta_into(&self, t: f64, out: &mut [f64]) {
        for (o, s) in out.iter_mut().zip(&self.theta) {
            *o = s.at(t);
        }
    }

    /// u(t) into `out`.
    fn u_into(&self, t: f64, out: &mut [f64]) {
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

/// A simulated trajectory of plant and observer, one row per time step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Trajectory {
    /// Time instants, starting at 0.
    pub t: Vec<f64>,
    /// Plant state x(t).
    pub x: Vec<Vec<f64>>,
    /// Observer state x̂(t).
    pub xhat: Vec<Vec<f64>>,
    /// Parameters θ(t) as given by the scenario (before clamping).
    pub theta: Vec<Vec<f64>>,
    /// Vertex weights μ_l(θ(t)).
    pub mu: Vec<Vec<f64>>,
    /// Euclidean norm of the estimation error ‖x(t) − x̂(t)‖.
    pub error_norm: Vec<f64>,
    /// If the simulation stopped early: the time at which a non-finite value
    /// appeared (in x, x̂, θ or u at an RK4 stage). Rows before it are kept.
    pub diverged_at: Option<f64>,
}

impl Trajectory {
    /// An empty trajectory with room for `rows` time steps.
    pub fn with_capacity(rows: usize) -> Self {
        Trajectory {
            t: Vec::with_capacity(rows),
            x: Vec::with_capacity(rows),
            xhat: Vec::with_capacity(rows),
            theta: Vec::with_capacity(rows),
            mu: Vec::with_capacity(rows),
            error_norm: Vec::with_capacity(rows),
            diverged_at: None,
        }
    }

    /// Number of recorded time steps.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True if nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The first recorded time after which the error norm stays below `tol`
    /// until the end, or `None` if it is not below `tol` at the end, the
    /// simulation diverged, or `tol` is NaN.
    pub fn error_below(&self, tol: f64) -> Option<f64> {
        if self.diverged_at.is_some() || self.is_empty() || tol.is_nan() {
            return None;
        }
        match self
            .error_norm
            .iter()
            .rposition(|&e| e.is_nan() || e >= tol)
        {
            None => self.t.first().copied(),
            Some(i) => self.t.get(i + 1).copied(),
        }
    }

    /// V(t) = e(t)ᵀ P e(t) along the trajectory, e = x − x̂, for a Lyapunov
    /// matrix P (nx × nx); `None` if P has the wrong shape. A design with
    /// decay rate α promises V(t) ≤ V(0) e^{−αt} while e(0) is in its set.
    pub fn lyapunov(&self, p: &DMatrix<f64>) -> Option<Vec<f64>> {
        let nx = self.x.first().map_or(p.nrows(), Vec::len);
        if p.shape() != (nx, nx) {
            return None;
        }
        let values = self
            .x
            .iter()
            .zip(&self.xhat)
            .map(|(x, xhat)| {
                let e: Vec<f64> = x.iter().zip(xhat).map(|(a, b)| a - b).collect();
                let mut pe = vec![0.0; nx];
                add_mul(&mut pe, p, &e);
                e.iter().zip(&pe).map(|(a, b)| a * b).sum()
            })
            .collect();
        Some(values)
    }

    /// Writes the trajectory as CSV: a header
    /// `t,x1..,xhat1..,theta1..,mu1..,error_norm`, then one row per step.
    /// Numbers use Rust's shortest round-trip formatting.
    pub fn write_csv<W: Write>(&self, mut w: W) -> io::Result<()> {
        let width = |rows: &[Vec<f64>]| rows.first().map_or(0, Vec::len);
        let mut header = vec!["t".to_string()];
        for (name, rows) in [
            ("x", &self.x),
            ("xhat", &self.xhat),
            ("theta", &self.theta),
            ("mu", &self.mu),
        ] {
            header.extend((1..=width(rows)).map(|i| format!("{name}{i}")));
        }
        header.push("error_norm".to_string());
        writeln!(w, "{}", header.join(","))?;
        for i in 0..self.len() {
            let mut row = vec![self.t[i]];
            for rows in [&self.x, &self.xhat, &self.theta, &self.mu] {
                row.extend(rows.get(i).map_or(&[][..], Vec::as_slice));
            }
            row.extend(self.error_norm.get(i));
            let cells: Vec<String> = row.iter().map(f64::to_string).collect();
            writeln!(w, "{}", cells.join(","))?;
        }
        Ok(())
    }
}

/// Plant and observer stacked as one ODE z = (x, x̂), with reusable buffers.
struct Closed<'a> {
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
    fn new(model: &'a PolytopicModel, gains: &'a [DMatrix<f64>], scenario: &'a Scenario) -> Self {
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
    fn rhs(&mut self, t: f64, z: &[f64], dz: &mut [f64]) -> bool {
        self.scenario.theta_into(t, &mut self.theta);
        self.scenario.u_into(t, &mut self.u);
        if self.theta.iter().chain(&self.u).any(|v| !v.is_finite()) {
            return false;
        }
        self.frozen.set(self.model, self.gains, &self.theta);
        let nx = self.model.nx();
        let (x, xhat) = z.split_at(nx);
        let (dx, dxhat) = dz.split_at_mut(nx);
        // plant
        self.frozen.drift(x, dx);
        self.frozen.add_input(&self.u, dx);
        // observer, eq. (9), fed the measurement y + v
        self.frozen.output(x, &mut self.y);
        if let Some(v) = &self.v {
            for (y, v) in self.y.iter_mut().zip(v) {
                *y += v;
            }
        }
        self.frozen.output(xhat, &mut self.yhat);
        for (y, yh) in self.y.iter_mut().zip(&self.yhat) {
            *y -= yh;
        }
        self.frozen.drift(xhat, dxhat);
        self.frozen.add_input(&self.u, dxhat);
        self.frozen.add_gain(&self.y, dxhat);
        true
    }

    /// Hands the row for time `t` to `each` (θ(t) is evaluated again for
    /// the row); `each`'s answer: whether the run goes on.
    fn emit(&mut self, t: f64, z: &[f64], each: &mut dyn FnMut(&Row<'_>) -> bool) -> bool {
        let nx = self.model.nx();
        self.scenario.theta_into(t, &mut self.theta);
        let error_norm = z[..nx]
            .iter()
            .zip(&z[nx..])
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        let mu = self.model.mu(&self.theta);
        each(&Row {
            t,
            x: &z[..nx],
            xhat: &z[nx..],
            theta: &self.theta,
            mu: &mu,
            error_norm,
        })
    }
}

/// One instant of a run, as [`simulate_each`] hands it out (the columns
/// of a [`Trajectory`] row).
#[derive(Debug, Clone, Copy)]
pub struct Row<'a> {
    /// Time.
    pub t: f64,
    /// Plant state x(t).
    pub x: &'a [f64],
    /// Observer state x̂(t).
    pub xhat: &'a [f64],
    /// Parameters θ(t) as given by the scenario (before clamping).
    pub theta: &'a [f64],
    /// Vertex weights μ_l(θ(t)).
    pub mu: &'a [f64],
    /// ‖x(t) − x̂(t)‖.
    pub error_norm: f64,
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

/// `steps` if a run of that many steps may be recorded (at most
/// [`MAX_RECORDED_STEPS`]), else the error that says so.
pub(crate) fn recorded(steps: usize) -> Result<usize, SimError> {
    if steps > MAX_RECORDED_STEPS {
        return Err(SimError::TimeGrid(format!(
            "t_end / dt = {steps} steps (at most {MAX_RECORDED_STEPS} are recorded; \
             simulate_each streams up to {MAX_STEPS})"
        )));
    }
    Ok(steps)
}

/// Simulates plant and observer (spec eq. 9) with classical fixed-step RK4;
/// θ and u are sampled at the RK4 stage times and y = C x + M(x) x is taken
/// from the plant's stage state. Every step is recorded (at most
/// [`MAX_RECORDED_STEPS`]; [`simulate_each`] streams longer runs).
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
        traj.t.push(r.t);
        traj.x.push(r.x.to_vec());
        traj.xhat.push(r.xhat.to_vec());
        traj.theta.push(r.theta.to_vec());
        traj.mu.push(r.mu.to_vec());
        traj.error_norm.push(r.error_norm);
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
    check_model(model)?;
    check_gains(model, gains)?;
    let nx = model.nx();
    check_len("x0", &scenario.x0, nx)?;
    check_len("xhat0", &scenario.xhat0, nx)?;
    if scenario.theta.len() != model.ntheta() {
        return Err(SimError::Length {
            what: "scenario theta".to_string(),
            expected: model.ntheta(),
            got: scenario.theta.len(),
        });
    }
    if scenario.u.len() != model.nu() {
        return Err(SimError::Length {
            what: "scenario u".to_string(),
            expected: model.nu(),
            got: scenario.u.len(),
        });
    }
    let steps = scenario.steps()?;

    let mut sys = Closed::new(model, gains, scenario);
    let mut z: Vec<f64> = scenario.x0.iter().chain(&scenario.xhat0).copied().collect();
    let dim = z.len();
    let (mut k1, mut k2, mut k3, mut k4, mut stage) = (
        vec![0.0; dim],
        vec![0.0; dim],
        vec![0.0; dim],
        vec![0.0; dim],
        vec![0.0; dim],
    );
    if !sys.scenario.theta.iter().all(|s| s.at(0.0).is_finite()) {
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
        let h = t_next - t;
        if let Some(n) = noise.as_deref_mut() {
            sys.v = Some(n.sample(model.ny()));
        }
        let mut ok = sys.rhs(t, &z, &mut k1);
        let axpy = |dst: &mut Vec<f64>, c: f64, kv: &[f64]| {
            for ((d, zi), ki) in dst.iter_mut().zip(&z).zip(kv) {
                *d = zi + c * ki;
            }
        };
        axpy(&mut stage, 0.5 * h, &k1);
        ok = ok && sys.rhs(t + 0.5 * h, &stage, &mut k2);
        axpy(&mut stage, 0.5 * h, &k2);
        ok = ok && sys.rhs(t + 0.5 * h, &stage, &mut k3);
        axpy(&mut stage, h, &k3);
        ok = ok && sys.rhs(t_next, &stage, &mut k4);
        if !ok {
            return Ok(Some(t));
        }
        for i in 0..dim {
            z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        let theta_ok = sys.scenario.theta.iter().all(|s| s.at(t_next).is_finite());
        if !theta_ok || z.iter().any(|v| !v.is_finite()) {
            return Ok(Some(t_next));
        }
        if !sys.emit(t_next, &z, each) {
            return Ok(None);
        }
    }
    Ok(None)
}

/// √cond(P) = √(λ_max/λ_min) of a Lyapunov matrix: V(t) ≤ V(0)e^{−αt} with
/// V = eᵀPe gives ‖e(t)‖ ≤ √cond(P) ‖e(0)‖ e^{−αt/2}, the certified error
/// envelope drawn in the figures. `None` if P is not positive definite.
pub fn envelope_factor(p: &DMatrix<f64>) -> Option<f64> {
    if p.is_empty() || !p.is_square() || !p.iter().all(|v| v.is_finite()) {
        return None;
    }
    let eig = nalgebra::SymmetricEigen::new(p.clone()).eigenvalues;
    let (lo, hi) = (eig.min(), eig.max());
    (lo > 0.0).then(|| (hi / lo).sqrt())
}

/// Units in the last place the rounding of one step of a run may leave
/// in the computed error x − x̂ (per state, relative to the state scale).
const FLOOR_ULPS: f64 = 16.0;

/// The resolution of a run in f64 below which a certified envelope or
/// bound is not compared: the computed error x − x̂ carries a rounding of
/// a few ulps of the state scale at each step (`scale` = the largest |x_i|
/// or |x̂_i| seen so far), which the error dynamics, contracting at α/2 per
/// second in the P-norm, accumulate to at most that per-step rounding
/// times 1 + 2/(α·dt) steps, and √cond(P) (`kf`) turns back into the
/// Euclidean norm. A run whose error is below this floor has converged to
/// the arithmetic's resolution and is never reported as leaving its
/// envelope.
pub fn arithmetic_floor(kf: f64, alpha: f64, dt: f64, scale: f64) -> f64 {
    let steps = 1.0 + 2.0 / (alpha * dt).max(f64::MIN_POSITIVE);
    kf * FLOOR_ULPS * f64::EPSILON * scale * steps
}

/// The certified bound on ‖e(t)‖ of a design with a noise bound
/// ([`crate::report::NoiseBound`]: V' + αV ≤ σ|v|²) under measurement
/// noise of amplitude ν ≤ ν_max: V(t) ≤ e^{−αt}V(0) + (σν²/α)(1 − e^{−αt})
/// and ‖e‖ ≤ √(V/λ_min(P)), which tends to ν times the bound's
/// `error_bound` per unit amplitude.
#[derive(Debug, Clone, Copy)]
pub struct NoiseEnvelope {
    /// V(0) = e(0)ᵀ P e(0).
    v0: f64,
    /// Decay rate α.
    alpha: f64,
    /// λ_min(P).
    lambda_min: f64,
    /// The ultimate bound lim sup ‖e‖ ≤ ν · error_bound.
    ultimate: f64,
}

impl NoiseEnvelope {
    /// The envelope of P (the design's, as its noise bound was computed
    /// with), e(0), α and the bound at amplitude ν; `None` if P is not
    /// positive definite or does not fit e(0).
    pub fn new(
        p: &DMatrix<f64>,
        e0: &[f64],
        alpha: f64,
        bound: &crate::certificate::noise::NoiseBound,
        nu: f64,
    ) -> Option<Self> {
        if p.is_empty() || !p.is_square() || e0.len() != p.nrows() {
            return None;
        }
        if !p.iter().all(|v| v.is_finite()) {
            return None;
        }
        let ps = (p + p.transpose()) * 0.5;
        let lambda_min = ps.symmetric_eigenvalues().min();
        if lambda_min.is_nan() || lambda_min <= 0.0 {
            return None;
        }
        let e = nalgebra::DVector::from_column_slice(e0);
        Some(NoiseEnvelope {
            v0: e.dot(&(p * &e)),
            alpha,
            lambda_min,
            ultimate: nu * bound.error_bound,
        })
    }

    /// The bound on ‖e(t)‖.
    pub fn at(&self, t: f64) -> f64 {
        let d = (-self.alpha * t).exp();
        (d * self.v0 / self.lambda_min + (1.0 - d) * self.ultimate * self.ultimate).sqrt()
    }

    /// The ultimate bound lim sup ‖e(t)‖ ≤ ν √(σ/(α λ_min(P))).
    pub fn ultimate(&self) -> f64 {
        self.ultimate
    }
}
