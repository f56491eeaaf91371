//! A report or gains file read as the [`Design`] it claims, the same way by
//! `qpv check`, `qpv simulate` and `qpv codegen --gains`; its
//! [`Design::recheck`] judges it (the one re-check path of all three).
//!
//! The file is parsed straight into [`Design`] (serde: the keys a gains
//! file may leave out take defaults), then cut down to its claim by
//! [`Design::into_claim`]: a report's own margins, data checks, verdict, σ
//! or sampling figures are never read; they are recomputed from the model
//! as it is now (docs/schema.md, "What a report may claim"). Only a
//! verdict short of `certified` is respected (a report may claim less than
//! its gains achieve).

use super::input::{read_bounded, CliError, JSON_LIMIT};
use super::schema::SCHEMA;
use qpv_dsl::{Mode, Split};
use qpv_solve::report::Design;
use qpv_solve::vocab::Verdict;
use serde::de::{DeserializeSeed, IgnoredAny};
use serde_json::Value;
use std::marker::PhantomData;
use std::path::Path;

/// A report or gains file read: the design it claims and which of the keys
/// with defaults it states itself (a missing `mode`, `alpha`, `gamma` or
/// `split` is taken from a flag, the model or the mode).
pub struct Claim {
    /// P, L_l and the representation they were designed in
    /// ([`Design::into_claim`]); its α, γ, mode and split are the file's or
    /// their defaults until [`Claim::at`] fixes them.
    pub design: Design,
    /// The file's `mode`.
    pub mode: Option<Mode>,
    /// The file's `alpha`.
    pub alpha: Option<f64>,
    /// The file's `gamma`.
    pub gamma: Option<f64>,
    /// Whether the file names its split.
    split: bool,
    /// The file's own verdict: `false` is respected, `true` never trusted.
    pub certifies: Option<bool>,
}

impl Claim {
    /// The model the file names (a design report does), if any.
    pub fn model(&self) -> Option<&str> {
        Some(self.design.model.as_str()).filter(|m| !m.is_empty())
    }

    /// The design to re-check in `mode` at (`alpha`, `gamma`): the split
    /// the file names, else the mode's default; a sample period the file
    /// claims is checked at `alpha`.
    pub fn at(self, mode: Mode, alpha: f64, gamma: f64) -> Design {
        let mut d = self.design;
        d.mode = mode;
        d.alpha = alpha;
        d.gamma = gamma;
        if !self.split {
            d.split = Split::default_for(mode);
        }
        d.sample = d
            .sample
            .map(|s| qpv_solve::certificate::sampling::SampleInfo::new(s.h, alpha));
        d
    }
}

/// The keys of one design a reader needs before its matrices: the verdict
/// (to choose among several designs; never trusted for a claim) and which
/// keys with defaults it states.
#[derive(serde::Deserialize)]
struct Stated {
    verdict: Option<Value>,
    certifies: Option<Value>,
    feasible: Option<Value>,
    mode: Option<Value>,
    alpha: Option<Value>,
    gamma: Option<Value>,
    split: Option<IgnoredAny>,
}

impl Stated {
    /// Whether it states whether it certifies (`verdict`, or the
    /// `certifies` of older reports).
    fn has_verdict(&self) -> bool {
        self.verdict.is_some() || self.certifies.is_some()
    }

    /// The verdict it states (not certified where it states none or an
    /// unknown one): `verdict`, else the two booleans of older reports.
    fn says(&self) -> Verdict {
        let yes = |v: &Option<Value>| v == &Some(Value::Bool(true));
        match &self.verdict {
            Some(v) => v
                .as_str()
                .and_then(Verdict::from_name)
                .unwrap_or(Verdict::NotCertified),
            None => Verdict::from_flags(yes(&self.feasible), yes(&self.certifies)),
        }
    }
}

/// The envelope of a JSON object, read without its matrices (skipped, not
/// built: a 60 MiB report must not become gigabytes of JSON values).
#[derive(serde::Deserialize)]
struct Head {
    schema: Option<Value>,
    command: Option<Value>,
    designs: Option<IgnoredAny>,
    #[serde(rename = "P")]
    p: Option<IgnoredAny>,
    #[serde(rename = "L")]
    l: Option<IgnoredAny>,
}

/// `{"designs": [...]}` of a versioned report: what each design states.
#[derive(serde::Deserialize)]
struct Designs {
    designs: Vec<Stated>,
}

/// Deserialises element `n` of a JSON array as `T`, skipping the others
/// without building them; `None` if the array is shorter.
struct Nth<T>(usize, PhantomData<T>);

impl<'de, T: serde::Deserialize<'de>> DeserializeSeed<'de> for Nth<T> {
    type Value = Option<T>;
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de, T: serde::Deserialize<'de>> serde::de::Visitor<'de> for Nth<T> {
    type Value = Option<T>;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("an array of design reports")
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut out = None;
        let mut i = 0;
        loop {
            if i == self.0 {
                match seq.next_element::<T>()? {
                    Some(g) => out = Some(g),
                    None => break,
                }
            } else if seq.next_element::<IgnoredAny>()?.is_none() {
                break;
            }
            i += 1;
        }
        Ok(out)
    }
}

/// Deserialises design `n` of the `designs` key of a report object.
struct DesignsNth(usize);

