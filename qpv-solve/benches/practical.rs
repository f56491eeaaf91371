//! Bench: the practical `alpha = max` on every example plant (the table of
//! docs/method.md §11a): the certified supremum α_sup, the design returned (its α,
//! max ‖L_l‖₂, certified Euler step), the same with `within = 0` (the
//! fastest point), solves and CPU seconds of each.
//!
//! `cargo bench --bench practical [-- PLANT ...]` (default: every example
//! but the elastic arm; name it to include it, `-- elastic_arm`).

use qpv_dsl::{AlphaSpec, GammaSpec, Mode};
use qpv_solve::{design_with_progress, request, Design, Settings};

#[path = "cpu.rs"]
mod cpu;
use cpu::cpu_seconds;

const PLANTS: [&str; 11] = [
    "paper",
    "paper_auto",
    "lorenz",
    "lotka_volterra",
    "van_de_vusse",
    "varying_output",
    "arrhenius_reactor",
    "manipulator",
    "spacecraft",
    "sir",
    "pmsm",
];

fn gain(d: &Design) -> f64 {
    d.gain_norms.iter().copied().fold(0.0, f64::max)
}

fn step(d: &Design) -> f64 {
    d.sampling.as_ref().map_or(f64::NAN, |s| s.max_step_euler)
}

fn main() {
    let named: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let plants: Vec<String> = if named.is_empty() {
        PLANTS.iter().map(|s| s.to_string()).collect()
    } else {
        named
    };
    let settings = Settings::default();
    println!(
        "bench practical: alpha = max, gamma = search (sound), within = 0.01 against within = 0"
    );
    println!(
        "{:<18} {:>10} {:>10} {:>6} {:>10} {:>10} {:>6} {:>7} | {:>10} {:>10} {:>6} {:>7}",
        "plant",
        "α_sup",
        "α",
        "%",
        "max‖L‖",
        "Euler h",
        "solves",
        "cpu s",
        "α (0)",
        "max‖L‖ (0)",
        "solves",
        "cpu s"
    );
    for name in &plants {
        let path = format!("examples/{name}.qpv");
        let Ok(src) = std::fs::read_to_string(&path) else {
            println!("{name:<18} cannot read {path}");
            continue;
        };
        let model = match qpv_dsl::parse(&src) {
            Ok(m) => m[0].polytopic(),
            Err(e) => {
                println!("{name:<18} {e}");
                continue;
            }
        };
        let mut runs = Vec::new();
        for within in [0.01, 0.0] {
            let mut r = request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound);
            r.within = within;
            let c0 = cpu_seconds();
            let d = design_with_progress(&model, &r, &settings, &mut |_| {});
            runs.push((d, cpu_seconds() - c0));
        }
        match (&runs[0], &runs[1]) {
            ((Ok(p), cp), (Ok(f), cf)) => {
                let sup = p.practical.as_ref().map_or(p.alpha, |x| x.alpha_sup);
                println!(
                    "{name:<18} {sup:>10.4} {:>10.4} {:>6.1} {:>10.3e} {:>10.3e} {:>6} {cp:>7.1} | {:>10.4} {:>10.3e} {:>6} {cf:>7.1}{}",
                    p.alpha,
                    100.0 * p.alpha / sup,
                    gain(p),
                    step(p),
                    p.search.len(),
                    f.alpha,
                    gain(f),
                    f.search.len(),
                    if p.practical.as_ref().is_some_and(|x| x.high_gain) {
                        "  (high gain: knee)"
                    } else {
                        ""
                    }
                );
            }
            ((Err(e), _), _) | (_, (Err(e), _)) => println!("{name:<18} error: {e}"),
        }
    }
}
