//! The continuous plant sampled by a `sample = h` observer
//! (docs/method.md §16, "The real plant is continuous").
//!
//! The certificate S5d is about the plant stepped by the observer's own
//! Euler step. The real plant follows its ODE between samples:
//! x_{k+1} = x_k + h f(x_k, u_k, θ_k) + r_k with the local truncation error
//! r_k = ∫_{t_k}^{t_k+h} (t_k + h − s) ẍ(s) ds, so componentwise
//! |r_k,i| ≤ (h²/2) sup |ẍ_i| along the step. With the observer fed the
//! samples y_k = h(x(t_k)), u_k, θ_k, the error obeys
//! e_{k+1} = (I + hF_k) e_k + r_k, and S5d gives ‖(I + hF_k)e‖_P ≤ ρ‖e‖_P,
//! ρ = √(1 − hα), ‖e‖_P = √(eᵀPe). Hence
//!
//! ```text
//!     ‖e_{k+1}‖_P ≤ ρ ‖e_k‖_P + δ,   δ = √λ_max(P) · |r̄|,
//! ```
//!
//! and if δ ≤ 1 − ρ the certified set {V ≤ 1} stays invariant, and
//! ‖e_k‖_P ≤ ρ^k ‖e_0‖_P + δ(1 − ρ^k)/(1 − ρ) → δ/(1 − ρ) (an ultimate
//! bound), ‖e‖ ≤ ‖e‖_P / √λ_min(P).
//!
//! ẍ = f_x f + B(θ) u̇ + Σ_i ∂f/∂θ_i θ̇_i (f = f(x, u, θ)). On the polytopic
//! model f(x, u, θ) = Σ_l μ_l(θ) f_l(x, u) exactly, with
//! f_l(x, u) = A_l x + (xᵀN_{l,k}x)_k + B_l u: f_x f = Σ_{l,m} μ_l μ_m J_l(x) f_m(x)
//! lies in the hull of the J_l f_m over the pairs (l, m) of one box (with a
//! cover μ is zero outside the piece that holds θ). Each is bounded by
//! interval arithmetic on the bounding box of F = {xᵀQ⁻¹x ≤ 1},
//! |x_i| ≤ √Q_ii, and the inputs' declared ranges; B(θ)u̇ lies in the hull
//! of the B_l u̇ with |u̇_j| ≤ its declared rate. A parameter or an input
//! without a declared `rate` is assumed constant over each step (its term
//! is 0).
//!
//! *The θ-derivative, with derived scheduling variables and a cover.* The
//! vertices are the corners of a box in the coordinates c = (θ_s, φ)
//! (scheduling parameters, then derived variables φ_j(θ); with a cover, one
//! such box per piece), and f = F(x, u, c(θ)) with F multi-affine in c and
//! c(θ) = (θ_s, φ(θ)) inside the box. The box holds points (θ, φ) no θ
//! produces — the polytopic form over-approximates the plant — but every
//! bound here is a hull over the box, which contains the actual point, so
//! it stays a bound for the plant. Along a trajectory
//! d/dt f(x, u, θ) = f_x ẋ + f_u u̇ + Σ_c ∂F/∂c ċ; ∂F/∂c at any point of
//! the box is a convex combination of the edge differences
//! (f_{l+} − f_{l−})/(width of c) along c (formed coefficient by
//! coefficient, then enclosed on X × U). For a parameter ċ = θ̇_i; for a
//! derived variable φ̇_j = Σ_i ∂φ_j/∂θ_i θ̇_i, so
//! |φ̇_j| ≤ Σ_i sup|∂φ_j/∂θ_i| |θ̇_i| with the supremum over the box's θ
//! range enclosed by interval arithmetic on φ_j's expression tree
//! ([`qpv_dsl::sched::gradient_bound`]; φ depends on θ only, never on x:
//! a state inside a function is outside the model class). A parameter held
//! over the step contributes nothing, and φ_j is held when all of its
//! parameters are. With a cover, θ(t) lies in one piece at each instant and
//! f (the plant itself, exact on every piece) is continuous across the
//! breakpoints, so ẋ stays absolutely continuous and the largest bound over
//! the pieces bounds ẍ almost everywhere, which is all the truncation
//! integral needs.

