//! The one fixed-step integrator of the simulations: a classical RK4 step
//! ([`Rk4`]: the continuous run and the plant of the sampled run) and the
//! explicit Euler step ([`euler`]: the Euler run and the sampled observer).

/// A right-hand side dz = f(t, z); false if it cannot be evaluated there
/// (a signal that is not finite).
pub(crate) type Rhs<'a> = dyn FnMut(f64, &[f64], &mut [f64]) -> bool + 'a;

/// The stage buffers of classical RK4 for a system of one dimension.
pub(crate) struct Rk4 {
    k: [Vec<f64>; 4],
    stage: Vec<f64>,
}

impl Rk4 {
    /// Buffers for `dim` states.
    pub(crate) fn new(dim: usize) -> Self {
        Rk4 {
            k: [
                vec![0.0; dim],
                vec![0.0; dim],
                vec![0.0; dim],
                vec![0.0; dim],
            ],
            stage: vec![0.0; dim],
        }
    }

    /// One classical RK4 step of length `h` from (t, z), its last stage
    /// evaluated at `t1` (t + h, or the grid's end exactly):
    /// z ← z + h/6 (k1 + 2k2 + 2k3 + k4). False if `f` failed at a stage
    /// (z unchanged then).
    pub(crate) fn step(
        &mut self,
        f: &mut Rhs<'_>,
        (t, h, t1): (f64, f64, f64),
        z: &mut [f64],
    ) -> bool {
        let [k1, k2, k3, k4] = &mut self.k;
        let stage = &mut self.stage;
        let axpy = |dst: &mut [f64], c: f64, k: &[f64], z: &[f64]| {
            for ((d, zi), ki) in dst.iter_mut().zip(z).zip(k) {
                *d = zi + c * ki;
            }
        };
        let mut ok = f(t, z, k1);
        axpy(stage, 0.5 * h, k1, z);
        ok = ok && f(t + 0.5 * h, stage, k2);
        axpy(stage, 0.5 * h, k2, z);
        ok = ok && f(t + 0.5 * h, stage, k3);
        axpy(stage, h, k3, z);
        ok = ok && f(t1, stage, k4);
        if ok {
            for i in 0..z.len() {
                z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        ok
    }
}

/// z ← z + h·dz: the explicit Euler step with the derivative `dz` at z.
pub(crate) fn euler(z: &mut [f64], h: f64, dz: &[f64]) {
    for (z, d) in z.iter_mut().zip(dz) {
        *z += h * d;
    }
}
