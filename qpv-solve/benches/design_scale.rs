//! Bench (3): scale. Synthetic models with nx states, the box region
//! (p = 2^nx vertices) and N = 4 parameter vertices: one fixed (α, γ)
//! sound design per condition set, with wall time and peak memory (VmHWM):
//!
//! * `full`: all N p² = 4^(nx+1) rate LMIs of nx × nx;
//! * `decoupled` (docs/method.md §8): N·2p rate LMIs and one slack Z_l per
//!   θ-vertex; the certificate still checks all N p² blocks (its time is
//!   the `cert s` column).
//!
//! γ = min(0.3, 0.95 γ_max) ((S4) needs γ ≤ γ_max = 1/√(1.5 nx), which is
//! below 0.3 from nx = 8 on). Every (nx, conditions) runs in its own
//! process so that the peak is its own. The full family is not solved above
//! nx = 7 (nx = 8: 262 144 blocks); its size is printed instead. Goals:
//! nx = 6 full in < 60 s and < 4 GiB; nx = 8 decoupled certified in < 10 s.
//!
//! `cargo bench --bench design_scale [-- NX...] [-- full|decoupled]`

use qpv_dsl::{AlphaSpec, Conditions, GammaSpec, Mode};
use qpv_solve::conditions::reference::synthetic_model;
use qpv_solve::conditions::{gamma_max, ConditionSet};
use qpv_solve::linalg::svec::svec_len as tri;
use qpv_solve::lmi::{Objective, Problem};
use qpv_solve::{design, request, Settings};
use std::process::Command;
use std::time::Instant;

fn vm_hwm_mib() -> f64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

const ALPHA: f64 = 1.0;
const GAMMA: f64 = 0.3;
/// Largest nx at which the full family is solved.
const FULL_MAX_NX: usize = 7;

fn name(c: Conditions) -> &'static str {
    c.name()
}

fn gamma_for(nx: usize) -> f64 {
    let model = synthetic_model(nx);
    GAMMA.min(0.95 * gamma_max(&model).expect("synthetic models have Q"))
}

fn child(nx: usize, conditions: Conditions) {
    let model = synthetic_model(nx);
    let gamma = gamma_for(nx);
    let settings = Settings::default();
    let prob = Problem::new(&model, ConditionSet::Sound)
        .unwrap()
        .with_conditions(conditions)
        .unwrap();
    let t = Instant::now();
    let asm = prob.assemble(ALPHA, gamma, &settings, Objective::Gains);
    let t_asm = t.elapsed().as_secs_f64();
    let (m, n, nnz) = (asm.a.m, asm.a.n, asm.a.nzval.len());
    drop(asm);
    let mut req = request(
        AlphaSpec::Fixed(ALPHA),
        GammaSpec::Fixed(gamma),
        Mode::Sound,
    );
    req.conditions = conditions;
    let t0 = Instant::now();
    let d = design(&model, &req, &settings).expect("design");
    let wall = t0.elapsed().as_secs_f64();
    println!(
        "{:>3} {:>9} {:>6} {:>8} {:>8} {:>9} {:>5} {:>10} {:>7.3} {:>8.2} {:>9.2} {:>8.3} {:>6} {:>9.0}  {} certified={} (γ = {gamma:.4})",
        nx,
        name(conditions),
        model.region.vertices.len(),
        prob.n_rate_blocks(),
        prob.n_full_rate_blocks(),
        m,
        n,
        nnz,
        t_asm,
        wall,
        d.solver.seconds,
        d.solver.certify_seconds,
        d.solver.iterations,
        vm_hwm_mib(),
        d.solver.detail,
        d.feasible() && d.certifies()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(pos) = args.iter().position(|a| a == "--child") {
        let c = match args[pos + 2].as_str() {
            "full" => Conditions::Full,
            _ => Conditions::Decoupled,
        };
        child(args[pos + 1].parse().unwrap(), c);
        return;
    }
    let mut nxs: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    if nxs.is_empty() {
        nxs = vec![3, 4, 5, 6, 8];
    }
    let sets: Vec<Conditions> = match (
        args.iter().any(|a| a == "full"),
        args.iter().any(|a| a == "decoupled"),
    ) {
        (true, false) => vec![Conditions::Full],
        (false, true) => vec![Conditions::Decoupled],
        _ => vec![Conditions::Full, Conditions::Decoupled],
    };
    println!(
        "bench design_scale: synthetic model, sound mode, α = {ALPHA}, γ = min({GAMMA}, 0.95 γ_max), 4 θ-vertices, box region; `cert s` checks the full family"
    );
    println!(
        "{:>3} {:>9} {:>6} {:>8} {:>8} {:>9} {:>5} {:>10} {:>7} {:>8} {:>9} {:>8} {:>6} {:>9}",
        "nx",
        "conds",
        "verts",
        "LMIs",
        "full",
        "rows",
        "vars",
        "nnz(A)",
        "asm s",
        "wall s",
        "solver s",
        "cert s",
        "iters",
        "peak MiB"
    );
    let exe = std::env::current_exe().unwrap();
    for nx in nxs {
        for &c in &sets {
            if c == Conditions::Full && nx > FULL_MAX_NX {
                let p = 1usize << nx;
                let blocks = 4 * p * p;
                println!(
                    "{nx:>3} {:>9} {p:>6} {blocks:>8} {blocks:>8} {:>9}  not run (the full family: {blocks} blocks of {nx} × {nx})",
                    name(c),
                    blocks * tri(nx)
                );
                continue;
            }
            let status = Command::new(&exe)
                .args(["--child", &nx.to_string(), name(c)])
                .status()
                .unwrap();
            if !status.success() {
                println!("{nx:>3} {:>9} failed: {status}", name(c));
            }
        }
    }
}
