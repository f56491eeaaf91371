//! One solve of a [`Problem`] at (α, γ), in named steps: the objective the
//! observer is solved with, the metric in the problem's coordinates, the
//! solver's tolerances, the run, the de-homogenised point, and the point
//! back in the model's units and the user's coordinates.

use super::{Objective, Problem};
use crate::backend::{clarabel_settings, ensure_lapack, run_sdp, SdpRun, Status};
use crate::conditions::cube::CubeSlacks;
use crate::error::SolveError;
use crate::settings::Settings;
use clarabel::solver::DefaultSettings;
use nalgebra::DMatrix;
use std::time::Instant;

/// The relative step above α at which the global observer's gain objective
/// is solved (see [`Problem::solved_as`]).
pub(crate) const GLOBAL_BACKOFF: f64 = 1e-3;

/// The raw result of one solve, unscaled to the model's units.
#[derive(Debug, Clone)]
pub struct SolveResult {
    /// Interpreted status.
    pub status: Status,
    /// Clarabel's status name.
    pub detail: String,
    /// Iterations.
    pub iterations: u32,
    /// Clarabel's solve time, seconds.
    pub solve_seconds: f64,
    /// Assembly time, seconds.
    pub assembly_seconds: f64,
    /// P (model units) if Clarabel returned a point (Solved / AlmostSolved / …).
    pub p: Option<DMatrix<f64>>,
    /// Γ_l (model units).
    pub gammas: Vec<DMatrix<f64>>,
    /// [`Objective::MaxMargin`]: the optimal normalised margin t̂;
    /// [`Objective::MinGain`]: the optimal gain bound κ (the solver's, not
    /// certified); NaN otherwise.
    pub margin: f64,
    /// The slacks of cube conditions (model units), with the point.
    pub cube: Option<CubeSlacks>,
}

/// A point in the model's units: P, the Γ_l and the cube slacks.
pub(super) type Point = (Option<DMatrix<f64>>, Vec<DMatrix<f64>>, Option<CubeSlacks>);

