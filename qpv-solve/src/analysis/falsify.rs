//! Monte-Carlo falsification of a certified claim on the true nonlinear error
//! dynamics, independent of the LMIs.
//!
//! The claim of a sound design (docs/method.md) is: for every e in E = {e : eᵀPe ≤ 1},
//! every x in F = {x : xᵀQ⁻¹x ≤ 1} and every θ in the box,
//! V' + αV < 0 with V = eᵀPe and V' = 2eᵀPe', where
//!
//! ```text
//! e' = f(x, θ) − f(x̂, θ) − L(θ) (h(x) − h(x̂)),   x̂ = x − e,
//! f(x, θ) = A(θ) x + N(θ, x) x,   h(x) = C x + M(x) x.
//! ```
//!
//! [`falsify`] samples (e, x, θ) and reports the largest ratio
//! r = (V' + αV)/V found; any r ≥ 0 is a counterexample to the claim.
//!
//! ```
//! use nalgebra::DMatrix;
//! use qpv_solve::falsify::falsify;
//!
//! // x' = −x, y = x: with L = 0 and P = I, V' = −2V, so α = 1 holds (r = −1)
//! let src = "model decay {
//!     state x;  output y;  param th in [0, 1];
//!     der x = -x;  out y = x;
//!     region box(1);  state_bound Q = [4];
//! }";
//! let model = qpv_dsl::parse(src)?.remove(0).polytopic();
//! let gains = vec![DMatrix::zeros(1, 1); model.nv()];
//! let f = falsify(&model, &DMatrix::identity(1, 1), &gains, 1.0, 0.5, 1000, 7)?;
//! assert!(f.passed());
//! assert!((f.worst_ratio + 1.0).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::analysis::checks::{check_gains, check_model, SimError};
use crate::analysis::rhs::Frozen;
use crate::report::Design;
use crate::vocab::Candidate;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{PolytopicModel, StateBound};
use serde::Serialize;

/// One evaluated point of the falsification.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sample {
    /// The estimation error e (eᵀPe ≤ 1).
    pub e: Vec<f64>,
    /// The plant state x.
    pub x: Vec<f64>,
    /// The parameter vector θ (one entry per declared parameter).
    pub theta: Vec<f64>,
    /// r = (V' + αV)/V at this point; negative means the claim holds here.
    pub ratio: f64,
}

/// Where the plant state x was sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StateSet {
    /// The model's state bound F = {xᵀQ⁻¹x ≤ 1}.
    StateBound,
    /// The scaled region P/γ (the model has no state bound).
    ScaledRegion,
}

/// The outcome of [`falsify`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Falsification {
    /// The decay rate α that was checked.
    pub alpha: f64,
    /// The seed of the pseudo-random sampler (same seed, same samples).
    pub seed: u64,
    /// Where x was sampled.
    pub state_set: StateSet,
    /// Number of points evaluated (e = 0 excluded).
    pub samples: usize,
    /// Number of points skipped because e = 0 (V = 0, no ratio).
    pub skipped: usize,
    /// Number of points with r ≥ 0 (or a non-finite r, counted conservatively).
    pub counterexamples: usize,
    /// The largest ratio found (+∞ if some ratio was non-finite, −∞ if no
    /// point was evaluated).
    pub worst_ratio: f64,
    /// The point with the largest ratio.
    pub worst: Option<Sample>,
}

impl Falsification {
    /// True if points were evaluated and none was a counterexample.
    pub fn passed(&self) -> bool {
        self.samples > 0 && self.counterexamples == 0
    }
}

pub(crate) use super::rng::Rng;

