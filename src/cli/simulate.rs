//! `qpv simulate`: plant + observer with a design's gains; SVG figures and CSV.
//!
//! What the run is compared with depends on what is certified: only when
//! the report certifies *and* the independent certificate re-checked on the
//! model as it is now passes, the error is compared with the certified
//! envelope ‖e(t)‖ ≤ √cond(P) ‖e(0)‖ e^{−αt/2} (drawn in `error.svg`). The
//! certificate assumes e(0) in the region and x(t) in F = {xᵀQ⁻¹x ≤ 1}; a
//! run that leaves F is reported as a warning.
//!
//! Exit codes: 0 the run finished (and stayed inside the certified envelope
//! when there is one); 1 the simulation diverged, or it left the certified
//! envelope although e(0) was in the region and x stayed in F; 2 bad input.
//!
//! The integration streams ([`simulate_each`]): the CSV is written row by
//! row (every [`Options::every`] seconds of simulated time) and the figures
//! keep at most [`PLOT_POINTS`] points per curve, so memory does not grow
//! with the number of steps (at most [`MAX_STEPS`]).

use super::gains::read_claim;
use super::input::{load_model_for, prepare_plot_dir, CliError};
use super::signal::{expr_signal, parse_assignment, table_signal, Table, TimeFn};
use nalgebra::DMatrix;
use qpv::plot::{line_chart, Series, PALETTE};
use qpv_dsl::diagnostic::fmt_num;
use qpv_dsl::PolytopicModel;
use qpv_solve::analysis::continuous::not_certified_reason;
use qpv_solve::report::Design;
use qpv_solve::simulate::{
    simulate_each, ContinuousCheck, MeasurementNoise, Scenario, Signal, Trajectory, TrajectoryCsv,
    MAX_STEPS, SETTLED,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Most points kept per curve of a figure (the CSV has every output row).
pub const PLOT_POINTS: usize = 5000;

/// Default number of CSV rows when `--every` is not given: the output
/// interval is max(dt, t_end / DEFAULT_ROWS).
pub const DEFAULT_ROWS: f64 = 10_000.0;

/// Largest CSV `qpv simulate --plot` writes, estimated before the run as
/// rows × columns × [`CSV_CELL_BYTES`]: 1 GiB.
pub const MAX_CSV_BYTES: f64 = 1024.0 * 1024.0 * 1024.0;

/// Bytes per CSV cell in that estimate (a shortest round-trip number and
/// its comma).
pub const CSV_CELL_BYTES: f64 = 24.0;

/// The RK4 step of a run without `--dt` whose design gives no smaller one.
pub const DEFAULT_DT: f64 = 1e-3;

/// The share of a certified design's RK4 step estimate (a frozen, linear
/// stability limit, not a proof) the default step takes when 1e-3 is above it.
pub const DT_SHARE_OF_RK4_ESTIMATE: f64 = 0.25;

/// The shortest default horizon.
pub const DEFAULT_T_END_MIN: f64 = 2.0;

/// The default horizon in units of 1/α: the envelope's e^{−αt/2} falls to
/// e^{−10} ≈ 4.5e-5 of its start, four decades and more.
pub const T_END_PER_RATE: f64 = 20.0;

/// Most steps of a default horizon; a longer one is cut there (and said so).
pub const DEFAULT_MAX_STEPS: f64 = 2e6;

/// The time grid of a run: its RK4 step and its horizon, each as given on
/// the command line or chosen from the design.
#[derive(Clone, Copy, Debug)]
pub(super) struct Grid {
    pub dt: f64,
    pub t_end: f64,
}

/// `v` to two significant digits (the defaults print as short numbers).
fn two_digits(v: f64) -> f64 {
    format!("{v:.1e}").parse().unwrap_or(v)
}

/// `v` to three significant digits, printed.
fn three_digits(v: f64) -> String {
    fmt_num(format!("{v:.2e}").parse().unwrap_or(v))
}

/// Refuses a `--t-end` or `--dt` that is given and not usable.
pub(super) fn check_grid_flags(o: &Options) -> Result<(), CliError> {
    if let Some(t) = o.t_end.filter(|t| !(t.is_finite() && *t >= 0.0)) {
        return Err(CliError::Input(format!(
            "--t-end {}: expected a non-negative number of seconds",
            fmt_num(t)
        )));
    }
    if let Some(dt) = o.dt.filter(|dt| !(dt.is_finite() && *dt > 0.0)) {
        return Err(CliError::Input(format!(
            "--dt {}: expected a positive number of seconds",
            fmt_num(dt)
        )));
    }
    Ok(())
}

/// The default RK4 step and why: [`DEFAULT_DT`], or
/// [`DT_SHARE_OF_RK4_ESTIMATE`] of the design's RK4 step estimate when that
/// is smaller and the design is certified here (its figures recomputed,
/// [`qpv_solve::report::figures::attach`]).
fn default_dt(design: &Design, certified: bool) -> (f64, String) {
    let usual = fmt_num(DEFAULT_DT);
    let Some(sp) = design.sampling.as_ref().filter(|_| certified) else {
        let why = if certified {
            "the design carries no RK4 step estimate"
        } else {
            "the design is not certified here, so no step estimate of its own is used"
        };
        return (DEFAULT_DT, format!("--dt {usual} ({why})"));
    };
    let share = two_digits(DT_SHARE_OF_RK4_ESTIMATE * sp.step_estimate_rk4);
    if share >= DEFAULT_DT {
        return (
            DEFAULT_DT,
            format!(
                "--dt {usual} (inside the design's RK4 step estimate {:.3e})",
                sp.step_estimate_rk4
            ),
        );
    }
    (
        share,
        format!(
            "--dt {} (a quarter of the design's RK4 step estimate {:.3e}, below the usual {usual}; \
             its certified Euler step is {:.3e})",
            fmt_num(share),
            sp.step_estimate_rk4,
            sp.max_step_euler
        ),
    )
}

/// The default horizon and why: max([`DEFAULT_T_END_MIN`],
/// [`T_END_PER_RATE`]/α), cut at [`DEFAULT_MAX_STEPS`] steps of `step`.
pub(super) fn default_t_end(alpha: f64, step: f64) -> (f64, String) {
    let by_rate = two_digits(T_END_PER_RATE / alpha);
    let cap = two_digits(DEFAULT_MAX_STEPS * step);
    let t = by_rate.max(DEFAULT_T_END_MIN);
    let a = three_digits(alpha);
    let why = if t > cap && by_rate <= cap {
        format!(
            "--t-end {} ({:.0e} steps of {}; 20/alpha = {} with alpha = {a} lies within it)",
            fmt_num(cap),
            DEFAULT_MAX_STEPS,
            fmt_num(step),
            fmt_num(by_rate)
        )
    } else if t > cap {
        format!(
            "--t-end {} (capped at {:.0e} steps of {}; max(2, 20/alpha) = {} with alpha = {a}: \
             give --t-end for the whole decay)",
            fmt_num(cap),
            DEFAULT_MAX_STEPS,
            fmt_num(step),
            fmt_num(t)
        )
    } else if by_rate <= DEFAULT_T_END_MIN {
        format!(
            "--t-end {} (20/alpha = {} with alpha = {a} is shorter)",
            fmt_num(t),
            fmt_num(by_rate)
        )
    } else {
        format!(
            "--t-end {} (20/alpha with alpha = {a}: the envelope e^(-alpha t/2) falls to e^-10)",
            fmt_num(t)
        )
    };
    (t.min(cap), why)
}

/// The run's grid: `--dt` and `--t-end` when given, else the defaults of
/// [`default_dt`] and [`default_t_end`]; and the line that says which
/// defaults were used and why, if any were.
fn grid_for(o: &Options, design: &Design, certified: bool) -> (Grid, Option<String>) {
    let mut said = Vec::new();
    let dt = o.dt.unwrap_or_else(|| {
        let (dt, why) = default_dt(design, certified);
        said.push(why);
        dt
    });
    let t_end = o.t_end.unwrap_or_else(|| {
        let (t, why) = default_t_end(design.alpha, dt);
        said.push(why);
        t
    });
    let line = (!said.is_empty()).then(|| format!("default time grid: {}", said.join("; ")));
    (Grid { dt, t_end }, line)
}

/// The options of `qpv simulate`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The model file (.qpv).
    pub file: PathBuf,
    /// A design report written by `qpv design --json`.
    #[arg(long, value_name = "REPORT.json")]
    pub design: PathBuf,
    /// Which model of the file.
    #[arg(long, value_name = "NAME")]
    pub model: Option<String>,
    /// End time [s] (default: from the design's rate, max(2, 20/alpha),
    /// at most 2e6 steps of --dt).
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    pub t_end: Option<f64>,
    /// RK4 step [s] (default: 1e-3, or a quarter of the design's RK4 step
    /// estimate when that is smaller).
    #[arg(long, value_name = "DT", allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// Initial plant state, comma-separated (default: the scenario's).
    #[arg(
        long,
        value_name = "a,b,c",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub x0: Option<Vec<f64>>,
    /// Ready-made scenario: `paper` (the published example's θ(t)) or `default`.
    #[arg(long, default_value = "default", value_parser = ["paper", "default"])]
    pub scenario: String,
    /// Directory for the SVG figures and the CSV of trajectories.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// An input as an expression of t: `NAME=EXPR` with numbers, t, pi,
    /// + - * / ^, sin, cos, exp, sqrt (repeatable; default 0).
    #[arg(long = "input", value_name = "NAME=EXPR")]
    pub inputs: Vec<String>,
    /// A parameter θ(t) as an expression of t, like `--input`, or a state's
    /// name (`p=x1`: fed with the plant's state as the run goes, for a
    /// parameter scheduling on a measured state) (repeatable; default: the
    /// scenario's).
    #[arg(long = "param", value_name = "NAME=EXPR")]
    pub params: Vec<String>,
    /// Inputs and/or parameters from a CSV file: a header `t,NAME,...`,
    /// rows with increasing t; linear interpolation, held at the ends.
    #[arg(long = "input-csv", value_name = "FILE")]
    pub input_csv: Option<PathBuf>,
    /// Output interval of the CSV [s] (default: max(dt, t_end/10000));
    /// the figures keep at most 5000 points per curve.
    #[arg(long, value_name = "DT", allow_hyphen_values = true)]
    pub every: Option<f64>,
    /// Bounded measurement noise: |v(t)| = NU on the report's noisy
    /// outputs (every output by default), a random direction held over
    /// each step. With a certified noise bound and NU <= nu_max the
    /// error is checked against the certified bound.
    #[arg(long, value_name = "NU", allow_hyphen_values = true)]
    pub noise: Option<f64>,
    /// Seed of the noise.
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub seed: u64,
    /// Run the observer stepped at the sample period H seconds (explicit
    /// Euler on sampled y, u, θ) against the continuous plant (RK4 at
    /// min(--dt, H/20)), and check the error against the certified
    /// continuous-plant bound (docs/method.md §16).
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub sample: Option<f64>,
}

