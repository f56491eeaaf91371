//! The cost of the noise figures against one ordinary design, on the paper
//! example (sound mode, symmetric split, γ = 0.18898): the certified σ of a
//! given design (Schur formula plus the full-block check), the largest
//! Euler step, the noise-optimal design (one SDP), the noise-optimal design
//! with γ searched, and a trade-off sweep of 6 points.
//!
//! Run: `cargo bench --bench noise`. Prints a table; nothing
//! is asserted on time.

use qpv_dsl::{AlphaSpec, GammaSpec, Mode};
use qpv_solve::certificate::noise::noise_bound;
use qpv_solve::certificate::sampling::sampling;
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::model::noise::NoiseChannels;
use qpv_solve::search::noise::{design_noise, tradeoff};
use qpv_solve::{design, request, Settings};
use std::time::Instant;

/// Median wall time of `reps` runs of `f`, seconds.
fn time<T>(reps: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut ts: Vec<f64> = (0..reps)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(f());
            t.elapsed().as_secs_f64()
        })
        .collect();
    ts.sort_by(f64::total_cmp);
    ts[ts.len() / 2]
}

fn main() {
    let model = paper_model();
    let sym = model.with_split(qpv_dsl::Split::Symmetric);
    let settings = Settings::default();
    let gamma = 0.18898;
    let req = request(AlphaSpec::Fixed(5.0), GammaSpec::Fixed(gamma), Mode::Sound);
    let ch = NoiseChannels::all_outputs();

    let d = design(&model, &req, &settings).unwrap();
    let (p, l) = (d.p_matrix(), d.l_matrices());
    let t_design = time(5, || design(&model, &req, &settings).unwrap());
    let t_sigma = time(20, || noise_bound(&sym, &ch, 5.0, gamma, &p, &l).unwrap());
    let t_step = time(20, || sampling(&sym, 5.0, gamma, &p, &l).unwrap());
    let t_opt = time(5, || design_noise(&model, &req, &ch, &settings).unwrap());
    let search = request(AlphaSpec::Fixed(5.0), GammaSpec::Search, Mode::Sound);
    let t_search = time(1, || design_noise(&model, &search, &ch, &settings).unwrap());
    let alphas = [1.0, 3.0, 5.0, 8.0, 10.0, 12.0];
    let t_sweep = time(1, || {
        tradeoff(&model, &req, &ch, &alphas, &settings).unwrap();
    });
    let opt = design_noise(&model, &req, &ch, &settings).unwrap();
    let sg = design_noise(&model, &search, &ch, &settings).unwrap();

    println!("noise figures, paper example (α = 5, γ = {gamma}), median wall time:");
    println!(
        "  ordinary design (includes σ and the Euler step) {:>9.2} ms",
        1e3 * t_design
    );
    println!(
        "  σ of a given design (Schur + block check)     {:>9.2} ms",
        1e3 * t_sigma
    );
    println!(
        "  largest Euler step + RK4 estimate             {:>9.2} ms",
        1e3 * t_step
    );
    println!(
        "  noise-optimal design, fixed γ (σ = {:.1})      {:>9.2} ms",
        opt.noise.as_ref().map_or(f64::NAN, |n| n.sigma),
        1e3 * t_opt
    );
    println!(
        "  noise-optimal design, γ searched ({} SDPs, σ = {:.1}, ‖e(∞)‖/ν ≤ {:.3} at γ = {:.4}) {:>9.2} ms",
        sg.search.len(),
        sg.noise.as_ref().map_or(f64::NAN, |n| n.sigma),
        sg.noise.as_ref().map_or(f64::NAN, |n| n.error_bound),
        sg.gamma,
        1e3 * t_search
    );
    println!(
        "  trade-off sweep, {} points at fixed γ          {:>9.2} ms",
        alphas.len(),
        1e3 * t_sweep
    );
}
