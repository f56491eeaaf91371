//! The baseline of benches/ekf.rs: a continuous-discrete extended Kalman
//! filter for any QPV model of the language, and the pieces it shares with
//! the qpv observer it is compared with there: the polytopic model frozen
//! at μ(θ) in fixed-size matrices, its right-hand side, its output and
//! their exact Jacobians,
//!
//! ```text
//! ∂(A x + N(θ,x) x)/∂x = A + rows ((N_k + N_kᵀ) x)ᵀ,   ∂(C x + M(θ,x) x)/∂x = C + rows ((M_k + M_kᵀ) x)ᵀ.
//! ```
//!
//! Used only to compare; validated by tests/ekf_baseline.rs (a module of
//! the `generated` test binary, which includes this file).

use nalgebra::{DMatrix, SMatrix, SVector};
use qpv::dsl::PolytopicModel;

/// A fixed-size matrix.
pub type Mat<const R: usize, const C: usize> = SMatrix<f64, R, C>;
/// A fixed-size vector.
pub type Vector<const N: usize> = SVector<f64, N>;

/// A QPV model's matrices at one vertex, or frozen at one μ(θ). N_k and
/// M_k are kept as S_k = N_k + N_kᵀ: xᵀN_k x = ½ xᵀS_k x, and row k of the
/// Jacobian is (S_k x)ᵀ. Inputs are not kept (every run here has u = 0).
#[derive(Debug, Clone, Copy)]
pub struct Frozen<const NX: usize, const NY: usize> {
    /// A.
    pub a: Mat<NX, NX>,
    /// N_k + N_kᵀ, one per state.
    pub sn: [Mat<NX, NX>; NX],
    /// C.
    pub c: Mat<NY, NX>,
    /// M_k + M_kᵀ, one per output.
    pub sm: [Mat<NX, NX>; NY],
    /// The observer gain L (zero for a model without gains).
    pub l: Mat<NX, NY>,
}

impl<const NX: usize, const NY: usize> Frozen<NX, NY> {
    fn zero() -> Self {
        Frozen {
            a: Mat::zeros(),
            sn: [Mat::zeros(); NX],
            c: Mat::zeros(),
            sm: [Mat::zeros(); NY],
            l: Mat::zeros(),
        }
    }

    /// f(x) = A x + N(θ, x) x.
    pub fn f(&self, x: &Vector<NX>) -> Vector<NX> {
        let mut out = self.a * x;
        for (o, s) in out.iter_mut().zip(&self.sn) {
            *o += 0.5 * x.dot(&(s * x));
        }
        out
    }

    /// f(x) and its Jacobian ∂f/∂x.
    pub fn f_jac(&self, x: &Vector<NX>) -> (Vector<NX>, Mat<NX, NX>) {
        let mut out = self.a * x;
        let mut jac = self.a;
        for (k, s) in self.sn.iter().enumerate() {
            let sx = s * x;
            out[k] += 0.5 * x.dot(&sx);
            for j in 0..NX {
                jac[(k, j)] += sx[j];
            }
        }
        (out, jac)
    }

    /// h(x) = C x + M(θ, x) x.
    pub fn h(&self, x: &Vector<NX>) -> Vector<NY> {
        let mut out = self.c * x;
        for (o, s) in out.iter_mut().zip(&self.sm) {
            *o += 0.5 * x.dot(&(s * x));
        }
        out
    }

    /// h(x) and its Jacobian ∂h/∂x.
    pub fn h_jac(&self, x: &Vector<NX>) -> (Vector<NY>, Mat<NY, NX>) {
        let mut out = self.c * x;
        let mut jac = self.c;
        for (k, s) in self.sm.iter().enumerate() {
            let sx = s * x;
            out[k] += 0.5 * x.dot(&sx);
            for j in 0..NX {
                jac[(k, j)] += sx[j];
            }
        }
        (out, jac)
    }

    /// The qpv observer's right-hand side, docs/method.md §2 with u = 0:
    /// f(x̂) + L (y − h(x̂)).
    pub fn observer(&self, xhat: &Vector<NX>, y: &Vector<NY>) -> Vector<NX> {
        self.f(xhat) + self.l * (y - self.h(xhat))
    }
}

/// A polytopic QPV model in fixed-size matrices: one [`Frozen`] per vertex
/// (with its gain L_l when gains are given).
#[derive(Debug, Clone)]
pub struct Qpv<const NX: usize, const NY: usize> {
    vertices: Vec<Frozen<NX, NY>>,
    gains: bool,
}

/// `m` (nr × nc dynamic) as a fixed-size matrix.
fn fixed<const R: usize, const C: usize>(m: &DMatrix<f64>) -> Mat<R, C> {
    assert_eq!((m.nrows(), m.ncols()), (R, C), "matrix size");
    Mat::from_fn(|i, j| m[(i, j)])
}