/// The design a report's gains are simulated and re-checked with: its
/// mode (sound if absent), α and γ (required: the claim is made at them),
/// split and the rest of its claim ([`super::gains::Claim::at`]).
pub(super) fn claimed_design(claim: super::gains::Claim, path: &Path) -> Result<Design, CliError> {
    let mode = claim.mode.unwrap_or(qpv_dsl::Mode::Sound);
    let value = |name: &str, v: Option<f64>, ok: fn(f64) -> bool, expected: &str| match v {
        Some(v) if ok(v) => Ok(v),
        Some(v) => Err(CliError::Input(format!(
            "{}: the report's `{name}` is {}: expected {expected}",
            path.display(),
            qpv_dsl::diagnostic::fmt_num(v)
        ))),
        None => Err(CliError::Input(format!(
            "{}: the report has no `{name}` ({expected}): the gains are re-checked at it",
            path.display()
        ))),
    };
    let alpha = value(
        "alpha",
        claim.alpha,
        |a| a.is_finite() && a > 0.0,
        "a positive finite number",
    )?;
    let gamma = value(
        "gamma",
        claim.gamma,
        // 1: a global design (LPV plant), whose γ is unused; the
        // certificate refuses γ = 1 for any other.
        |v| v > 0.0 && v <= 1.0,
        "a number in (0, 1) (1 for the global observer of an LPV plant)",
    )?;
    Ok(claim.at(mode, alpha, gamma))
}