/// The Cholesky factor: returns R with S = R Rᵀ (R lower
/// triangular), or an error if S is not symmetric positive definite.
pub(crate) fn factor(what: &str, s: &DMatrix<f64>, n: usize) -> Result<DMatrix<f64>, SimError> {
    if s.shape() != (n, n) {
        return Err(SimError::Shape {
            what: what.to_string(),
            expected: (n, n),
            got: s.shape(),
        });
    }
    if s.iter().any(|v| !v.is_finite()) {
        return Err(SimError::NotFinite {
            what: what.to_string(),
        });
    }
    let scale = s.amax().max(f64::MIN_POSITIVE);
    if (s - s.transpose()).amax() > 1e-9 * scale {
        return Err(SimError::NotPositiveDefinite {
            what: what.to_string(),
        });
    }
    let sym = (s + s.transpose()) * 0.5;
    nalgebra::Cholesky::new(sym)
        .map(|c| c.l())
        .ok_or_else(|| SimError::NotPositiveDefinite {
            what: what.to_string(),
        })
}

/// The evaluator of r = (V' + αV)/V with reusable buffers.
struct Ratio<'a> {
    model: &'a PolytopicModel,
    gains: &'a [DMatrix<f64>],
    p: &'a DMatrix<f64>,
    alpha: f64,
    /// `sample = h`: the ratio is that of the Euler step (see
    /// [`falsify_sampled`]).
    sample: Option<f64>,
    frozen: Frozen,
    xhat: Vec<f64>,
    fx: Vec<f64>,
    fxhat: Vec<f64>,
    hx: Vec<f64>,
    hxhat: Vec<f64>,
    pe: Vec<f64>,
}

impl<'a> Ratio<'a> {
    /// r at (e, x, θ), or `None` if V = eᵀPe is 0.
    fn eval(&mut self, e: &[f64], x: &[f64], theta: &[f64]) -> Option<f64> {
        self.frozen.set(self.model, self.gains, theta);
        for ((xh, xi), ei) in self.xhat.iter_mut().zip(x).zip(e) {
            *xh = xi - ei;
        }
        // e' = f(x) − f(x̂) − L (h(x) − h(x̂)), accumulated in fx
        self.frozen.drift(x, &mut self.fx);
        self.frozen.drift(&self.xhat, &mut self.fxhat);
        self.frozen.output(x, &mut self.hx);
        self.frozen.output(&self.xhat, &mut self.hxhat);
        for (a, b) in self.fx.iter_mut().zip(&self.fxhat) {
            *a -= b;
        }
        for (hxhat, hx) in self.hxhat.iter_mut().zip(&self.hx) {
            *hxhat -= hx; // now h(x̂) − h(x), so fx += L (h(x̂) − h(x))
        }
        self.frozen.add_gain(&self.hxhat, &mut self.fx);
        // P e
        self.pe.fill(0.0);
        for (j, ej) in e.iter().enumerate() {
            for (i, pei) in self.pe.iter_mut().enumerate() {
                *pei += self.p[(i, j)] * ej;
            }
        }
        let v: f64 = e.iter().zip(&self.pe).map(|(a, b)| a * b).sum();
        if v == 0.0 {
            return None;
        }
        if let Some(h) = self.sample {
            // e⁺ = e + h e' (the Euler step of plant and observer), and
            // r = V(e⁺)/V(e) − (1 − hα).
            let ep: Vec<f64> = e.iter().zip(&self.fx).map(|(a, b)| a + h * b).collect();
            let mut vp = 0.0;
            for (i, ei) in ep.iter().enumerate() {
                for (j, ej) in ep.iter().enumerate() {
                    vp += ei * self.p[(i, j)] * ej;
                }
            }
            return Some(vp / v - (1.0 - h * self.alpha));
        }
        let vdot: f64 = 2.0
            * self
                .fx
                .iter()
                .zip(&self.pe)
                .map(|(a, b)| a * b)
                .sum::<f64>();
        Some((vdot + self.alpha * v) / v)
    }
}

/// The local search keeps V(e) = eᵀPe above this (‖e‖ at least 1e-3 of the
/// size of E): see [`falsify`].
const LOCAL_MIN_V: f64 = 1e-6;

