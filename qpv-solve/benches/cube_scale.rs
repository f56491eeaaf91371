//! Bench: `conditions = cube` at scale, and what it costs in α.
//!
//! * `scale` (default sizes nx = 6, 8, 10, 12, 16): the synthetic model
//!   (`synthetic_model`: 4 θ-vertices, 2 outputs, the box |x_i| ≤ 0.02, so
//!   r = nx generators and 2^nx vertices), sound mode, cube conditions,
//!   γ = min(0.3, 0.95 γ_max). Per size, in its own process (so that the
//!   peak memory, VmHWM, is that size's): one fixed-(α = 1, γ) design
//!   (wall time; Clarabel's own solve time, the assembly and the
//!   certificate) and the α search at that γ (α = max: certified α, wall
//!   time, solves). Goals: nx = 12 under 10 s and nx = 16 under 60 s for
//!   the fixed design, peak under 1 GiB.
//! * `loss` (nx = 3..8): α_max at γ = min(0.3, 0.95 γ_max) with cube,
//!   decoupled and (nx ≤ 4) full conditions, and the paper example at
//!   γ = 0.18898; loss = 1 − α_cube/α_ref against the vertex family
//!   (full where solved, else decoupled). `cube-only` leaves the vertex
//!   families out (their α does not depend on the cube's formulation).
//!
//! * `profile` (default nx = 10): where one fixed-(α = 1, γ) cube solve
//!   spends its time: the problem's size, the KKT system's and its LDL
//!   factor's nonzeros, and Clarabel's own timers (cone scaling, KKT update,
//!   which is the numerical factorisation, and KKT solves). The problem is
//!   assembled from the synthetic model with the design's symmetric split
//!   of N_k and M_k (so with one slack per generator, as the design).
//! * `compare` (default nx = 10, 12): the fixed-(α = 1, γ) cube design
//!   against an independent formulation of the same relaxation written
//!   directly on Clarabel's standard form (`cube_reference.rs`), in the same
//!   process with the same settings: with four slack blocks per θ-vertex and
//!   generator (with the design's objective, then as a pure feasibility
//!   problem) and in its lean form (one slack per generator). Sizes (nnz(A),
//!   cones, KKT nonzeros and LDL fill), times, iterations, and whether each
//!   reference point passes the independent certificate; `kkt` solves the
//!   library's problem once more to print its KKT fill.
//! * `check` (default nx = 10): the fixed cube design against the re-check
//!   of its report (JSON, then `Design::recheck`: what `qpv check` runs),
//!   with the families and condition counts the re-check went through.
//!
//! The KKT solver is `Settings::default()`'s unless one of `qdldl`, `faer`
//! (one thread per core), `faer1`, `faer2` (1 or 2 threads) or `auto` is
//! given; all but `qdldl` need `--features faer`. `verbose` prints
//! Clarabel's iteration log; `alpha=A` fixes α = A instead of 1 (`fixed`,
//! `scale`, `profile`, `compare`, `check`); `weight=W` sets the gain
//! weight of the objective (0: feasibility); `chordal` turns Clarabel's
//! chordal decomposition on (`profile` only).
//!
//! `cargo bench --bench cube_scale [--features faer] -- [scale|fixed|loss|profile|compare|check] [qdldl|faer|faer1|faer2|auto] [verbose] [alpha=A] [weight=W] [chordal] [kkt] [cube-only] [NX...]`
//! (`fixed`: the scale table without the α search). Times are wall-clock and,
//! because the machine may be shared, the process's CPU time too.
//!
//! Measured on the shared 2-core machine (docs/method.md, "Cube conditions:
//! zonotope regions without vertex enumeration", has the tables and the
//! profile).

#[path = "cube_reference.rs"]
mod cube_reference;

use qpv_dsl::{AlphaSpec, Conditions, GammaSpec, Mode, PolytopicModel};
use qpv_solve::certificate::Gains;
use qpv_solve::conditions::gamma_max;
use qpv_solve::conditions::reference::{paper_model, synthetic_model};
use qpv_solve::vocab::Candidate;
use qpv_solve::{design, request, Design, KktSolver, Settings};
use std::process::Command;
use std::time::Instant;

