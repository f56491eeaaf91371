//! `qpv check`: certify externally supplied P and L_l.

use super::design::{parse_mode, parse_split};
use super::input::{emit_json, load_model, read_report, CliError};
use qpv_dsl::{AlphaSpec, GammaSpec, Mode, OutputRoute, Split, StateBound};
use qpv_solve::output_filter::OutputRouteInfo;
use qpv_solve::report::{rows_to_matrix, skew_matrices};
use std::path::Path;

/// The gains file: `P` (rows), `L` (per vertex, NX rows of NY), and
/// optionally the `alpha`, `gamma` and `mode` they were designed for (a
/// `qpv design --json` report is such a file).
#[derive(serde::Deserialize)]
struct Gains {
    #[serde(rename = "P")]
    p: Vec<Vec<f64>>,
    #[serde(rename = "L")]
    l: Vec<Vec<Vec<f64>>>,
    alpha: Option<f64>,
    gamma: Option<f64>,
    mode: Option<String>,
    /// Representation of N_k, M_k the gains were designed with
    /// ("as_written" | "symmetric"; a design report carries it).
    split: Option<String>,
    /// The state bound the design used (a design report carries it); its Q
    /// is needed to check a model with `state_bound auto`.
    state_bound: Option<GainsBound>,
    /// The output route the design used (a design report carries it): a
    /// filter-route design is checked against the augmented plant.
    output_route: Option<OutputRouteInfo>,
    /// `split = skew_slack`: the skew-symmetric slack K_{k,l} the gains were
    /// certified with (a design report carries it).
    skew: Option<Vec<Vec<Vec<Vec<f64>>>>>,
}

/// The part of a design report's `state_bound` entry `qpv check` uses.
#[derive(serde::Deserialize)]
struct GainsBound {
    #[serde(rename = "Q")]
    q: Option<Vec<Vec<f64>>>,
}

fn rectangular(rows: &[Vec<f64>]) -> bool {
    rows.iter()
        .all(|r| r.len() == rows.first().map_or(0, Vec::len))
}

/// Runs `qpv check`.
pub fn run(
    file: &Path,
    gains: &Path,
    model_name: Option<&str>,
    mode: Option<&str>,
    alpha: Option<f64>,
    gamma: Option<f64>,
    json: Option<&str>,
) -> Result<i32, CliError> {
    let (_, model) = load_model(file, model_name)?;
    let g: Gains = serde_json::from_value(read_report(gains)?)
        .map_err(|e| CliError::Input(format!("{}: {e}", gains.display())))?;
    if !rectangular(&g.p) || g.l.iter().any(|l| !rectangular(l)) {
        return Err(CliError::Input(format!(
            "{}: P and every L_l must have rows of equal length",
            gains.display()
        )));
    }
    let first = model.designs.first();
    let mode = match mode.or(g.mode.as_deref()) {
        Some(m) => parse_mode(m)?,
        None => first.map_or(Mode::Sound, |d| d.mode),
    };
    let alpha = alpha
        .or(g.alpha)
        .or(first.and_then(|d| match d.alpha {
            AlphaSpec::Fixed(a) => Some(a),
            AlphaSpec::Max => None,
        }))
        .ok_or_else(|| CliError::Input("no alpha to check: pass --alpha".into()))?;
    let gamma = gamma
        .or(g.gamma)
        .or(first.and_then(|d| match d.gamma {
            GammaSpec::Fixed(g) => Some(g),
            GammaSpec::Search => None,
        }))
        .ok_or_else(|| CliError::Input("no gamma to check: pass --gamma".into()))?;
    // The same plant either way; the conditions are checked in the
    // representation the gains were designed with (default: the mode's).
    let split = match g.split.as_deref() {
        Some(name) => parse_split(name)
            .map_err(|_| CliError::Input(format!("{}: unknown split {name:?}", gains.display())))?,
        None => Split::default_for(mode),
    };
    let mut poly = model.polytopic().with_split(split);
    if let StateBound::Auto { .. } = poly.state_bound {
        // the Q the design computed; without it (S4) cannot be checked
        match g.state_bound.and_then(|b| b.q) {
            Some(q) if q.len() == model.nx() && q.iter().all(|r| r.len() == model.nx()) => {
                poly.state_bound = StateBound::Given(rows_to_matrix(&q));
            }
            _ => {
                return Err(CliError::Input(format!(
                    "{}: the model has `state_bound auto`, so the gains file must carry the \
                     design's state bound (`state_bound.Q`, {n}×{n}; a `qpv design --json` report does)",
                    gains.display(),
                    n = model.nx()
                )))
            }
        }
    }
    if let Some(OutputRoute::Filter(f)) = g.output_route.as_ref().map(|r| r.output_route()) {
        poly = qpv_solve::output_filter::augment(&poly, &f)
            .map_err(|e| CliError::Input(format!("{}: output filter: {e}", gains.display())))?;
        eprintln!(
            "output filter route (pole {}, gain {}): checking against the augmented plant ({})",
            f.pole,
            f.gain,
            poly.states.join(", ")
        );
    }
    if let Some(k) = &g.skew {
        let k = skew_matrices(k);
        let fits = k.len() == poly.nv()
            && k.iter().all(|kl| {
                kl.len() == poly.nx()
                    && kl.iter().all(|kk| {
                        kk.shape() == (poly.nx(), poly.nx())
                            && (kk + kk.transpose()).amax() <= 1e-12 * (1.0 + kk.amax())
                    })
            });
        if !fits {
            return Err(CliError::Input(format!(
                "{}: `skew` must hold one skew-symmetric {n}×{n} matrix per state and θ-vertex",
                gains.display(),
                n = poly.nx()
            )));
        }
        poly = qpv_solve::skew_slack::with_skew(&poly, &k);
        eprintln!("skew-symmetric slack K_k (from the gains file) added to N_k: the same plant");
    }
    let p = rows_to_matrix(&g.p);
    let l: Vec<_> = g.l.iter().map(|r| rows_to_matrix(r)).collect();
    let cert = qpv_solve::check(&poly, mode, alpha, gamma, &p, &l);
    let mut s = format!(
        "check of {} against {} mode at alpha = {alpha}, gamma = {gamma}:\n",
        gains.display(),
        match mode {
            Mode::Sound => "sound",
            Mode::Paper => "paper (reproduction: certifies nothing)",
        }
    );
    for e in &cert.input_errors {
        s.push_str(&format!("  input error: {e}\n"));
    }
    for f in &cert.families {
        s.push_str(&format!(
            "  {:<6} worst margin {:>12.4e} at {:<16} over {:>6} conditions: {}\n",
            f.name,
            f.margin,
            f.worst_at,
            f.count,
            if f.passed { "pass" } else { "FAIL" }
        ));
    }
    for (k, c) in &cert.data_checks {
        s.push_str(&format!(
            "  {k:<6} value {:.4} <= {}: {}{}  ({})\n",
            c.value,
            c.bound,
            if c.passed { "pass" } else { "FAIL" },
            if c.required { "" } else { " (not required)" },
            c.description
        ));
    }
    s.push_str(if cert.passed {
        "  => all conditions hold\n"
    } else {
        "  => NOT certified\n"
    });
    if json == Some("-") {
        eprint!("{s}");
    } else {
        print!("{s}");
    }
    emit_json(json, &cert)?;
    Ok(if cert.passed { 0 } else { 1 })
}
