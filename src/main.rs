//! The `qpv` command line: design, check, inspect and simulate QPV observers
//! from model files. Exit codes: 0 success (for `check`: certified), 1 not
//! certified, 2 bad input, 3 `check --mode paper` whose reproduction
//! conditions hold (not a certificate); `qpv --help` and docs/cli.md say
//! more.

mod cli;

fn main() {
    let args = cli::Cli::from_args();
    let code = match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    };
    std::process::exit(code);
}
