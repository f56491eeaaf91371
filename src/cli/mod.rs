//! Command-line front end: argument definitions and one module per
//! subcommand.

mod check;
mod codegen;
mod design;
mod gains;
mod input;
mod noisy;
mod schema;
mod signal;
mod simulate;
mod tradeoff;
mod vertices;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

pub use input::CliError;

/// Exit codes of every command, shown after `qpv --help`.
const EXIT_CODES: &str = "\
Exit codes:
  0  success. check: certified (sound mode, every condition holds). design:
     every request run is feasible (certified in sound mode; a paper-mode
     request's printed conditions hold, which certifies nothing: its report
     says `certifies: false`)
  1  not certified: a condition fails, no certified point was found, or
     `state_bound auto` found no invariant ellipsoid
  2  bad input: unreadable or oversized file, syntax or validation error, bad flag value
  3  check --mode paper: the paper's printed conditions hold (a reproduction,
     not a certificate)
JSON output (--json): one schema for every command, documented in docs/schema.md.";

/// qpv: certified gain-scheduled observers for quadratic parameter-varying systems.
#[derive(Parser, Debug)]
#[command(name = "qpv", version, about, long_about = None, after_help = EXIT_CODES)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Parse, derive, solve and certify an observer design.
    Design {
        /// The model file (.qpv).
        file: PathBuf,
        /// Which model of the file (default: the only one, or the first).
        #[arg(long)]
        model: Option<String>,
        /// Condition set: sound (default, certifies) or paper (reproduction only).
        #[arg(long)]
        mode: Option<String>,
        /// Decay rate: a number or `max`.
        #[arg(long, allow_negative_numbers = true)]
        alpha: Option<String>,
        /// Region scaling: a number in (0,1) or `search`.
        #[arg(long, allow_negative_numbers = true)]
        gamma: Option<String>,
        /// Representation of N_k, M_k: `as_written`, `symmetric` or
        /// `skew_slack` (symmetric plus a searched skew-symmetric slack;
        /// sound mode) (default: symmetric in sound mode, as_written in
        /// paper mode). Overrides the model's design blocks.
        #[arg(long)]
        split: Option<String>,
        /// Rate conditions solved: `full` (all p² vertex pairs),
        /// `decoupled` (one slack per θ-vertex, 2p blocks; the certificate
        /// still checks all pairs), `cube` (box or zonotope regions: one
        /// pair of slacks per generator, certified on the slack
        /// inequalities) or `auto` (chosen by size; the default, the report
        /// says which). Overrides the model's design blocks.
        #[arg(long)]
        conditions: Option<String>,
        /// How a θ-dependent output map is handled: `double_sum` (the
        /// double-sum relaxation) or `filter` (output post-filter
        /// augmentation). Overrides the model's design blocks.
        #[arg(long = "output-route")]
        output_route: Option<String>,
        /// Pole a of the output filter x_y' = −a x_y + b y (implies
        /// `--output-route filter`; default 50).
        #[arg(long = "filter-pole", allow_negative_numbers = true)]
        filter_pole: Option<f64>,
        /// Gain b of the output filter (implies `--output-route filter`;
        /// default: the pole, unit DC gain).
        #[arg(long = "filter-gain", allow_negative_numbers = true)]
        filter_gain: Option<f64>,
        /// Design objective for sensor noise: `min` minimises the certified
        /// noise gain σ at the requested (fixed) alpha and gamma (sound
        /// mode); `free` (default) is the ordinary design. Every certified
        /// sound design reports its noise bound either way.
        #[arg(long)]
        noise: Option<String>,
        /// With alpha = max: return the smallest-gain design certified at
        /// alpha >= (1 - WITHIN) x the certified supremum (a fraction, 0 to
        /// 0.5; default 0.01; 0 returns the fastest point found).
        #[arg(long, allow_negative_numbers = true)]
        within: Option<f64>,
        /// Bound every gain: ||L_l||_2 <= G at every vertex, imposed in the
        /// SDP and checked by the certificate from the reported gains.
        #[arg(long = "max-gain", allow_negative_numbers = true)]
        max_gain: Option<f64>,
        /// Design at the sample period H seconds (e.g. 1e-4 for 10 kHz):
        /// the observer stepped by explicit Euler at H is certified by the
        /// discrete decrease V(e_k+1) <= (1 - H alpha) V(e_k) in place of
        /// the continuous rate condition (sound mode, full conditions).
        #[arg(long, allow_negative_numbers = true)]
        sample: Option<f64>,
        /// The largest alpha the search tries (default 1e6): a design that
        /// reaches it says so.
        #[arg(long = "alpha-cap", allow_negative_numbers = true)]
        alpha_cap: Option<f64>,
        /// Write the JSON report to this file (`-` for stdout).
        #[arg(long)]
        json: Option<String>,
    },
    /// Sweep the decay rate from small to its maximum with noise-optimal
    /// designs: the certified error bound per unit noise and the largest
    /// gain at each alpha, and the knee of the trade-off.
    Tradeoff {
        /// The model file (.qpv).
        file: PathBuf,
        /// Which model of the file.
        #[arg(long)]
        model: Option<String>,
        /// Number of alpha values in the sweep (at least 2).
        #[arg(long, default_value_t = 8)]
        points: usize,
        /// Region scaling: a number in (0,1) or `search` (default: search).
        #[arg(long, allow_negative_numbers = true)]
        gamma: Option<String>,
        /// Write the table as JSON to this file (`-` for stdout).
        #[arg(long)]
        json: Option<String>,
        /// Directory for the SVG figure (tradeoff.svg).
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Certify gains that came from anywhere (a paper, another tool).
    Check {
        /// The model file (.qpv).
        file: PathBuf,
        /// JSON file with `P` (rows) and `L` (per vertex, NX rows of NY).
        #[arg(long)]
        gains: PathBuf,
        /// Which model of the file.
        #[arg(long)]
        model: Option<String>,
        /// Condition set to check: sound or paper (default: the gains
        /// file's `mode`, else sound; never the model's design blocks).
        /// Paper mode certifies nothing: it exits 3 when its conditions hold.
        #[arg(long)]
        mode: Option<String>,
        /// Decay rate to check (default: the gains file's `alpha`, else the
        /// first of the model's design blocks of the checked mode that fixes it).
        #[arg(long, allow_negative_numbers = true)]
        alpha: Option<f64>,
        /// Region scaling to check (default: the gains file's `gamma`, else
        /// the first of the model's design blocks of the checked mode that fixes it).
        #[arg(long, allow_negative_numbers = true)]
        gamma: Option<f64>,
        /// Check the gains at the sample period H seconds: the discrete
        /// decrease S5d of the Euler-stepped observer in place of S5
        /// (default: the gains file's `sample.h`, else continuous time).
        #[arg(long, allow_negative_numbers = true)]
        sample: Option<f64>,
        /// Write the JSON report to this file (`-` for stdout).
        #[arg(long)]
        json: Option<String>,
    },
    /// Show the derived polytopic model: vertices, μ order, matrices, region.
    Vertices {
        /// The model file (.qpv).
        file: PathBuf,
        /// Which model of the file.
        #[arg(long)]
        model: Option<String>,
        /// Write the JSON to this file (`-` for stdout).
        #[arg(long)]
        json: Option<String>,
    },
    /// Export a certified observer as C99 (`<model>.h`, `<model>.c`): a
    /// design block solved and independently certified, or a report's
    /// gains re-certified; with `--float f32` the constants are rounded to
    /// float before the certificate. Exit 1 (nothing written) when the
    /// numbers to bake are not certified.
    Codegen {
        /// The model file (.qpv).
        file: PathBuf,
        /// Target language: `c`.
        #[arg(long, default_value = "c")]
        lang: String,
        /// Number type of the generated code: `f64` (default) or `f32`.
        #[arg(long)]
        float: Option<String>,
        /// The design block to export, 1-based (default: the first sound one).
        #[arg(long)]
        design: Option<usize>,
        /// Export these gains (a `qpv design --json` report) instead of
        /// solving; they are re-certified first.
        #[arg(long)]
        gains: Option<PathBuf>,
        /// Which model of the file.
        #[arg(long)]
        model: Option<String>,
        /// The directory the files are written to.
        #[arg(long)]
        out: PathBuf,
    },
    /// Simulate plant + observer with a design report's gains and plot it.
    ///
    /// Exit codes: 0 the run finished (inside the certified envelope when
    /// the design is certified on this model); 1 it diverged, or left the
    /// certified envelope while e(0) was in the region and x stayed in F;
    /// 2 bad input (including more than 1e8 steps: increase --dt).
    Simulate {
        /// The model file (.qpv).
        file: PathBuf,
        /// A design report written by `qpv design --json`.
        #[arg(long)]
        design: PathBuf,
        /// Which model of the file.
        #[arg(long)]
        model: Option<String>,
        /// End time [s].
        #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
        t_end: f64,
        /// RK4 step [s].
        #[arg(long, default_value_t = 1e-3, allow_negative_numbers = true)]
        dt: f64,
        /// Initial plant state, comma-separated (default: the scenario's).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        x0: Option<Vec<f64>>,
        /// Ready-made scenario: `paper` (the published example's θ(t)) or `default`.
        #[arg(long, default_value = "default")]
        scenario: String,
        /// Directory for the SVG figures and the CSV of trajectories.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// An input as an expression of t: `NAME=EXPR` with numbers, t, pi,
        /// + - * / ^, sin, cos, exp, sqrt (repeatable; default 0).
        #[arg(long = "input", value_name = "NAME=EXPR")]
        inputs: Vec<String>,
        /// A parameter θ(t) as an expression of t, like `--input`
        /// (repeatable; default: the scenario's).
        #[arg(long = "param", value_name = "NAME=EXPR")]
        params: Vec<String>,
        /// Inputs and/or parameters from a CSV file: a header `t,NAME,...`,
        /// rows with increasing t; linear interpolation, held at the ends.
        #[arg(long = "input-csv", value_name = "FILE")]
        input_csv: Option<PathBuf>,
        /// Output interval of the CSV [s] (default: max(dt, t_end/10000));
        /// the figures keep at most 5000 points per curve.
        #[arg(long, value_name = "DT", allow_negative_numbers = true)]
        every: Option<f64>,
        /// Bounded measurement noise: |v(t)| = NU on the report's noisy
        /// outputs (every output by default), a random direction held over
        /// each step. With a certified noise bound and NU <= nu_max the
        /// error is checked against the certified bound.
        #[arg(long, value_name = "NU", allow_negative_numbers = true)]
        noise: Option<f64>,
        /// Seed of the noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
}

/// Runs one command and returns the process exit code.
pub fn run(cli: Cli) -> Result<i32, CliError> {
    match cli.command {
        Command::Vertices { file, model, json } => {
            vertices::run(&file, model.as_deref(), json.as_deref())
        }
        Command::Design {
            file,
            model,
            mode,
            alpha,
            gamma,
            split,
            conditions,
            output_route,
            filter_pole,
            filter_gain,
            noise,
            within,
            max_gain,
            sample,
            alpha_cap,
            json,
        } => design::run(
            &file,
            model.as_deref(),
            design::Flags {
                mode: mode.as_deref(),
                alpha: alpha.as_deref(),
                gamma: gamma.as_deref(),
                split: split.as_deref(),
                conditions: conditions.as_deref(),
                output_route: output_route.as_deref(),
                filter_pole,
                filter_gain,
                noise: noise.as_deref(),
                within,
                max_gain,
                sample,
                alpha_cap,
            },
            json.as_deref(),
        ),
        Command::Tradeoff {
            file,
            model,
            points,
            gamma,
            json,
            plot,
        } => tradeoff::run(tradeoff::Options {
            file: &file,
            model: model.as_deref(),
            points,
            gamma: gamma.as_deref(),
            json: json.as_deref(),
            plot: plot.as_deref(),
        }),
        Command::Check {
            file,
            gains,
            model,
            mode,
            alpha,
            gamma,
            sample,
            json,
        } => check::run(
            &file,
            &gains,
            model.as_deref(),
            check::Flags {
                mode: mode.as_deref(),
                alpha,
                gamma,
                sample,
            },
            json.as_deref(),
        ),
        Command::Codegen {
            file,
            lang,
            float,
            design,
            gains,
            model,
            out,
        } => codegen::run(codegen::Options {
            file: &file,
            model: model.as_deref(),
            lang: &lang,
            float: float.as_deref(),
            design,
            gains: gains.as_deref(),
            out: &out,
        }),
        Command::Simulate {
            file,
            design,
            model,
            t_end,
            dt,
            x0,
            scenario,
            plot,
            inputs,
            params,
            input_csv,
            every,
            noise,
            seed,
        } => simulate::run(simulate::Options {
            file: &file,
            design: &design,
            model: model.as_deref(),
            t_end,
            dt,
            x0,
            scenario: &scenario,
            plot: plot.as_deref(),
            inputs,
            params,
            input_csv: input_csv.as_deref(),
            every,
            noise,
            seed,
        }),
    }
}