/// A signal given on the command line: where it came from (`--param
/// s=...`, `--input-csv FILE`), the name it sets, Θ of a parameter, and
/// the function.
struct Given {
    source: String,
    name: String,
    theta: Option<(f64, f64)>,
    f: TimeFn,
}

/// Applies `--param`, `--input` and `--input-csv` to the scenario's
/// signals; a name set twice (by two flags, or a flag and a CSV column) is
/// refused, never silently the last.
fn apply_signals(
    sc: &mut Scenario,
    poly: &PolytopicModel,
    o: &Options,
) -> Result<Vec<Given>, CliError> {
    // Parameters fed with a plant state first: a name given again below
    // is refused like any name given twice.
    let mut tied: Vec<&String> = Vec::new();
    for a in &o.params {
        if tie_to_state(sc, poly, a)? {
            tied.push(a);
        }
    }
    let mut given: Vec<Given> = Vec::new();
    let mut set = |name: &str, f: TimeFn, source: String, flag: &str| -> Result<(), CliError> {
        if let Some(first) = given.iter().find(|g| g.name == name) {
            return Err(CliError::Input(format!(
                "{source}: `{name}` is given twice (first by {}); give each input or parameter once",
                first.source
            )));
        }
        let theta = if let Some(i) = poly.inputs.iter().position(|n| n == name) {
            if flag == "--param" {
                return Err(CliError::Input(format!(
                    "{source}: `{name}` is an input; use --input"
                )));
            }
            sc.u[i] = Signal::Custom(f.clone());
            None
        } else if let Some(i) = poly.params.iter().position(|p| p.name == name) {
            if flag == "--input" {
                return Err(CliError::Input(format!(
                    "{source}: `{name}` is a parameter; use --param"
                )));
            }
            if let Some(m) = &poly.params[i].measured {
                return Err(measured_given(&source, name, &m.output_name));
            }
            if let Signal::State(k) = sc.theta[i] {
                return Err(CliError::Input(format!(
                    "{source}: `{name}` is given twice (first by --param {name}={}); give each input or parameter once",
                    poly.states[k]
                )));
            }
            sc.theta[i] = Signal::Custom(f.clone());
            Some((poly.params[i].lo, poly.params[i].hi))
        } else {
            let params: Vec<&str> = poly.params.iter().map(|p| p.name.as_str()).collect();
            return Err(CliError::Input(format!(
                "{flag}: `{name}` is neither an input ({}) nor a parameter ({}) of model {}",
                if poly.inputs.is_empty() {
                    "none".to_string()
                } else {
                    poly.inputs.join(", ")
                },
                params.join(", "),
                poly.name
            )));
        };
        given.push(Given {
            source,
            name: name.to_string(),
            theta,
            f,
        });
        Ok(())
    };
    if let Some(path) = &o.input_csv {
        let table = Arc::new(Table::read(path)?);
        for (k, name) in table.names.iter().enumerate() {
            let flag = format!("--input-csv {}", path.display());
            set(name, table_signal(&table, k), flag.clone(), &flag)?;
        }
    }
    for (flag, args) in [("--param", &o.params), ("--input", &o.inputs)] {
        for a in args {
            if flag == "--param" && tied.contains(&a) {
                continue;
            }
            let (name, e) = parse_assignment(flag, a)?;
            set(&name, expr_signal(e), format!("{flag} {a}"), flag)?;
        }
    }
    Ok(given)
}

/// The error for a parameter computed from a measured output given on the
/// command line: the run computes it from the plant's output, as the
/// generated observer does from y.
fn measured_given(source: &str, name: &str, output: &str) -> CliError {
    CliError::Input(format!(
        "{source}: `{name}` is computed from the measured output {output} (`param {name} = \
         {output}`): the run feeds it with the plant's output as it goes, as the generated \
         observer computes it from y; it cannot be given"
    ))
}

