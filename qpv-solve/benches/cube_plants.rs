//! Bench: the cube assembly on plants it was not tuned on.
//!
//! A generator of QPV plants ([`plants`]): mass-spring chains (half the
//! states positions, half rates) with θ-dependent quadratic terms N_k(θ) on
//! a few rate products v_i v_j, and random sparse plants (A(θ) and N_k(θ)
//! with a few nonzeros per row), nx = 6..16, one to three θ, box regions
//! with per-state half-widths (some far from 1, so that the unit balancing
//! runs), with or without a given state bound. For each plant, sound mode,
//! the symmetric split and the unit balancing of a design, at fixed α and
//! γ, it prints the size of the library's `conditions = cube` problem
//! (variables, rows, nnz(A), and nnz(A) per block family) and of the
//! independent formulation of the same relaxation written directly on
//! Clarabel's standard form (`cube_reference.rs`, pairs and lean forms),
//! and with `solve` the solve of both (wall, CPU, Clarabel iterations,
//! status) in this process with the same settings.
//!
//! `cargo bench --bench cube_plants -- [solve] [design] [timers] [aswritten] [alpha=A] [gamma=G] [NAME...]`
//! (`list` prints the names; no name: every plant). `design` also runs the
//! whole fixed design (`qpv_solve::design`, plants with a state bound) and
//! prints its wall and CPU time; `timers` prints Clarabel's timers per
//! solve; `aswritten` keeps N_k, M_k as written (no symmetric split: the
//! library then has a pair of slacks per generator, compared with the
//! pairs reference); α = 1 and γ = 0.2 unless given. The problem sizes also
//! show the size estimate made before assembly (`model::size::estimate`).
//! docs/method.md, "Held-out plants", has the table.

// The reference is also read for its solution elsewhere (cube_scale).
#[allow(dead_code)]
#[path = "cube_reference.rs"]
mod cube_reference;
#[path = "plant_gen.rs"]
mod plant_gen;

use cube_reference::{Form, Reference};
use plant_gen::{plants, Plant};
use qpv_clarabel::clarabel::solver::SupportedConeT;
use qpv_dsl::{AlphaSpec, Conditions, GammaSpec, Mode, PolytopicModel, Split, StateBound};
use qpv_solve::backend::Sdp;
use qpv_solve::conditions::ConditionSet;
use qpv_solve::lmi::{Objective, Problem};
use qpv_solve::model::StateScaling;
use qpv_solve::Settings;
use std::time::Instant;

#[path = "cpu.rs"]
mod cpu;
use cpu::cpu_seconds;

/// The model a design solves: the symmetric split, in balanced units.
fn solved_model(model: &PolytopicModel) -> (PolytopicModel, Option<StateScaling>) {
    // `aswritten`: N_k, M_k as written (no symmetric split; the library
    // then solves a pair of slacks per generator).
    let split = if std::env::args().any(|a| a == "aswritten") {
        model.with_split(Split::AsWritten)
    } else {
        model.with_split(Split::Symmetric)
    };
    match StateScaling::of(&split, Mode::Sound).and_then(|s| s.model(&split).map(|m| (m, s))) {
        Some((m, s)) => (m, Some(s)),
        None => (split, None),
    }
}

/// nnz(A) per cone, in cone order.
fn nnz_per_cone(sdp: &Sdp) -> Vec<(String, usize)> {
    let mut row_cone = Vec::with_capacity(sdp.a.m);
    let mut labels = Vec::new();
    for (i, c) in sdp.cones.iter().enumerate() {
        let (len, label) = match c {
            SupportedConeT::PSDTriangleConeT(d) => (d * (d + 1) / 2, format!("PSD({d})")),
            SupportedConeT::NonnegativeConeT(d) => (*d, format!("R+^{d}")),
            other => panic!("unexpected cone {other:?}"),
        };
        row_cone.extend(std::iter::repeat(i).take(len));
        labels.push(label);
    }
    let mut counts = vec![0usize; sdp.cones.len()];
    for &r in &sdp.a.rowval {
        counts[row_cone[r]] += 1;
    }
    labels.into_iter().zip(counts).collect()
}

/// The library's cube problem's nnz(A) by block family (one slack per
/// generator: per combination r × [Ŝ alone, Ŝ + 6G], then the main block).
fn families(sdp: &Sdp, n_combos: usize, r: usize, per: usize) -> String {
    let cones = nnz_per_cone(sdp);
    // (S1)? The cube problem starts with the region block, the trace row,
    // the facet blocks; the rate family is the last n_combos(2·per·r + 1).
    let n_rate = n_combos * (2 * per * r + 1);
    let first = cones.len() - n_rate;
    let head: usize = cones[..first].iter().map(|c| c.1).sum();
    let (mut alone, mut g, mut main) = (0, 0, 0);
    for c in 0..n_combos {
        let base = first + c * (2 * per * r + 1);
        for k in 0..per * r {
            alone += cones[base + 2 * k].1;
            g += cones[base + 2 * k + 1].1;
        }
        main += cones[base + 2 * per * r].1;
    }
    format!("region+facets {head}, slack-only {alone}, slack±G {g}, main {main}")
}

fn size(sdp: &Sdp) -> String {
    format!(
        "{:>6} vars {:>6} rows nnz(A) {:>8}",
        sdp.a.n,
        sdp.a.m,
        sdp.a.nzval.len()
    )
}

