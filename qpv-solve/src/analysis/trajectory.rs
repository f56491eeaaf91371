//! What a run produces: its rows ([`Row`], handed out one at a time), a
//! recorded [`Trajectory`], and the one CSV writer of both
//! ([`TrajectoryCsv`], the `trajectories.csv` of `qpv simulate --plot`).

use crate::analysis::checks::SimError;
use crate::analysis::rhs::{add_mul, Frozen};
use crate::analysis::scenario::MAX_STEPS;
use nalgebra::DMatrix;
use qpv_dsl::diagnostic::fmt_num;
use qpv_dsl::PolytopicModel;
use serde::Serialize;
use std::io::{self, Write};

/// Largest number of steps a recorded [`Trajectory`] holds
/// ([`crate::analysis::simulate::simulate`],
/// [`crate::analysis::euler::simulate_euler`]): every row stays in memory
/// (a few hundred bytes each), so a longer run streams through
/// [`crate::analysis::simulate::simulate_each`].
pub(crate) const MAX_RECORDED_STEPS: usize = MAX_STEPS / 10;

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

/// The error a run has settled to: "error below 1e-6" in `qpv simulate`'s
/// summary ([`crate::analysis::continuous::ContinuousCheck::below_from`]).
pub const SETTLED: f64 = 1e-6;

/// The time from which ‖e‖ has stayed below `tol`, after the row at `t`
/// with ‖e‖ = `err`, given the time `from` before it (None: not below; a
/// NaN error or tolerance is never below).
pub(crate) fn below_from(from: Option<f64>, t: f64, err: f64, tol: f64) -> Option<f64> {
    if err < tol {
        from.or(Some(t))
    } else {
        None
    }
}

/// ‖x − x̂‖.
pub(crate) fn error_norm(x: &[f64], xhat: &[f64]) -> f64 {
    x.iter()
        .zip(xhat)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt()
}

/// One instant of a run, as [`crate::analysis::simulate::simulate_each`]
/// hands it out (the columns of a [`Trajectory`] row).
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
    /// Inputs u(t).
    pub u: &'a [f64],
    /// Vertex weights μ_l(θ(t)).
    pub mu: &'a [f64],
    /// ‖x(t) − x̂(t)‖.
    pub error_norm: f64,
}

/// A simulated trajectory of plant and observer, one row per time step.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Trajectory {
    /// Time instants, starting at 0.
    pub t: Vec<f64>,
    /// Plant state x(t).
    pub x: Vec<Vec<f64>>,
    /// Observer state x̂(t).
    pub xhat: Vec<Vec<f64>>,
    /// Parameters θ(t) as given by the scenario (before clamping).
    pub theta: Vec<Vec<f64>>,
    /// Inputs u(t).
    pub u: Vec<Vec<f64>>,
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
        let rows_of = || Vec::with_capacity(rows);
        Trajectory {
            t: Vec::with_capacity(rows),
            x: rows_of(),
            xhat: rows_of(),
            theta: rows_of(),
            u: rows_of(),
            mu: rows_of(),
            error_norm: Vec::with_capacity(rows),
            diverged_at: None,
        }
    }

    /// Appends the row `r`.
    pub fn push(&mut self, r: &Row<'_>) {
        self.t.push(r.t);
        self.x.push(r.x.to_vec());
        self.xhat.push(r.xhat.to_vec());
        self.theta.push(r.theta.to_vec());
        self.u.push(r.u.to_vec());
        self.mu.push(r.mu.to_vec());
        self.error_norm.push(r.error_norm);
    }

    /// Row `i` (which must be below [`Trajectory::len`]).
    pub fn row(&self, i: usize) -> Row<'_> {
        Row {
            t: self.t[i],
            x: &self.x[i],
            xhat: &self.xhat[i],
            theta: &self.theta[i],
            u: &self.u[i],
            mu: &self.mu[i],
            error_norm: self.error_norm[i],
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
        if self.diverged_at.is_some() {
            return None;
        }
        let rows = self.t.iter().zip(&self.error_norm);
        rows.fold(None, |from, (&t, &e)| below_from(from, t, e, tol))
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

    /// Writes the trajectory of a run of `model` as CSV ([`TrajectoryCsv`]).
    pub fn write_csv<W: Write>(&self, model: &PolytopicModel, w: W) -> io::Result<()> {
        let mut csv = TrajectoryCsv::new(model, w)?;
        (0..self.len()).try_for_each(|i| csv.row(&self.row(i)))?;
        csv.into_inner().flush()
    }
}

/// The CSV of a run of a model: a header of t, the states (model names),
/// their estimates (`xhat1`, … in state order), parameters, inputs and
/// outputs (model names), the vertex weights `mu1`, … and `error_norm`;
/// then one line per [`Row`], numbers in shortest round-trip form
/// ([`fmt_num`]).
pub struct TrajectoryCsv<'a, W: Write> {
    model: &'a PolytopicModel,
    w: W,
    frozen: Frozen,
    y: Vec<f64>,
}

impl<'a, W: Write> TrajectoryCsv<'a, W> {
    /// The writer into `w`, its header written.
    pub fn new(model: &'a PolytopicModel, mut w: W) -> io::Result<Self> {
        let m = model;
        let mut h: Vec<String> = vec!["t".into()];
        h.extend(m.states.iter().cloned());
        h.extend((1..=m.nx()).map(|i| format!("xhat{i}")));
        h.extend(m.params.iter().map(|p| p.name.clone()));
        h.extend(m.inputs.iter().cloned());
        h.extend(m.outputs.iter().cloned());
        h.extend((1..=m.nv()).map(|l| format!("mu{l}")));
        h.push("error_norm".into());
        writeln!(w, "{}", h.join(","))?;
        Ok(TrajectoryCsv {
            model,
            w,
            frozen: Frozen::new(model),
            y: vec![0.0; model.ny()],
        })
    }

    /// Writes row `r`; its outputs are y = C(θ) x + M(θ, x) x (NaN when
    /// the row does not fit the model).
    pub fn row(&mut self, r: &Row<'_>) -> io::Result<()> {
        let m = self.model;
        if r.x.len() == m.nx() && r.theta.len() == m.ntheta() {
            self.frozen.set(m, &[], r.theta);
            self.frozen.output(r.x, &mut self.y);
        } else {
            self.y.fill(f64::NAN);
        }
        let mut cells: Vec<f64> = vec![r.t];
        for part in [r.x, r.xhat, r.theta, r.u, &self.y, r.mu] {
            cells.extend(part);
        }
        cells.push(r.error_norm);
        let text: Vec<String> = cells.iter().map(|&v| fmt_num(v)).collect();
        writeln!(self.w, "{}", text.join(","))
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }

    /// Flushes the underlying writer.
    pub fn flush(&mut self) -> io::Result<()> {
        self.w.flush()
    }
}