/// `--param NAME=STATE`: the parameter fed with the plant's state as the
/// run goes ([`Signal::State`]; a parameter that schedules a term on a
/// measured state), so that the plant is simulated as written. True if
/// `arg` named a state (and the parameter was tied); false for an
/// expression of t. Whether θ stays in Θ is checked as the run goes
/// ([`ContinuousCheck::left_theta`]).
fn tie_to_state(sc: &mut Scenario, poly: &PolytopicModel, arg: &str) -> Result<bool, CliError> {
    let Some((name, rhs)) = arg.split_once('=') else {
        return Ok(false);
    };
    let (name, rhs) = (name.trim(), rhs.trim());
    let Some(k) = poly.states.iter().position(|s| s == rhs) else {
        return Ok(false);
    };
    let Some(i) = poly.params.iter().position(|p| p.name == name) else {
        return Err(CliError::Input(format!(
            "--param {arg}: `{name}` is not a parameter of model {}; a state ({rhs}) can only feed a parameter",
            poly.name
        )));
    };
    if let Some(m) = &poly.params[i].measured {
        return Err(measured_given(
            &format!("--param {arg}"),
            name,
            &m.output_name,
        ));
    }
    if matches!(sc.theta[i], Signal::State(_)) {
        return Err(CliError::Input(format!(
            "--param {arg}: `{name}` is given twice; give each parameter once"
        )));
    }
    sc.theta[i] = Signal::State(k);
    println!("parameter {name} is fed with the plant's state {rhs} as the run goes");
    Ok(true)
}

/// Checks every signal given on the command line at every time the run
/// evaluates it (each RK4 step's start, midpoint and end): a value that
/// is not a finite number (0/0, 1/t at t = 0, exp(1000 t) overflowing) or
/// a parameter outside its interval Θ (where the plant's matrices are not
/// known) is bad input, named with the flag, the value and the time.
fn check_signals(given: &[Given], steps: usize, dt: f64, t_end: f64) -> Result<(), CliError> {
    for g in given {
        let bad = |t: f64, v: f64| -> Option<String> {
            if !v.is_finite() {
                return Some(format!(
                    "{}: {}(t) is {v} at t = {}: expected a finite number",
                    g.source,
                    g.name,
                    fmt_num(t)
                ));
            }
            let (lo, hi) = g.theta?;
            let tol = 1e-12 * lo.abs().max(hi.abs()).max(hi - lo);
            (v < lo - tol || v > hi + tol).then(|| {
                format!(
                    "{}: {}(t) = {} at t = {} is outside Θ: {} ∈ [{}, {}] (the plant is only \
                     known there; give a θ(t) inside the interval)",
                    g.source,
                    g.name,
                    fmt_num(v),
                    fmt_num(t),
                    g.name,
                    fmt_num(lo),
                    fmt_num(hi)
                )
            })
        };
        let at = |t: f64| bad(t, (g.f)(t)).map_or(Ok(()), |m| Err(CliError::Input(m)));
        at(0.0)?;
        for k in 0..steps {
            let t = k as f64 * dt;
            let t_next = if k + 1 == steps {
                t_end
            } else {
                (k + 1) as f64 * dt
            };
            at(t + 0.5 * (t_next - t))?;
            at(t_next)?;
        }
    }
    Ok(())
}

/// What a streamed run found besides its verdict ([`ContinuousCheck`]).
#[derive(Default)]
struct Findings {
    /// Rows kept for the figures (at most about [`PLOT_POINTS`]).
    plot: Trajectory,
    /// The summary's times ([`summary_times`]).
    targets: Vec<f64>,
    /// Decimals the summary's times are printed with ([`time_decimals`]).
    decimals: usize,
    /// (t, ‖e‖) at the summary's times: the first row at or after each.
    table: Vec<(f64, f64)>,
    rows_written: usize,
    t_last: f64,
}

/// The summary table's times as shares of the run's horizon.
const SUMMARY_SHARES: [f64; 7] = [0.0, 0.05, 0.125, 0.25, 0.5, 0.75, 1.0];

/// The summary table's times of a run to `t_end`.
fn summary_times(t_end: f64) -> Vec<f64> {
    SUMMARY_SHARES.iter().map(|s| s * t_end).collect()
}

/// Decimals that show times up to `t_end` to about four digits.
fn time_decimals(t_end: f64) -> usize {
    if !(t_end.is_finite() && t_end > 0.0) {
        return 3;
    }
    (3.0 - t_end.log10().floor()).clamp(0.0, 12.0) as usize
}

/// Prints what the run is compared with ([`ContinuousCheck`]: the certified
/// envelope without noise, the noise bound's lines are [`noise_setup`]'s),
/// and whether e(0) lies in the region (outside it, nothing is guaranteed).
fn print_claim(
    (design, obs): (&Design, &PolytopicModel),
    reason: &Option<String>,
    check: &ContinuousCheck,
    noisy: bool,
) {
    match (reason, check.envelope) {
        (None, None) if noisy => {}
        (None, Some((k, a))) if design.kind_on(obs).is_global() => println!(
            "certified, global (independent re-check on this model, an LPV plant): V(t) <= V(0) e^(-alpha t) \
             with alpha = {a:.6} for every e(0), ||e(t)|| <= {k:.4} ||e(0)|| e^(-alpha t/2)"
        ),
        (None, Some((k, a))) => println!(
            "certified (independent re-check on this model): V(t) <= V(0) e^(-alpha t) with alpha = {a:.6}, \
             gamma = {:.6}; for e(0) in the region and x(t) in F, ||e(t)|| <= {k:.4} ||e(0)|| e^(-alpha t/2)",
            design.gamma
        ),
        (None, None) => println!(
            "not certified: P of the report is not positive definite; no envelope drawn"
        ),
        (Some(why), _) => println!(
            "NOT certified: {why}; simulating its gains anyway (no decay rate is claimed, no envelope drawn)"
        ),
    }
    if (check.envelope.is_some() || check.noise_bound.is_some()) && !check.e0_inside {
        println!(
            "note: e(0) = x(0) - xhat(0) is outside the region of guaranteed convergence; \
             the envelope is not a guarantee for this run"
        );
    }
}