/// Solves `sdp` with the design's Clarabel settings: (wall, cpu, iterations, status).
fn solve(sdp: Sdp, settings: &Settings) -> String {
    use qpv_solve::backend::{clarabel_settings, ensure_lapack};
    ensure_lapack();
    let (cpu0, t) = (cpu_seconds(), Instant::now());
    let solved = qpv_clarabel::solve(sdp, clarabel_settings(settings)).expect("solver setup");
    if std::env::args().any(|a| a == "timers") {
        if let Some(t) = &solved.timers {
            t.print();
        }
    }
    let li = &solved.info.linsolver;
    format!(
        "wall {:>6.2} s cpu {:>6.2} s {:>3} it {:?}; KKT nnz {}, nnz(L) {}",
        t.elapsed().as_secs_f64(),
        cpu_seconds() - cpu0,
        solved.solution.iterations,
        solved.solution.status,
        li.nnzA,
        li.nnzL
    )
}

fn run(plant: &Plant, do_solve: bool, do_design: bool) {
    let settings = Settings::default();
    let arg = |key: &str| {
        std::env::args().find_map(|a| a.strip_prefix(key).and_then(|v| v.parse::<f64>().ok()))
    };
    let (alpha, gamma) = (
        arg("alpha=").unwrap_or(1.0),
        arg("gamma=").unwrap_or(plant.gamma),
    );
    let (zm, scaling) = solved_model(&plant.model);
    let prob = Problem::new(&zm, ConditionSet::Sound)
        .and_then(|p| p.with_conditions(Conditions::Cube))
        .expect("a box region")
        .with_scaling(scaling.clone());
    let t = Instant::now();
    let lib = prob.assemble(alpha, gamma, &settings, Objective::Gains);
    let asm = t.elapsed().as_secs_f64();
    let per = if prob.cube_one_slack() { 1 } else { 2 };
    let nnz_n: usize = zm.vertices[0]
        .n
        .iter()
        .map(|m| m.iter().filter(|x| **x != 0.0).count())
        .sum();
    let nnz_a: usize = zm.vertices[0].a.iter().filter(|x| **x != 0.0).count();
    println!(
        "{}: nx {}, {} θ-vertices, nnz A_1 {nnz_a}, nnz N_1 {nnz_n}, balanced {}",
        plant.name,
        zm.nx(),
        zm.nv(),
        scaling.is_some()
    );
    let mut req = qpv_solve::request(
        AlphaSpec::Fixed(alpha),
        GammaSpec::Fixed(gamma),
        Mode::Sound,
    );
    req.conditions = Conditions::Cube;
    let est = qpv_solve::model::size::estimate(&plant.model, &req);
    println!("  library   {} (assembly {asm:.2} s)", size(&lib));
    println!(
        "            estimated before assembly: {:.0} vars, {:.0} rows, nnz(A) {:.0}, {:.1} s per solve",
        est.variables, est.rows, est.nonzeros, est.seconds_per_solve
    );
    println!(
        "            {}",
        families(&lib, prob.combos().len(), prob.n_generators(), per)
    );
    let eps = settings.margin_rel;
    let w = settings.gain_weight;
    let (_, pairs) = Reference::new(&zm, (alpha, gamma), eps, w, Form::Pairs);
    let lean_form = if prob.cube_one_slack() {
        Form::Lean
    } else {
        Form::Pairs
    };
    let (_, lean) = Reference::new(&zm, (alpha, gamma), eps, w, lean_form);
    println!("  ref pairs {}", size(&pairs));
    println!("  ref lean  {}", size(&lean));
    println!(
        "  nnz(A) library / reference: {:.2}× pairs, {:.2}× lean",
        lib.a.nzval.len() as f64 / pairs.a.nzval.len() as f64,
        lib.a.nzval.len() as f64 / lean.a.nzval.len() as f64
    );
    if do_solve {
        println!("  solve library   {}", solve(lib, &settings));
        println!("  solve ref pairs {}", solve(pairs, &settings));
        println!("  solve ref lean  {}", solve(lean, &settings));
    }
    if do_design && matches!(plant.model.state_bound, StateBound::Given(_)) {
        let (cpu0, t) = (cpu_seconds(), Instant::now());
        let d = qpv_solve::design(&plant.model, &req, &settings).expect("design");
        println!(
            "  design: wall {:.2} s, cpu {:.2} s, Clarabel {:.2} s, {} it, {}",
            t.elapsed().as_secs_f64(),
            cpu_seconds() - cpu0,
            d.solver.seconds,
            d.solver.iterations,
            if d.certifies() {
                "certified"
            } else {
                "NOT certified"
            }
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let do_solve = args.iter().any(|a| a == "solve");
    let do_design = args.iter().any(|a| a == "design");
    let specs = plants();
    if args.iter().any(|a| a == "list") {
        for s in &specs {
            println!("{}", s.name());
        }
        return;
    }
    let wanted: Vec<&String> = args
        .iter()
        .filter(|a| {
            !matches!(
                a.as_str(),
                "solve" | "design" | "timers" | "aswritten" | "--bench"
            ) && !a.contains('=')
        })
        .collect();
    for s in specs {
        if wanted.is_empty() || wanted.iter().any(|w| **w == s.name()) {
            run(&s.build(), do_solve, do_design);
        }
    }
}
