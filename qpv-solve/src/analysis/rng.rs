//! The seeded generator of the analyses: the falsifier's samples and the
//! measurement noise of a simulation, the same on every platform.

/// splitmix64: a tiny, good-enough generator for sampling (not cryptographic).
#[derive(Debug, Clone)]
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub(crate) fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform index in 0..n (n > 0).
    pub(crate) fn index(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n - 1)
    }

    /// Standard normal (Box-Muller).
    pub(crate) fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// A point in the unit ball of dimension z.len(): uniform inside, or
    /// uniform on the sphere if `boundary`.
    pub(crate) fn ball(&mut self, z: &mut [f64], boundary: bool) {
        loop {
            for v in z.iter_mut() {
                *v = self.normal();
            }
            let norm = z.iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm > 1e-300 {
                let radius = if boundary {
                    1.0
                } else {
                    self.uniform().powf(1.0 / z.len() as f64)
                };
                for v in z.iter_mut() {
                    *v *= radius / norm;
                }
                return;
            }
            if z.is_empty() {
                return;
            }
        }
    }
}