#[path = "cpu.rs"]
mod cpu;
use cpu::cpu_seconds;

fn vm_hwm_mib() -> f64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn gamma_for(model: &PolytopicModel) -> f64 {
    0.3f64.min(0.95 * gamma_max(model).expect("synthetic models have Q"))
}

/// The KKT solver named on the command line (`None`: the default).
fn kkt_solver(args: &[String]) -> Option<KktSolver> {
    args.iter().find_map(|a| match a.as_str() {
        "qdldl" => Some(KktSolver::Qdldl),
        #[cfg(feature = "faer")]
        "faer" => Some(KktSolver::Faer { threads: 0 }),
        #[cfg(feature = "faer")]
        "faer1" => Some(KktSolver::Faer { threads: 1 }),
        #[cfg(feature = "faer")]
        "faer2" => Some(KktSolver::Faer { threads: 2 }),
        #[cfg(feature = "faer")]
        "auto" => Some(KktSolver::Auto),
        #[cfg(not(feature = "faer"))]
        "faer" | "faer1" | "faer2" | "auto" => panic!("{a} needs `--features faer`"),
        _ => None,
    })
}

/// The settings of every solve of this process.
fn settings() -> Settings {
    let args: Vec<String> = std::env::args().collect();
    let mut s = Settings::default();
    if let Some(k) = kkt_solver(&args) {
        s.kkt_solver = k;
    }
    s.verbose = args.iter().any(|a| a == "verbose");
    if let Some(w) = args
        .iter()
        .find_map(|a| a.strip_prefix("weight=").and_then(|v| v.parse().ok()))
    {
        s.gain_weight = w;
    }
    s
}

fn run(model: &PolytopicModel, alpha: AlphaSpec, gamma: f64, c: Conditions) -> (Design, f64) {
    let mut req = request(alpha, GammaSpec::Fixed(gamma), Mode::Sound);
    req.conditions = c;
    // α = max means the certified supremum here, not the practical point
    // within 1 % of it (the default `within`).
    req.within = 0.0;
    let t = Instant::now();
    let d = design(model, &req, &settings()).expect("design");
    (d, t.elapsed().as_secs_f64())
}

/// One size of the scale table, in this process.
/// The α of the fixed design: 1, or `alpha=A` on the command line.
fn fixed_alpha() -> f64 {
    std::env::args()
        .find_map(|a| a.strip_prefix("alpha=").and_then(|v| v.parse().ok()))
        .unwrap_or(1.0)
}

fn scale_child(nx: usize, search: bool) {
    let model = synthetic_model(nx);
    let gamma = gamma_for(&model);
    let cpu0 = cpu_seconds();
    let (d, wall) = run(
        &model,
        AlphaSpec::Fixed(fixed_alpha()),
        gamma,
        Conditions::Cube,
    );
    let cpu = cpu_seconds() - cpu0;
    let peak_fixed = vm_hwm_mib();
    if !search {
        println!(
            "{:>3} {:>6} {:>6.4} {:>8.2} {:>7.2} {:>8.2} {:>6.2} {:>6.3} {:>5} {:>9} | (no α search) {:>9.0}",
            nx,
            model.region.vertices.len(),
            gamma,
            wall,
            cpu,
            d.solver.seconds,
            d.solver.assembly_seconds,
            d.solver.certify_seconds,
            d.solver.iterations,
            if d.certifies() { "yes" } else { "NO" },
            peak_fixed
        );
        if !d.certifies() {
            println!("    (Clarabel: {})", d.solver.detail);
        }
        return;
    }
    let cpu0 = cpu_seconds();
    let (m, wall_max) = run(&model, AlphaSpec::Max, gamma, Conditions::Cube);
    let cpu_max = cpu_seconds() - cpu0;
    let solves = m.search.len() + 1;
    let solver_total: f64 =
        m.search.iter().map(|s| s.solver_seconds).sum::<f64>() + m.solver.seconds;
    println!(
        "{:>3} {:>6} {:>6.4} {:>8.2} {:>7.2} {:>8.2} {:>6.2} {:>6.3} {:>5} {:>9} | {:>8.4} {:>8.2} {:>7.2} {:>8.2} {:>6} {:>9.0} {:>9.0}",
        nx,
        model.region.vertices.len(),
        gamma,
        wall,
        cpu,
        d.solver.seconds,
        d.solver.assembly_seconds,
        d.solver.certify_seconds,
        d.solver.iterations,
        if d.certifies() { "yes" } else { "NO" },
        if m.certifies() { m.alpha } else { f64::NAN },
        wall_max,
        cpu_max,
        solver_total,
        solves,
        peak_fixed,
        vm_hwm_mib(),
    );
}

