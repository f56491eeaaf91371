//! `qpv check`: certify externally supplied P and L_l.

use super::design::{parse_mode, parse_split};
use super::input::{emit_json, load_model, read_report, CliError};
use qpv_dsl::{AlphaSpec, GammaSpec, Mode, OutputRoute, Split, StateBound};
use qpv_solve::model::{ClaimedBound, ObserverModel, ObserverOptions, StateBoundClaim};
use qpv_solve::output_filter::OutputRouteInfo;
use qpv_solve::report::{rows_to_matrix, skew_matrices};
use qpv_solve::{Certificate, SolveError};
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

/// The part of a design report's `state_bound` entry `qpv check` uses: Q,
/// and the box size and split its invariance was checked with.
#[derive(serde::Deserialize)]
struct GainsBound {
    #[serde(rename = "Q")]
    q: Option<Vec<Vec<f64>>>,
    h: Option<f64>,
    split: Option<String>,
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
    let plant = model.polytopic();
    let n = model.nx();
    // A `state_bound auto` Q from the gains file is a claim: the builder
    // verifies it against the model as it is now.
    let claim = match g.state_bound.as_ref() {
        Some(GainsBound {
            q: Some(q),
            h,
            split,
        }) if q.len() == n && q.iter().all(|r| r.len() == n) => Some(ClaimedBound {
            q: rows_to_matrix(q),
            h: *h,
            split: split.as_deref().and_then(|s| parse_split(s).ok()),
        }),
        _ => None,
    };
    if matches!(plant.state_bound, StateBound::Auto { .. }) && claim.is_none() {
        return Err(CliError::Input(format!(
            "{}: the model has `state_bound auto`, so the gains file must carry the \
             design's state bound (`state_bound.Q`, {n}×{n}; a `qpv design --json` report does)",
            gains.display()
        )));
    }
    let route = g
        .output_route
        .as_ref()
        .map(|r| r.output_route())
        .unwrap_or_default();
    let skew = g.skew.as_ref().map(|k| skew_matrices(k));
    let options = ObserverOptions {
        output_route: &route,
        split,
        skew: skew.as_deref(),
    };
    let defaults = qpv_solve::Settings::default();
    let bound = match &claim {
        Some(c) => StateBoundClaim::Claimed(c),
        None => StateBoundClaim::Compute(&defaults),
    };
    let p = rows_to_matrix(&g.p);
    let l: Vec<_> = g.l.iter().map(|r| rows_to_matrix(r)).collect();
    let cert = match ObserverModel::prepare(&plant, &options, bound) {
        Ok(observer) => {
            if let OutputRoute::Filter(f) = &route {
                eprintln!(
                    "output filter route (pole {}, gain {}): checking against the augmented plant ({})",
                    f.pole,
                    f.gain,
                    observer.model.states.join(", ")
                );
            }
            if skew.is_some() {
                eprintln!(
                    "skew-symmetric slack K_k (from the gains file) added to N_k: the same plant"
                );
            }
            qpv_solve::check(&observer.model, mode, alpha, gamma, &p, &l)
        }
        // A refused state bound: the gains are not certified (exit 1).
        Err(e @ SolveError::StateBound(_)) => {
            Certificate::refused(mode, alpha, gamma, format!("state bound: {e}"))
        }
        Err(e) => return Err(CliError::Input(format!("{}: {e}", gains.display()))),
    };
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
