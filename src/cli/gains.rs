//! The gains a report or gains file claims, read the same way by `qpv
//! check` and `qpv simulate`, and turned into the [`Design`] whose
//! [`Design::recheck`] judges them (the one re-check path of both).
//!
//! Only what a claim is made of is read: P, L_l, α, γ, the mode, the
//! model's name, the representation of N_k (split and skew slack), the
//! state bound's Q, the output route and the cube slacks. A report's own
//! margins, data checks, verdict, σ or sampling figures are never read:
//! they are recomputed from the model as it is now (docs/schema.md, "What
//! a report may claim").

use super::design::parse_split;
use super::input::CliError;
use super::schema::read_report;
use qpv_dsl::{Conditions, Mode, Split};
use qpv_solve::conditions::cube::CubeReport;
use qpv_solve::output_filter::OutputRouteInfo;
use qpv_solve::report::Design;
use qpv_solve::state_bound::StateBoundInfo;
use std::path::Path;

/// The claim of a gains file: `P` (rows), `L` (per vertex, NX rows of NY),
/// and optionally what they were designed for (a `qpv design --json`
/// report is such a file).
#[derive(serde::Deserialize)]
pub struct Gains {
    /// P (rows).
    #[serde(rename = "P")]
    pub p: Vec<Vec<f64>>,
    /// L_l (per vertex, rows).
    #[serde(rename = "L")]
    pub l: Vec<Vec<Vec<f64>>>,
    /// The decay rate claimed.
    pub alpha: Option<f64>,
    /// The region scaling claimed.
    pub gamma: Option<f64>,
    /// "sound" or "paper".
    pub mode: Option<String>,
    /// The model the gains were designed for (a design report names it).
    pub model: Option<String>,
    /// Representation of N_k, M_k the gains were designed with.
    pub split: Option<String>,
    /// The conditions the design was solved with (a report carries it).
    pub conditions: Option<String>,
    /// A report's own verdict: `false` is respected (a report may claim
    /// less than its gains achieve); `true` is never taken on trust.
    pub certifies: Option<bool>,
    /// The state bound the design used (its Q is needed to check a model
    /// with `state_bound auto`).
    pub state_bound: Option<GainsBound>,
    /// The output route the design used (a filter-route design is checked
    /// against the augmented plant).
    pub output_route: Option<OutputRouteInfo>,
    /// `split = skew_slack`: the skew-symmetric slack K_{k,l}.
    pub skew: Option<Vec<Vec<Vec<Vec<f64>>>>>,
    /// `conditions = cube`: the slacks Y, X and D.
    pub cube: Option<CubeReport>,
}

/// The part of a design report's `state_bound` entry a check uses.
#[derive(serde::Deserialize)]
pub struct GainsBound {
    /// Q (rows).
    #[serde(rename = "Q")]
    pub q: Option<Vec<Vec<f64>>>,
    /// The box size of a computed bound.
    pub h: Option<f64>,
    /// The split of N_k its invariance was certified with.
    pub split: Option<String>,
}

fn rectangular(rows: &[Vec<f64>]) -> bool {
    rows.iter()
        .all(|r| r.len() == rows.first().map_or(0, Vec::len))
}

/// Reads the gains file or report at `path` (any form [`read_report`]
/// accepts); errors name the file and what was expected.
pub fn read_gains(path: &Path) -> Result<Gains, CliError> {
    let bad = |m: String| CliError::Input(format!("{}: {m}", path.display()));
    let value = read_report(path)?;
    let Some(obj) = value.as_object() else {
        return Err(bad(
            "expected a JSON object with the gains `P` and `L` (or a `qpv design --json` report)"
                .into(),
        ));
    };
    let missing: Vec<&str> = ["P", "L"]
        .into_iter()
        .filter(|k| !obj.contains_key(*k))
        .collect();
    if !missing.is_empty() {
        return Err(bad(format!(
            "no {} key: a gains file holds `P` (rows) and `L` (per vertex, NX rows of NY), as a \
             `qpv design --json` report does{}",
            missing
                .iter()
                .map(|k| format!("`{k}`"))
                .collect::<Vec<_>>()
                .join(" or "),
            if obj.contains_key("designs") || obj.contains_key("command") {
                " (a document with `designs` needs `\"schema\": \"qpv/1\"`)"
            } else {
                ""
            }
        )));
    }
    let g: Gains = serde_json::from_value(value).map_err(|e| bad(e.to_string()))?;
    if !rectangular(&g.p) || g.l.iter().any(|l| !rectangular(l)) {
        return Err(bad("P and every L_l must have rows of equal length".into()));
    }
    if let Some(s) = g.state_bound.as_ref().and_then(|b| b.split.as_deref()) {
        if !matches!(s, "as_written" | "symmetric") {
            return Err(bad(format!(
                "`state_bound.split` is {s:?}: expected \"as_written\" or \"symmetric\" (the \
                 representation of N_k the bound's invariance was certified with)"
            )));
        }
    }
    Ok(g)
}

/// Parses a mode name (`what` says where it came from, for the error).
pub fn parse_mode_name(s: &str, what: &str) -> Result<Mode, CliError> {
    match s {
        "sound" => Ok(Mode::Sound),
        "paper" => Ok(Mode::Paper),
        _ => Err(CliError::Input(format!(
            "{what} is {s:?}: expected \"sound\" or \"paper\""
        ))),
    }
}

impl Gains {
    /// The split the gains were designed with, else the mode's default.
    pub fn split(&self, mode: Mode, path: &Path) -> Result<Split, CliError> {
        match self.split.as_deref() {
            Some(name) => parse_split(name).map_err(|_| {
                CliError::Input(format!(
                    "{}: `split` is {name:?}: expected \"as_written\", \"symmetric\" or \"skew_slack\"",
                    path.display()
                ))
            }),
            None => Ok(Split::default_for(mode)),
        }
    }

    /// The conditions the design was solved with (full when absent).
    fn conditions(&self, path: &Path) -> Result<Conditions, CliError> {
        match self.conditions.as_deref() {
            None => Ok(Conditions::Full),
            Some(name) => Conditions::ALL
                .into_iter()
                .find(|c| c.name() == name)
                .ok_or_else(|| {
                    CliError::Input(format!(
                        "{}: `conditions` is {name:?}: expected \"full\", \"decoupled\", \"cube\" \
                         or \"auto\"",
                        path.display()
                    ))
                }),
        }
    }

    /// The design whose [`Design::recheck`] judges these gains for model
    /// `model` in `mode` at (`alpha`, `gamma`) with `split`: everything the
    /// file claims about the representation (skew slack, state bound,
    /// output route, cube slacks) and nothing it says about its verdict.
    pub fn design(
        &self,
        model: &str,
        (mode, alpha, gamma, split): (Mode, f64, f64, Split),
        path: &Path,
    ) -> Result<Design, CliError> {
        let mut d = Design::claimed(model, mode, alpha, gamma, self.p.clone(), self.l.clone());
        d.split = split;
        d.conditions = self.conditions(path)?;
        d.skew = self.skew.clone();
        d.cube = self.cube.clone();
        d.output_route = self.output_route.clone();
        d.state_bound = self.state_bound.as_ref().map(|b| StateBoundInfo {
            source: qpv_solve::vocab::BoundSource::Auto,
            q: b.q.clone(),
            h: b.h,
            h_fixed: false,
            gamma_max: None,
            gamma_upper: None,
            split: b.split.clone(),
            check: None,
            solves: 0,
            seconds: 0.0,
            notes: Vec::new(),
        });
        Ok(d)
    }
}