/// The profile of one fixed-(α = 1, γ) cube solve, in this process: the
/// assembled problem run through Clarabel directly, with its timers.
fn profile_child(nx: usize) {
    use qpv_solve::backend::{clarabel_settings, ensure_lapack};
    use qpv_solve::conditions::ConditionSet;
    use qpv_solve::lmi::{Objective, Problem};
    let model = synthetic_model(nx).with_split(qpv_dsl::Split::Symmetric);
    let gamma = gamma_for(&model);
    let prob = Problem::new(&model, ConditionSet::Sound)
        .and_then(|p| p.with_conditions(Conditions::Cube))
        .expect("a box region");
    let settings = settings();
    let t = Instant::now();
    let sdp = prob.assemble(fixed_alpha(), gamma, &settings, Objective::Gains);
    let asm = t.elapsed().as_secs_f64();
    println!(
        "nx = {nx}: {} variables, {} rows, {} cones, nnz(A) = {}, assembly {asm:.3} s",
        sdp.a.n,
        sdp.a.m,
        sdp.cones.len(),
        sdp.a.nzval.len()
    );
    ensure_lapack();
    let (cpu0, t) = (cpu_seconds(), Instant::now());
    let mut cs = clarabel_settings(&settings);
    // `chordal`: Clarabel's chordal decomposition of the PSD cones (off in
    // the design), to see whether it pays.
    cs.chordal_decomposition_enable = std::env::args().any(|a| a == "chordal");
    let solver = qpv_clarabel::solve(sdp, cs).expect("solver setup");
    let li = &solver.info.linsolver;
    println!(
        "{:?} after {} iterations; wall {:.2} s, cpu {:.2} s; KKT: nnz {} , LDL factor nnz(L) {} ({})",
        solver.solution.status,
        solver.solution.iterations,
        t.elapsed().as_secs_f64(),
        cpu_seconds() - cpu0,
        li.nnzA,
        li.nnzL,
        li.name
    );
    if let Some(timers) = &solver.timers {
        timers.print();
    }
}

/// Size of one problem: variables, rows, nnz(A) and its cones by size.
fn describe(sdp: &qpv_solve::backend::Sdp) -> String {
    use qpv_clarabel::clarabel::solver::SupportedConeT;
    let mut sizes: Vec<(String, usize)> = Vec::new();
    for c in &sdp.cones {
        let key = match c {
            SupportedConeT::PSDTriangleConeT(d) => format!("PSD({d})"),
            SupportedConeT::NonnegativeConeT(d) => format!("R+^{d}"),
            other => format!("{other:?}"),
        };
        match sizes.iter_mut().find(|(k, _)| *k == key) {
            Some((_, n)) => *n += 1,
            None => sizes.push((key, 1)),
        }
    }
    let cones: Vec<String> = sizes.iter().map(|(k, n)| format!("{n} × {k}")).collect();
    format!(
        "{} variables, {} rows, nnz(A) = {}, cones: {}",
        sdp.a.n,
        sdp.a.m,
        sdp.a.nzval.len(),
        cones.join(", ")
    )
}

