//! What a skew-symmetric slack K_k buys (docs/method.md §7): alternating
//! solves from the certified sound design of the paper example, at its γ,
//! for both splits of N_k; every α printed is certified by the independent
//! check on the model with N_k + K_k (the same plant).
//!
//! `cargo bench --bench skew_slack [-- ROUNDS]`

use qpv_dsl::{AlphaSpec, Conditions, GammaSpec, Mode, Split};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::{design, request, Settings};
use std::time::Instant;

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(6);
    let model = paper_model();
    let settings = Settings::default();
    println!("bench skew_slack: paper example, at most {rounds} rounds");
    for split in [Split::AsWritten, Split::Symmetric] {
        let mut req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
        req.split = split;
        let start = design(&model, &req, &settings).expect("design");
        let t0 = Instant::now();
        let r = qpv_solve::search::skew_search(&model, &start, rounds, &settings, Conditions::Full)
            .expect("search");
        let secs = t0.elapsed().as_secs_f64();
        println!(
            "split {split:?}: start α = {:.5} at γ = {:.5}; best with K: α = {:.5} ({:+.2} %), {} rounds, {secs:.2} s",
            r.alpha_start,
            r.gamma,
            r.alpha_best(),
            100.0 * (r.alpha_best() / r.alpha_start - 1.0),
            r.rounds.len()
        );
        for (i, round) in r.rounds.iter().enumerate() {
            println!(
                "  round {}: α (P fixed, Γ and K free) = {:.5}; α (K fixed, P free) = {:.5}; max ‖K_k,l‖_F = {:.4}",
                i + 1,
                round.alpha_fixed_p,
                round.alpha,
                round.k_norm
            );
        }
        assert!(r.design.certifies(), "the reported design is certified");
    }
}
