//! Bench: the γ search against a dense logarithmic γ grid, per plant.
//!
//! For every example plant (and the elastic arm with `--heavy`): the α of
//! `alpha = max; gamma = search` with `conditions = full`
//! ([`qpv_solve::design`]), the best α of a dense grid of α_max(γ) over
//! [γ_hi · 1e-4, γ_hi] with the same conditions
//! ([`qpv_solve::alpha_profile`], each point to the full bisection
//! tolerance, seeded by its neighbour), their relative gap, the solves and
//! CPU seconds of each, and the search's α with `conditions = decoupled`
//! (which the full search must never fall below). The last column is the
//! one-minute load average when the plant's row was printed (the machine
//! may be shared).
//!
//! `cargo bench --bench gamma_search [-- [POINTS] [--heavy] [--steps] [--decoupled] [NAME...]]`
//! (POINTS: dense grid size, default 200; `--steps`: print the search's
//! solves and the dense profile; `--decoupled`: the search and the dense
//! grid both solve the decoupled conditions instead of the full ones, for a
//! plant whose full family is too costly for a dense grid, such as the
//! elastic arm; NAME: only plants whose name contains it).

use qpv_dsl::{AlphaSpec, Conditions, GammaSpec, Mode, PolytopicModel};
use qpv_solve::{alpha_profile, design, request, Design, Settings};
use std::time::Instant;

#[path = "cpu.rs"]
mod cpu;
use cpu::cpu_seconds;

/// The one-minute load average (NaN if unreadable).
fn load() -> f64 {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or(f64::NAN)
}

fn parse(name: &str, src: &str) -> (String, PolytopicModel) {
    let models = qpv_dsl::parse(src).unwrap_or_else(|e| panic!("{name}: {e}"));
    (name.to_string(), models[0].polytopic())
}

fn search(model: &PolytopicModel, conditions: Conditions, s: &Settings) -> (Design, f64, f64) {
    let mut req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
    req.conditions = conditions;
    let (t0, c0) = (Instant::now(), cpu_seconds());
    let d = design(model, &req, s).expect("design");
    (d, t0.elapsed().as_secs_f64(), cpu_seconds() - c0)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let points: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(200);
    let heavy = args.iter().any(|a| a == "--heavy");
    let steps = args.iter().any(|a| a == "--steps");
    let family = if args.iter().any(|a| a == "--decoupled") {
        Conditions::Decoupled
    } else {
        Conditions::Full
    };
    let only: Vec<&String> = args
        .iter()
        .filter(|a| !a.starts_with("--") && a.parse::<usize>().is_err())
        .collect();
    let mut plants = vec![
        parse("paper", include_str!("../../examples/paper.qpv")),
        parse(
            "paper_equations",
            include_str!("../../examples/paper_equations.qpv"),
        ),
        parse("paper_auto", include_str!("../../examples/paper_auto.qpv")),
        parse("lorenz", include_str!("../../examples/lorenz.qpv")),
        parse(
            "lotka_volterra",
            include_str!("../../examples/lotka_volterra.qpv"),
        ),
        parse(
            "van_de_vusse",
            include_str!("../../examples/van_de_vusse.qpv"),
        ),
        parse(
            "varying_output",
            include_str!("../../examples/varying_output.qpv"),
        ),
        parse("spacecraft", include_str!("../../examples/spacecraft.qpv")),
        parse(
            "arrhenius_reactor",
            include_str!("../../examples/arrhenius_reactor.qpv"),
        ),
    ];
    if heavy {
        plants.push(parse(
            "elastic_arm",
            include_str!("../../examples/elastic_arm.qpv"),
        ));
    }
    let settings = Settings::default();
    println!(
        "bench gamma_search: search vs a dense log grid of {points} points over [γ_hi·1e-4, γ_hi] (sound, default split, {} conditions); cpu seconds",
        family.name()
    );
    println!(
        "{:<17} {:>10} {:>10} {:>10} {:>10} {:>8} {:>7} {:>8} {:>7} {:>8} {:>10} {:>6} {:>5}  local maxima",
        "plant",
        "dense α",
        "dense γ",
        "search α",
        "search γ",
        "gap %",
        "solves",
        "cpu s",
        "dense n",
        "dense s",
        "decoupl α",
        "full≥d",
        "load"
    );
    for (name, model) in plants
        .iter()
        .filter(|(n, _)| only.is_empty() || only.iter().any(|o| n.contains(o.as_str())))
    {
        let (d, _, cpu) = search(model, family, &settings);
        let info = d
            .gamma_search
            .clone()
            .expect("a γ search reports what it searched");
        if steps {
            for s in &d.search {
                println!(
                    "  {:<12} γ {:.5e} α {:>12.5} {:<9} certified {} → {:.5}",
                    s.phase.name(),
                    s.gamma,
                    s.alpha,
                    s.detail,
                    s.certified,
                    s.alpha_certified
                );
            }
            println!("  {}", info.statement());
        }
        let hi = info.gamma_hi;
        let lo = hi * 1e-4;
        let grid: Vec<f64> = (0..points)
            .map(|k| (lo.ln() + (hi.ln() - lo.ln()) * k as f64 / (points - 1) as f64).exp())
            .rev()
            .collect();
        let c0 = cpu_seconds();
        let mut req = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
        req.conditions = family;
        // One call: every point is seeded by the previous certified one (a
        // grid cut into pieces would restart each piece from scratch).
        let prof = alpha_profile(model, &req, &grid, &settings).expect("profile");
        let dense_cpu = cpu_seconds() - c0;
        if steps {
            for p in &prof {
                println!(
                    "  dense γ {:.5e} α {:.5} ({} solves)",
                    p.gamma, p.alpha, p.solves
                );
            }
        }
        let best = prof.iter().copied().fold((0.0, 0.0), |b, p| {
            if p.alpha > b.0 {
                (p.alpha, p.gamma)
            } else {
                b
            }
        });
        let dense_solves: usize = prof.iter().map(|p| p.solves).sum();
        let dd = if family == Conditions::Decoupled {
            d.clone()
        } else {
            search(model, Conditions::Decoupled, &settings).0
        };
        let alpha = if d.certifies() { d.alpha } else { 0.0 };
        let alpha_d = if dd.certifies() { dd.alpha } else { 0.0 };
        let gap = 100.0 * (best.0 - alpha) / best.0.max(1e-300);
        let maxima: Vec<String> = info
            .local_maxima
            .iter()
            .map(|m| format!("{:.4}@{:.4e}", m.alpha, m.gamma))
            .collect();
        println!(
            "{:<17} {:>10.4} {:>10.4e} {:>10.4} {:>10.4e} {:>8.3} {:>7} {:>8.2} {:>7} {:>8.2} {:>10.4} {:>6} {:>5.2}  {}",
            name,
            best.0,
            best.1,
            alpha,
            d.gamma,
            gap,
            d.search.len(),
            cpu,
            dense_solves,
            dense_cpu,
            alpha_d,
            // Within the bisection tolerance of each result.
            alpha >= alpha_d * (1.0 - 2.0 * settings.bisection_rel_tol),
            load(),
            maxima.join(" ")
        );
    }
}