/// The CSV writer of `--plot DIR` (DIR/trajectories.csv, header written).
fn open_csv<'a>(dir: Option<&Path>, obs: &'a PolytopicModel) -> Result<Option<Csv<'a>>, CliError> {
    let Some(dir) = dir else {
        return Ok(None);
    };
    std::fs::create_dir_all(dir)
        .map_err(|e| CliError::Io(format!("cannot create {}: {e}", dir.display())))?;
    let path = dir.join("trajectories.csv");
    let f = std::fs::File::create(&path)
        .map_err(|e| CliError::Io(format!("cannot write {}: {e}", path.display())))?;
    let w = TrajectoryCsv::new(obs, std::io::BufWriter::new(f));
    Ok(Some(w.map_err(|e| CliError::Io(e.to_string()))?))
}

/// The `trajectories.csv` of `--plot DIR`.
type Csv<'a> = TrajectoryCsv<'a, std::io::BufWriter<std::fs::File>>;

/// The RK4 step count, the CSV row stride and the plot stride of a run on
/// `grid` (its flags checked by [`check_grid_flags`]), after checking `--every`.
fn step_counts(o: &Options, grid: Grid) -> Result<(usize, usize, usize), CliError> {
    let Grid { dt, t_end } = grid;
    let steps_f = (t_end / dt - 1e-9).ceil().max(0.0);
    if steps_f > MAX_STEPS as f64 {
        return Err(CliError::Input(format!(
            "--t-end {} with --dt {} needs {steps_f:.3e} RK4 steps; at most {:.0e} are run: \
             increase --dt or shorten --t-end",
            fmt_num(t_end),
            fmt_num(dt),
            MAX_STEPS as f64
        )));
    }
    let steps = steps_f as usize;
    let every = o.every.unwrap_or((t_end / DEFAULT_ROWS).max(dt));
    if !(every.is_finite() && every > 0.0) {
        return Err(CliError::Input(format!(
            "--every {}: expected a positive number of seconds",
            fmt_num(every)
        )));
    }
    let stride = ((every / dt).round() as usize).max(1);
    let plot_stride = stride.max(steps.div_ceil(PLOT_POINTS));
    Ok((steps, stride, plot_stride))
}

/// Refuses a CSV larger than [`MAX_CSV_BYTES`] before the run (the step
/// limit alone allowed about 19 GB with a small `--every`).
fn csv_size_guard(
    grid: Grid,
    obs: &PolytopicModel,
    steps: usize,
    stride: usize,
) -> Result<(), CliError> {
    let rows = (steps / stride + 2) as f64;
    let columns =
        (2 + 2 * obs.nx() + obs.params.len() + obs.inputs.len() + obs.ny() + obs.nv()) as f64;
    let bytes = rows * columns * CSV_CELL_BYTES;
    if bytes <= MAX_CSV_BYTES {
        return Ok(());
    }
    let every = stride as f64 * grid.dt;
    let fits = every * bytes / MAX_CSV_BYTES * 1.01;
    Err(CliError::Input(format!(
        "--every {}: trajectories.csv would have {rows:.3e} rows of {columns} columns (about \
         {:.1} GiB); at most 1 GiB is written: give --every {fits:.2e} or more, or a shorter --t-end",
        fmt_num(every),
        bytes / MAX_CSV_BYTES
    )))
}

/// The scenario of `--scenario`, with the run's horizon and step, the
/// signals and initial state given on the command line.
pub(super) fn scenario(
    o: &Options,
    poly: &PolytopicModel,
    grid: Grid,
) -> Result<Scenario, CliError> {
    let mut sc = match o.scenario.as_str() {
        "paper" => Scenario::paper(poly),
        _ => Scenario::default_for(poly),
    };
    sc.t_end = grid.t_end;
    sc.dt = grid.dt;
    for p in &poly.params {
        if let Some(m) = &p.measured {
            eprintln!(
                "note: parameter {} is computed from the plant's output {} as the run goes",
                p.name, m.output_name
            );
        }
    }
    let given = apply_signals(&mut sc, poly, o)?;
    if !given.is_empty() {
        let names: Vec<String> = given
            .iter()
            .map(|g| {
                let kind = if g.theta.is_some() {
                    "parameter"
                } else {
                    "input"
                };
                format!("{kind} {}", g.name)
            })
            .collect();
        println!("signals given: {}", names.join(", "));
    }
    let (steps, _, _) = step_counts(o, grid)?;
    check_signals(&given, steps, grid.dt, grid.t_end)?;
    let unset: Vec<&str> = poly
        .inputs
        .iter()
        .enumerate()
        .filter(|(i, _)| matches!(sc.u[*i], Signal::Constant(_)))
        .map(|(_, n)| n.as_str())
        .collect();
    if !unset.is_empty() {
        println!(
            "inputs {} are 0 (give them with --input NAME=EXPR or --input-csv)",
            unset.join(", ")
        );
    }
    if let Some(x0) = o.x0.clone() {
        sc.x0 = x0;
    }
    Ok(sc)
}

