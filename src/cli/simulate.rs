//! `qpv simulate`: plant + observer with a design's gains; SVG figures and CSV.

use super::input::{load_model, read_report, CliError};
use qpv::plot::{line_chart, Series, PALETTE};
use qpv_solve::report::Design;
use qpv_solve::simulate::{envelope_factor, simulate, Scenario, Trajectory};
use std::path::Path;

/// Options of `qpv simulate`.
pub struct Options<'a> {
    /// Model file.
    pub file: &'a Path,
    /// Design report (JSON).
    pub design: &'a Path,
    /// Model name.
    pub model: Option<&'a str>,
    /// End time.
    pub t_end: f64,
    /// Step.
    pub dt: f64,
    /// Initial state override.
    pub x0: Option<Vec<f64>>,
    /// `paper` or `default`.
    pub scenario: &'a str,
    /// Output directory for figures and CSV.
    pub plot: Option<&'a Path>,
}

/// Runs `qpv simulate`.
pub fn run(o: Options<'_>) -> Result<i32, CliError> {
    let (_, model) = load_model(o.file, o.model)?;
    let poly = model.polytopic();
    let design: Design = serde_json::from_value(read_report(o.design)?)
        .map_err(|e| CliError::Input(format!("{}: {e}", o.design.display())))?;
    if design.l.is_empty() {
        return Err(CliError::Input(format!(
            "{}: the design has no gains (it was not solved)",
            o.design.display()
        )));
    }
    if !design.feasible {
        eprintln!("warning: this design was NOT certified; simulating its gains anyway");
    }
    let mut sc = match o.scenario {
        "paper" => Scenario::paper(&poly),
        "default" => Scenario::default_for(&poly),
        other => {
            return Err(CliError::Input(format!(
                "--scenario {other:?}: expected `paper` or `default`"
            )))
        }
    };
    sc.t_end = o.t_end;
    sc.dt = o.dt;
    if let Some(x0) = o.x0 {
        sc.x0 = x0;
    }
    // The gains belong to the design's observer model: for the filter route
    // the plant augmented by the output filter, whose states start at 0
    // (and the observer's filter estimate exactly there).
    let obs = design
        .observer_model(&poly)
        .map_err(|e| CliError::Input(format!("{}: {e}", o.design.display())))?;
    if obs.nx() != poly.nx() {
        sc.x0.resize(obs.nx(), 0.0);
        sc.xhat0.resize(obs.nx(), 0.0);
        println!(
            "output filter route: simulating the plant with its output filter ({} states: {}); \
             filter states start at 0, as does their estimate",
            obs.nx(),
            obs.states.join(", ")
        );
    }
    let poly = obs;
    let traj = simulate(&poly, &design.l_matrices(), &sc)
        .map_err(|e| CliError::Input(format!("simulation: {e}")))?;
    println!("{}", describe(&traj, design.alpha));
    if let Some(dir) = o.plot {
        write_figures(dir, &poly, &traj, &design)?;
        println!("figures and trajectories.csv written to {}", dir.display());
    }
    Ok(0)
}

fn describe(traj: &Trajectory, alpha: f64) -> String {
    let mut s = String::from("      t     ||x - xhat||\n");
    for target in [0.0, 0.1, 0.25, 0.5, 1.0, 1.5, 2.0, 5.0, 10.0] {
        if let Some(i) = traj.t.iter().position(|&t| t >= target - 1e-12) {
            s.push_str(&format!(
                "  {:>6.3}   {:.3e}\n",
                traj.t[i], traj.error_norm[i]
            ));
        }
    }
    match traj.error_below(1e-6) {
        Some(t) => s.push_str(&format!("error below 1e-6 from t = {t:.3} s on")),
        None => s.push_str("error not below 1e-6 at the end"),
    }
    s.push_str(&format!(
        " (certified decay rate alpha = {alpha:.4}: V(t) <= V(0) e^(-alpha t))"
    ));
    if let Some(t) = traj.diverged_at {
        s.push_str(&format!("\nsimulation diverged at t = {t}"));
    }
    s
}

fn column(rows: &[Vec<f64>], t: &[f64], k: usize) -> Vec<(f64, f64)> {
    t.iter()
        .zip(rows)
        .filter_map(|(&t, r)| r.get(k).map(|&v| (t, v)))
        .collect()
}

/// Writes `x{i}.svg` (state and estimate), `mu.svg`, `error.svg` (log
/// scale, with the guaranteed envelope) and `trajectories.csv` into `dir`.
pub fn write_figures(
    dir: &Path,
    poly: &qpv_dsl::PolytopicModel,
    traj: &Trajectory,
    design: &Design,
) -> Result<(), CliError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| CliError::Io(format!("cannot create {}: {e}", dir.display())))?;
    let io = |e: String| CliError::Io(e);
    for (k, name) in poly.states.iter().enumerate() {
        let series = vec![
            Series::new(name.clone(), column(&traj.x, &traj.t, k), PALETTE[0], false),
            Series::new(
                format!("{name} estimate"),
                column(&traj.xhat, &traj.t, k),
                PALETTE[1],
                true,
            ),
        ];
        let title = format!("{} and its estimate ({} model)", name, poly.name);
        line_chart(
            &dir.join(format!("x{}.svg", k + 1)),
            &title,
            name,
            &series,
            false,
        )
        .map_err(io)?;
    }
    let mu: Vec<Series> = (0..poly.nv())
        .map(|l| {
            Series::new(
                format!("mu{}", l + 1),
                column(&traj.mu, &traj.t, l),
                PALETTE[l % PALETTE.len()],
                false,
            )
        })
        .collect();
    line_chart(
        &dir.join("mu.svg"),
        "vertex weights mu_l(theta(t))",
        "mu",
        &mu,
        false,
    )
    .map_err(io)?;
    let e0 = traj.error_norm.first().copied().unwrap_or(0.0);
    let mut series = vec![Series::new(
        "||x - xhat||",
        traj.t
            .iter()
            .copied()
            .zip(traj.error_norm.iter().copied())
            .collect(),
        PALETTE[0],
        false,
    )];
    // ||e(t)|| <= sqrt(cond P) ||e(0)|| e^{-alpha t / 2} (from V(t) <= V(0) e^{-alpha t}).
    if let Some(factor) = envelope_factor(&design.p_matrix()).filter(|_| e0 > 0.0) {
        let k = factor * e0;
        series.push(Series::new(
            format!(
                "guaranteed envelope sqrt(cond P)||e0|| e^(-{:.2} t/2)",
                design.alpha
            ),
            traj.t
                .iter()
                .map(|&t| (t, k * (-design.alpha * t / 2.0).exp()))
                .collect(),
            PALETTE[1],
            true,
        ));
    }
    line_chart(
        &dir.join("error.svg"),
        "estimation error (log scale)",
        "||e||",
        &series,
        true,
    )
    .map_err(io)?;
    let mut csv = Vec::new();
    traj.write_csv(&mut csv)
        .map_err(|e| CliError::Io(e.to_string()))?;
    std::fs::write(dir.join("trajectories.csv"), csv)
        .map_err(|e| CliError::Io(format!("cannot write trajectories.csv: {e}")))?;
    Ok(())
}
