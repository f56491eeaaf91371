//! `qpv vertices`: the derived polytopic model, as text and as JSON.

use super::input::{check_json_target, emit_json, fmt_matrix, load_model, print_text, CliError};
use super::schema::{count_warning, VerticesOutput};
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;
use std::path::PathBuf;

/// The options of `qpv vertices`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The model file (.qpv).
    pub file: PathBuf,
    /// Which model of the file.
    #[arg(long, value_name = "NAME")]
    pub model: Option<String>,
    /// Write the JSON to this file (`-` for stdout).
    #[arg(long, value_name = "OUT")]
    pub json: Option<String>,
}

/// Runs `qpv vertices`.
pub fn run(o: &Options) -> Result<i32, CliError> {
    let json = o.json.as_deref();
    check_json_target(json, &[&o.file])?;
    let (_, m) = load_model(&o.file, o.model.as_deref())?;
    // nonlinear terms bounded on S: expanded at the γ a searching design uses
    let poly = m.polytopic();
    let poly = qpv_solve::model::jacobian::expand(poly.clone(), None).unwrap_or(poly);
    emit_json(json, &VerticesOutput::new(&poly))?;
    print_text(json, &describe_vertices(&poly));
    Ok(0)
}

/// The parameters computed from a measured output: where each comes
/// from, its interval, the output's range over F, and the terms rewritten
/// onto it.
fn push_measured(s: &mut String, p: &PolytopicModel) {
    let q = match &p.state_bound {
        qpv_dsl::StateBound::Given(q) => Some(q.as_slice()),
        _ => None,
    };
    for par in &p.params {
        if let Some(m) = &par.measured {
            s.push_str(&format!("{}\n", m.describe(&par.name, par.lo, par.hi, q)));
        }
    }
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
        .chain(p.derived.iter().map(|d| d.name.as_str()))
        .collect();
    s.push_str(&format!(
        "vertex order: corners of ({}), first most significant, lo before hi\n",
        sched.join(", ")
    ));
    push_measured(&mut s, p);
    push_jacobian(&mut s, p);
    if let Some(c) = &p.cover {
        s.push_str(&format!(
            "vertices: {} piece(s) x 2^{} = {} ({} parameter(s) and {} derived scheduling \
             variable(s) per piece)\n",
            c.len(),
            p.scheduling.len() + p.derived.len(),
            p.nv(),
            p.scheduling.len(),
            p.derived.len()
        ));
    } else if !p.derived.is_empty() {
        s.push_str(&format!(
            "vertices: 2^{} = {} ({} parameter(s) and {} derived scheduling variable(s))\n",
            p.scheduling.len() + p.derived.len(),
            p.nv(),
            p.scheduling.len(),
            p.derived.len()
        ));
    }
    if !p.derived.is_empty() {
        s.push_str("derived scheduling variables (functions of the parameters that are not multi-affine):\n");
        for d in &p.derived {
            s.push_str(&format!(
                "  {} = {}\n    range [{}, {}] (sampled on Θ: [{}, {}])\n    obtained by {}\n    used in {}\n",
                d.name,
                d.text,
                d.lo,
                d.hi,
                d.range.sampled_lo,
                d.range.sampled_hi,
                d.range.method,
                d.used_in.join(", ")
            ));
        }
    }
    if let Some(c) = &p.cover {
        push_cover(&mut s, p, c);
    }
    if let Some(w) = count_warning(p) {
        s.push_str(&format!("warning: {w}\n"));
    }
    let varies = p.output_varies();
    for (l, v) in p.vertices.iter().enumerate() {
        let corner: Vec<String> = p
            .corner(l)
            .iter()
            .map(|(n, x)| format!("{n} = {x}"))
            .collect();
        let piece = if p.cover.is_some() {
            format!(" of piece {}", p.piece_of(l) + 1)
        } else {
            String::new()
        };
        s.push_str(&format!(
            "\nvertex {} ({}){piece}:\n  A:\n{}",
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
    s.push_str(&region_head(p));
    for (i, v) in p.region.vertices.iter().enumerate() {
        s.push_str(&format!("  x_({}) = {:?}\n", i + 1, v.as_slice()));
    }
    for (k, a) in p.region.facets.iter().enumerate() {
        s.push_str(&format!("  a_{} = {:?}\n", k + 1, a.as_slice()));
    }
    s
}

/// The region's heading: its vertex and facet counts, or that there is
/// none, and whether a sound design uses it (an LPV plant's is the global
/// observer, which has no region).
/// The nonlinear terms of unmeasured states, their Jacobian box and the
/// vertex dimensions it adds (nothing without such terms).
fn push_jacobian(s: &mut String, p: &PolytopicModel) {
    let Some(j) = &p.jacobian else { return };
    s.push_str(
        "nonlinear terms of unmeasured states (kept as written, bounded through their Jacobian):\n",
    );
    for t in &j.terms {
        s.push_str(&format!("  der {}: {}\n", p.states[t.row], t.text));
    }
    match &j.bound {
        Some(b) => {
            s.push_str(&format!("  Jacobian bounded on {}\n", b.set));
            for e in &b.entries {
                s.push_str(&format!("    {} in [{}, {}]\n", e.name, e.lo, e.hi));
            }
            s.push_str(&format!(
                "  {} robust vertex dimension(s), after the θ-corners (one gain per θ-vertex): x 2^{} = {} vertices\n",
                b.dims.len(),
                b.dims.len(),
                p.nv()
            ));
        }
        None => s.push_str(
            "  no bound yet: the set S needs a region and a given state bound (`state_bound Q = [...]`)\n",
        ),
    }
}

fn region_head(p: &PolytopicModel) -> String {
    let global = "LPV plant (every N_k and M_k is zero): a sound design is the global observer, \
                  certified for every initial error (docs/method.md §17)";
    match (p.region.vertices.is_empty(), p.is_lpv()) {
        (true, true) => format!("\nregion: none; {global}\n"),
        (true, false) => "\nregion: none\n".to_string(),
        (false, lpv) => format!(
            "\nregion: {} vertices, {} facets (a_k^T x <= 1){}\n",
            p.region.vertices.len(),
            p.region.facets.len(),
            if lpv {
                format!("; not used by a sound design: {global}")
            } else {
                String::new()
            }
        ),
    }
}

/// The cover: the parameters cut, their breakpoints, and for every piece
/// its vertices and the ranges of the derived variables on it.
fn push_cover(s: &mut String, p: &PolytopicModel, c: &qpv_dsl::Cover) {
    let per = p.nv() / c.len().max(1);
    let axes: Vec<String> = c
        .axes
        .iter()
        .map(|a| {
            let b: Vec<String> = a.breaks.iter().map(|x| x.to_string()).collect();
            format!(
                "{} into {} (breakpoints {})",
                a.name,
                a.breaks.len() - 1,
                b.join(", ")
            )
        })
        .collect();
    s.push_str(&format!(
        "cover: {}; each piece has its own box of ({}); a breakpoint belongs to the piece above it\n",
        axes.join("; "),
        p.scheduling
            .iter()
            .map(|&i| p.params[i].name.as_str())
            .chain(p.derived.iter().map(|d| d.name.as_str()))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    for (k, piece) in c.pieces.iter().enumerate() {
        s.push_str(&format!(
            "  piece {} ({}): vertices {} to {}\n",
            k + 1,
            c.label(k),
            k * per + 1,
            (k + 1) * per
        ));
        for ((d, &(lo, hi)), info) in p.derived.iter().zip(&piece.phi).zip(&piece.range) {
            s.push_str(&format!(
                "    {} in [{lo}, {hi}] (sampled: [{}, {}])\n",
                d.name, info.sampled_lo, info.sampled_hi
            ));
        }
    }
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