impl Problem<'_> {
    /// Assembles and solves at (α, γ).
    pub fn solve(
        &self,
        alpha: f64,
        gamma: f64,
        settings: &Settings,
        objective: Objective,
    ) -> Result<SolveResult, SolveError> {
        self.solve_with_metric(alpha, gamma, settings, objective, None)
    }

    /// As [`Problem::solve`] with the [`Objective::MaxMargin`] metric P_ref.
    pub fn solve_with_metric(
        &self,
        alpha: f64,
        gamma: f64,
        settings: &Settings,
        objective: Objective,
        metric: Option<&DMatrix<f64>>,
    ) -> Result<SolveResult, SolveError> {
        ensure_lapack();
        let (objective, alpha) = self.solved_as(objective, alpha);
        let t0 = Instant::now();
        let metric_z = self.metric_in_z(metric);
        let metric = metric_z.as_ref().or(metric);
        let prob = self.assemble_with_metric(alpha, gamma, settings, objective, metric);
        let assembly_seconds = t0.elapsed().as_secs_f64();
        let mut run = run_sdp(prob, solver_settings(settings, objective))?;
        let margin = self.dehomogenise(&mut run, objective);
        let (p, gammas, cube) = self.in_user_coordinates(self.point(run.x.as_deref()));
        Ok(SolveResult {
            status: run.status,
            detail: run.detail,
            iterations: run.iterations,
            solve_seconds: run.solve_seconds,
            assembly_seconds,
            p,
            gammas,
            margin,
            cube,
        })
    }

    /// The objective and α actually solved. The global observer's
    /// conditions bound P̂ from below only (P̂ ⪰ I): ½ Σ‖Γ̂_l‖² may be
    /// approached only as P̂ grows without bound along some direction, and
    /// the solver does not stop. Its gain objective is the min-gain one
    /// (homogeneous, normalised, bounded). The min-gain point lies on the
    /// boundary of the rate conditions (its margin ε κ is tiny against
    /// gains of the size this objective often has to accept), so it is
    /// solved at α(1 + GLOBAL_BACKOFF): at α it then holds with the margin
    /// of that step, γ-free.
    fn solved_as(&self, objective: Objective, alpha: f64) -> (Objective, f64) {
        if self.global && objective == Objective::Gains {
            (Objective::MinGain, alpha * (1.0 + GLOBAL_BACKOFF))
        } else {
            (objective, alpha)
        }
    }

    /// The metric P_ref (user's coordinates) in the problem's, D P_ref D;
    /// None without a change of coordinates or a metric of the right shape.
    fn metric_in_z(&self, metric: Option<&DMatrix<f64>>) -> Option<DMatrix<f64>> {
        match (&self.scaling, metric) {
            (Some(s), Some(m)) if m.shape() == (self.nx, self.nx) => {
                Some(DMatrix::from_fn(self.nx, self.nx, |r, c| {
                    m[(r, c)] * s.d[r] * s.d[c]
                }))
            }
            _ => None,
        }
    }

    /// The margin the objective reports (NaN for the others), after
    /// dividing a homogenised [`Objective::MinGain`] point by c (no point
    /// without c > 0).
    fn dehomogenise(&self, run: &mut SdpRun, objective: Objective) -> f64 {
        let nv = self.n_vars();
        match objective {
            Objective::MinGain => {
                let mut margin = f64::NAN;
                run.x = run.x.take().and_then(|x| {
                    let c = x[nv];
                    (c.is_finite() && c > 0.0).then(|| {
                        margin = x[nv + 1];
                        x[..nv].iter().map(|v| v / c).collect()
                    })
                });
                margin
            }
            Objective::MaxMargin => run.x.as_ref().map_or(f64::NAN, |x| x[nv]),
            Objective::Feasibility | Objective::Gains => f64::NAN,
        }
    }

    /// (P, Γ_l, the cube slacks) of a solution vector, in model units (in
    /// the problem's coordinates).
    fn point(&self, x: Option<&[f64]>) -> Point {
        match x {
            Some(x) => {
                let (p, g) = self.unpack(x);
                (Some(p), g, self.unpack_cube(x))
            }
            None => (None, Vec::new(), None),
        }
    }

    /// A point back in the user's coordinates (P = D⁻¹P_zD⁻¹, Γ_l =
    /// D⁻¹Γ_z,l, the cube slacks like P).
    pub(super) fn in_user_coordinates(&self, (p, gammas, cube): Point) -> Point {
        let Some(s) = &self.scaling else {
            return (p, gammas, cube);
        };
        let each = |ms: Vec<Vec<DMatrix<f64>>>| -> Vec<Vec<DMatrix<f64>>> {
            ms.iter()
                .map(|r| r.iter().map(|m| s.p_from_z(m)).collect())
                .collect()
        };
        (
            p.map(|p| s.p_from_z(&p)),
            gammas.iter().map(|g| s.gamma_from_z(g)).collect(),
            cube.map(|c| CubeSlacks {
                y: each(c.y),
                x: each(c.x),
                d: c.d,
            }),
        )
    }
}

/// Clarabel's settings for `objective`: the max-margin search steps only
/// need a good interior point (the certificate and the capacity are
/// computed independently of the solver's accuracy, and these problems are
/// always feasible), so their tolerances are loosened to
/// [`Settings::search_tol`].
fn solver_settings(settings: &Settings, objective: Objective) -> DefaultSettings<f64> {
    let mut cs = clarabel_settings(settings);
    if objective == Objective::MaxMargin {
        cs.tol_gap_abs = cs.tol_gap_abs.max(settings.search_tol);
        cs.tol_gap_rel = cs.tol_gap_rel.max(settings.search_tol);
        cs.tol_feas = cs.tol_feas.max(settings.search_tol);
    }
    cs
}