/// One solve of the reference formulation (`cube_reference.rs`) of `obs`
/// with gain weight `w` in the given form, in this process: its size, its
/// wall and CPU time, Clarabel's iterations, status and KKT fill, and
/// whether its point passes the independent certificate. Returns (wall, cpu).
fn reference_solve(
    obs: &PolytopicModel,
    (alpha, gamma): (f64, f64),
    w: f64,
    form: cube_reference::Form,
) -> (f64, f64) {
    use cube_reference::Reference;
    use qpv_solve::backend::{clarabel_settings, ensure_lapack};
    use qpv_solve::conditions::cube::CubeSlacks;
    let settings = settings();
    let t = Instant::now();
    let (reference, sdp) = Reference::new(obs, (alpha, gamma), settings.margin_rel, w, form);
    let asm = t.elapsed().as_secs_f64();
    let what = format!(
        "reference {form:?}{}",
        if w > 0.0 { "" } else { " (feasibility)" }
    );
    println!("  {what} problem: {} (assembly {asm:.2} s)", describe(&sdp));
    ensure_lapack();
    let (cpu0, t) = (cpu_seconds(), Instant::now());
    let solved = qpv_clarabel::solve(sdp, clarabel_settings(&settings)).expect("solver setup");
    let (wall, cpu) = (t.elapsed().as_secs_f64(), cpu_seconds() - cpu0);
    let point = reference.unpack(&solved.solution.x);
    let ls: Vec<_> = point
        .gammas
        .iter()
        .map(|g| point.p.clone().lu().solve(g).expect("P invertible"))
        .collect();
    let slacks = CubeSlacks {
        y: point.y,
        x: point.x,
        d: point.d,
    };
    let cert = qpv_solve::certificate::check(
        obs,
        &Gains::new(&point.p, &ls).with_cube(Some(&slacks)),
        &Candidate::new(alpha, gamma),
        Mode::Sound,
    );
    let li = &solved.info.linsolver;
    println!(
        "  {what} solve: wall {wall:.2} s, cpu {cpu:.2} s ({} iterations, {:?}; KKT nnz {}, nnz(L) {}), its point {}",
        solved.solution.iterations,
        solved.solution.status,
        li.nnzA,
        li.nnzL,
        if cert.passed { "certified" } else { "NOT certified" }
    );
    (wall, cpu)
}

/// The library's fixed cube design against the reference formulation
/// (`cube_reference.rs`) of the same relaxation on the same (split) model,
/// in this process: the design's wall and CPU time and its problem's size
/// (and, with `kkt`, its KKT fill, from one more solve of that problem),
/// then the reference with four slack blocks per generator (with the
/// design's objective and as a pure feasibility problem) and in its lean
/// form, each with the same settings.
fn compare_child(nx: usize) {
    use cube_reference::Form;
    use qpv_solve::conditions::ConditionSet;
    use qpv_solve::lmi::{Objective, Problem};
    let model = synthetic_model(nx);
    let gamma = gamma_for(&model);
    let alpha = fixed_alpha();
    let settings = settings();
    let cpu0 = cpu_seconds();
    let (d, wall) = run(&model, AlphaSpec::Fixed(alpha), gamma, Conditions::Cube);
    let cpu = cpu_seconds() - cpu0;
    let obs = d.observer_model(&model).expect("the design's own model");
    let builder = Problem::new(&obs, ConditionSet::Sound)
        .and_then(|p| p.with_conditions(Conditions::Cube))
        .expect("a box region")
        .assemble(alpha, gamma, &settings, Objective::Gains);
    println!("nx = {nx}, α = {alpha}, γ = {gamma:.4}");
    println!("  library problem: {}", describe(&builder));
    println!(
        "  library design: wall {wall:.2} s, cpu {cpu:.2} s (Clarabel {:.2} s, {} iterations, {}), {}",
        d.solver.seconds,
        d.solver.iterations,
        d.solver.detail,
        if d.certifies() { "certified" } else { "NOT certified" }
    );
    if std::env::args().any(|a| a == "kkt") {
        qpv_solve::backend::ensure_lapack();
        let cs = qpv_solve::backend::clarabel_settings(&settings);
        let solved = qpv_clarabel::solve(builder, cs).expect("solver setup");
        let li = &solved.info.linsolver;
        println!(
            "  library problem's KKT: nnz {}, nnz(L) {} ({} iterations)",
            li.nnzA, li.nnzL, solved.solution.iterations
        );
    } else {
        drop(builder);
    }
    let w = settings.gain_weight;
    let (rwall, rcpu) = reference_solve(&obs, (alpha, gamma), w, Form::Pairs);
    let (fwall, fcpu) = reference_solve(&obs, (alpha, gamma), 0.0, Form::Pairs);
    let (lwall, lcpu) = reference_solve(&obs, (alpha, gamma), w, Form::Lean);
    println!(
        "  design / reference solve (wall, cpu): {:.2}×, {:.2}× (feasibility: {:.2}×, {:.2}×; lean: {:.2}×, {:.2}×)",
        wall / rwall,
        cpu / rcpu,
        wall / fwall,
        cpu / fcpu,
        wall / lwall,
        cpu / lcpu
    );
}

