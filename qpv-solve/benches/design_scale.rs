//! Bench (3): scale. Synthetic models with nx = 3..6 states, the box region
//! (2^nx vertices, 4^nx vertex pairs) and 4 parameter vertices: one fixed
//! (α, γ) sound design each (4^(nx+1) rate LMIs of nx × nx), with wall time
//! and peak memory (VmHWM). Every nx runs in its own process so that the
//! peak is its own. Goal: nx = 6 in < 60 s and < 4 GiB.
//!
//! `cargo bench -p qpv-solve --bench design_scale [-- NX...]`

use qpv_dsl::{AlphaSpec, GammaSpec, Mode};
use qpv_solve::conditions::reference::synthetic_model;
use qpv_solve::sdp::{Objective, Problem};
use qpv_solve::conditions::ConditionSet;
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

fn child(nx: usize) {
    let model = synthetic_model(nx);
    let settings = Settings::default();
    let prob = Problem::new(&model, ConditionSet::Sound).unwrap();
    let t = Instant::now();
    let asm = prob.assemble(ALPHA, GAMMA, &settings, Objective::Gains);
    let t_asm = t.elapsed().as_secs_f64();
    let (m, n, nnz) = (asm.a.m, asm.a.n, asm.a.nzval.len());
    drop(asm);
    let req = request(AlphaSpec::Fixed(ALPHA), GammaSpec::Fixed(GAMMA), Mode::Sound);
    let t0 = Instant::now();
    let d = design(&model, &req, &settings).expect("design");
    let wall = t0.elapsed().as_secs_f64();
    println!(
        "{:>3} {:>6} {:>8} {:>9} {:>5} {:>10} {:>8.3} {:>9.2} {:>9.2} {:>8.3} {:>6} {:>9.0}  {} feasible={}",
        nx,
        model.region.vertices.len(),
        prob.n_rate_blocks(),
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
        d.feasible
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(pos) = args.iter().position(|a| a == "--child") {
        child(args[pos + 1].parse().unwrap());
        return;
    }
    let mut nxs: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    if nxs.is_empty() {
        nxs = vec![3, 4, 5, 6];
    }
    println!("bench design_scale: synthetic model, sound mode, α = {ALPHA}, γ = {GAMMA}, 4 θ-vertices, box region");
    println!(
        "{:>3} {:>6} {:>8} {:>9} {:>5} {:>10} {:>8} {:>9} {:>9} {:>8} {:>6} {:>9}",
        "nx", "verts", "LMIs", "rows", "vars", "nnz(A)", "asm s", "wall s", "solver s", "cert s", "iters", "peak MiB"
    );
    let exe = std::env::current_exe().unwrap();
    for nx in nxs {
        let status = Command::new(&exe).args(["--child", &nx.to_string()]).status().unwrap();
        if !status.success() {
            println!("{nx:>3} failed: {status}");
        }
    }
}