/// The outputs `--noise` enters: the report's noisy outputs, by name on
/// the observer model; every output when the report names none that the
/// model has.
pub(super) fn noisy_outputs(design: &Design, obs: &PolytopicModel) -> Vec<usize> {
    let named: Vec<usize> = design
        .noise
        .as_ref()
        .map(|n| {
            n.noisy_outputs
                .iter()
                .filter_map(|name| obs.outputs.iter().position(|o| o == name))
                .collect()
        })
        .unwrap_or_default();
    if named.is_empty() {
        (0..obs.ny()).collect()
    } else {
        named
    }
}

/// The measurement-noise generator of `--noise` (on the report's noisy
/// outputs); prints what is claimed with it (the certified bound the run
/// is compared with, [`ContinuousCheck::noise_bound`], or why there is none).
fn noise_setup(
    o: &Options,
    (design, obs): (&Design, &PolytopicModel),
    reason: &Option<String>,
    check: &ContinuousCheck,
) -> Result<Option<MeasurementNoise>, CliError> {
    if let Some(nu) = o.noise {
        if !(nu.is_finite() && nu >= 0.0) {
            return Err(CliError::Input(format!(
                "--noise {}: expected a non-negative amplitude",
                fmt_num(nu)
            )));
        }
    }
    let noise_gen = o
        .noise
        .map(|nu| MeasurementNoise::new(o.seed, nu, noisy_outputs(design, obs)));
    let noise_bound = check.noise_bound;
    if let (Some(nu), Some(g)) = (o.noise, &noise_gen) {
        let names: Vec<&str> = g
            .outputs()
            .iter()
            .map(|&i| obs.outputs[i].as_str())
            .collect();
        println!(
            "measurement noise: |v(t)| = {} on {} (random direction, seed {}, held over each step)",
            fmt_num(nu),
            names.join(", "),
            o.seed
        );
        match (reason, &design.noise) {
            (None, Some(nb)) if noise_bound.is_some() => println!(
                "certified under noise (nu = {nu} <= nu_max = {:.4e}): ||e(t)|| <= sqrt(V(t)/lambda_min(P)), \
                 V(t) <= e^(-alpha t) V(0) + (sigma nu^2/alpha)(1 - e^(-alpha t)), sigma = {:.4e}; \
                 ultimate bound {:.4e}",
                nb.max_amplitude,
                nb.sigma,
                noise_bound.map_or(f64::NAN, |b| b.ultimate())
            ),
            (None, Some(nb)) => println!(
                "no bound is certified at this noise level: nu = {nu} > nu_max = {:.4e} (the region is not \
                 certified invariant); no claim is made and no bound is drawn",
                nb.max_amplitude
            ),
            (None, None) => println!(
                "the report carries no noise bound: no bound is certified with noise; no claim is made"
            ),
            (Some(_), _) => {}
        }
    }
    Ok(noise_gen)
}

/// Says when the run's step exceeds the certified Euler step of the gains
/// (recomputed): the RK4 run says nothing about the observer stepped there.
fn note_euler_step(design: &Design, dt: f64) {
    if let Some(sp) = design.sampling.as_ref().filter(|sp| dt > sp.max_step_euler) {
        println!(
            "note: --dt {} exceeds the certified Euler step h = {} of these gains: this run \
             integrates the continuous plant and observer together by RK4, so it says nothing \
             about the observer stepped at that rate (stepped by Euler, the decay is certified \
             for steps up to h only)",
            fmt_num(dt),
            fmt_num(sp.max_step_euler)
        );
    }
}