impl<const NX: usize, const NY: usize> Qpv<NX, NY> {
    /// The vertices of `model` with the gains `gains` (one per vertex, or
    /// none). Panics if the sizes are not NX, NY.
    pub fn new(model: &PolytopicModel, gains: &[DMatrix<f64>]) -> Self {
        assert_eq!((model.nx(), model.ny()), (NX, NY), "model size");
        assert!(
            gains.is_empty() || gains.len() == model.nv(),
            "one gain per vertex"
        );
        let sym = |m: &DMatrix<f64>| {
            let f: Mat<NX, NX> = fixed(m);
            f + f.transpose()
        };
        let vertices = model
            .vertices
            .iter()
            .enumerate()
            .map(|(l, v)| Frozen {
                a: fixed(&v.a),
                sn: std::array::from_fn(|k| sym(&v.n[k])),
                c: fixed(&v.c),
                sm: std::array::from_fn(|k| sym(&v.m[k])),
                l: gains.get(l).map_or_else(Mat::zeros, fixed),
            })
            .collect();
        Qpv {
            vertices,
            gains: !gains.is_empty(),
        }
    }

    /// The model frozen at the weights `mu` (μ_l(θ), vertex order):
    /// X(θ) = Σ_l μ_l X_l.
    pub fn at(&self, mu: &[f64]) -> Frozen<NX, NY> {
        let mut out = Frozen::zero();
        for (v, &w) in self.vertices.iter().zip(mu) {
            if w == 0.0 {
                continue;
            }
            out.a += v.a * w;
            out.c += v.c * w;
            for (s, vs) in out.sn.iter_mut().zip(&v.sn) {
                *s += vs * w;
            }
            for (s, vs) in out.sm.iter_mut().zip(&v.sm) {
                *s += vs * w;
            }
            if self.gains {
                out.l += v.l * w;
            }
        }
        out
    }
}

/// One classic RK4 step of x' = g(stage, x) over dt, where the stage is 0
/// (t), 1 (t + dt/2) or 2 (t + dt).
pub fn rk4<const N: usize>(
    x: &Vector<N>,
    dt: f64,
    mut g: impl FnMut(usize, &Vector<N>) -> Vector<N>,
) -> Vector<N> {
    let k1 = g(0, x);
    let k2 = g(1, &(x + k1 * (0.5 * dt)));
    let k3 = g(1, &(x + k2 * (0.5 * dt)));
    let k4 = g(2, &(x + k3 * dt));
    x + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0)
}

/// A continuous-discrete extended Kalman filter: the mean predicted by RK4
/// of the model between measurements, the covariance by
/// P ← Φ P Φᵀ + Q_d with Φ = I + dt ∂f/∂x at the updated estimate, and a
/// Joseph-form update at each measurement.
#[derive(Debug, Clone)]
pub struct Ekf<const NX: usize, const NY: usize> {
    /// The estimate x̂.
    pub x: Vector<NX>,
    /// Its covariance P.
    pub p: Mat<NX, NX>,
    /// The process noise per step Q_d.
    pub q: Mat<NX, NX>,
    /// The measurement noise covariance R.
    pub r: Mat<NY, NY>,
}

impl<const NX: usize, const NY: usize> Ekf<NX, NY> {
    /// The update with the measurement `y`, on the model frozen at the
    /// measurement's θ; returns the gain K (None if H P Hᵀ + R is singular:
    /// nothing is updated then).
    pub fn update(&mut self, m: &Frozen<NX, NY>, y: &Vector<NY>) -> Option<Mat<NX, NY>> {
        let (yhat, h) = m.h_jac(&self.x);
        let ph = self.p * h.transpose();
        let s = h * ph + self.r;
        let k = ph * s.try_inverse()?;
        self.x += k * (y - yhat);
        let ikh = Mat::<NX, NX>::identity() - k * h;
        self.p = ikh * self.p * ikh.transpose() + k * self.r * k.transpose();
        Some(k)
    }

    /// The prediction over dt, the model frozen at t, t + dt/2 and t + dt.
    pub fn predict(&mut self, m: [&Frozen<NX, NY>; 3], dt: f64) {
        let (k1, f) = m[0].f_jac(&self.x);
        let phi = Mat::<NX, NX>::identity() + f * dt;
        self.p = phi * self.p * phi.transpose() + self.q;
        let mut first = Some(k1);
        self.x = rk4(&self.x, dt, |s, x| match first.take() {
            Some(k1) if s == 0 => k1,
            _ => m[s].f(x),
        });
    }

    /// The prediction over dt by one Euler step of the mean (the model
    /// frozen at t).
    pub fn predict_euler(&mut self, m: &Frozen<NX, NY>, dt: f64) {
        let (dx, f) = m.f_jac(&self.x);
        let phi = Mat::<NX, NX>::identity() + f * dt;
        self.p = phi * self.p * phi.transpose() + self.q;
        self.x += dx * dt;
    }
}