/// A random e: a region vertex scaled into E (1/8), on the boundary of E
/// (1/4) or uniform inside it (5/8).
pub(crate) fn draw_e(
    rng: &mut Rng,
    z: &mut DVector<f64>,
    e_vertices: &[DVector<f64>],
    to_e: &impl Fn(&DVector<f64>) -> Option<DVector<f64>>,
) -> DVector<f64> {
    let pick = rng.uniform();
    if pick < 0.125 && !e_vertices.is_empty() {
        return e_vertices[rng.index(e_vertices.len())].clone();
    }
    rng.ball(z.as_mut_slice(), pick >= 0.75);
    // the factor has a positive diagonal, so the solve cannot fail
    to_e(z).unwrap_or_else(|| DVector::zeros(z.len()))
}

/// A random x: in F = {x = R_q z, |z| ≤ 1} like e (with region vertices
/// scaled onto ∂F), or, without a state bound (`rq` = None), a vertex of P/γ
/// (1/4) or a random convex combination of them.
pub(crate) fn draw_x(
    rng: &mut Rng,
    z: &mut DVector<f64>,
    rq: Option<&DMatrix<f64>>,
    x_vertices: &[DVector<f64>],
) -> DVector<f64> {
    let pick = rng.uniform();
    match rq {
        Some(rq) => {
            if pick < 0.125 && !x_vertices.is_empty() {
                x_vertices[rng.index(x_vertices.len())].clone()
            } else {
                rng.ball(z.as_mut_slice(), pick >= 0.75);
                rq * &*z
            }
        }
        None => {
            if pick < 0.25 {
                x_vertices[rng.index(x_vertices.len())].clone()
            } else {
                // random convex combination (exponential weights)
                let w: Vec<f64> = x_vertices
                    .iter()
                    .map(|_| -(1.0 - rng.uniform()).ln())
                    .collect();
                let total: f64 = w.iter().sum();
                x_vertices
                    .iter()
                    .zip(&w)
                    .fold(DVector::zeros(z.len()), |acc, (v, wi)| {
                        acc + v * (wi / total)
                    })
            }
        }
    }
}

/// A random θ: uniform in the box (3/4) or a random corner (1/4).
pub(crate) fn draw_theta(rng: &mut Rng, model: &PolytopicModel, theta: &mut [f64]) {
    let corner = rng.uniform() < 0.25;
    for (t, prm) in theta.iter_mut().zip(&model.params) {
        let s = if corner {
            if rng.uniform() < 0.5 {
                0.0
            } else {
                1.0
            }
        } else {
            rng.uniform()
        };
        *t = prm.lo + s * (prm.hi - prm.lo);
    }
}

/// Where [`falsify`] samples: E = {eᵀPe ≤ 1}, the set x is drawn from (F,
/// or P/γ without a state bound), the points both start from, and the
/// local search's moves inside them.
struct SampleSets<'a> {
    /// The model sampled.
    model: &'a PolytopicModel,
    /// The Lyapunov matrix P.
    p: &'a DMatrix<f64>,
    /// R_pᵀ with P = R_p R_pᵀ: e = R_p⁻ᵀ z maps the unit ball onto E.
    rp_t: DMatrix<f64>,
    /// The region's vertices scaled into E (unchanged if already inside).
    e_vertices: Vec<DVector<f64>>,
    /// Which set x is drawn from.
    state_set: StateSet,
    /// R_q with Q = R_q R_qᵀ (with a state bound): x = R_q z maps the unit
    /// ball onto F.
    rq: Option<DMatrix<f64>>,
    /// The region's vertices scaled onto the boundary of F, or divided by γ.
    x_vertices: Vec<DVector<f64>>,
    /// The facets of P/γ (γ a_kᵀ x ≤ 1), to keep local moves inside it.
    x_facets: Vec<DVector<f64>>,
    /// The largest norm of `x_vertices`: the scale of a local move in P/γ.
    x_radius: f64,
}

