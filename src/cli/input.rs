//! Reading input files with a size limit, choosing a model, writing JSON,
//! and the CLI's error type with its exit codes.

use qpv_dsl::Model;
use std::io::Read;
use std::path::Path;

/// The process exit codes of every command (documented in `qpv --help` and
/// docs/cli.md).
pub mod exit {
    /// Certified: sound mode, every condition family and required data check holds.
    pub const CERTIFIED: i32 = 0;
    /// Not certified: some condition fails, the solver found no certified
    /// point, or a step the design needs (such as `state_bound auto`) found
    /// nothing.
    pub const NOT_CERTIFIED: i32 = 1;
    /// Bad input: unreadable or oversized file, syntax or validation error,
    /// bad flag value.
    pub const BAD_INPUT: i32 = 2;
    /// `qpv check --mode paper`: the paper's printed conditions hold. A
    /// reproduction, not a certificate.
    pub const REPRODUCTION: i32 = 3;
}

/// Largest model file read (bytes): models are a few kilobytes of text.
pub const MODEL_LIMIT: u64 = 1 << 20;

/// Largest JSON file read (bytes): a report of a large design (a few
/// hundred vertices and its whole search log) stays far below it.
pub const JSON_LIMIT: u64 = 64 << 20;

/// Everything that can stop a command, each mapped to an exit code.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// Bad input: unreadable file, syntax or validation error, bad flag value (exit 2).
    #[error("{0}")]
    Input(String),
    /// An I/O failure writing results (exit 2).
    #[error("{0}")]
    Io(String),
}

impl CliError {
    /// The process exit code for this error (a design that is not certified
    /// is not an error: the commands return exit code 1 for it themselves).
    pub fn exit_code(&self) -> i32 {
        match self {
            CliError::Input(_) | CliError::Io(_) => exit::BAD_INPUT,
        }
    }
}

/// `bytes` in words (`1 MiB`, `64 MiB`, `512 bytes`).
fn size_words(bytes: u64) -> String {
    if bytes >= 1 << 20 && bytes % (1 << 20) == 0 {
        format!("{} MiB", bytes >> 20)
    } else {
        format!("{bytes} bytes")
    }
}

/// Reads the text file `path` (`what` names it in errors), refusing more
/// than `limit` bytes. Reads at most `limit + 1` bytes whatever the file
/// is, so a device such as /dev/zero or a pipe cannot exhaust memory.
pub fn read_bounded(path: &Path, limit: u64, what: &str) -> Result<String, CliError> {
    let file = std::fs::File::open(path)
        .map_err(|e| CliError::Input(format!("cannot read {}: {e}", path.display())))?;
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| CliError::Input(format!("cannot read {}: {e}", path.display())))?;
    if bytes.len() as u64 > limit {
        return Err(CliError::Input(format!(
            "{}: larger than {}, the limit for {what}",
            path.display(),
            size_words(limit)
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        CliError::Input(format!(
            "{}: not UTF-8 text (invalid byte at offset {})",
            path.display(),
            e.utf8_error().valid_up_to()
        ))
    })
}

/// Reads `path` and parses it, returning the text and the chosen model.
pub fn load_model(path: &Path, name: Option<&str>) -> Result<(String, Model), CliError> {
    let src = read_bounded(path, MODEL_LIMIT, "model files")?;
    let models =
        qpv_dsl::parse(&src).map_err(|e| CliError::Input(format!("{}:{e}", path.display())))?;
    let model = match name {
        Some(n) => models
            .into_iter()
            .find(|m| m.name == n)
            .ok_or_else(|| CliError::Input(format!("{}: no model named `{n}`", path.display())))?,
        None => models.into_iter().next().ok_or_else(|| {
            CliError::Input(format!("{}: the file holds no model", path.display()))
        })?,
    };
    for w in &model.warnings {
        let (l, c) = qpv_dsl::diagnostic::line_col(&src, w.span.start);
        eprintln!("warning: {}:{l}:{c}: {}", path.display(), w.message);
    }
    Ok((src, model))
}

/// The model a report's gains are checked or simulated against: the one
/// the report names (`report_model`, a design report's `model`), unless
/// `--model` names one; a `--model` that disagrees with the report is an
/// error naming both, never a silent choice (gains designed for one model
/// say nothing about another).
pub fn load_model_for(
    path: &Path,
    flag: Option<&str>,
    report: &Path,
    report_model: Option<&str>,
) -> Result<(String, Model), CliError> {
    match (flag, report_model) {
        (Some(f), Some(r)) if f != r => Err(CliError::Input(format!(
            "--model {f} disagrees with {}, whose gains were designed for model `{r}`",
            report.display()
        ))),
        (_, Some(r)) => load_model(path, Some(r)).map_err(|e| match e {
            CliError::Input(m) if m.ends_with(&format!("no model named `{r}`")) => {
                CliError::Input(format!(
                    "{}: no model named `{r}`, which {} names as the model of its gains",
                    path.display(),
                    report.display()
                ))
            }
            other => other,
        }),
        (f, None) => load_model(path, f),
    }
}

/// Reads and parses the JSON file `path` (at most [`JSON_LIMIT`] bytes).
pub fn read_json(path: &Path) -> Result<serde_json::Value, CliError> {
    let text = read_bounded(path, JSON_LIMIT, "JSON files")?;
    serde_json::from_str(&text).map_err(|e| CliError::Input(format!("{}: {e}", path.display())))
}

/// Writes `value` as pretty JSON to `target` (`-` = stdout); does nothing for `None`.
pub fn emit_json<T: serde::Serialize>(target: Option<&str>, value: &T) -> Result<(), CliError> {
    let Some(target) = target else { return Ok(()) };
    let text = serde_json::to_string_pretty(value).map_err(|e| CliError::Io(e.to_string()))?;
    if target == "-" {
        use std::io::Write;
        writeln!(std::io::stdout().lock(), "{text}")
            .map_err(|e| CliError::Io(format!("cannot write to stdout: {e}")))
    } else {
        std::fs::write(target, text + "\n")
            .map_err(|e| CliError::Io(format!("cannot write {target}: {e}")))
    }
}

/// Prints the human-readable `text` where it does not mix with JSON: on
/// stderr when the JSON goes to stdout (`--json -`), else on stdout.
pub fn print_text(json: Option<&str>, text: &str) {
    if json == Some("-") {
        eprint!("{text}");
    } else {
        print!("{text}");
    }
}

/// Formats a matrix as aligned rows for terminal output.
pub fn fmt_matrix(m: &nalgebra::DMatrix<f64>, indent: &str) -> String {
    let mut s = String::new();
    for i in 0..m.nrows() {
        s.push_str(indent);
        s.push('[');
        for j in 0..m.ncols() {
            s.push_str(&format!(" {:>11.5}", m[(i, j)]));
        }
        s.push_str(" ]\n");
    }
    s
}
