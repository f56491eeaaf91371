//! Bench (2): the full α/γ search of the paper example (goal < 1 s in
//! release), and the α bisections at the published γ values; N_k as printed
//! (the paper's example), plus the sound search with the symmetric split,
//! and the paper plant with a θ-dependent output map (C_22 = 1 + θ1,
//! M_1[2,3] = 0.5 θ2) designed by the double sum and by the output filter.
//!
//! `cargo bench --bench design_search [-- REPEATS]`

use qpv_dsl::{AlphaSpec, GammaSpec, Mode, OutputFilter, OutputRoute, PolytopicModel, Split};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::{design, request, Settings};
use std::time::Instant;

#[path = "cpu.rs"]
mod cpu;
use cpu::cpu_seconds;

fn main() {
    let repeats: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(5);
    let constant = paper_model();
    let mut varying: PolytopicModel = paper_model();
    for v in &mut varying.vertices {
        v.c[(1, 1)] = 1.0 + v.theta[0];
        v.m[0][(1, 2)] = 0.5 * v.theta[1];
    }
    let settings = Settings::default();
    println!("bench design_search: paper example, {repeats} repeats (median wall time)");
    println!(
        "{:<34} {:>9} {:>9} {:>9} {:>7} {:>7} {:>11} {:>10} {:>9}",
        "case", "wall s", "cpu s", "clarabel", "solves", "iters", "α", "γ", "feasible"
    );
    let w = Split::AsWritten;
    let cases = [
        (
            "sound α=max γ=search",
            Mode::Sound,
            AlphaSpec::Max,
            GammaSpec::Search,
            w,
        ),
        (
            "paper α=max γ=search",
            Mode::Paper,
            AlphaSpec::Max,
            GammaSpec::Search,
            w,
        ),
        (
            "sound α=max γ=0.1889",
            Mode::Sound,
            AlphaSpec::Max,
            GammaSpec::Fixed(0.1889),
            w,
        ),
        (
            "paper α=max γ=0.4",
            Mode::Paper,
            AlphaSpec::Max,
            GammaSpec::Fixed(0.4),
            w,
        ),
        (
            "sound sym. α=max γ=search",
            Mode::Sound,
            AlphaSpec::Max,
            GammaSpec::Search,
            Split::Symmetric,
        ),
    ];
    let routes = [
        ("C(θ) double sum α=max γ=0.1844", OutputRoute::DoubleSum),
        (
            "C(θ) filter(50) α=max γ=0.1844",
            OutputRoute::Filter(OutputFilter {
                pole: 50.0,
                gain: 50.0,
            }),
        ),
    ];
    let all = cases
        .iter()
        .map(|&(n, m, a, g, sp)| (n, m, a, g, sp, OutputRoute::DoubleSum, &constant))
        .chain(routes.iter().map(|&(n, r)| {
            (
                n,
                Mode::Sound,
                AlphaSpec::Max,
                GammaSpec::Fixed(0.1844),
                Split::Symmetric,
                r,
                &varying,
            )
        }));
    for (name, mode, alpha, gamma, split, route, model) in all {
        let mut req = request(alpha, gamma, mode);
        req.split = split;
        req.output_route = route;
        let mut walls = vec![];
        let mut cpus = vec![];
        let mut last = None;
        for _ in 0..repeats {
            let (t0, c0) = (Instant::now(), cpu_seconds());
            let d = design(model, &req, &settings).expect("design");
            walls.push(t0.elapsed().as_secs_f64());
            cpus.push(cpu_seconds() - c0);
            last = Some(d);
        }
        walls.sort_by(|a, b| a.partial_cmp(b).unwrap());
        cpus.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let d = last.unwrap();
        let clarabel: f64 = d.search.iter().map(|s| s.solver_seconds).sum();
        let iters: u32 = d.search.iter().map(|s| s.iterations).sum();
        println!(
            "{:<34} {:>9.3} {:>9.2} {:>9.3} {:>7} {:>7} {:>11.5} {:>10.5} {:>9}",
            name,
            walls[walls.len() / 2],
            cpus[cpus.len() / 2],
            clarabel,
            d.search.len(),
            iters,
            d.alpha,
            d.gamma,
            d.feasible()
        );
    }
}