impl<'a> SampleSets<'a> {
    /// The sets of `model` for the Lyapunov matrix `p` (`gamma` is used only
    /// without a state bound); errors for a P or Q that is not positive
    /// definite, `state_bound auto`, or nowhere to sample x.
    fn new(model: &'a PolytopicModel, p: &'a DMatrix<f64>, gamma: f64) -> Result<Self, SimError> {
        let nx = model.nx();
        let rp_t = factor("P", p, nx)?.transpose();
        let region: Vec<DVector<f64>> = model
            .region
            .vertices
            .iter()
            .filter(|v| v.len() == nx && v.iter().all(|c| c.is_finite()))
            .cloned()
            .collect();
        let e_vertices: Vec<DVector<f64>> = region
            .iter()
            .filter_map(|v| {
                let vpv = v.dot(&(p * v));
                (vpv > 0.0).then(|| v * (1.0 / vpv.sqrt()).min(1.0))
            })
            .collect();
        let (state_set, rq, x_vertices) = match &model.state_bound {
            StateBound::Given(q) => {
                let rq = factor("state bound Q", q, nx)?;
                let onto_boundary: Vec<DVector<f64>> = region
                    .iter()
                    .filter_map(|v| {
                        let r = rq.solve_lower_triangular(v)?.norm();
                        (r > 0.0).then(|| v / r)
                    })
                    .collect();
                (StateSet::StateBound, Some(rq), onto_boundary)
            }
            StateBound::Auto { .. } => {
                return Err(SimError::Model(
                    "the state bound is `auto`: compute Q first (a design reports it; \
                     `qpv_solve::state_bound::resolve` gives the model with Q)"
                        .to_string(),
                ));
            }
            StateBound::None => {
                if !(gamma.is_finite() && gamma > 0.0) {
                    return Err(SimError::Argument(format!(
                        "gamma = {gamma}: must be > 0 when the model has no state bound"
                    )));
                }
                if region.is_empty() {
                    return Err(SimError::Model(
                        "no state bound and no region vertices: nowhere to sample x".to_string(),
                    ));
                }
                let scaled = region.iter().map(|v| v / gamma).collect();
                (StateSet::ScaledRegion, None, scaled)
            }
        };
        let x_facets: Vec<DVector<f64>> = model
            .region
            .facets
            .iter()
            .filter(|a| a.len() == nx && a.iter().all(|c| c.is_finite()))
            .map(|a| a * gamma)
            .collect();
        let x_radius = x_vertices.iter().map(|v| v.norm()).fold(0.0, f64::max);
        Ok(SampleSets {
            model,
            p,
            rp_t,
            e_vertices,
            state_set,
            rq,
            x_vertices,
            x_facets,
            x_radius,
        })
    }

    /// e = R_p⁻ᵀ z.
    fn to_e(&self, z: &DVector<f64>) -> Option<DVector<f64>> {
        self.rp_t.solve_upper_triangular(z)
    }

