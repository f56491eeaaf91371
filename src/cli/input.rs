//! Loading model files, choosing a model, writing JSON, and the CLI's error
//! type with its exit codes.

use nalgebra::DMatrix;
use qpv_dsl::{Model, PolytopicModel};
use std::path::Path;

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
            CliError::Input(_) | CliError::Io(_) => 2,
        }
    }
}

/// Reads `path` and parses it, returning the text and the chosen model.
pub fn load_model(path: &Path, name: Option<&str>) -> Result<(String, Model), CliError> {
    let src = std::fs::read_to_string(path)
        .map_err(|e| CliError::Input(format!("cannot read {}: {e}", path.display())))?;
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

/// Writes `value` as pretty JSON to `target` (`-` = stdout); does nothing for `None`.
pub fn emit_json<T: serde::Serialize>(target: Option<&str>, value: &T) -> Result<(), CliError> {
    let Some(target) = target else { return Ok(()) };
    let text = serde_json::to_string_pretty(value).map_err(|e| CliError::Io(e.to_string()))?;
    if target == "-" {
        println!("{text}");
        Ok(())
    } else {
        std::fs::write(target, text + "\n")
            .map_err(|e| CliError::Io(format!("cannot write {target}: {e}")))
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

/// A human-readable listing of the polytopic model.
pub fn describe_vertices(p: &PolytopicModel) -> String {
    let mut s = format!(
        "model {}: nx = {}, ny = {}, nu = {}, {} parameter(s), {} vertices\n",
        p.name,
        p.nx(),
        p.ny(),
        p.nu(),
        p.ntheta(),
        p.nv()
    );
    let sched: Vec<&str> = p
        .scheduling
        .iter()
        .map(|&i| p.params[i].name.as_str())
        .collect();
    s.push_str(&format!(
        "vertex order: corners of ({}), first most significant, lo before hi\n",
        sched.join(", ")
    ));
    let varies = p.output_varies();
    for (l, v) in p.vertices.iter().enumerate() {
        let corner: Vec<String> = p
            .scheduling
            .iter()
            .map(|&i| format!("{} = {}", p.params[i].name, v.theta[i]))
            .collect();
        s.push_str(&format!(
            "\nvertex {} ({}):\n  A:\n{}",
            l + 1,
            corner.join(", "),
            fmt_matrix(&v.a, "    ")
        ));
        for (k, n) in v.n.iter().enumerate() {
            if n.iter().any(|x| *x != 0.0) {
                s.push_str(&format!("  N{}:\n{}", k + 1, fmt_matrix(n, "    ")));
            }
        }
        if p.nu() > 0 {
            s.push_str(&format!("  B:\n{}", fmt_matrix(&v.b, "    ")));
        }
        if varies {
            push_output(&mut s, &v.c, &v.m, "  ");
        }
    }
    if !varies {
        let (c, m) = p.c0();
        s.push('\n');
        push_output(&mut s, c, m, "");
    }
    s.push_str(&format!(
        "\nregion: {} vertices, {} facets (a_k^T x <= 1)\n",
        p.region.vertices.len(),
        p.region.facets.len()
    ));
    for (i, v) in p.region.vertices.iter().enumerate() {
        s.push_str(&format!("  x_({}) = {:?}\n", i + 1, v.as_slice()));
    }
    for (k, a) in p.region.facets.iter().enumerate() {
        s.push_str(&format!("  a_{} = {:?}\n", k + 1, a.as_slice()));
    }
    s
}

/// Appends C and the nonzero M_k, indented by `indent`.
fn push_output(s: &mut String, c: &DMatrix<f64>, m: &[DMatrix<f64>], indent: &str) {
    let inner = format!("{indent}  ");
    s.push_str(&format!("{indent}C:\n{}", fmt_matrix(c, &inner)));
    for (k, mk) in m.iter().enumerate() {
        if mk.iter().any(|x| *x != 0.0) {
            s.push_str(&format!("{indent}M{}:\n{}", k + 1, fmt_matrix(mk, &inner)));
        }
    }
}

/// Reads a JSON report or gains file. A `qpv design` run over several
/// requests writes an array of reports: then the first certified one is
/// used (else the first feasible one, else the first), and stderr says which.
pub fn read_report(path: &Path) -> Result<serde_json::Value, CliError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::Input(format!("cannot read {}: {e}", path.display())))?;
    let value: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| CliError::Input(format!("{}: {e}", path.display())))?;
    let serde_json::Value::Array(items) = value else {
        return Ok(value);
    };
    let flag =
        |v: &serde_json::Value, key: &str| v.get(key) == Some(&serde_json::Value::Bool(true));
    let pick = items
        .iter()
        .position(|v| flag(v, "certifies"))
        .or_else(|| items.iter().position(|v| flag(v, "feasible")))
        .unwrap_or(0);
    let chosen = items
        .into_iter()
        .nth(pick)
        .ok_or_else(|| CliError::Input(format!("{}: an empty list of reports", path.display())))?;
    eprintln!(
        "note: {} holds several reports; using report {} (the first certified one, else the first feasible one)",
        path.display(),
        pick + 1
    );
    Ok(chosen)
}
