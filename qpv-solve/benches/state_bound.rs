//! Timing of `state_bound auto`: the paper's example (both
//! splits of N_k, the h search step by step) and the synthetic scale models
//! (nx = 3..8, 2^nx box vertices × 4 θ-vertices invariance blocks). Run with
//! `cargo bench --bench state_bound`; prints numbers.

use qpv_dsl::{Split, StateBound};
use qpv_solve::conditions::gamma_max;
use qpv_solve::conditions::reference::{paper_model, synthetic_model};
use qpv_solve::state_bound::{compute, resolve, BoundSearch};
use qpv_solve::Settings;
use std::time::Instant;

fn main() {
    let settings = Settings::default();
    let search = BoundSearch::default();
    let paper = paper_model();
    println!(
        "paper example: γ_max of the paper's Q = {:.5}",
        gamma_max(&paper).unwrap_or(f64::NAN)
    );
    for split in [Split::AsWritten, Split::Symmetric] {
        let m = paper.with_split(split);
        match compute(&m, None, &settings, &search) {
            Ok(b) => {
                let feasible = b.steps.iter().filter(|s| s.gamma_max.is_some()).count();
                println!(
                    "  invariance with N_k {split:?}: h = {:.5}, γ_max = {:.5}, {} solves ({} feasible), {:.3} s",
                    b.h,
                    b.gamma_max,
                    b.steps.len(),
                    feasible,
                    b.seconds
                );
            }
            Err(e) => println!("  invariance with N_k {split:?}: {e}"),
        }
    }
    let mut auto = paper.clone();
    auto.state_bound = StateBound::Auto { h: None };
    let mut walls = Vec::new();
    let mut last = None;
    for _ in 0..5 {
        let t0 = Instant::now();
        last = Some(resolve(&auto, &settings).expect("paper bound"));
        walls.push(t0.elapsed().as_secs_f64());
    }
    walls.sort_by(f64::total_cmp);
    let info = last.map(|(_, i)| i).expect("ran");
    println!(
        "  resolve (both splits, best kept): γ_max = {:.5} (upper estimate {:.5}), h = {:.5}, N_k {}, {} solves, wall {:.3} s (median of 5)",
        info.gamma_max.unwrap_or(f64::NAN),
        info.gamma_upper.unwrap_or(f64::NAN),
        info.h.unwrap_or(f64::NAN),
        info.split.map_or("-", |s| s.name()),
        info.solves,
        walls[2]
    );
    println!("synthetic models (box |x_i| ≤ 0.02, Q = 1.5·nx·h²·I given):");
    for nx in [3, 4, 6, 8] {
        let mut m = synthetic_model(nx);
        let given = gamma_max(&m).unwrap_or(f64::NAN);
        m.state_bound = StateBound::Auto { h: None };
        let t0 = Instant::now();
        match resolve(&m, &settings) {
            Ok((_, info)) => println!(
                "  nx = {nx}: {} invariance blocks per solve, γ_max {:.4} (upper {:.4}, given Q: {given:.4}), h = {:.4}, N_k {}, {} solves, {:.2} s",
                m.nv() << nx,
                info.gamma_max.unwrap_or(f64::NAN),
                info.gamma_upper.unwrap_or(f64::NAN),
                info.h.unwrap_or(f64::NAN),
                info.split.map_or("-", |s| s.name()),
                info.solves,
                t0.elapsed().as_secs_f64()
            ),
            Err(e) => println!("  nx = {nx}: {e} ({:.2} s)", t0.elapsed().as_secs_f64()),
        }
    }
}