    /// One step of the local search: a random move of size `step` from the
    /// worst point `w` so far, projected back into E, the x set and the
    /// parameter box (θ is written into `theta`).
    fn local_move(
        &self,
        rng: &mut Rng,
        z: &mut DVector<f64>,
        w: &Sample,
        step: f64,
        theta: &mut [f64],
    ) -> (DVector<f64>, DVector<f64>) {
        let nx = z.len();
        let mut e = DVector::from_row_slice(&w.e);
        rng.ball(z.as_mut_slice(), false);
        e += self.to_e(z).unwrap_or_else(|| DVector::zeros(nx)) * step;
        let v = e.dot(&(self.p * &e));
        if v > 1.0 {
            e /= v.sqrt();
        } else if v < LOCAL_MIN_V {
            // f(x) − f(x̂) loses digits as e → 0 (rounding error about
            // ε‖x‖/‖e‖): do not let the search chase that noise
            e = DVector::from_row_slice(&w.e);
        }
        let mut x = DVector::from_row_slice(&w.x);
        rng.ball(z.as_mut_slice(), false);
        match &self.rq {
            Some(rq) => {
                x += rq * &*z * step;
                if let Some(r) = rq.solve_lower_triangular(&x).map(|y| y.norm()) {
                    if r > 1.0 {
                        x /= r;
                    }
                }
            }
            None if !self.x_facets.is_empty() => {
                x += &*z * (step * self.x_radius);
                let m = self.x_facets.iter().map(|a| a.dot(&x)).fold(0.0, f64::max);
                if m > 1.0 {
                    x /= m;
                }
            }
            None => {}
        }
        for ((t, prm), t0) in theta.iter_mut().zip(&self.model.params).zip(&w.theta) {
            let s = (t0 - prm.lo) / (prm.hi - prm.lo) + step * rng.normal();
            *t = prm.lo + s.clamp(0.0, 1.0) * (prm.hi - prm.lo);
        }
        (e, x)
    }
}

/// Samples the claim "V' + αV < 0 for e ∈ E, x ∈ F, θ ∈ Θ" on the true
/// nonlinear error dynamics and reports the worst ratio r = (V' + αV)/V.
///
/// * e: uniform in E = {eᵀPe ≤ 1} (5/8 of the draws), uniform on its
///   boundary (1/4), or a region vertex scaled into E (1/8).
/// * x: if the model has a state bound Q, uniform in F = {xᵀQ⁻¹x ≤ 1} (5/8),
///   on its boundary (1/4), or a region vertex scaled onto the boundary of F
///   (1/8). Without a state bound, x is drawn in P/γ instead (a region vertex
///   divided by γ, or a random convex combination of those vertices);
///   `gamma` is used only then.
/// * θ: uniform in the parameter box (3/4) or a random corner (1/4).
///
/// The last tenth of the `samples` is a local search instead: random steps
/// from the worst point found so far (projected back into E, F or P/γ and
/// the box; the step grows after an improvement and shrinks otherwise), which
/// pushes the worst ratio towards the true maximum. It does not move e
/// below V(e) = 1e-6: e' is computed as the difference f(x) − f(x̂) of the
/// true dynamics, whose rounding error grows like ε‖x‖/‖e‖ as e → 0.
///
/// `gains[l]` = L_l in the model's vertex order; `p` is the Lyapunov matrix.
/// The same `seed` gives the same samples. Points with e = 0 are skipped.
pub fn falsify(
    model: &PolytopicModel,
    p: &DMatrix<f64>,
    gains: &[DMatrix<f64>],
    alpha: f64,
    gamma: f64,
    samples: usize,
    seed: u64,
) -> Result<Falsification, SimError> {
    run(
        model,
        p,
        gains,
        Candidate::new(alpha, gamma),
        None,
        samples,
        seed,
    )
}

/// [`falsify`] for the claim of a `sample = h` design: the plant and the
/// observer stepped by the same explicit Euler step h, e⁺ = e + h·e' with
/// e' the true error derivative above, and the ratio
/// r = V(e⁺)/V(e) − (1 − hα); any r ≥ 0 is a counterexample to
/// V(e_{k+1}) ≤ (1 − hα)V(e_k). The samples are drawn exactly as by
/// [`falsify`].
pub fn falsify_sampled(
    model: &PolytopicModel,
    p: &DMatrix<f64>,
    gains: &[DMatrix<f64>],
    claim: Candidate,
    h: f64,
    samples: usize,
    seed: u64,
) -> Result<Falsification, SimError> {
    if !(h.is_finite() && h > 0.0) {
        return Err(SimError::NotFinite {
            what: "the sample period h".to_string(),
        });
    }
    run(model, p, gains, claim, Some(h), samples, seed)
}

