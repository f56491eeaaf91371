//! The plant generator of the `cube_plants` bench, shared with
//! the test that compares the cube assembly's nnz(A) with the independent
//! formulation's (tests/lmi_assembly.rs): mass-spring chains (half the
//! states positions, half rates) with θ-dependent quadratic terms N_k(θ) on
//! a few rate products v_i v_j, and random sparse plants (A(θ) and N_k(θ)
//! with a few nonzeros per row), one to three θ (every entry affine in θ,
//! 2^n_theta vertices), box regions with per-state half-widths (optionally
//! spread over decades, so that the unit balancing runs), with or without a
//! given state bound. Deterministic (a fixed-seed LCG).

#![allow(dead_code)]

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{PolytopicModel, StateBound, Vertex};
use qpv_solve::fixtures::{names, param};

/// A small deterministic generator (64-bit LCG).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.next() * n as f64) as usize).min(n - 1)
    }
    fn sym(&mut self) -> f64 {
        2.0 * self.next() - 1.0
    }
}

/// The box |x_i| ≤ h_i: 2^n vertices (first coordinate most significant,
/// − before +) and 2n facets ±e_i/h_i.
pub fn box_of(h: &[f64]) -> qpv_dsl::Region {
    let n = h.len();
    let vertices = (0..1usize << n)
        .map(|v| {
            DVector::from_fn(n, |i, _| {
                if (v >> (n - 1 - i)) & 1 == 1 {
                    h[i]
                } else {
                    -h[i]
                }
            })
        })
        .collect();
    let mut facets = Vec::with_capacity(2 * n);
    for (i, hi) in h.iter().enumerate() {
        for s in [1.0, -1.0] {
            let mut a = DVector::zeros(n);
            a[i] = s / hi;
            facets.push(a);
        }
    }
    qpv_dsl::Region {
        vertices,
        facets,
        generators: Vec::new(),
    }
}

/// The corners of the unit box [0, 1]^n_theta, first coordinate most
/// significant.
fn corners(n_theta: usize) -> Vec<Vec<f64>> {
    (0..1usize << n_theta)
        .map(|v| {
            (0..n_theta)
                .map(|i| ((v >> (n_theta - 1 - i)) & 1) as f64)
                .collect()
        })
        .collect()
}

/// One generated plant.
pub struct Plant {
    pub name: String,
    pub model: PolytopicModel,
    pub gamma: f64,
}

/// What a generated plant looks like.
#[derive(Clone, Copy)]
pub struct Spec {
    pub nx: usize,
    pub n_theta: usize,
    /// Chain (true) or random sparse (false).
    pub chain: bool,
    /// Quadratic terms (rate products for a chain, random entries else).
    pub n_quad: usize,
    pub ny: usize,
    /// A given state bound (else none).
    pub bound: bool,
    /// Half-widths spread over several decades (unit balancing runs).
    pub spread: bool,
    pub seed: u64,
}

impl Spec {
    pub fn name(&self) -> String {
        format!(
            "{}{}-th{}-q{}-y{}{}{}",
            if self.chain { "chain" } else { "rand" },
            self.nx,
            self.n_theta,
            self.n_quad,
            self.ny,
            if self.bound { "-Q" } else { "" },
            if self.spread { "-units" } else { "" }
        )
    }

