//! Design at the sample period (docs/method.md §16), measured: the α
//! certified at h against the continuous α on the example plants (α = max
//! with within = 0, the supremum, at a fixed γ per plant), solves and CPU
//! time of each, and the continuous-plant bound per unit h; then the
//! figure docs/figures/sampled_alpha.svg (α certified against h on the
//! paper example, the continuous α as the h → 0 asymptote).
//!
//! `cargo bench --bench sampled` (prints numbers, writes the figure;
//! `-- figure` or `-- table` runs one part); `QPV_BENCH_QUICK=1` skips the
//! slow plants.

use qpv::dsl::{AlphaSpec, GammaSpec, Mode, PolytopicModel, Split};
use qpv::plot::{line_chart_x, Series, PALETTE};
use qpv::solve::{design, Design, Settings};

/// CPU time of this thread in seconds (Linux), so the numbers mean
/// something on a loaded machine; wall time elsewhere.
fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|t| t.split_whitespace().next()?.parse::<f64>().ok())
        .map_or_else(
            || {
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0.0, |d| d.as_secs_f64())
            },
            |ns| ns * 1e-9,
        )
}

/// One plant of the table: its file, the text edits (input ranges the
/// continuous-plant bound needs), γ and the sample periods.
struct Case {
    file: &'static str,
    edits: &'static [(&'static str, &'static str)],
    gamma: f64,
    hs: &'static [f64],
    slow: bool,
}

fn model(case: &Case) -> PolytopicModel {
    let mut text = std::fs::read_to_string(case.file).expect("the example");
    for (a, b) in case.edits {
        text = text.replace(a, b);
    }
    qpv::dsl::parse(&text)
        .expect("parses")
        .remove(0)
        .polytopic()
}

/// α = max (supremum) at γ, continuous (`h` None) or at the period h:
/// the design, its solves and CPU seconds.
fn alpha_max(m: &PolytopicModel, gamma: f64, h: Option<f64>) -> (Design, usize, f64) {
    let mut r = qpv::solve::request(AlphaSpec::Max, GammaSpec::Fixed(gamma), Mode::Sound);
    r.split = Split::Symmetric;
    r.within = 0.0;
    r.sample = h;
    let t0 = cpu_seconds();
    let d = design(m, &r, &Settings::default()).expect("the design runs");
    let solves = d.search.len();
    (d, solves, cpu_seconds() - t0)
}

