//! The reference right-hand sides of plant and observer (docs/method.md):
//! the model's matrices frozen at one θ ([`Frozen`]), and the plant's and
//! the observer's derivatives and output on slices.

use crate::analysis::checks::{check_gains, check_len, check_model, SimError};
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

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
pub(crate) fn add_mul(out: &mut [f64], t: &DMatrix<f64>, v: &[f64]) {
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
    /// The nonlinear terms of unmeasured states and the middle of their
    /// Jacobian box (which Σ_l μ_l A_l carries), if the model has them.
    nonlinear: Option<(qpv_dsl::Jacobian, DMatrix<f64>)>,
    /// The θ of the last [`Frozen::set`] (the nonlinear terms read it).
    theta: Vec<f64>,
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
            nonlinear: model.jacobian.as_ref().map(|j| {
                let mid = j
                    .bound
                    .as_ref()
                    .map_or_else(|| DMatrix::zeros(nx, nx), |b| b.mid.clone());
                (j.clone(), mid)
            }),
            theta: vec![0.0; model.ntheta()],
        }
    }

    /// Sets every matrix to its value at `theta`: X(θ) = Σ_l μ_l(θ) X_l.
    /// With `gains` empty, L(θ) = 0.
    pub(crate) fn set(&mut self, model: &PolytopicModel, gains: &[DMatrix<f64>], theta: &[f64]) {
        self.mu = model.mu(theta);
        self.theta.clear();
        self.theta.extend_from_slice(theta);
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

    /// out = A(θ) x + N(θ, x) x + f(x, θ): the drift without input, with
    /// the nonlinear terms of unmeasured states evaluated as written (the
    /// middle of their Jacobian box, which the weighted A carries, taken
    /// off again).
    pub(crate) fn drift(&self, x: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        add_mul(out, &self.a, x);
        for (o, nk) in out.iter_mut().zip(&self.n) {
            *o += quad(nk, x);
        }
        if let Some((j, mid)) = &self.nonlinear {
            let f = j.eval(out.len(), x, &self.theta);
            for (o, fk) in out.iter_mut().zip(f) {
                *o += fk;
            }
            add_mul(out, &(-mid), x);
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

    /// out = A(θ) x + N(θ, x) x + B(θ) u: the plant's right-hand side.
    pub(crate) fn plant(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        self.drift(x, out);
        self.add_input(u, out);
    }

    /// out = the observer's right-hand side, docs/method.md §2, fed the
    /// measurement `y`, which becomes the innovation y − C x̂ − M(x̂) x̂
    /// (`yhat` a buffer of ny entries).
    pub(crate) fn observer(
        &self,
        (xhat, u): (&[f64], &[f64]),
        (y, yhat): (&mut [f64], &mut [f64]),
        out: &mut [f64],
    ) {
        self.output(xhat, yhat);
        for (y, yh) in y.iter_mut().zip(yhat.iter()) {
            *y -= yh;
        }
        self.plant(xhat, u, out);
        self.add_gain(y, out);
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
    frozen.plant(x, u, &mut dx);
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

/// The observer's right-hand side, docs/method.md §2:
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
    let (mut y, mut yhat) = (y.to_vec(), vec![0.0; model.ny()]);
    frozen.observer((xhat, u), (&mut y, &mut yhat), &mut dxhat);
    Ok(dxhat)
}