use crate::report::Design;
use nalgebra::DMatrix;
use qpv_dsl::{PolytopicModel, StateBound};

pub use crate::certificate::sampling::ContinuousBound;

/// A closed interval.
#[derive(Debug, Clone, Copy)]
struct Iv(f64, f64);

impl Iv {
    fn point(v: f64) -> Iv {
        Iv(v, v)
    }
    fn add(self, o: Iv) -> Iv {
        Iv(self.0 + o.0, self.1 + o.1)
    }
    fn mul(self, o: Iv) -> Iv {
        let c = [self.0 * o.0, self.0 * o.1, self.1 * o.0, self.1 * o.1];
        Iv(
            c.iter().copied().fold(f64::INFINITY, f64::min),
            c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    }
    fn scale(self, k: f64) -> Iv {
        Iv::point(k).mul(self)
    }
    fn mag(self) -> f64 {
        self.0.abs().max(self.1.abs())
    }
}

/// f_l(X, U) componentwise: A_l x + (xᵀN_{l,k}x)_k + B_l u on the box X × U.
fn f_iv(v: &qpv_dsl::Vertex, x: &[Iv], u: &[Iv]) -> Vec<Iv> {
    f_parts_iv(&v.a, &v.n, &v.b, x, u)
}

/// (f_b − f_a)(X, U): the difference of two vertices' right-hand sides,
/// formed coefficient by coefficient before the interval evaluation (an
/// interval difference of the two enclosures would double the width).
fn f_diff_iv(a: &qpv_dsl::Vertex, b: &qpv_dsl::Vertex, x: &[Iv], u: &[Iv]) -> Vec<Iv> {
    let n: Vec<DMatrix<f64>> = b.n.iter().zip(&a.n).map(|(nb, na)| nb - na).collect();
    let bu = if a.b.shape() == b.b.shape() {
        &b.b - &a.b
    } else {
        DMatrix::zeros(0, 0)
    };
    f_parts_iv(&(&b.a - &a.a), &n, &bu, x, u)
}

/// A x + (xᵀN_k x)_k + B u componentwise on the box X × U.
fn f_parts_iv(
    a: &DMatrix<f64>,
    n: &[DMatrix<f64>],
    b: &DMatrix<f64>,
    x: &[Iv],
    u: &[Iv],
) -> Vec<Iv> {
    let nx = x.len();
    (0..nx)
        .map(|k| {
            let mut s = Iv::point(0.0);
            for j in 0..nx {
                s = s.add(x[j].scale(a[(k, j)]));
            }
            if let Some(nk) = n.get(k) {
                for i in 0..nx {
                    for j in 0..nx {
                        if nk[(i, j)] != 0.0 {
                            s = s.add(x[i].mul(x[j]).scale(nk[(i, j)]));
                        }
                    }
                }
            }
            for (j, uj) in u.iter().enumerate() {
                if b.ncols() > j && b[(k, j)] != 0.0 {
                    s = s.add(uj.scale(b[(k, j)]));
                }
            }
            s
        })
        .collect()
}

/// The Jacobian J_l(X)[k][j] = A_l[k][j] + ((N_{l,k} + N_{l,k}ᵀ)x)_j.
fn jac_iv(a: &DMatrix<f64>, n: &[DMatrix<f64>], x: &[Iv]) -> Vec<Vec<Iv>> {
    let nx = x.len();
    (0..nx)
        .map(|k| {
            (0..nx)
                .map(|j| {
                    let mut s = Iv::point(a[(k, j)]);
                    if let Some(nk) = n.get(k) {
                        for i in 0..nx {
                            let c = nk[(i, j)] + nk[(j, i)];
                            if c != 0.0 {
                                s = s.add(x[i].scale(c));
                            }
                        }
                    }
                    s
                })
                .collect()
        })
        .collect()
}

/// The box X × U of the bound: |x_i| ≤ √Q_ii (F's bounding box) and each
/// input's declared range, and each input's declared rate (None: held over
/// the step), or why it cannot be formed.
type Boxes = (Vec<Iv>, Vec<Iv>, Vec<Option<f64>>);

fn boxes(model: &PolytopicModel) -> Result<Boxes, String> {
    let nx = model.nx();
    let StateBound::Given(q) = &model.state_bound else {
        return Err("no state bound Q: F is not known".into());
    };
    if q.shape() != (nx, nx) {
        return Err("Q is not nx × nx".into());
    }
    let x = (0..nx)
        .map(|i| {
            let r = q[(i, i)].max(0.0).sqrt();
            Iv(-r, r)
        })
        .collect();
    let mut u = Vec::with_capacity(model.nu());
    let mut missing = Vec::new();
    for (j, name) in model.inputs.iter().enumerate() {
        match model.input_ranges.get(j).copied().flatten() {
            Some((lo, hi)) => u.push(Iv(lo, hi)),
            None => missing.push(name.as_str()),
        }
    }
    if !missing.is_empty() {
        return Err(format!(
            "input(s) {} declare no range (`input u in [lo, hi];`): f over F is not bounded",
            missing.join(", ")
        ));
    }
    let rates = (0..model.nu())
        .map(|j| model.input_rates.get(j).copied().flatten())
        .collect();
    Ok((x, u, rates))
}

/// A closed range (lo, hi).
type Range = (f64, f64);

/// One box of the polytopic model (the whole of it, or a piece of the
/// cover): the vertices it owns, and per vertex coordinate (the scheduling
/// parameters, then the derived variables, in the vertex order) the
/// coordinate's width on the box and the bound on its rate of change
/// (None: held over each step).
struct PieceBox {
    /// Index of the box's first vertex (its 2^s vertices follow).
    first: usize,
    /// Width of each coordinate's range on the box.
    widths: Vec<f64>,
    /// |ċ| ≤ rate for each coordinate c; None: constant over each step.
    rates: Vec<Option<f64>>,
}

/// The boxes of the model's vertex list with their coordinates' widths and
/// rates, and whether every parameter the plant depends on declares a rate.
/// A derived variable φ_j(θ) moves at |φ̇_j| ≤ Σ_i sup|∂φ_j/∂θ_i| |θ̇_i|
/// over the box's θ range (interval gradient, [`qpv_dsl::sched::gradient_bound`]);
/// the parameters without a rate are held, so they contribute nothing, and
/// φ_j is held when none of its parameters has a rate.
fn piece_boxes(model: &PolytopicModel) -> Result<(Vec<PieceBox>, bool), String> {
    let ns = model.scheduling.len();
    let s = ns + model.derived.len();
    let whole_theta: Vec<(f64, f64)> = model.params.iter().map(|p| (p.lo, p.hi)).collect();
    let whole_phi: Vec<(f64, f64)> = model.derived.iter().map(|d| (d.lo, d.hi)).collect();
    let ranges: Vec<(&[Range], &[Range])> = match &model.cover {
        Some(c) => c
            .pieces
            .iter()
            .map(|p| (p.theta.as_slice(), p.phi.as_slice()))
            .collect(),
        None => vec![(whole_theta.as_slice(), whole_phi.as_slice())],
    };
    let names: Vec<String> = model.params.iter().map(|p| p.name.clone()).collect();
    let mut used = model
        .scheduling
        .iter()
        .fold(0u64, |m, &pi| m | (1u64 << pi));
    let mut out = Vec::with_capacity(ranges.len());
    for (k, (theta, phi)) in ranges.into_iter().enumerate() {
        let mut widths = Vec::with_capacity(s);
        let mut rates = Vec::with_capacity(s);
        for &pi in &model.scheduling {
            widths.push(theta[pi].1 - theta[pi].0);
            rates.push(model.params[pi].rate);
        }
        for (j, d) in model.derived.iter().enumerate() {
            widths.push(phi[j].1 - phi[j].0);
            let mask = d.expr.param_mask();
            used |= mask;
            let moving = model
                .params
                .iter()
                .enumerate()
                .any(|(i, p)| mask >> i & 1 == 1 && p.rate.is_some());
            if !moving {
                rates.push(None);
                continue;
            }
            let grad = qpv_dsl::sched::gradient_bound(&d.expr, theta, &names).map_err(|e| {
                format!(
                    "the rate of the derived variable {} is not bounded: {e}",
                    d.name
                )
            })?;
            let r = model
                .params
                .iter()
                .zip(&grad)
                .filter_map(|(p, g)| p.rate.map(|r| r * g))
                .sum::<f64>();
            rates.push(Some(r));
        }
        out.push(PieceBox {
            first: k << s,
            widths,
            rates,
        });
    }
    let declared = model
        .params
        .iter()
        .enumerate()
        .all(|(i, p)| used >> i & 1 == 0 || p.rate.is_some());
    Ok((out, declared))
}

/// Componentwise bounds on ẍ over X × U × Θ: the hull of J_l(f_m + B_m u)
/// over the pairs (l, m) of one box (μ is zero outside the box that holds
/// θ), plus Σ_j |B_l e_j| |u̇_j| over l for the inputs with a declared rate,
/// plus the largest over the boxes of Σ_c |ċ| |∂f/∂c| (edges of the box
/// along each vertex coordinate c with a rate). Also: whether every
/// parameter the plant depends on and every input declares a rate.
fn accel_bounds(
    model: &PolytopicModel,
    x: &[Iv],
    u: &[Iv],
    urates: &[Option<f64>],
) -> Result<(Vec<f64>, bool), String> {
    let nx = x.len();
    let vs = &model.vertices;
    let (pieces, params_declared) = piece_boxes(model)?;
    let s = model.scheduling.len() + model.derived.len();
    let fs: Vec<Vec<Iv>> = vs.iter().map(|v| f_iv(v, x, u)).collect();
    let js: Vec<Vec<Vec<Iv>>> = vs.iter().map(|v| jac_iv(&v.a, &v.n, x)).collect();
    let mut acc = vec![0.0f64; nx];
    let mut theta_term = vec![0.0f64; nx];
    for pb in &pieces {
        let own = pb.first..(pb.first + (1usize << s)).min(vs.len());
        // f_x f: the hull over (l, m) of J_l f_m.
        for j in &js[own.clone()] {
            for f in &fs[own.clone()] {
                for k in 0..nx {
                    let mut sum = Iv::point(0.0);
                    for (jj, fj) in f.iter().enumerate() {
                        sum = sum.add(j[k][jj].mul(*fj));
                    }
                    acc[k] = acc[k].max(sum.mag());
                }
            }
        }
        // Σ_c ∂f/∂c ċ: edges along each coordinate with a rate.
        let mut here = vec![0.0f64; nx];
        for (c, (&w, r)) in pb.widths.iter().zip(&pb.rates).enumerate() {
            let Some(rate) = *r else { continue };
            if w <= 0.0 || rate == 0.0 {
                continue; // a coordinate constant on the box does not move f
            }
            let bit = 1usize << (s - 1 - c);
            let mut worst = vec![0.0f64; nx];
            for lo in (0..1usize << s).filter(|l| l & bit == 0) {
                let (a, b) = (&vs[pb.first + lo], &vs[pb.first + (lo | bit)]);
                for (wk, d) in worst.iter_mut().zip(f_diff_iv(a, b, x, u)) {
                    *wk = wk.max(d.mag() / w);
                }
            }
            for k in 0..nx {
                here[k] += rate * worst[k];
            }
        }
        for k in 0..nx {
            theta_term[k] = theta_term[k].max(here[k]);
        }
    }
    // B(θ) u̇: the hull over l of B_l u̇, |u̇_j| ≤ rate_j.
    let mut input_term = vec![0.0f64; nx];
    for v in vs {
        for (k, it) in input_term.iter_mut().enumerate() {
            let s: f64 = urates
                .iter()
                .enumerate()
                .filter_map(|(j, r)| r.map(|r| v.b[(k, j)].abs() * r))
                .sum();
            *it = it.max(s);
        }
    }
    let total = (0..nx)
        .map(|k| acc[k] + input_term[k] + theta_term[k])
        .collect();
    Ok((total, params_declared && urates.iter().all(Option::is_some)))
}

/// The bound for the continuous plant at (h, α) with the Lyapunov matrix
/// `p` (model units, nx × nx), or why it is not computed. Inputs need a
/// declared range (`input u in [lo, hi]`); an input or a scheduling
/// parameter without a declared `rate` is assumed constant over each step.
pub fn continuous_bound(
    model: &PolytopicModel,
    alpha: f64,
    h: f64,
    p: &DMatrix<f64>,
) -> Result<ContinuousBound, String> {
    let nx = model.nx();
    if model.jacobian.is_some() {
        return Err(
            "not computed for nonlinear terms of unmeasured states (the acceleration bound \
             covers A, N_k and B only)"
                .into(),
        );
    }
    let (x, u, urates) = boxes(model)?;
    if p.shape() != (nx, nx) {
        return Err(
            "P is not nx × nx (an output filter design): not computed for this route".into(),
        );
    }
    if !(h > 0.0 && h * alpha > 0.0 && h * alpha < 1.0) {
        return Err(format!("hα = {} is not in (0, 1)", h * alpha));
    }
    let (acc, rates_declared) = accel_bounds(model, &x, &u, &urates)?;
    let accel = acc.iter().map(|a| a * a).sum::<f64>().sqrt();
    let ps = (p + p.transpose()) * 0.5;
    let eig = ps.symmetric_eigenvalues();
    let (lmin, lmax) = (eig.min(), eig.max());
    if lmin.is_nan() || lmin <= 0.0 {
        return Err("P is not positive definite".into());
    }
    let truncation = 0.5 * h * h * accel;
    let delta = lmax.sqrt() * truncation;
    let rho = (1.0 - h * alpha).sqrt();
    let ultimate_v_sqrt = delta / (1.0 - rho);
    Ok(ContinuousBound {
        accel,
        truncation,
        delta,
        invariant: delta <= 1.0 - rho,
        ultimate_v_sqrt,
        ultimate_error: ultimate_v_sqrt / lmin.sqrt(),
        rates_declared,
        global: false,
        noise_amplitude_max: None,
        noise_per_unit: None,
    })
}

/// What a design's gains certify at a sample period h, recomputed from the
/// model as it is now and the gains as given (never read from a report):
/// the discrete family at α, and the continuous-plant bound at (h, α).
#[derive(Debug, Clone)]
pub struct SampledClaim {
    /// The sample period h.
    pub h: f64,
    /// The α checked: the report's α, lowered to just below the gains'
    /// capacity at h when it exceeds it (a continuous design's gains
    /// checked at a rate, or a report's α the gains do not reach).
    pub alpha: f64,
    /// The largest α the same P, L_l satisfy the discrete family with
    /// ([`crate::certificate::alpha_capacity_sampled`]; 0: none).
    pub capacity: f64,
    /// The independent certificate (family S5d) at (h, `alpha`).
    pub certificate: crate::certificate::Certificate,
    /// The bound for the continuous plant sampled at h, or why it is not
    /// computed (not certified, inputs without a range, no state bound,
    /// a derived variable whose rate is unbounded, the filter route).
    pub bound: Result<ContinuousBound, String>,
}

/// Recomputes what `design`'s P and L_l certify at the sample period `h`
/// on the plant `model`: the α capacity of the discrete family, the
/// independent certificate at α = min(the design's α, 0.999999 × that
/// capacity), and the continuous-plant bound when the certificate passes.
pub fn sampled_claim(model: &PolytopicModel, design: &Design, h: f64) -> SampledClaim {
    let p = design.p_matrix();
    let obs = design.observer_model(model);
    let capacity = match &obs {
        Ok(obs) if p.nrows() == obs.nx() => {
            let gammas: Vec<DMatrix<f64>> = design.l_matrices().iter().map(|l| &p * l).collect();
            crate::certificate::alpha_capacity_sampled(obs, design.gamma, h, &p, &gammas)
        }
        _ => 0.0,
    };
    let alpha = if capacity > 0.0 {
        design.alpha.min(capacity * (1.0 - 1e-6))
    } else {
        design.alpha
    };
    let at = design.at_sample(h, alpha);
    let certificate = match &obs {
        Ok(obs) => at.recheck_on(obs),
        Err(_) => at.recheck(model),
    };
    let bound = if !certificate.passed {
        Err(format!(
            "the gains are not certified at h = {h:e} (the discrete family fails at α = {alpha:.6})"
        ))
    } else {
        design_bound(model, design, alpha, h)
    };
    SampledClaim {
        h,
        alpha,
        capacity,
        certificate,
        bound,
    }
}

/// Why the global observer of an LPV plant without a declared state bound
/// gets no continuous-plant bound, and what to add.
const GLOBAL_WITHOUT_Q: &str = "the global observer (LPV plant) needs no state bound, but the bound on the truncation error does: declare the plant's operating envelope with `state_bound Q = [...];` (x(t) stays in {xᵀQ⁻¹x ≤ 1}) to get one";

/// The model the continuous-plant bound is computed on for `design`: its
/// observer model, which carries the Q the design used (also a computed
/// one, `state_bound auto`); for the global observer of an LPV plant, whose
/// observer model has no state bound, that model with the plant's declared
/// `state_bound` as the operating envelope the bound assumes x(t) stays in
/// (docs/method.md §16). An error for the filter route and for a global
/// observer without a declared Q.
pub fn bound_model(model: &PolytopicModel, design: &Design) -> Result<PolytopicModel, String> {
    let mut obs = design
        .observer_model(model)
        .map_err(|e| format!("observer's model: {e}"))?;
    if obs.nx() != model.nx() {
        return Err("the output filter route: not computed for this route".into());
    }
    if design.kind_on(model).is_global() {
        match &model.state_bound {
            StateBound::Given(q) => obs.state_bound = StateBound::Given(q.clone()),
            _ => return Err(GLOBAL_WITHOUT_Q.into()),
        }
    }
    Ok(obs)
}

/// The continuous-plant bound of `design`'s P at (h, α) on
/// [`bound_model`], marked `global` for the global observer (whose
/// recursion holds for every e).
fn design_bound(
    model: &PolytopicModel,
    design: &Design,
    alpha: f64,
    h: f64,
) -> Result<ContinuousBound, String> {
    bound_on(&bound_model(model, design)?, model, design, (alpha, h))
}

/// [`design_bound`] on the bound's model `m` ([`bound_model`]) already built.
fn bound_on(
    m: &PolytopicModel,
    model: &PolytopicModel,
    design: &Design,
    (alpha, h): (f64, f64),
) -> Result<ContinuousBound, String> {
    let mut b = continuous_bound(m, alpha, h, &design.p_matrix())?;
    b.global = design.kind_on(model).is_global();
    Ok(b)
}

/// The largest ‖x‖ of the state bound F of `m`, if it has one.
fn envelope_reach(m: &PolytopicModel) -> Option<f64> {
    match &m.state_bound {
        StateBound::Given(q) => Some(q.symmetric_eigenvalues().max().max(0.0).sqrt()),
        _ => None,
    }
}

/// Adds the continuous-plant bound to a certified sampled design's `sample`
/// key, or a note saying why it is not computed.
pub fn attach(model: &PolytopicModel, d: &mut Design) {
    let Some(h) = d.sample.map(|s| s.h) else {
        return;
    };
    let bound = bound_model(model, d).and_then(|m| {
        let b = bound_on(&m, model, d, (d.alpha, h))?;
        Ok((b, envelope_reach(&m)))
    });
    match bound {
        Ok((b, reach)) => {
            let b = match &d.noise {
                Some(nb) => b.with_noise((h, d.alpha), nb.sigma, nb.error_bound),
                None => b,
            };
            if let Some(s) = d.sample.as_mut() {
                s.continuous_bound = Some(b);
            }
            // A bound wider than the plant's own envelope is sound but
            // says nothing about the estimate's accuracy: say so.
            if let Some(reach) = reach {
                if b.holds() && b.ultimate_error >= reach {
                    d.notes.push(format!(
                        "sample = h: the continuous-plant bound lim sup ‖e‖ ≤ {:.4e} is not smaller than the largest ‖x‖ of the state bound F ({reach:.4e}): sound, but vacuous as a statement of the estimate's accuracy (a shorter period or a design at this h lowers it)",
                        b.ultimate_error
                    ));
                }
            }
            if b.global {
                d.notes.push(
                    "sample = h: the continuous-plant bound takes the declared state_bound Q as the plant's operating envelope: it assumes x(t) stays in {xᵀQ⁻¹x ≤ 1} (the global observer's certificate itself needs no state bound)",
                );
            }
        }
        Err(why) => d.notes.push(format!(
            "sample = h: no bound for the continuous plant sampled at h ({why})"
        )),
    }
}