impl<'de> DeserializeSeed<'de> for DesignsNth {
    type Value = Option<Design>;
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> serde::de::Visitor<'de> for DesignsNth {
    type Value = Option<Design>;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a design report document")
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut out = None;
        while let Some(key) = map.next_key::<String>()? {
            if key == "designs" {
                out = map.next_value_seed(Nth(self.0, PhantomData))?;
            } else {
                map.next_value::<IgnoredAny>()?;
            }
        }
        Ok(out)
    }
}

/// Of several designs the first certified one (else the first feasible
/// one, else the first), and stderr says which.
fn pick(stated: &[Stated], path: &Path) -> Result<usize, CliError> {
    if stated.is_empty() {
        return Err(CliError::Input(format!(
            "{}: the report holds no design (an empty list): nothing to check",
            path.display()
        )));
    }
    let i = stated
        .iter()
        .position(|v| v.says().certifies())
        .or_else(|| stated.iter().position(|v| v.says().feasible()))
        .unwrap_or(0);
    if stated.len() > 1 {
        eprintln!(
            "note: {} holds several reports; using report {} (the first certified one, else the first feasible one)",
            path.display(),
            i + 1
        );
    }
    Ok(i)
}

fn rectangular(rows: &[Vec<f64>]) -> bool {
    rows.iter()
        .all(|r| r.len() == rows.first().map_or(0, Vec::len))
}

/// Reads the report or gains file at `path` (`what` names it in messages:
/// "gains file", "report"), in any of its forms:
///
/// * a `qpv design --json` document (`"schema": "qpv/1"`, `designs`);
/// * the unversioned forms older versions wrote: one report object, or an
///   array of reports for several requests;
/// * a plain gains object written by hand (`P`, `L`, optionally `alpha`,
///   `gamma`, `mode` and the other keys of a report).
///
/// Of several designs the first certified one is used (else the first
/// feasible one, else the first), and stderr says which. The file is read
/// bounded ([`JSON_LIMIT`]) and only the chosen design is built; errors
/// name the file and what was expected.
pub fn read_claim(path: &Path, what: &str) -> Result<Claim, CliError> {
    let bad = |m: String| CliError::Input(format!("{}: {m}", path.display()));
    let json = |e: serde_json::Error| bad(e.to_string());
    let text = read_bounded(path, JSON_LIMIT, "JSON files")?;
    let none = || bad("the report holds no design".to_string());
    let (stated, design): (Stated, Design) = match text.trim_start().chars().next() {
        Some('[') => {
            let mut all: Vec<Stated> = serde_json::from_str(&text).map_err(json)?;
            let i = pick(&all, path)?;
            check_mode(&all[i], path, what)?;
            let mut de = serde_json::Deserializer::from_str(&text);
            let d = Nth(i, PhantomData)
                .deserialize(&mut de)
                .map_err(json)?
                .ok_or_else(none)?;
            (all.swap_remove(i), d)
        }
        Some('{') => {
            let head: Head = serde_json::from_str(&text).map_err(json)?;
            match &head.schema {
                Some(Value::String(v)) if v == SCHEMA => {
                    match head.command.as_ref().and_then(|c| c.as_str()) {
                        Some("design") => {}
                        Some(other) => {
                            return Err(bad(format!(
                                "a `qpv {other}` document holds no gains; give a `qpv design --json` report"
                            )))
                        }
                        None => return Err(bad("`command` is missing".into())),
                    }
                    let mut all: Designs = serde_json::from_str(&text).map_err(|e| {
                        bad(format!(
                            "`designs` must be an array of design reports ({e})"
                        ))
                    })?;
                    let i = pick(&all.designs, path)?;
                    check_mode(&all.designs[i], path, what)?;
                    let mut de = serde_json::Deserializer::from_str(&text);
                    let d = DesignsNth(i)
                        .deserialize(&mut de)
                        .map_err(|e| bad(format!("design {}: {e}", i + 1)))?
                        .ok_or_else(none)?;
                    (all.designs.swap_remove(i), d)
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
                None => {
                    let stated: Stated = serde_json::from_str(&text).map_err(json)?;
                    check_mode(&stated, path, what)?;
                    (stated, serde_json::from_str(&text).map_err(json)?)
                }
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
    let mode = check_mode(&stated, path, what)?;
    if !rectangular(&design.p) || design.l.iter().any(|l| !rectangular(l)) {
        return Err(bad("P and every L_l must have rows of equal length".into()));
    }
    Ok(Claim {
        mode,
        alpha: stated.alpha.is_some().then_some(design.alpha),
        gamma: stated.gamma.is_some().then_some(design.gamma),
        split: stated.split.is_some(),
        certifies: stated.has_verdict().then_some(design.certifies()),
        design: design.into_claim(),
    })
}

/// The file's `mode`, if it states one: a mode name, else an error saying
/// which names there are.
fn check_mode(stated: &Stated, path: &Path, what: &str) -> Result<Option<Mode>, CliError> {
    let Some(v) = &stated.mode else {
        return Ok(None);
    };
    let name = v.as_str();
    Mode::ALL
        .into_iter()
        .find(|m| Some(m.name()) == name)
        .map(Some)
        .ok_or_else(|| {
            CliError::Input(format!(
                "{}: the {what}'s `mode` is {v}: expected {}",
                path.display(),
                super::input::one_of(Mode::ALL.map(Mode::name), "\"")
            ))
        })
}