    /// The plant: x' = A(θ)x + Σ_k e_k xᵀN_k(θ)x, y = Cx, θ ∈ [0, 1]^n_theta
    /// (2^n_theta vertices, every entry affine in θ).
    pub fn build(&self) -> Plant {
        let (nx, ny, nt) = (self.nx, self.ny, self.n_theta);
        let mut rng = Lcg(self.seed);
        // A = A0 + Σ_t θ_t A_t, N_k = Σ_t θ_t N_{k,t} (plus a constant part).
        let mut a0 = DMatrix::zeros(nx, nx);
        let mut at: Vec<DMatrix<f64>> = vec![DMatrix::zeros(nx, nx); nt];
        // Quadratic entries: (row k, i, j, constant, per-θ coefficients).
        let mut quad: Vec<(usize, usize, usize, f64, Vec<f64>)> = Vec::new();
        if self.chain {
            let m = nx / 2;
            for i in 0..m {
                a0[(i, m + i)] = 1.0;
                a0[(m + i, i)] = -2.0;
                a0[(m + i, m + i)] = -0.4;
                if i > 0 {
                    a0[(m + i, i - 1)] = 1.0;
                }
                if i + 1 < m {
                    a0[(m + i, i + 1)] = 1.0;
                }
                // θ_t stiffens spring i (t = i mod nt) and damps rate i.
                let t = i % nt;
                at[t][(m + i, i)] -= 0.5;
                at[t][(m + i, m + i)] -= 0.1;
            }
            for q in 0..self.n_quad {
                // Rate product v_i v_j into rate rows k and k' (equal and
                // opposite, a momentum exchange), θ-dependent.
                let i = m + (q * 2) % m;
                let j = m + (q * 2 + 1) % m;
                let k = m + (q * 3 + 1) % m;
                let k2 = m + (q * 3 + 2) % m;
                let mut c: Vec<f64> = (0..nt).map(|_| 0.0).collect();
                c[q % nt] = 0.3;
                quad.push((k, i, j, 0.1, c.clone()));
                quad.push((k2, i, j, -0.1, c.iter().map(|x| -x).collect()));
            }
        } else {
            for r in 0..nx {
                a0[(r, r)] = -1.0 - 0.5 * rng.next();
                for _ in 0..2 {
                    let c = rng.below(nx);
                    if c != r {
                        a0[(r, c)] += 0.8 * rng.sym();
                    }
                }
                let t = rng.below(nt);
                let c = rng.below(nx);
                at[t][(r, c)] += 0.3 * rng.sym();
            }
            for _ in 0..self.n_quad {
                let (k, i, j) = (rng.below(nx), rng.below(nx), rng.below(nx));
                let mut c: Vec<f64> = (0..nt).map(|_| 0.0).collect();
                c[rng.below(nt)] = 0.4 * rng.sym();
                quad.push((k, i, j, 0.2 * rng.sym(), c));
            }
        }
        let c = DMatrix::from_fn(ny, nx, |r, c| {
            let stride = (nx / 2).max(1) / ny.max(1);
            if c == r * stride.max(1) {
                1.0
            } else {
                0.0
            }
        });
        let vertices = corners(nt)
            .into_iter()
            .map(|theta| {
                let mut a = a0.clone();
                for (t, m) in at.iter().enumerate() {
                    a += m * theta[t];
                }
                let mut n = vec![DMatrix::zeros(nx, nx); nx];
                for (k, i, j, c0, ct) in &quad {
                    let v: f64 = c0 + ct.iter().zip(&theta).map(|(c, t)| c * t).sum::<f64>();
                    n[*k][(*i, *j)] += v;
                }
                Vertex {
                    theta,
                    a,
                    n,
                    b: DMatrix::zeros(nx, 0),
                    c: c.clone(),
                    m: vec![DMatrix::zeros(nx, nx); ny],
                }
            })
            .collect();
        // Half-widths: 0.05 (or spread over decades: positions 0.002,
        // rates 0.05 · 2^(i mod 3)).
        let h: Vec<f64> = (0..nx)
            .map(|i| {
                if !self.spread {
                    0.05
                } else if i < nx / 2 {
                    0.001
                } else {
                    0.05 * f64::from(1u32 << (i % 3))
                }
            })
            .collect();
        let q = DMatrix::from_fn(nx, nx, |r, c| {
            if r == c {
                1.5 * nx as f64 * h[r] * h[r]
            } else {
                0.0
            }
        });
        let model = PolytopicModel {
            name: self.name(),
            states: names("x", nx),
            inputs: vec![],
            input_rates: vec![],
            input_ranges: vec![],
            outputs: names("y", ny),
            params: (0..nt)
                .map(|t| param(&format!("th{t}"), 0.0, 1.0))
                .collect(),
            scheduling: (0..nt).collect(),
            vertices,
            region: box_of(&h),
            state_bound: if self.bound {
                StateBound::Given(q)
            } else {
                StateBound::None
            },
            designs: vec![],
            noise: Default::default(),
            derived: Vec::new(),
            cover: None,
            time_unit: Default::default(),
            jacobian: None,
        };
        Plant {
            name: self.name(),
            model,
            gamma: 0.2,
        }
    }
}

/// Every plant of the bench.
pub fn plants() -> Vec<Spec> {
    let s = |nx, n_theta, chain, n_quad, ny, bound, spread| Spec {
        nx,
        n_theta,
        chain,
        n_quad,
        ny,
        bound,
        spread,
        seed: 40 + nx as u64,
    };
    vec![
        // The held-out plant of docs/method.md, "Held-out plants": 12-state chain, two θ, θ-dependent
        // N_k on four rate products, three outputs, box region.
        s(12, 2, true, 4, 3, true, false),
        s(12, 2, true, 4, 3, true, true),
        s(12, 2, true, 4, 3, false, false),
        s(6, 1, true, 2, 2, true, false),
        s(8, 2, true, 3, 2, true, true),
        s(10, 3, true, 4, 3, false, false),
        s(16, 2, true, 6, 3, true, false),
        s(6, 2, false, 4, 2, true, false),
        s(8, 1, false, 6, 2, false, true),
        s(10, 2, false, 8, 3, true, false),
        s(12, 2, false, 10, 3, true, true),
        s(14, 3, false, 10, 3, false, false),
        s(16, 2, false, 12, 3, true, false),
    ]
}
