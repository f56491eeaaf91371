//! Timing of the simulator and the falsifier on the paper's example
//! (spec §7). Run with `cargo bench -p qpv-solve --bench sim`; prints numbers.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{
    AlphaSpec, DesignRequest, GammaSpec, Mode, Param, PolytopicModel, Region, Span, StateBound,
    Vertex,
};
use qpv_solve::falsify::{falsify, falsify_design};
use qpv_solve::simulate::{simulate, Scenario};
use std::hint::black_box;
use std::time::Instant;

fn param(name: &str, lo: f64, hi: f64) -> Param {
    Param {
        name: name.to_string(),
        lo,
        hi,
        span: Span::default(),
    }
}

fn names(prefix: &str, n: usize) -> Vec<String> {
    (1..=n).map(|i| format!("{prefix}{i}")).collect()
}

fn box_region(half: f64, n: usize) -> Region {
    let vertices = (0..1usize << n)
        .map(|c| DVector::from_fn(n, |i, _| if c >> i & 1 == 1 { half } else { -half }))
        .collect();
    let facets = (0..n)
        .flat_map(|i| {
            [1.0, -1.0].map(|s| DVector::from_fn(n, |j, _| if i == j { s / half } else { 0.0 }))
        })
        .collect();
    Region { vertices, facets }
}

/// A(θ) of the paper's example (spec §7).
fn paper_a(t1: f64, t2: f64) -> DMatrix<f64> {
    DMatrix::from_row_slice(
        3,
        3,
        &[
            -4.0 - t1,
            10.0,
            2.0 + 2.0 * t2,
            -1.0,
            -1.0 - t2,
            1.5 + 2.0 * t1,
            1.0,
            1.0,
            -4.0 - 3.0 * t1,
        ],
    )
}

/// N_1(θ), N_2(θ), N_3(θ) of the paper's example (spec §7).
fn paper_n(t1: f64, t2: f64) -> Vec<DMatrix<f64>> {
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

/// The paper's example built by hand, vertices in the order
/// μ1 = (1−θ1)(1−θ2), μ2 = (1−θ1)θ2, μ3 = θ1(1−θ2), μ4 = θ1θ2.
fn paper_model() -> PolytopicModel {
    let corners = [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)];
    let vertices = corners
        .iter()
        .map(|&(t1, t2)| Vertex {
            theta: vec![t1, t2],
            a: paper_a(t1, t2),
            n: paper_n(t1, t2),
            b: DMatrix::zeros(3, 0),
        })
        .collect();
    let mut m1 = DMatrix::zeros(3, 3);
    m1[(1, 2)] = 1.0;
    let mut m2 = DMatrix::zeros(3, 3);
    m2[(0, 2)] = 1.0;
    PolytopicModel {
        name: "paper".to_string(),
        states: names("x", 3),
        inputs: vec![],
        outputs: names("y", 2),
        params: vec![param("theta1", 0.0, 1.0), param("theta2", 0.0, 1.0)],
        scheduling: vec![0, 1],
        vertices,
        c: DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]),
        m: vec![m1, m2],
        region: box_region(0.02, 3),
        state_bound: StateBound::Given(DMatrix::from_row_slice(
            3,
            3,
            &[
                0.0112, 0.0017, 0.0006, 0.0017, 0.0025, -0.0022, 0.0006, -0.0022, 0.0061,
            ],
        )),
        designs: vec![],
    }
}

/// CPU time of this thread in seconds (Linux: /proc/thread-self/schedstat),
/// so the numbers mean something on a loaded machine; `None` elsewhere.
fn cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

/// Median wall and CPU time of `runs` runs of `f`, in seconds.
fn median_seconds(runs: usize, mut f: impl FnMut()) -> (f64, Option<f64>) {
    let mut wall = Vec::with_capacity(runs);
    let mut cpu = Vec::with_capacity(runs);
    for _ in 0..runs {
        let (start, cpu_start) = (Instant::now(), cpu_seconds());
        f();
        wall.push(start.elapsed().as_secs_f64());
        if let (Some(a), Some(b)) = (cpu_start, cpu_seconds()) {
            cpu.push(b - a);
        }
    }
    wall.sort_by(f64::total_cmp);
    cpu.sort_by(f64::total_cmp);
    (wall[runs / 2], cpu.get(cpu.len() / 2).copied())
}

fn cpu_text(cpu: Option<f64>, scale: f64, unit: &str) -> String {
    cpu.map_or(String::new(), |c| format!(", CPU {:.3} {unit}", c * scale))
}

fn main() {
    let model = paper_model();
    // moderate output injection on y1 → x1, y2 → x2 (any finite gain times the same)
    let mut gain = DMatrix::zeros(3, 2);
    gain[(0, 0)] = 20.0;
    gain[(1, 1)] = 20.0;
    let gains = vec![gain; 4];

    let scenario = Scenario::paper(&model);
    let mut steps = 0;
    let (t_sim, cpu_sim) = median_seconds(21, || {
        let traj = simulate(&model, &gains, black_box(&scenario)).expect("valid scenario");
        steps = traj.len() - 1;
        black_box(traj);
    });
    println!(
        "simulate, paper scenario (t_end = 2, dt = 1e-3, {steps} RK4 steps): wall {:.3} ms{} (median of 21; {:.2} µs/step wall)",
        t_sim * 1e3,
        cpu_text(cpu_sim, 1e3, "ms"),
        t_sim * 1e6 / steps as f64
    );

    let p = DMatrix::identity(3, 3) * 2500.0;
    let samples = 1_000_000;
    let (t_fals, cpu_fals) = median_seconds(5, || {
        black_box(falsify(&model, &p, &gains, 1.0, 0.1889, samples, 1).expect("valid input"));
    });
    println!(
        "falsify, paper example: {samples} samples: wall {:.3} s{} (median of 5; {:.2} M samples/s wall{})",
        t_fals,
        cpu_text(cpu_fals, 1.0, "s"),
        samples as f64 / t_fals / 1e6,
        cpu_fals.map_or(String::new(), |c| format!(", {:.2} M samples/s CPU", samples as f64 / c / 1e6))
    );

    // the certified sound design of spec §7 (α = 10, γ = 0.1889)
    let request = DesignRequest {
        alpha: AlphaSpec::Fixed(10.0),
        gamma: GammaSpec::Fixed(0.1889),
        mode: Mode::Sound,
        ..Default::default()
    };
    match qpv_solve::design(&model, &request, &qpv_solve::Settings::default()) {
        Ok(design) if design.certifies => {
            let traj = simulate(&model, &design.l_matrices(), &scenario).expect("valid scenario");
            println!(
                "certified design (α = 10, γ = 0.1889): error {:.3e} at t = 1, below 1e-6 from t = {:?}",
                traj.error_norm[1000],
                traj.error_below(1e-6)
            );
            let start = Instant::now();
            let f = falsify_design(&model, &design, 100_000, 2026).expect("valid design");
            println!(
                "falsify certified design: {} samples, {} counterexamples, worst ratio {:.4} ({:.3} s)",
                f.samples,
                f.counterexamples,
                f.worst_ratio,
                start.elapsed().as_secs_f64()
            );
        }
        Ok(design) => println!("design not certified: {}", design.summary),
        Err(e) => println!("design failed: {e}"),
    }
}
