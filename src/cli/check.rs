//! `qpv check`: certify externally supplied P and L_l.
//!
//! Exit 0 means certified: sound mode, every condition family and every
//! required data check holds. The mode comes from `--mode` or the gains
//! file's `mode` key and is sound otherwise, never from the model's
//! `design` blocks; a paper-mode check whose conditions hold exits 3
//! (a reproduction, not a certificate).

use super::design::parse_split;
use super::input::{emit_json, exit, load_model_for, print_text, CliError};
use super::schema::read_report;
use super::schema::CheckOutput;
use qpv_dsl::{AlphaSpec, GammaSpec, Mode, Model, OutputRoute, PolytopicModel, Split, StateBound};
use qpv_solve::model::{ClaimedBound, ObserverModel, ObserverOptions, StateBoundClaim};
use qpv_solve::output_filter::OutputRouteInfo;
use qpv_solve::report::{rows_to_matrix, skew_matrices};
use qpv_solve::{Certificate, SolveError};
use std::path::Path;

/// The gains file: `P` (rows), `L` (per vertex, NX rows of NY), and
/// optionally the `alpha`, `gamma` and `mode` they were designed for (a
/// `qpv design --json` report is such a file).
#[derive(serde::Deserialize)]
pub(super) struct Gains {
    #[serde(rename = "P")]
    pub(super) p: Vec<Vec<f64>>,
    #[serde(rename = "L")]
    pub(super) l: Vec<Vec<Vec<f64>>>,
    pub(super) alpha: Option<f64>,
    pub(super) gamma: Option<f64>,
    pub(super) mode: Option<String>,
    /// The model the gains were designed for (a design report names it);
    /// the model checked, unless `--model` disagrees (an error).
    pub(super) model: Option<String>,
    /// Representation of N_k, M_k the gains were designed with
    /// ("as_written" | "symmetric"; a design report carries it).
    pub(super) split: Option<String>,
    /// The state bound the design used (a design report carries it); its Q
    /// is needed to check a model with `state_bound auto`.
    state_bound: Option<GainsBound>,
    /// The output route the design used (a design report carries it): a
    /// filter-route design is checked against the augmented plant.
    pub(super) output_route: Option<OutputRouteInfo>,
    /// `split = skew_slack`: the skew-symmetric slack K_{k,l} the gains were
    /// certified with (a design report carries it).
    skew: Option<Vec<Vec<Vec<Vec<f64>>>>>,
}

/// The part of a design report's `state_bound` entry `qpv check` uses.
#[derive(serde::Deserialize)]
struct GainsBound {
    #[serde(rename = "Q")]
    q: Option<Vec<Vec<f64>>>,
    h: Option<f64>,
    split: Option<String>,
}

/// The flags of `qpv check` (each `None` when not given).
#[derive(Debug, Clone, Copy, Default)]
pub struct Flags<'a> {
    /// `--mode`.
    pub mode: Option<&'a str>,
    /// `--alpha`.
    pub alpha: Option<f64>,
    /// `--gamma`.
    pub gamma: Option<f64>,
}

fn rectangular(rows: &[Vec<f64>]) -> bool {
    rows.iter()
        .all(|r| r.len() == rows.first().map_or(0, Vec::len))
}

/// Reads the gains file (any report form [`read_report`] accepts).
pub(super) fn read_gains(path: &Path) -> Result<Gains, CliError> {
    let g: Gains = serde_json::from_value(read_report(path)?)
        .map_err(|e| CliError::Input(format!("{}: {e}", path.display())))?;
    if !rectangular(&g.p) || g.l.iter().any(|l| !rectangular(l)) {
        return Err(CliError::Input(format!(
            "{}: P and every L_l must have rows of equal length",
            path.display()
        )));
    }
    Ok(g)
}

/// The mode to check and where it came from: `--mode`, else the gains
/// file's `mode`, else sound.
fn choose_mode(
    flag: Option<&str>,
    g: &Gains,
    path: &Path,
) -> Result<(Mode, &'static str), CliError> {
    let parse = |s: &str| match s {
        "sound" => Some(Mode::Sound),
        "paper" => Some(Mode::Paper),
        _ => None,
    };
    if let Some(m) = flag {
        return parse(m)
            .map(|m| (m, "--mode"))
            .ok_or_else(|| CliError::Input(format!("--mode {m:?}: expected `sound` or `paper`")));
    }
    match g.mode.as_deref() {
        Some(m) => parse(m).map(|m| (m, "gains file")).ok_or_else(|| {
            CliError::Input(format!(
                "{}: the gains file's `mode` is {m:?}: expected \"sound\" or \"paper\"",
                path.display()
            ))
        }),
        None => Ok((Mode::Sound, "default")),
    }
}

/// A value of α or γ to check and where it came from: the flag, else the
/// gains file, else the first of the model's `design` blocks of the checked
/// mode that fixes it. `valid` says whether a number is acceptable and
/// `expected` what is.
fn choose_value(
    name: &str,
    flag: Option<f64>,
    from_gains: Option<f64>,
    from_model: Option<(f64, usize)>,
    path: &Path,
    (valid, expected): (fn(f64) -> bool, &str),
) -> Result<(f64, String), CliError> {
    if let Some(v) = flag {
        return if valid(v) {
            Ok((v, format!("--{name}")))
        } else {
            Err(CliError::Input(format!(
                "--{name} {v}: expected {expected}"
            )))
        };
    }
    if let Some(v) = from_gains {
        return if valid(v) {
            Ok((v, "gains file".into()))
        } else {
            Err(CliError::Input(format!(
                "{}: the gains file's `{name}` is {v}: expected {expected}",
                path.display()
            )))
        };
    }
    from_model
        .map(|(v, block)| (v, format!("the model's design block {block}")))
        .ok_or_else(|| CliError::Input(format!("no {name} to check: pass --{name}")))
}