/// Runs `qpv simulate`.
pub fn run(o: &Options) -> Result<i32, CliError> {
    check_grid_flags(o)?;
    let claim = read_claim(&o.design, "report")?;
    let (_, model) = load_model_for(&o.file, o.model.as_deref(), &o.design, claim.model())?;
    let claims = claim.certifies;
    let mut design = claimed_design(claim, &o.design)?;
    let poly = model.polytopic();
    if design.l.is_empty() {
        return Err(CliError::Input(format!(
            "{}: the design has no gains (it was not solved)",
            o.design.display()
        )));
    }
    // The gains belong to the design's observer model: for the filter route
    // the plant augmented by the output filter, whose states start at 0
    // (and the observer's filter estimate exactly there).
    let obs = design
        .observer_model(&poly)
        .map_err(|e| CliError::Input(format!("{}: {e}", o.design.display())))?;

    // What is certified, and therefore what the run is compared with.
    let reason = not_certified_reason(&design, claims, &obs);
    // Every figure a claim rests on (σ, ν_max, the error bound, the Euler
    // step) is recomputed from the model as it is now and the gains as
    // given; the report's own figures are claims, never read as facts.
    design.verdict = qpv_solve::vocab::Verdict::of(reason.is_none(), design.mode);
    if reason.is_none() {
        qpv_solve::report::figures::attach(&poly, &mut design);
    }
    let (grid, grid_line) = grid_for(o, &design, reason.is_none());
    let (steps, stride, plot_stride) = step_counts(o, grid)?;

    let mut sc = scenario(o, &poly, grid)?;
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
    if sc.x0.len() != obs.nx() {
        return Err(CliError::Input(format!(
            "--x0 has {} entries, expected {} ({})",
            sc.x0.len(),
            poly.nx(),
            poly.states.join(", ")
        )));
    }

    if let Some(dir) = &o.plot {
        csv_size_guard(grid, &obs, steps, stride)?;
        let mut files: Vec<String> = ["trajectories.csv", "mu.svg", "error.svg"]
            .map(String::from)
            .to_vec();
        files.extend((1..=obs.nx()).map(|k| format!("x{k}.svg")));
        let mut inputs = vec![o.file.as_path(), o.design.as_path()];
        inputs.extend(o.input_csv.as_deref());
        prepare_plot_dir(dir, &files, &inputs)?;
    }
    note_euler_step(&design, grid.dt);
    let e0: Vec<f64> = sc.x0.iter().zip(&sc.xhat0).map(|(a, b)| a - b).collect();
    let certified = reason.is_none();
    let mut check = ContinuousCheck::new(&design, &obs, certified, &e0, (o.noise, grid.dt));
    let mut noise_gen = noise_setup(o, (&design, &obs), &reason, &check)?;
    print_claim((&design, &obs), &reason, &check, o.noise.is_some());
    if let Some(line) = grid_line {
        println!("{line}");
    }

    let mut csv = open_csv(o.plot.as_deref(), &obs)?;

    let gains = design.l_matrices();
    let mut found = Findings {
        targets: summary_times(grid.t_end),
        decimals: time_decimals(grid.t_end),
        ..Findings::default()
    };
    run_streamed(
        &obs,
        (&gains, &sc),
        (&mut check, &mut found),
        (stride, plot_stride),
        &mut csv,
        noise_gen.as_mut(),
    )?;
    if let Some(w) = csv.as_mut() {
        w.flush()
            .map_err(|e| CliError::Io(format!("cannot write trajectories.csv: {e}")))?;
    }
    println!("{}", describe(&found, &check, &obs));

    if let Some(dir) = &o.plot {
        write_figures(dir, &obs, &found, &check)?;
        println!(
            "figures and trajectories.csv ({} rows, every {} s) written to {}",
            found.rows_written,
            fmt_num(stride as f64 * grid.dt),
            dir.display()
        );
    }
    Ok(if check.failed() { 1 } else { 0 })
}

/// Integrates with the library's RK4 ([`simulate_each`], with the noise
/// of `--noise` if any), handing every step to the check and the summary,
/// every `stride`-th to the CSV and every `plot_stride`-th to the figures.
fn run_streamed(
    obs: &PolytopicModel,
    (gains, sc): (&[DMatrix<f64>], &Scenario),
    (check, found): (&mut ContinuousCheck, &mut Findings),
    (stride, plot_stride): (usize, usize),
    csv: &mut Option<Csv<'_>>,
    noise: Option<&mut MeasurementNoise>,
) -> Result<(), CliError> {
    let mut k = 0usize;
    let mut next_target = 0usize;
    let mut failed = None;
    let mut last: Option<(Trajectory, bool, bool)> = None;
    let mut each = |r: &qpv_solve::simulate::Row<'_>| {
        check.see(r);
        let reached = |target: f64| r.t >= target - 1e-9 * sc.t_end;
        if found.targets.get(next_target).is_some_and(|&t| reached(t)) {
            found.table.push((r.t, r.error_norm));
            while found.targets.get(next_target).is_some_and(|&t| reached(t)) {
                next_target += 1;
            }
        }
        let end = r.t >= sc.t_end;
        let to_csv = k % stride == 0 || end;
        if to_csv {
            if let Err(e) = write_csv_row(csv, r, found) {
                failed = Some(e);
                return false;
            }
        }
        found.t_last = r.t;
        let to_plot = k % plot_stride == 0 || end;
        if to_plot {
            found.plot.push(r);
        }
        let mut one = Trajectory::with_capacity(1);
        one.push(r);
        last = Some((one, to_csv, to_plot));
        k += 1;
        true
    };
    let diverged = simulate_each(obs, gains, sc, noise, &mut each)
        .map_err(|e| CliError::Input(format!("simulation: {e}")))?;
    if let Some(e) = failed {
        return Err(e);
    }
    check.diverged_at = diverged;
    // A run that stopped early: its last row closes the CSV and the figures.
    if let Some((r, to_csv, to_plot)) = last {
        if !to_csv {
            write_csv_row(csv, &r.row(0), found)?;
        }
        if !to_plot {
            found.plot.push(&r.row(0));
        }
    }
    Ok(())
}

/// Writes `r` to the CSV of `--plot`, if there is one, and counts it.
fn write_csv_row(
    csv: &mut Option<Csv<'_>>,
    r: &qpv_solve::simulate::Row<'_>,
    found: &mut Findings,
) -> Result<(), CliError> {
    if let Some(w) = csv.as_mut() {
        w.row(r)
            .map_err(|e| CliError::Io(format!("cannot write trajectories.csv: {e}")))?;
        found.rows_written += 1;
    }
    Ok(())
}