/// [`falsify`] and [`falsify_sampled`].
fn run(
    model: &PolytopicModel,
    p: &DMatrix<f64>,
    gains: &[DMatrix<f64>],
    claim: Candidate,
    sample: Option<f64>,
    samples: usize,
    seed: u64,
) -> Result<Falsification, SimError> {
    let Candidate { alpha, gamma, .. } = claim;
    check_model(model)?;
    check_gains(model, gains)?;
    let nx = model.nx();
    if !alpha.is_finite() {
        return Err(SimError::NotFinite {
            what: "alpha".to_string(),
        });
    }
    let sets = SampleSets::new(model, p, gamma)?;
    let mut ratio = Ratio {
        model,
        gains,
        p,
        alpha,
        sample,
        frozen: Frozen::new(model),
        xhat: vec![0.0; nx],
        fx: vec![0.0; nx],
        fxhat: vec![0.0; nx],
        hx: vec![0.0; model.ny()],
        hxhat: vec![0.0; model.ny()],
        pe: vec![0.0; nx],
    };
    let mut rng = Rng(seed);
    let mut z = DVector::zeros(nx);
    let mut theta = vec![0.0; model.ntheta()];
    let mut out = Falsification {
        alpha,
        seed,
        state_set: sets.state_set,
        samples: 0,
        skipped: 0,
        counterexamples: 0,
        worst_ratio: f64::NEG_INFINITY,
        worst: None,
    };
    let local_start = samples - samples / 10;
    let mut step = 0.1;

    for i in 0..samples {
        let local = match &out.worst {
            Some(w) if i >= local_start => Some(w.clone()),
            _ => None,
        };
        let (e, x) = if let Some(w) = &local {
            sets.local_move(&mut rng, &mut z, w, step, &mut theta)
        } else {
            let e = draw_e(&mut rng, &mut z, &sets.e_vertices, &|z| sets.to_e(z));
            let x = draw_x(&mut rng, &mut z, sets.rq.as_ref(), &sets.x_vertices);
            draw_theta(&mut rng, model, &mut theta);
            (e, x)
        };

        let Some(r) = ratio.eval(e.as_slice(), x.as_slice(), &theta) else {
            out.skipped += 1;
            continue;
        };
        out.samples += 1;
        let r_key = if r.is_nan() { f64::INFINITY } else { r };
        if r.is_nan() || r >= 0.0 {
            out.counterexamples += 1;
        }
        let improved = out.worst.is_none() || r_key > out.worst_ratio;
        if local.is_some() {
            step = if improved { step * 2.0 } else { step * 0.85 }.clamp(1e-6, 1.0);
        }
        if improved {
            out.worst_ratio = r_key;
            out.worst = Some(Sample {
                e: e.iter().copied().collect(),
                x: x.iter().copied().collect(),
                theta: theta.clone(),
                ratio: r,
            });
        }
    }
    Ok(out)
}

/// [`falsify`] applied to a finished [`Design`]: its P, L_l, α and γ (and
/// for a `sample = h` design [`falsify_sampled`] at its h).
///
/// A design without a solution (empty P) is reported as a [`SimError::Shape`]
/// error. Falsifying a paper-mode design is allowed; it tests the claim
/// V' + αV < 0 on E × F even though that mode certifies nothing. The gains
/// are tested on [`Design::observer_model`]: for a model with
/// `state_bound auto` x is sampled in the F the design computed, and a
/// filter-route design is tested on the augmented plant.
pub fn falsify_design(
    model: &PolytopicModel,
    design: &Design,
    samples: usize,
    seed: u64,
) -> Result<Falsification, SimError> {
    let model = design
        .observer_model(model)
        .map_err(|e| SimError::Model(e.to_string()))?;
    run(
        &model,
        &design.p_matrix(),
        &design.l_matrices(),
        Candidate::new(design.alpha, design.gamma),
        design.sample.map(|s| s.h),
        samples,
        seed,
    )
}
