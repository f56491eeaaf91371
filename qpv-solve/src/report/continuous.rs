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
//! ẍ = f_x(x, θ) f(x, θ) + Σ_i ∂f/∂θ_i θ̇_i (no inputs). On the polytopic
//! model f(x, θ) = Σ_l μ_l(θ) f_l(x) exactly (multi-affine in θ, no derived
//! scheduling variables, no cover), with f_l(x) = A_l x + (xᵀN_{l,k}x)_k:
//! f_x f = Σ_{l,m} μ_l μ_m J_l(x) f_m(x) lies in the hull of the J_l f_m,
//! and ∂f/∂θ_i lies in the hull of (f_{l+} − f_{l−})/(hi_i − lo_i) over the
//! edges of the box along θ_i. Each is bounded by interval arithmetic on
//! the bounding box of F = {xᵀQ⁻¹x ≤ 1}, |x_i| ≤ √Q_ii. A parameter without
//! a declared `rate` is assumed constant over each step (its term is 0).

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
    fn sub(self, o: Iv) -> Iv {
        Iv(self.0 - o.1, self.1 - o.0)
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

/// f_l(X) componentwise: A_l x + (xᵀN_{l,k}x)_k on the box X.
fn f_iv(a: &DMatrix<f64>, n: &[DMatrix<f64>], x: &[Iv]) -> Vec<Iv> {
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

/// The bound for the continuous plant at (h, α) with the Lyapunov matrix
/// `p` (model units, nx × nx), or why it is not computed.
pub fn continuous_bound(
    model: &PolytopicModel,
    alpha: f64,
    h: f64,
    p: &DMatrix<f64>,
) -> Result<ContinuousBound, String> {
    let nx = model.nx();
    if model.nu() > 0 {
        return Err(
            "the model has inputs and declares no bound on their amplitude: f over F is not bounded"
                .into(),
        );
    }
    if !model.derived.is_empty() || model.cover.is_some() {
        return Err("the model has derived scheduling variables or a cover: its polytopic form over-approximates the plant, whose θ-derivative is not bounded yet".into());
    }
    let StateBound::Given(q) = &model.state_bound else {
        return Err("no state bound Q: F is not known".into());
    };
    if p.shape() != (nx, nx) || q.shape() != (nx, nx) {
        return Err(
            "P is not nx × nx (an output filter design): not computed for this route".into(),
        );
    }
    if !(h > 0.0 && h * alpha > 0.0 && h * alpha < 1.0) {
        return Err(format!("hα = {} is not in (0, 1)", h * alpha));
    }
    let x: Vec<Iv> = (0..nx)
        .map(|i| {
            let r = q[(i, i)].max(0.0).sqrt();
            Iv(-r, r)
        })
        .collect();
    let vs = &model.vertices;
    let fs: Vec<Vec<Iv>> = vs.iter().map(|v| f_iv(&v.a, &v.n, &x)).collect();
    let js: Vec<Vec<Vec<Iv>>> = vs.iter().map(|v| jac_iv(&v.a, &v.n, &x)).collect();
    // f_x f: the hull over (l, m) of J_l f_m.
    let mut acc = vec![0.0f64; nx];
    for j in &js {
        for f in &fs {
            for k in 0..nx {
                let mut s = Iv::point(0.0);
                for (jj, fj) in f.iter().enumerate() {
                    s = s.add(j[k][jj].mul(*fj));
                }
                acc[k] = acc[k].max(s.mag());
            }
        }
    }
    // Σ_i ∂f/∂θ_i θ̇_i: edges along each scheduling parameter.
    let s = model.scheduling.len();
    let mut rates_declared = true;
    let mut theta_term = vec![0.0f64; nx];
    for (i, &pi) in model.scheduling.iter().enumerate() {
        let par = &model.params[pi];
        let Some(rate) = par.rate else {
            rates_declared = false;
            continue;
        };
        let bit = 1usize << (s - 1 - i);
        let mut worst = vec![0.0f64; nx];
        for lo in (0..vs.len()).filter(|l| l & bit == 0) {
            let hi = lo | bit;
            for k in 0..nx {
                let d = fs[hi][k].sub(fs[lo][k]).mag() / (par.hi - par.lo);
                worst[k] = worst[k].max(d);
            }
        }
        for k in 0..nx {
            theta_term[k] += rate * worst[k];
        }
    }
    let accel = acc
        .iter()
        .zip(&theta_term)
        .map(|(a, t)| (a + t).powi(2))
        .sum::<f64>()
        .sqrt();
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
    })
}

/// Adds the continuous-plant bound to a certified sampled design's `sample`
/// key, or a note saying why it is not computed.
pub fn attach(model: &PolytopicModel, d: &mut Design) {
    let Some(h) = d.sample.map(|s| s.h) else {
        return;
    };
    match continuous_bound(model, d.alpha, h, &d.p_matrix()) {
        Ok(b) => {
            if let Some(s) = d.sample.as_mut() {
                s.continuous_bound = Some(b);
            }
        }
        Err(why) => d.notes.push(format!(
            "sample = h: no bound for the continuous plant sampled at h ({why})"
        )),
    }
}