fn table(quick: bool) {
    let cases = [
        Case {
            file: "examples/paper.qpv",
            edits: &[],
            gamma: 0.18898,
            hs: &[1e-4, 1e-3, 1e-2],
            slow: false,
        },
        Case {
            file: "examples/paper_auto.qpv",
            edits: &[],
            gamma: 0.2066,
            hs: &[1e-3, 1e-2],
            slow: false,
        },
        Case {
            file: "examples/lorenz.qpv",
            edits: &[],
            gamma: 0.1996,
            hs: &[1e-4, 1e-3, 1e-2],
            slow: false,
        },
        Case {
            file: "examples/lotka_volterra.qpv",
            edits: &[],
            gamma: 0.3133,
            hs: &[1e-3, 1e-2, 1e-1],
            slow: false,
        },
        Case {
            file: "examples/sir.qpv",
            edits: &[("input  b;", "input  b in [-0.1, 0.1];")],
            gamma: 0.1176,
            hs: &[1e-2, 1e-1, 1.0],
            slow: false,
        },
        Case {
            file: "examples/van_de_vusse.qpv",
            edits: &[("input  u;", "input  u in [-4.3, 5.8];")],
            gamma: 0.068,
            hs: &[1e-4, 1e-3],
            slow: false,
        },
        Case {
            file: "examples/varying_output.qpv",
            edits: &[("input  u;", "input  u in [-0.1, 0.1];")],
            gamma: 0.3344,
            hs: &[1e-2, 1e-1],
            slow: false,
        },
        Case {
            file: "examples/arrhenius_reactor.qpv",
            edits: &[],
            gamma: 0.6,
            hs: &[1e-4, 1e-3, 1e-2],
            slow: false,
        },
        Case {
            file: "examples/spacecraft.qpv",
            edits: &[],
            gamma: 0.5,
            hs: &[1e-1, 1.0],
            slow: true,
        },
        Case {
            file: "examples/pmsm.qpv",
            edits: &[],
            gamma: 0.5,
            hs: &[1e-6, 1e-5],
            slow: true,
        },
    ];
    println!("α = max (within = 0) at a fixed γ, continuous and at h; CPU seconds; bound = lim sup ‖e_k‖ / h of the continuous plant");
    println!(
        "{:<18} {:>8} {:>9} {:>12} {:>7} {:>8} {:>14}",
        "plant", "gamma", "h (s)", "alpha", "solves", "cpu s", "bound / h"
    );
    for case in cases.iter().filter(|c| !(quick && c.slow)) {
        let m = model(case);
        let name = m.name.clone();
        let (d, n, t) = alpha_max(&m, case.gamma, None);
        println!(
            "{name:<18} {:>8} {:>9} {:>12.6} {n:>7} {t:>8.2} {:>14}",
            case.gamma,
            "cont.",
            if d.certifies() { d.alpha } else { 0.0 },
            "-"
        );
        for &h in case.hs {
            let (d, n, t) = alpha_max(&m, case.gamma, Some(h));
            let bound = match d.sample.as_ref().and_then(|s| s.continuous_bound) {
                Some(b) if b.holds() => format!("{:.4e}", b.ultimate_error / h),
                Some(_) => "not invariant".into(),
                None => "none".into(),
            };
            println!(
                "{name:<18} {:>8} {h:>9.0e} {:>12.6} {n:>7} {t:>8.2} {bound:>14}",
                case.gamma,
                if d.certifies() { d.alpha } else { 0.0 },
            );
        }
    }
}

/// α certified against h on the paper example (γ = 0.18898), the
/// continuous α as the asymptote; writes docs/figures/sampled_alpha.svg.
fn figure() {
    let m = model(&Case {
        file: "examples/paper.qpv",
        edits: &[],
        gamma: 0.18898,
        hs: &[],
        slow: false,
    });
    let gamma = 0.18898;
    let (c, _, _) = alpha_max(&m, gamma, None);
    let hs = [
        5e-4, 2e-3, 5e-3, 1e-2, 1.5e-2, 2e-2, 3e-2, 4e-2, 5e-2, 6e-2, 7e-2,
    ];
    let mut pts = Vec::new();
    println!(
        "figure: paper example, γ = {gamma}, continuous α = {:.4}",
        c.alpha
    );
    for &h in &hs {
        let (d, n, t) = alpha_max(&m, gamma, Some(h));
        let a = if d.certifies() { d.alpha } else { 0.0 };
        println!("  h = {h:>7.4}  α = {a:>9.4}  ({n} solves, {t:.2} s)");
        if d.certifies() {
            pts.push((h, a));
        }
    }
    let hi = hs[hs.len() - 1];
    let series = vec![
        Series::new("alpha certified at h (sample = h)", pts, PALETTE[0], false),
        Series::new(
            format!("continuous alpha = {:.3} (the h -> 0 limit)", c.alpha),
            vec![(0.0, c.alpha), (hi, c.alpha)],
            PALETTE[1],
            true,
        ),
    ];
    let path = std::path::Path::new("docs/figures/sampled_alpha.svg");
    line_chart_x(
        path,
        "paper example: certified alpha against the sample period h, gamma = 0.18898",
        ("sample period h [s]", "alpha [1/s]"),
        &series,
        false,
    )
    .expect("the figure is written");
    println!("wrote {}", path.display());
}

fn main() {
    let quick = std::env::var_os("QPV_BENCH_QUICK").is_some();
    let args: Vec<String> = std::env::args().collect();
    let only = |w: &str| args.iter().any(|a| a == w);
    if !only("table") {
        figure();
    }
    if !only("figure") {
        table(quick);
    }
}
