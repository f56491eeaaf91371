//! Ready-made models: the paper's example (see docs/method.md), built by
//! hand, and a synthetic scale family for benchmarks and tests.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{Param, PolytopicModel, Region, Span, StateBound, Vertex};

/// Names `prefix1` .. `prefix<n>` (states, outputs of a hand-built model).
pub fn names(prefix: &str, n: usize) -> Vec<String> {
    (1..=n).map(|i| format!("{prefix}{i}")).collect()
}

/// A parameter `name ∈ [lo, hi]` without a source position.
pub fn param(name: &str, lo: f64, hi: f64) -> Param {
    Param {
        name: name.to_string(),
        lo,
        hi,
        span: Span::default(),
        rate: None,
        measured: None,
    }
}

/// The box |x_i| ≤ h in R^n: 2^n vertices (first coordinate most
/// significant, − before +) and 2n facets ±e_i/h.
pub fn box_region(n: usize, h: f64) -> Region {
    let vertices = (0..1usize << n)
        .map(|v| DVector::from_fn(n, |i, _| if (v >> (n - 1 - i)) & 1 == 1 { h } else { -h }))
        .collect();
    let mut facets = Vec::with_capacity(2 * n);
    for i in 0..n {
        for s in [1.0, -1.0] {
            let mut a = DVector::zeros(n);
            a[i] = s / h;
            facets.push(a);
        }
    }
    Region {
        vertices,
        facets,
        generators: Vec::new(),
    }
}

/// A(θ) of the paper's example.
pub fn paper_a(t1: f64, t2: f64) -> DMatrix<f64> {
    DMatrix::from_row_slice(
        3,
        3,
        &[
            -4.0 - t1,
            10.0,
            2.0 + 2.0 * t2, //
            -1.0,
            -1.0 - t2,
            1.5 + 2.0 * t1, //
            1.0,
            1.0,
            -4.0 - 3.0 * t1,
        ],
    )
}

/// N_1(θ), N_2(θ), N_3(θ) of the paper's example, as printed.
pub fn paper_n(t1: f64, t2: f64) -> Vec<DMatrix<f64>> {
    vec![
        DMatrix::from_row_slice(
            3,
            3,
            &[0.5, 1.0 + t1, 0.0, 0.0, 0.0, -t2, 0.0, 1.0 + t2, 0.0],
        ),
        DMatrix::from_row_slice(
            3,
            3,
            &[-0.4, 0.0, 1.0 - t1, 1.5, 0.0, 1.0 + t2, 2.0 + t2, 0.0, 0.0],
        ),
        DMatrix::from_row_slice(
            3,
            3,
            &[1.5, -0.5 - t1, 0.0, 3.0 + t1, 0.0, 0.0, 0.0, 2.0 - t2, 0.0],
        ),
    ]
}

/// The paper's Q.
pub fn paper_q() -> DMatrix<f64> {
    DMatrix::from_row_slice(
        3,
        3,
        &[
            0.0112, 0.0017, 0.0006, 0.0017, 0.0025, -0.0022, 0.0006, -0.0022, 0.0061,
        ],
    )
}

/// The paper's example (docs/method.md) in polytopic form: 4 vertices in the
/// order μ1 = (1−θ1)(1−θ2), μ2 = (1−θ1)θ2, μ3 = θ1(1−θ2), μ4 = θ1θ2;
/// the box |x_i| ≤ 0.02; the paper's Q. No design requests.
pub fn paper_model() -> PolytopicModel {
    let corners = [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)];
    let mut m1 = DMatrix::zeros(3, 3);
    m1[(1, 2)] = 1.0;
    let mut m2 = DMatrix::zeros(3, 3);
    m2[(0, 2)] = 1.0;
    let vertices = corners
        .iter()
        .map(|&(t1, t2)| Vertex {
            theta: vec![t1, t2],
            a: paper_a(t1, t2),
            n: paper_n(t1, t2),
            b: DMatrix::zeros(3, 0),
            c: DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]),
            m: vec![m1.clone(), m2.clone()],
        })
        .collect();
    PolytopicModel {
        name: "paper".to_string(),
        states: names("x", 3),
        inputs: vec![],
        input_rates: vec![],
        input_ranges: vec![],
        outputs: names("y", 2),
        params: vec![param("theta1", 0.0, 1.0), param("theta2", 0.0, 1.0)],
        scheduling: vec![0, 1],
        vertices,
        region: box_region(3, 0.02),
        state_bound: StateBound::Given(paper_q()),
        designs: vec![],
        noise: Default::default(),
        derived: Vec::new(),
        cover: None,
        time_unit: Default::default(),
        jacobian: None,
    }
}

/// A synthetic scale model: nx states, 2 outputs (x_1, x_2), two
/// parameters in [0, 1] (4 vertices), a stable chain-like A(θ) with
/// θ-dependent couplings, small quadratic terms, the box |x_i| ≤ h = 0.02
/// and Q = 1.5·nx·h²·I (so P ⊂ F and γ_max = 1/√(1.5·nx)). Deterministic.
pub fn synthetic_model(nx: usize) -> PolytopicModel {
    assert!(nx >= 2);
    let ny = 2;
    let h = 0.02;
    let c = DMatrix::from_fn(ny, nx, |r, c| if r == c { 1.0 } else { 0.0 });
    let m = (0..ny)
        .map(|k| {
            DMatrix::from_fn(nx, nx, |r, c| {
                if r == (k + 1) % nx && c == nx - 1 {
                    0.5
                } else {
                    0.0
                }
            })
        })
        .collect::<Vec<_>>();
    let corners = [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)];
    let vertices = corners
        .iter()
        .map(|&(t1, t2)| {
            let a = DMatrix::from_fn(nx, nx, |r, c| {
                if r == c {
                    -2.0 - 0.5 * t1 - 0.1 * r as f64
                } else if c == r + 1 {
                    1.0 + 0.5 * t2
                } else if r == c + 1 {
                    -0.5 + 0.3 * t1
                } else {
                    0.0
                }
            });
            let n = (0..nx)
                .map(|k| {
                    DMatrix::from_fn(nx, nx, |r, c| {
                        let v = ((k + 2 * r + 3 * c) % 5) as f64 - 2.0;
                        0.2 * v * (1.0 + 0.5 * if (r + c) % 2 == 0 { t1 } else { t2 })
                    })
                })
                .collect();
            Vertex {
                theta: vec![t1, t2],
                a,
                n,
                b: DMatrix::zeros(nx, 0),
                c: c.clone(),
                m: m.clone(),
            }
        })
        .collect();
    PolytopicModel {
        name: format!("synthetic{nx}"),
        states: names("x", nx),
        inputs: vec![],
        input_rates: vec![],
        input_ranges: vec![],
        outputs: names("y", ny),
        params: vec![param("theta1", 0.0, 1.0), param("theta2", 0.0, 1.0)],
        scheduling: vec![0, 1],
        vertices,
        region: box_region(nx, h),
        state_bound: StateBound::Given(DMatrix::identity(nx, nx) * (1.5 * h * h * nx as f64)),
        designs: vec![],
        noise: Default::default(),
        derived: Vec::new(),
        cover: None,
        time_unit: Default::default(),
        jacobian: None,
    }
}
