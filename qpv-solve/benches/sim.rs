//! Timing of the simulator and the falsifier on the paper's example
//! (docs/method.md §14). Run with `cargo bench --bench sim`; prints numbers.

use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::falsify::{falsify, falsify_design};
use qpv_solve::simulate::{simulate, Scenario};
use std::hint::black_box;
use std::time::Instant;

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

    // the certified sound design of the paper's example (α = 10, γ = 0.1889)
    let request = DesignRequest {
        alpha: AlphaSpec::Fixed(10.0),
        gamma: GammaSpec::Fixed(0.1889),
        mode: Mode::Sound,
        ..Default::default()
    };
    match qpv_solve::design(&model, &request, &qpv_solve::Settings::default()) {
        Ok(design) if design.certifies() => {
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
