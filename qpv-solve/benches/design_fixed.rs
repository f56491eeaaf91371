//! Bench (1): one fixed (α, γ) design of the paper example end to end —
//! assembly + Clarabel + certificate — beside Clarabel's own solve time.
//! Goal: overhead (everything that is not Clarabel) ≤ 50 % of the solve.
//!
//! `cargo bench --bench design_fixed [-- REPEATS]`

use qpv_dsl::{AlphaSpec, GammaSpec, Mode, Split};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::{design, request, Settings};
use std::time::Instant;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn main() {
    let repeats: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(21);
    let model = paper_model();
    let settings = Settings::default();
    println!("bench design_fixed: paper example, {repeats} repeats, medians");
    println!(
        "{:<28} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9} {:>6}",
        "case", "total ms", "clarabel", "assembly", "certify", "overhead", "overhead%", "iters"
    );
    for (name, mode, alpha, gamma) in [
        ("sound α=10 γ=0.1889", Mode::Sound, 10.0, 0.1889),
        ("paper α=10 γ=0.4", Mode::Paper, 10.0, 0.4),
        ("sound α=10 γ=0.4 (infeas.)", Mode::Sound, 10.0, 0.4),
    ] {
        // N_k as printed (the paper's example).
        let mut req = request(AlphaSpec::Fixed(alpha), GammaSpec::Fixed(gamma), mode);
        req.split = Split::AsWritten;
        let (mut tot, mut sol, mut asm, mut cer) = (vec![], vec![], vec![], vec![]);
        let mut iters = 0;
        let mut feasible = false;
        for _ in 0..repeats {
            let t0 = Instant::now();
            let d = design(&model, &req, &settings).expect("design");
            tot.push(t0.elapsed().as_secs_f64());
            sol.push(d.solver.seconds);
            asm.push(d.solver.assembly_seconds);
            cer.push(d.solver.certify_seconds);
            iters = d.solver.iterations;
            feasible = d.feasible();
        }
        let over: Vec<f64> = tot.iter().zip(&sol).map(|(t, s)| t - s).collect();
        let (t, s, a, c, o) = (
            median(&mut tot),
            median(&mut sol),
            median(&mut asm),
            median(&mut cer),
            median(&mut over.clone()),
        );
        println!(
            "{:<28} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>8.1}% {:>6}   feasible={}",
            name,
            t * 1e3,
            s * 1e3,
            a * 1e3,
            c * 1e3,
            o * 1e3,
            100.0 * o / s,
            iters,
            feasible
        );
    }
}