fn describe(f: &Findings, check: &ContinuousCheck, obs: &PolytopicModel) -> String {
    let d = f.decimals;
    let last = f.targets.last().copied().unwrap_or(0.0);
    let width = format!("{last:.d$}").len().max(6);
    let mut s = format!("  {:>width$}   ||x - xhat||\n", "t");
    for (t, e) in &f.table {
        s.push_str(&format!("  {t:>width$.d$}   {e:.3e}\n"));
    }
    let settled = fmt_num(SETTLED);
    match (check.diverged_at, check.below_from) {
        (Some(_), _) => {}
        (None, Some(t)) => s.push_str(&format!("error below {settled} from t = {t:.d$} s on\n")),
        (None, None) => s.push_str(&format!("error not below {settled} at the end\n")),
    }
    if let Some((t, i)) = check.left_theta {
        let p = &obs.params[i];
        s.push_str(&format!(
            "warning: the parameter {} leaves its interval [{}, {}] at t = {t:.4}; \
             the certificate holds for θ in that box only, so it says nothing about this run\n",
            p.name,
            fmt_num(p.lo),
            fmt_num(p.hi)
        ));
    }
    if let Some((t, v)) = check.left_f {
        s.push_str(&format!(
            "warning: the plant leaves the state bound F at t = {t:.4} (x^T Q^-1 x up to {v:.4} > 1); \
             the certificate assumes x stays in F, so it says nothing about this run\n"
        ));
    }
    if check.envelope.is_some() {
        match check.envelope_exceeded {
            Some((t, r)) => s.push_str(&format!(
                "the error LEAVES the certified envelope at t = {t:.4} (up to {r:.4} times the envelope)\n"
            )),
            None => s.push_str("the error stays inside the certified envelope\n"),
        }
    }
    if check.noise_bound.is_some() {
        match check.noise_exceeded {
            Some((t, r)) => s.push_str(&format!(
                "the error LEAVES the certified noise bound at t = {t:.4} (up to {r:.4} times the bound)\n"
            )),
            None => s.push_str("the error stays inside the certified noise bound\n"),
        }
    }
    if let Some(t) = check.diverged_at {
        s.push_str(&format!("simulation diverged at t = {t}\n"));
    }
    s.trim_end().to_string()
}

/// Writes `x{i}.svg` (state and estimate), `mu.svg` and `error.svg` (log
/// scale, with the certified envelope when there is one) into `dir`.
fn write_figures(
    dir: &Path,
    poly: &PolytopicModel,
    f: &Findings,
    check: &ContinuousCheck,
) -> Result<(), CliError> {
    let io = |e: String| CliError::Io(e);
    let col = |get: &dyn Fn(&qpv_solve::simulate::Row) -> Option<f64>| -> Vec<(f64, f64)> {
        (0..f.plot.len())
            .map(|i| f.plot.row(i))
            .filter_map(|r| get(&r).map(|v| (r.t, v)))
            .collect()
    };
    for (k, name) in poly.states.iter().enumerate() {
        let series = vec![
            Series::new(
                name.clone(),
                col(&|r| r.x.get(k).copied()),
                PALETTE[0],
                false,
            ),
            Series::new(
                format!("{name} estimate"),
                col(&|r| r.xhat.get(k).copied()),
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
                col(&|r| r.mu.get(l).copied()),
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
    let mut series = vec![Series::new(
        "||x - xhat||",
        col(&|r| Some(r.error_norm)),
        PALETTE[0],
        false,
    )];
    // ||e(t)|| <= sqrt(cond P) ||e(0)|| e^{-alpha t / 2}, only when certified.
    if let Some((k, alpha)) = check.envelope.filter(|_| check.e0 > 0.0) {
        let k = k * check.e0;
        series.push(Series::new(
            format!("certified envelope sqrt(cond P)||e0|| e^(-{alpha:.2} t/2)"),
            col(&|r| Some(k * (-alpha * r.t / 2.0).exp())),
            PALETTE[1],
            true,
        ));
    }
    if let Some(b) = check.noise_bound {
        series.push(Series::new(
            format!(
                "certified noise bound sqrt(V(t)/lambda_min(P)) (ultimate {:.2e})",
                b.ultimate()
            ),
            col(&|r| Some(b.at(r.t))),
            PALETTE[2],
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
    .map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_horizon_follows_the_rate_and_is_cut_at_its_step_budget() {
        let (t, why) = default_t_end(0.2, 1e-3);
        assert_eq!(t, 100.0, "{why}");
        assert!(why.contains("20/alpha with alpha = 0.2"), "{why}");
        let (t, why) = default_t_end(500.0, 1e-3);
        assert_eq!(t, 2.0, "{why}");
        assert!(why.contains("is shorter"), "{why}");
        // 100 s at 1e-6 is 1e8 steps: cut at 2e6 of them, and said so.
        let (t, why) = default_t_end(0.2, 1e-6);
        assert_eq!(t, 2.0, "{why}");
        assert!(why.contains("capped at 2e6 steps of 1e-6"), "{why}");
        let (t, why) = default_t_end(500.0, 1e-7);
        assert_eq!(t, 0.2, "{why}");
        assert!(why.contains("2e6 steps of 1e-7; 20/alpha = 0.04"), "{why}");
    }

    #[test]
    fn the_summary_times_end_at_the_horizon_in_a_form_of_its_scale() {
        assert_eq!(
            summary_times(400.0),
            [0.0, 20.0, 50.0, 100.0, 200.0, 300.0, 400.0]
        );
        assert_eq!(time_decimals(2.0), 3);
        assert_eq!(time_decimals(400.0), 1);
        assert_eq!(time_decimals(0.02), 5);
        assert_eq!(time_decimals(1e6), 0);
    }
}