/// A fixed cube design and the re-check of its report, in this process:
/// the design (wall and CPU time), its report through JSON and back, and
/// [`Design::recheck`] on the model, the one re-certification `qpv check`
/// runs (on the observer model the report describes, with its cube
/// slacks); the families it checked and how many conditions each.
fn check_child(nx: usize) {
    let model = synthetic_model(nx);
    let gamma = gamma_for(&model);
    let cpu0 = cpu_seconds();
    let (d, wall) = run(
        &model,
        AlphaSpec::Fixed(fixed_alpha()),
        gamma,
        Conditions::Cube,
    );
    let cpu = cpu_seconds() - cpu0;
    let (cpu0, t) = (cpu_seconds(), Instant::now());
    let back = Design::from_json(&d.to_json()).expect("the report reads back");
    let cert = back.recheck(&model);
    let (cwall, ccpu) = (t.elapsed().as_secs_f64(), cpu_seconds() - cpu0);
    let families: Vec<String> = cert
        .families
        .iter()
        .map(|f| {
            format!(
                "{} {} ({})",
                f.name,
                f.count,
                if f.passed { "pass" } else { "FAIL" }
            )
        })
        .collect();
    println!(
        "{:>3} {:>6} {:>8.2} {:>7.2} {:>9} | {:>8.3} {:>7.3} {:>9} | {:>6.3} {:>6.3}  {}",
        nx,
        model.region.vertices.len(),
        wall,
        cpu,
        if d.certifies() { "yes" } else { "NO" },
        cwall,
        ccpu,
        if cert.passed { "yes" } else { "NO" },
        cwall / wall,
        ccpu / cpu,
        families.join(", ")
    );
}

