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
use super::input::{read_bounded, CliError, JSON_LIMIT};
use super::schema::SCHEMA;
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
    /// `max_gain = G`: the bound on every ‖L_l‖₂ the design claims, checked
    /// from `L` (a required data check of the re-check).
    pub max_gain: Option<f64>,
    /// `sample = h`: the sample period the design is certified at (a
    /// report's `sample` key); checked on the discrete decrease S5d.
    pub sample: Option<qpv_solve::sampling::SampleInfo>,
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

/// What picking a design of a report needs to know of each: its verdict
/// (only to choose; never trusted for a claim).
#[derive(serde::Deserialize)]
struct Verdict {
    certifies: Option<serde_json::Value>,
    feasible: Option<serde_json::Value>,
}

/// The envelope of a JSON object, read without its matrices (skipped, not
/// built: a 60 MiB report must not become gigabytes of JSON values).
#[derive(serde::Deserialize)]
struct Head {
    schema: Option<serde_json::Value>,
    command: Option<serde_json::Value>,
    designs: Option<serde::de::IgnoredAny>,
    #[serde(rename = "P")]
    p: Option<serde::de::IgnoredAny>,
    #[serde(rename = "L")]
    l: Option<serde::de::IgnoredAny>,
}

/// `{"designs": [...]}` of a versioned report: only the verdicts.
#[derive(serde::Deserialize)]
struct Verdicts {
    designs: Vec<Verdict>,
}

/// Deserialises element `n` of a JSON array as [`Gains`], skipping the
/// others without building them; `None` if the array is shorter.
struct Nth(usize);

impl<'de> serde::de::DeserializeSeed<'de> for Nth {
    type Value = Option<Gains>;
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> serde::de::Visitor<'de> for Nth {
    type Value = Option<Gains>;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("an array of design reports")
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut out = None;
        let mut i = 0;
        loop {
            if i == self.0 {
                match seq.next_element::<Gains>()? {
                    Some(g) => out = Some(g),
                    None => break,
                }
            } else if seq.next_element::<serde::de::IgnoredAny>()?.is_none() {
                break;
            }
            i += 1;
        }
        Ok(out)
    }
}

/// Deserialises design `n` of the `designs` key of a report object.
struct DesignsNth(usize);

impl<'de> serde::de::DeserializeSeed<'de> for DesignsNth {
    type Value = Option<Gains>;
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> serde::de::Visitor<'de> for DesignsNth {
    type Value = Option<Gains>;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a design report document")
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut out = None;
        while let Some(key) = map.next_key::<String>()? {
            if key == "designs" {
                out = map.next_value_seed(Nth(self.0))?;
            } else {
                map.next_value::<serde::de::IgnoredAny>()?;
            }
        }
        Ok(out)
    }
}

/// Of several designs the first certified one (else the first feasible
/// one, else the first), and stderr says which.
fn pick(verdicts: &[Verdict], path: &Path) -> usize {
    let yes = |v: &Option<serde_json::Value>| v == &Some(serde_json::Value::Bool(true));
    let i = verdicts
        .iter()
        .position(|v| yes(&v.certifies))
        .or_else(|| verdicts.iter().position(|v| yes(&v.feasible)))
        .unwrap_or(0);
    if verdicts.len() > 1 {
        eprintln!(
            "note: {} holds several reports; using report {} (the first certified one, else the first feasible one)",
            path.display(),
            i + 1
        );
    }
    i
}

/// Reads the gains file or report at `path`, in any of its forms:
///
/// * a `qpv design --json` document (`"schema": "qpv/1"`, `designs`);
/// * the unversioned forms older versions wrote: one report object, or an
///   array of reports for several requests;
/// * a plain gains object written by hand (`P`, `L`, ...).
///
/// Of several designs the first certified one is used (else the first
/// feasible one, else the first), and stderr says which. The file is read
/// bounded ([`JSON_LIMIT`]) and parsed straight into [`Gains`], the other
/// designs and keys skipped; errors name the file and what was expected.
pub fn read_gains(path: &Path) -> Result<Gains, CliError> {
    let bad = |m: String| CliError::Input(format!("{}: {m}", path.display()));
    let json = |e: serde_json::Error| bad(e.to_string());
    let text = read_bounded(path, JSON_LIMIT, "JSON files")?;
    let none = || bad("the report holds no design".to_string());
    let g: Gains = match text.trim_start().chars().next() {
        Some('[') => {
            let verdicts: Vec<Verdict> = serde_json::from_str(&text).map_err(json)?;
            let i = pick(&verdicts, path);
            let mut de = serde_json::Deserializer::from_str(&text);
            serde::de::DeserializeSeed::deserialize(Nth(i), &mut de)
                .map_err(json)?
                .ok_or_else(none)?
        }
        Some('{') => {
            let head: Head = serde_json::from_str(&text).map_err(json)?;
            match &head.schema {
                Some(serde_json::Value::String(v)) if v == SCHEMA => {
                    match head.command.as_ref().and_then(|c| c.as_str()) {
                        Some("design") => {}
                        Some(other) => {
                            return Err(bad(format!(
                                "a `qpv {other}` document holds no gains; give a `qpv design --json` report"
                            )))
                        }
                        None => return Err(bad("`command` is missing".into())),
                    }
                    let verdicts: Verdicts = serde_json::from_str(&text).map_err(|e| {
                        bad(format!(
                            "`designs` must be an array of design reports ({e})"
                        ))
                    })?;
                    let i = pick(&verdicts.designs, path);
                    let mut de = serde_json::Deserializer::from_str(&text);
                    serde::de::DeserializeSeed::deserialize(DesignsNth(i), &mut de)
                        .map_err(|e| bad(format!("design {}: {e}", i + 1)))?
                        .ok_or_else(none)?
                }
                Some(other) => {
                    return Err(bad(format!(
                        "`schema` is {other}: this qpv reads `{SCHEMA}` (and the older reports \
                         without a `schema` key)"
                    )))
                }
                None if head.p.is_none() || head.l.is_none() => {
                    return Err(bad(format!(
                        "no {} key: a gains file holds `P` (rows) and `L` (per vertex, NX rows \
                         of NY), as a `qpv design --json` report does{}",
                        if head.p.is_none() { "`P`" } else { "`L`" },
                        if head.designs.is_some() || head.command.is_some() {
                            " (a document with `designs` needs `\"schema\": \"qpv/1\"`)"
                        } else {
                            ""
                        }
                    )))
                }
                None => serde_json::from_str(&text).map_err(json)?,
            }
        }
        _ => {
            return Err(bad(
                "expected a JSON object with the gains `P` and `L` (or a `qpv design --json` \
                 report)"
                    .into(),
            ))
        }
    };
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
        self,
        model: &str,
        (mode, alpha, gamma, split): (Mode, f64, f64, Split),
        path: &Path,
    ) -> Result<Design, CliError> {
        let conditions = self.conditions(path)?;
        let mut d = Design::claimed(model, mode, alpha, gamma, self.p, self.l);
        d.split = split;
        d.conditions = conditions;
        d.skew = self.skew;
        d.cube = self.cube;
        d.max_gain = self.max_gain;
        d.output_route = self.output_route;
        d.state_bound = self.state_bound.map(|b| StateBoundInfo {
            source: qpv_solve::vocab::BoundSource::Auto,
            q: b.q,
            h: b.h,
            h_fixed: false,
            gamma_max: None,
            gamma_upper: None,
            split: b.split,
            check: None,
            solves: 0,
            seconds: 0.0,
            notes: Vec::new(),
        });
        Ok(d)
    }
}