fn positive(a: f64) -> bool {
    a.is_finite() && a > 0.0
}

fn unit_interval(g: f64) -> bool {
    g > 0.0 && g < 1.0
}

/// The model the gains belong to, built by the same builder the design
/// uses ([`ObserverModel::prepare`]): the split, the state bound, the output
/// route (the filter augmentation) and the skew slack. An auto state
/// bound's Q from the gains file is a claim the builder verifies against the
/// model as it is now; a refused claim is `Ok(Err(reason))`: the gains are
/// then not certified (exit 1), which is not an input error.
pub(super) fn observer_model(
    model: &Model,
    split: Split,
    g: &Gains,
    gains: &Path,
) -> Result<Result<PolytopicModel, String>, CliError> {
    let plant = model.polytopic();
    let n = model.nx();
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
    match ObserverModel::prepare(&plant, &options, bound) {
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
            Ok(Ok(observer.model))
        }
        Err(e @ SolveError::StateBound(_)) => Ok(Err(format!("state bound: {e}"))),
        Err(e) => Err(CliError::Input(format!("{}: {e}", gains.display()))),
    }
}

/// The first of the model's `design` blocks in `mode` that fixes the value
/// `pick` reads, with its 1-based number.
fn from_blocks(
    model: &Model,
    mode: Mode,
    pick: impl Fn(&qpv_dsl::DesignRequest) -> Option<f64>,
) -> Option<(f64, usize)> {
    model
        .designs
        .iter()
        .enumerate()
        .filter(|(_, d)| d.mode == mode)
        .find_map(|(i, d)| pick(d).map(|v| (v, i + 1)))
}

/// Runs `qpv check`.
pub fn run(
    file: &Path,
    gains: &Path,
    model_name: Option<&str>,
    flags: Flags,
    json: Option<&str>,
) -> Result<i32, CliError> {
    let g = read_gains(gains)?;
    let (_, model) = load_model_for(file, model_name, gains, g.model.as_deref())?;
    let (mode, mode_source) = choose_mode(flags.mode, &g, gains)?;
    let (alpha, alpha_source) = choose_value(
        "alpha",
        flags.alpha,
        g.alpha,
        from_blocks(&model, mode, |d| match d.alpha {
            AlphaSpec::Fixed(a) => Some(a),
            AlphaSpec::Max => None,
        }),
        gains,
        (positive, "a positive finite number"),
    )?;
    let (gamma, gamma_source) = choose_value(
        "gamma",
        flags.gamma,
        g.gamma,
        from_blocks(&model, mode, |d| match d.gamma {
            GammaSpec::Fixed(g) => Some(g),
            GammaSpec::Search => None,
        }),
        gains,
        (unit_interval, "a number in (0, 1)"),
    )?;
    // The same plant either way; the conditions are checked in the
    // representation the gains were designed with (default: the mode's).
    let split = match g.split.as_deref() {
        Some(name) => parse_split(name)
            .map_err(|_| CliError::Input(format!("{}: unknown split {name:?}", gains.display())))?,
        None => Split::default_for(mode),
    };
    let p = rows_to_matrix(&g.p);
    let l: Vec<_> = g.l.iter().map(|r| rows_to_matrix(r)).collect();
    let cert = match observer_model(&model, split, &g, gains)? {
        Ok(poly) => qpv_solve::check(&poly, mode, alpha, gamma, &p, &l),
        Err(reason) => Certificate::refused(mode, alpha, gamma, reason),
    };
    let code = match (cert.passed, mode) {
        (true, Mode::Sound) => exit::CERTIFIED,
        (true, Mode::Paper) => exit::REPRODUCTION,
        (false, _) => exit::NOT_CERTIFIED,
    };
    let mut s = format!(
        "check of {} against {} mode ({}) at alpha = {alpha} ({alpha_source}), gamma = {gamma} ({gamma_source}):\n",
        gains.display(),
        match mode {
            Mode::Sound => "sound",
            Mode::Paper => "paper (reproduction: certifies nothing)",
        },
        match mode_source {
            "default" => "the default; --mode paper checks a reproduction",
            "--mode" => "from --mode",
            _ => "from the gains file's `mode`",
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
    s.push_str(match code {
        exit::CERTIFIED => "  => certified: all conditions hold (sound mode)\n",
        exit::REPRODUCTION => {
            "  => reproduction: the paper's printed conditions hold; this is not a certificate \
             (exit code 3; check in sound mode to certify)\n"
        }
        _ => "  => NOT certified\n",
    });
    // Every family holding but no verdict: say which assumption is missing.
    let families_hold = cert.input_errors.is_empty() && cert.families.iter().all(|f| f.passed);
    if code == exit::NOT_CERTIFIED && families_hold && mode == Mode::Sound {
        let s4 = qpv_solve::vocab::Family::S4.name();
        match cert.data_checks.get(s4) {
            None => s.push_str(
                "     why: every condition family holds, but the model has no state bound F \
                 (`state_bound Q = [..];` or `state_bound auto;`), so (S4) and Assumption 2 \
                 (the plant state stays in F) cannot be checked: without F nothing is certified\n",
            ),
            Some(c) if c.required && !c.passed => s.push_str(&format!(
                "     why: every condition family holds, but the data check (S4) fails: \
                 γ² a_kᵀ Q a_k = {:.4} > 1 (γ above γ_max: F does not lie in P/γ)\n",
                c.value
            )),
            _ => {}
        }
    }
    print_text(json, &s);
    emit_json(
        json,
        &CheckOutput::new(&model.name, gains, mode_source, split, &cert, code),
    )?;
    Ok(code)
}