/// One row of the loss table, in this process.
fn loss_child(nx: usize) {
    let (model, gamma, name) = if nx == 0 {
        (paper_model(), 0.18898, "paper".to_string())
    } else {
        let m = synthetic_model(nx);
        let g = gamma_for(&m);
        (m, g, format!("synthetic{nx}"))
    };
    let alpha = |c: Conditions| {
        let (d, wall) = run(&model, AlphaSpec::Max, gamma, c);
        (if d.certifies() { d.alpha } else { f64::NAN }, wall)
    };
    let (cube, tc) = alpha(Conditions::Cube);
    // `cube-only`: the vertex families are left out (their α does not
    // depend on the cube's formulation, and they take minutes from nx = 6).
    let cube_only = std::env::args().any(|a| a == "cube-only");
    let (dec, td) = if cube_only {
        (f64::NAN, f64::NAN)
    } else {
        alpha(Conditions::Decoupled)
    };
    let (full, tf) = if nx <= 4 && !cube_only {
        alpha(Conditions::Full)
    } else {
        (f64::NAN, f64::NAN)
    };
    let reference = if full.is_nan() { dec } else { full };
    println!(
        "{:>11} {:>6.4} {:>9.4} {:>7.2} {:>9.4} {:>7.2} {:>9.4} {:>7.2} {:>7.2}%",
        name,
        gamma,
        full,
        tf,
        dec,
        td,
        cube,
        tc,
        100.0 * (1.0 - cube / reference)
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(pos) = args.iter().position(|a| a == "--child") {
        let nx: usize = args[pos + 2].parse().unwrap();
        match args[pos + 1].as_str() {
            "scale" => scale_child(nx, true),
            "fixed" => scale_child(nx, false),
            "profile" => profile_child(nx),
            "compare" => compare_child(nx),
            "check" => check_child(nx),
            _ => loss_child(nx),
        }
        return;
    }
    let loss = args.iter().any(|a| a == "loss");
    let profile = args.iter().any(|a| a == "profile");
    let compare = args.iter().any(|a| a == "compare");
    let check = args.iter().any(|a| a == "check");
    let fixed = args.iter().any(|a| a == "fixed");
    let scale =
        args.iter().any(|a| a == "scale") || fixed || !(loss || profile || compare || check);
    let given: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    let exe = std::env::current_exe().unwrap();
    let passed: Vec<&String> = args
        .iter()
        .filter(|a| {
            [
                "qdldl",
                "faer",
                "faer1",
                "faer2",
                "auto",
                "verbose",
                "chordal",
                "kkt",
                "cube-only",
            ]
            .contains(&a.as_str())
                || a.starts_with("alpha=")
                || a.starts_with("weight=")
        })
        .collect();
    println!(
        "KKT solver: {:?}",
        kkt_solver(&args).unwrap_or(Settings::default().kkt_solver)
    );
    let child = |what: &str, nx: usize| {
        let st = Command::new(&exe)
            .args(["--child", what, &nx.to_string()])
            .args(&passed)
            .status()
            .expect("child runs");
        if !st.success() {
            println!("{nx:>3} {what}: child failed ({st})");
        }
    };
    if scale {
        println!(
            "bench cube_scale (scale): synthetic model, sound, cube, 4 θ-vertices, box region; fixed design α = {}, then α = max at the same γ",
            fixed_alpha()
        );
        println!(
            "{:>3} {:>6} {:>6} {:>8} {:>7} {:>8} {:>6} {:>6} {:>5} {:>9} | {:>8} {:>8} {:>7} {:>8} {:>6} {:>9} {:>9}",
            "nx",
            "verts",
            "γ",
            "wall s",
            "cpu s",
            "solver s",
            "asm s",
            "cert s",
            "iters",
            "certified",
            "α max",
            "wall s",
            "cpu s",
            "solver s",
            "solves",
            "peak MiB",
            "peak max"
        );
        for nx in sizes_or(&given, &[6, 8, 10, 12, 16]) {
            child(if fixed { "fixed" } else { "scale" }, nx);
        }
    }
    if profile {
        for nx in sizes_or(&given, &[10]) {
            child("profile", nx);
        }
    }
    if compare {
        println!("bench cube_scale (compare): the fixed cube design against the reference formulation of the same relaxation, same settings");
        for nx in sizes_or(&given, &[10, 12]) {
            child("compare", nx);
        }
    }
    if check {
        println!("bench cube_scale (check): a fixed cube design, then its report re-checked (JSON → Design::recheck, the path of `qpv check`)");
        println!(
            "{:>3} {:>6} {:>8} {:>7} {:>9} | {:>8} {:>7} {:>9} | {:>6} {:>6}  families (conditions)",
            "nx", "verts", "wall s", "cpu s", "certified", "check s", "cpu s", "passes", "wall ×", "cpu ×"
        );
        for nx in sizes_or(&given, &[10]) {
            child("check", nx);
        }
    }
    if loss {
        println!("bench cube_scale (loss): α_max at fixed γ, sound mode, symmetric split; loss of cube against full (nx ≤ 4) or decoupled");
        println!(
            "{:>11} {:>6} {:>9} {:>7} {:>9} {:>7} {:>9} {:>7} {:>8}",
            "model", "γ", "full α", "s", "dec α", "s", "cube α", "s", "loss"
        );
        for nx in sizes_or(&given, &[0, 3, 4, 5, 6, 7, 8]) {
            child("loss", nx);
        }
    }
}

/// The sizes given on the command line, or `default` when none were.
fn sizes_or(given: &[usize], default: &[usize]) -> Vec<usize> {
    if given.is_empty() {
        default.to_vec()
    } else {
        given.to_vec()
    }
}
