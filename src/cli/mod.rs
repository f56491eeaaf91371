//! Command-line front end: argument definitions and one module per
//! subcommand.

mod check;
mod codegen;
mod design;
mod gains;
mod input;
mod schema;
mod signal;
mod simulate;
mod simulate_sampled;
mod tradeoff;
mod vertices;

use clap::{Parser, Subcommand};

use input::one_of;
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

/// The subcommands, each with its options (the `Options` of its module).
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Parse, derive, solve and certify an observer design.
    Design(design::Options),
    /// Sweep the decay rate from small to its maximum with noise-optimal
    /// designs: the certified error bound per unit noise and the largest
    /// gain at each alpha, and the knee of the trade-off.
    Tradeoff(tradeoff::Options),
    /// Certify gains that came from anywhere (a paper, another tool).
    Check(check::Options),
    /// Show the derived polytopic model: vertices, μ order, matrices, region.
    Vertices(vertices::Options),
    /// Export a certified observer as C99 (`<model>.h`, `<model>.c`): a
    /// design block solved and independently certified, or a report's
    /// gains re-certified; with `--float f32` the constants are rounded to
    /// float before the certificate. Exit 1 (nothing written) when the
    /// numbers to bake are not certified.
    Codegen(codegen::Options),
    /// Simulate plant + observer with a design report's gains and plot it.
    ///
    /// Exit codes: 0 the run finished (inside the certified envelope when
    /// the design is certified on this model); 1 it diverged, or left the
    /// certified envelope while e(0) was in the region and x stayed in F;
    /// 2 bad input (including more than 1e8 steps: increase --dt).
    Simulate(simulate::Options),
}

impl Cli {
    /// The command line of this process. A flag value its parser refuses
    /// is reported as `--flag "value": expected ...` (exit 2), the form of
    /// every other input error; help, version and usage errors are clap's.
    pub fn from_args() -> Cli {
        Cli::try_parse().unwrap_or_else(|e| match flag_error(&e) {
            Some(message) => {
                eprintln!("error: {message}");
                std::process::exit(input::exit::BAD_INPUT)
            }
            None => e.exit(),
        })
    }
}

/// `--flag "value": why` for a value clap's parser of the flag refused.
fn flag_error(e: &clap::Error) -> Option<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    let text = |kind| match e.get(kind) {
        Some(ContextValue::String(s)) => Some(s.as_str()),
        _ => None,
    };
    let flag = text(ContextKind::InvalidArg)?.split_whitespace().next()?;
    let value = text(ContextKind::InvalidValue)?;
    let why = match e.kind() {
        ErrorKind::ValueValidation => std::error::Error::source(e)?.to_string(),
        ErrorKind::InvalidValue => match e.get(ContextKind::ValidValue) {
            Some(ContextValue::Strings(v)) => {
                format!("expected {}", one_of(v.iter().map(String::as_str), "`"))
            }
            _ => return None,
        },
        _ => return None,
    };
    Some(format!("{flag} {value:?}: {why}"))
}

/// Runs one command and returns the process exit code.
pub fn run(cli: Cli) -> Result<i32, CliError> {
    match cli.command {
        Command::Vertices(o) => vertices::run(&o),
        Command::Design(o) => design::run(&o),
        Command::Tradeoff(o) => tradeoff::run(&o),
        Command::Check(o) => check::run(&o),
        Command::Codegen(o) => codegen::run(&o),
        Command::Simulate(o) if o.sample.is_some() => simulate_sampled::run(&o),
        Command::Simulate(o) => simulate::run(&o),
    }
}
