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
/// is, so a device such as /dev/zero or a pipe cannot exhaust memory. A
/// leading byte-order mark (U+FEFF, as some editors write) is skipped.
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
    let text = String::from_utf8(bytes).map_err(|e| {
        CliError::Input(format!(
            "{}: not UTF-8 text (invalid byte at offset {})",
            path.display(),
            e.utf8_error().valid_up_to()
        ))
    })?;
    Ok(match text.strip_prefix('\u{FEFF}') {
        Some(rest) => rest.to_string(),
        None => text,
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

/// Writes `value` as pretty JSON to `target` (`-` = stdout); does nothing
/// for `None`. A file is written atomically ([`write_atomic`]): an
/// interrupted run leaves the old file or the new one, never half of one.
pub fn emit_json<T: serde::Serialize>(target: Option<&str>, value: &T) -> Result<(), CliError> {
    let Some(target) = target else { return Ok(()) };
    let text = serde_json::to_string_pretty(value).map_err(|e| CliError::Io(e.to_string()))?;
    if target == "-" {
        use std::io::Write;
        writeln!(std::io::stdout().lock(), "{text}")
            .map_err(|e| CliError::Io(format!("cannot write to stdout: {e}")))
    } else {
        write_atomic(Path::new(target), &(text + "\n"))
    }
}

/// Writes `text` to `target` through a temporary file in the same
/// directory, renamed over it at the end (the rename is atomic). A symlink
/// is written through: its target is replaced, the link stays.
pub fn write_atomic(target: &Path, text: &str) -> Result<(), CliError> {
    use std::io::Write;
    let io = |e: std::io::Error| CliError::Io(format!("cannot write {}: {e}", target.display()));
    let resolved = std::fs::canonicalize(target).unwrap_or_else(|_| target.to_path_buf());
    let dir = match resolved.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let name = resolved
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(text.as_bytes())?;
        f.sync_all()?;
        std::fs::rename(&tmp, &resolved)
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written.map_err(io)
}

/// Whether `a` and `b` name the same existing file (through `./`, `..`,
/// symlinks or hard links: the same device and inode on Unix, the same
/// canonical path elsewhere).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(ca), Ok(cb)) => ca == cb,
        _ => false,
    }
}

/// Checks an output file before any work: `flag` (`--json`, `--plot`)
/// names it in errors. It must not be an input of the run (it would be
/// overwritten: a model replaced by JSON), nor a directory, and its
/// directory must exist.
pub fn check_output_file(path: &Path, flag: &str, inputs: &[&Path]) -> Result<(), CliError> {
    if let Some(input) = inputs.iter().find(|i| same_file(path, i)) {
        return Err(CliError::Input(format!(
            "{flag} {}: the same file as the input {}, which it would overwrite; write the output \
             to another file",
            path.display(),
            input.display()
        )));
    }
    if path.is_dir() {
        return Err(CliError::Input(format!(
            "{flag} {}: a directory; expected the name of a file to write",
            path.display()
        )));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(CliError::Input(format!(
            "{flag} {}: the directory {} does not exist",
            path.display(),
            dir.display()
        )));
    }
    Ok(())
}

/// [`check_output_file`] for `--json TARGET` (nothing to check for stdout).
pub fn check_json_target(target: Option<&str>, inputs: &[&Path]) -> Result<(), CliError> {
    match target {
        None | Some("-") => Ok(()),
        Some(t) => check_output_file(Path::new(t), "--json", inputs),
    }
}

/// Prepares the directory of `--plot DIR` before any work: creates it
/// (an existing file of that name is an error) and checks each of the
/// `files` it will hold with [`check_output_file`].
pub fn prepare_plot_dir(dir: &Path, files: &[String], inputs: &[&Path]) -> Result<(), CliError> {
    if dir.exists() && !dir.is_dir() {
        return Err(CliError::Input(format!(
            "--plot {}: exists and is not a directory; expected a directory for the figures",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| CliError::Io(format!("--plot {}: cannot create it: {e}", dir.display())))?;
    for f in files {
        check_output_file(&dir.join(f), "--plot", inputs)?;
    }
    Ok(())
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

/// `names` as a list for a message: `a`, `b` or `c`, each between `quote`.
pub fn one_of<'a>(names: impl IntoIterator<Item = &'a str>, quote: &str) -> String {
    let names: Vec<String> = names
        .into_iter()
        .map(|n| format!("{quote}{n}{quote}"))
        .collect();
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        Some((last, _)) => last.clone(),
        None => String::new(),
    }
}

/// A flag parser (for clap) of one of `all` by its name in the vocabulary
/// (`Mode::name`, `Split::name`, ...): the names are the enum's own table,
/// never written here.
pub fn by_name<T: Copy + Send + Sync + 'static>(
    all: &'static [T],
    name: fn(T) -> &'static str,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        all.iter()
            .copied()
            .find(|v| name(*v) == s)
            .ok_or_else(|| format!("expected {}", one_of(all.iter().map(|v| name(*v)), "`")))
    }
}

/// `--alpha` of `qpv design`: a positive number or `max`.
pub fn parse_alpha(s: &str) -> Result<qpv_dsl::AlphaSpec, String> {
    match s {
        "max" => Ok(qpv_dsl::AlphaSpec::Max),
        _ => match s.parse::<f64>() {
            Ok(a) if a.is_finite() && a > 0.0 => Ok(qpv_dsl::AlphaSpec::Fixed(a)),
            _ => Err("expected a positive number or `max`".into()),
        },
    }
}

/// `--gamma` of `qpv design` and `qpv tradeoff`: a number in (0, 1) or
/// `search`.
pub fn parse_gamma(s: &str) -> Result<qpv_dsl::GammaSpec, String> {
    match s {
        "search" => Ok(qpv_dsl::GammaSpec::Search),
        _ => match s.parse::<f64>() {
            Ok(g) if g > 0.0 && g < 1.0 => Ok(qpv_dsl::GammaSpec::Fixed(g)),
            _ => Err("expected a number in (0, 1) or `search`".into()),
        },
    }
}
