//! Bench (2): the full α/γ search of the paper example (goal < 1 s in
//! release), and the α bisections at the published γ values.
//!
//! `cargo bench -p qpv-solve --bench design_search [-- REPEATS]`

use qpv_dsl::{AlphaSpec, GammaSpec, Mode};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::{design, request, Settings};
use std::time::Instant;

fn main() {
    let repeats: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(5);
    let model = paper_model();
    let settings = Settings::default();
    println!("bench design_search: paper example, {repeats} repeats (median wall time)");
    println!(
        "{:<30} {:>9} {:>9} {:>7} {:>7} {:>11} {:>10} {:>9}",
        "case", "wall s", "clarabel", "solves", "iters", "α", "γ", "feasible"
    );
    for (name, mode, alpha, gamma) in [
        ("sound α=max γ=search", Mode::Sound, AlphaSpec::Max, GammaSpec::Search),
        ("paper α=max γ=search", Mode::Paper, AlphaSpec::Max, GammaSpec::Search),
        ("sound α=max γ=0.1889", Mode::Sound, AlphaSpec::Max, GammaSpec::Fixed(0.1889)),
        ("paper α=max γ=0.4", Mode::Paper, AlphaSpec::Max, GammaSpec::Fixed(0.4)),
    ] {
        let req = request(alpha, gamma, mode);
        let mut walls = vec![];
        let mut last = None;
        for _ in 0..repeats {
            let t0 = Instant::now();
            let d = design(&model, &req, &settings).expect("design");
            walls.push(t0.elapsed().as_secs_f64());
            last = Some(d);
        }
        walls.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let d = last.unwrap();
        let clarabel: f64 = d.search.iter().map(|s| s.solver_seconds).sum();
        let iters: u32 = d.search.iter().map(|s| s.iterations).sum();
        println!(
            "{:<30} {:>9.3} {:>9.3} {:>7} {:>7} {:>11.5} {:>10.5} {:>9}",
            name,
            walls[walls.len() / 2],
            clarabel,
            d.search.len(),
            iters,
            d.alpha,
            d.gamma,
            d.feasible
        );
    }
}
