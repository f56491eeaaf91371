//! The noisy run of `qpv simulate --noise NU`: plant and observer with
//! bounded measurement noise on the noisy outputs (y_meas = y + v, |v| ≤ ν,
//! seeded, held constant over each RK4 step), and the certified ultimate
//! bound on the error that a noise-bounded design carries.

use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;
use qpv_solve::simulate::{
    observer_derivative, plant_derivative, plant_output, Scenario, Trajectory,
};

/// A seeded generator of noise vectors (splitmix64: small, deterministic
/// and the same on every platform).
pub struct NoiseGen {
    state: u64,
    /// Amplitude ν: every vector has Euclidean norm exactly ν.
    pub amplitude: f64,
    /// Indices of the outputs the noise enters.
    pub outputs: Vec<usize>,
}

impl NoiseGen {
    /// A generator of amplitude `amplitude` on `outputs`, from `seed`.
    pub fn new(seed: u64, amplitude: f64, outputs: Vec<usize>) -> Self {
        NoiseGen {
            state: seed ^ 0x9E37_79B9_7F4A_7C15,
            amplitude,
            outputs,
        }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform number in [−1, 1).
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// The next noise vector on all `ny` outputs: a random direction on the
    /// noisy outputs scaled to norm ν (the largest amplitude the bound
    /// allows), zero on the others.
    pub fn sample(&mut self, ny: usize) -> Vec<f64> {
        let mut v = vec![0.0; ny];
        if self.outputs.is_empty() {
            return v;
        }
        let dir: Vec<f64> = loop {
            let d: Vec<f64> = (0..self.outputs.len()).map(|_| self.uniform()).collect();
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

/// Integrates plant and observer with classical RK4, the observer fed
/// y + v with v from `noise`, held over each step; the same rows as the
/// noise-free integrator. Errors are input errors of the model or gains.
pub fn simulate_noisy(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    sc: &Scenario,
    steps: usize,
    noise: &mut NoiseGen,
) -> Result<Trajectory, String> {
    let nx = model.nx();
    let ny = model.ny();
    let mut traj = Trajectory {
        t: Vec::with_capacity(steps + 1),
        x: Vec::with_capacity(steps + 1),
        xhat: Vec::with_capacity(steps + 1),
        theta: Vec::with_capacity(steps + 1),
        mu: Vec::with_capacity(steps + 1),
        error_norm: Vec::with_capacity(steps + 1),
        diverged_at: None,
    };
    let at = |t: f64| -> (Vec<f64>, Vec<f64>) {
        (
            sc.theta.iter().map(|s| s.at(t)).collect(),
            sc.u.iter().map(|s| s.at(t)).collect(),
        )
    };
    let record = |traj: &mut Trajectory, t: f64, z: &[f64]| {
        let (th, _) = at(t);
        let e = (0..nx)
            .map(|i| (z[i] - z[nx + i]).powi(2))
            .sum::<f64>()
            .sqrt();
        traj.t.push(t);
        traj.x.push(z[..nx].to_vec());
        traj.xhat.push(z[nx..].to_vec());
        traj.mu.push(model.mu(&th));
        traj.theta.push(th);
        traj.error_norm.push(e);
    };
    let rhs = |t: f64, z: &[f64], v: &[f64]| -> Result<Vec<f64>, String> {
        let (th, u) = at(t);
        let (x, xh) = z.split_at(nx);
        let mut y = plant_output(model, x, &th).map_err(|e| e.to_string())?;
        for (yi, vi) in y.iter_mut().zip(v) {
            *yi += vi;
        }
        let mut d = plant_derivative(model, x, &u, &th).map_err(|e| e.to_string())?;
        d.extend(observer_derivative(model, gains, xh, &y, &u, &th).map_err(|e| e.to_string())?);
        Ok(d)
    };
    let mut z: Vec<f64> = sc.x0.iter().chain(&sc.xhat0).copied().collect();
    record(&mut traj, 0.0, &z);
    for k in 0..steps {
        let t = k as f64 * sc.dt;
        let t_next = if k + 1 == steps {
            sc.t_end
        } else {
            (k + 1) as f64 * sc.dt
        };
        let h = t_next - t;
        let v = noise.sample(ny);
        let add = |c: f64, kv: &[f64]| -> Vec<f64> {
            z.iter().zip(kv).map(|(zi, ki)| zi + c * ki).collect()
        };
        let k1 = rhs(t, &z, &v)?;
        let k2 = rhs(t + 0.5 * h, &add(0.5 * h, &k1), &v)?;
        let k3 = rhs(t + 0.5 * h, &add(0.5 * h, &k2), &v)?;
        let k4 = rhs(t_next, &add(h, &k3), &v)?;
        for i in 0..z.len() {
            z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        if z.iter().any(|x| !x.is_finite()) {
            traj.diverged_at = Some(t_next);
            break;
        }
        record(&mut traj, t_next, &z);
    }
    Ok(traj)
}

/// The certified ultimate bound of a noise-bounded design at amplitude ν:
/// V(t) ≤ e^{−αt}V(0) + (σν²/α)(1 − e^{−αt}), ‖e(t)‖ ≤ √(V(t)/λ_min(P)).
#[derive(Debug, Clone, Copy)]
pub struct NoiseBoundCurve {
    /// V(0) = e(0)ᵀ P e(0).
    pub v0: f64,
    /// Decay rate α.
    pub alpha: f64,
    /// σ ν².
    pub sigma_nu2: f64,
    /// λ_min(P).
    pub lambda_min: f64,
}

impl NoiseBoundCurve {
    /// The curve for P, e(0), α, σ and ν; `None` if P is not positive definite.
    pub fn new(p: &DMatrix<f64>, e0: &[f64], alpha: f64, sigma: f64, nu: f64) -> Option<Self> {
        if p.is_empty() || !p.is_square() || e0.len() != p.nrows() {
            return None;
        }
        if !p.iter().all(|v| v.is_finite()) {
            return None;
        }
        let lambda_min = p.clone().symmetric_eigenvalues().min();
        if lambda_min.is_nan() || lambda_min <= 0.0 {
            return None;
        }
        let e = nalgebra::DVector::from_column_slice(e0);
        Some(NoiseBoundCurve {
            v0: e.dot(&(p * &e)),
            alpha,
            sigma_nu2: sigma * nu * nu,
            lambda_min,
        })
    }

    /// The bound on ‖e(t)‖.
    pub fn at(&self, t: f64) -> f64 {
        let d = (-self.alpha * t).exp();
        let v = d * self.v0 + self.sigma_nu2 / self.alpha * (1.0 - d);
        (v / self.lambda_min).sqrt()
    }

    /// The ultimate bound ‖e(∞)‖ ≤ √(σν²/(α λ_min(P))).
    pub fn ultimate(&self) -> f64 {
        (self.sigma_nu2 / (self.alpha * self.lambda_min)).sqrt()
    }
}
