//! The one JSON schema of every command's `--json` output (docs/schema.md
//! documents every key); reading the gains of a report in it and in the
//! older unversioned forms is `cli::gains`.
//!
//! Every document is an object with the same envelope: `schema` (the
//! version, [`SCHEMA`]), `command` (`design`, `check` or `vertices`) and
//! `model` (the model's name), then the command's keys. Matrices are arrays
//! of rows everywhere; the same thing has the same key in every command
//! (`margins` is family → worst margin, `verdict` means the
//! same for `design` and `check`).

use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, OutputRoute, PolytopicModel};
use qpv_dsl::{Region, StateBound};
use qpv_solve::report::{matrix_to_rows, DataCheck, Design};
use qpv_solve::vocab::{Family, Verdict};
use qpv_solve::Certificate;
use serde::Serialize;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// The schema version every document carries in its `schema` key.
pub const SCHEMA: &str = "qpv/1";

/// `qpv design --json`: one entry in `designs` per request that produced a
/// design (the report of [`Design`], keys as qpv-solve writes them), and
/// the requests that did not.
#[derive(Serialize)]
pub struct DesignOutput<'a> {
    /// [`SCHEMA`].
    pub schema: &'static str,
    /// `"design"`.
    pub command: &'static str,
    /// The model's name.
    pub model: &'a str,
    /// One report per request run to the end, in request order (also for
    /// a single request).
    pub designs: &'a [Design],
    /// Requests not run because a flag's override does not apply to them.
    pub skipped: &'a [NotRun],
    /// Requests that ended without a design (e.g. `state_bound auto` found
    /// no invariant ellipsoid).
    pub failures: &'a [NotRun],
}

/// A design request that produced no report, and why.
#[derive(Serialize, Debug, Clone)]
pub struct NotRun {
    /// 1-based number of the request (the model's `design` block, or 1 for
    /// the request built from the flags).
    pub request: usize,
    /// The request's settings in words.
    pub settings: String,
    /// Why it did not produce a design.
    pub reason: String,
}

impl<'a> DesignOutput<'a> {
    /// The envelope around `designs`.
    pub fn new(
        model: &'a str,
        designs: &'a [Design],
        skipped: &'a [NotRun],
        failures: &'a [NotRun],
    ) -> Self {
        DesignOutput {
            schema: SCHEMA,
            command: "design",
            model,
            designs,
            skipped,
            failures,
        }
    }
}

/// One condition family of a `qpv check` (its worst margin is in `margins`).
#[derive(Serialize)]
pub struct FamilyDetail {
    /// The worst margin (positive = satisfied), as in `margins`.
    pub margin: f64,
    /// Floating-point guard: the margin must exceed it to count.
    pub guard: f64,
    /// margin > guard.
    pub passed: bool,
    /// Where the worst margin occurs (e.g. "l=2 i=5 j=1", 1-based).
    pub worst_at: String,
    /// Number of conditions in the family.
    pub count: usize,
}

/// `qpv check --json`.
#[derive(Serialize)]
pub struct CheckOutput<'a> {
    /// [`SCHEMA`].
    pub schema: &'static str,
    /// `"check"`.
    pub command: &'static str,
    /// The model's name.
    pub model: &'a str,
    /// The gains file checked.
    pub gains: String,
    /// Condition set checked ("sound" or "paper").
    pub mode: &'static str,
    /// Where the mode came from: "--mode", "gains file" or "default".
    pub mode_source: &'static str,
    /// Decay rate α checked.
    pub alpha: f64,
    /// Region scaling γ checked.
    pub gamma: f64,
    /// Representation of N_k, M_k checked.
    pub split: &'static str,
    /// `certified` (sound mode, every condition family and required data
    /// check holds), `reproduction` (paper mode, the printed conditions
    /// hold: certifies nothing) or `not_certified`.
    pub verdict: Verdict,
    /// The process exit code of this check.
    pub exit_code: i32,
    /// Family → worst margin (positive = satisfied).
    pub margins: BTreeMap<Family, f64>,
    /// Family → its guard, pass/fail, worst place and number of conditions.
    pub families: BTreeMap<String, FamilyDetail>,
    /// Checks on the data alone: "S4" and "region_in_F".
    pub data_checks: &'a BTreeMap<String, DataCheck>,
    /// Problems with the gains themselves (dimensions, non-finite numbers).
    pub input_errors: &'a [String],
}

impl<'a> CheckOutput<'a> {
    /// The `qpv check` document for the certificate `cert` of `gains`.
    pub fn new(
        model: &'a str,
        gains: &Path,
        mode_source: &'static str,
        split: qpv_dsl::Split,
        cert: &'a Certificate,
        exit_code: i32,
    ) -> Self {
        CheckOutput {
            schema: SCHEMA,
            command: "check",
            model,
            gains: gains.display().to_string(),
            mode: cert.mode.name(),
            mode_source,
            alpha: cert.alpha,
            gamma: cert.gamma,
            split: split.name(),
            verdict: Verdict::of(cert.passed, cert.mode),
            exit_code,
            margins: cert.margins(),
            families: cert
                .families
                .iter()
                .map(|f| {
                    (
                        f.name.clone(),
                        FamilyDetail {
                            margin: f.margin,
                            guard: f.guard,
                            passed: f.passed,
                            worst_at: f.worst_at.clone(),
                            count: f.count,
                        },
                    )
                })
                .collect(),
            data_checks: &cert.data_checks,
            input_errors: &cert.input_errors,
        }
    }
}

/// `qpv vertices --json`: the polytopic model with matrices as rows.
#[derive(Serialize)]
pub struct VerticesOutput {
    /// [`SCHEMA`].
    pub schema: &'static str,
    /// `"vertices"`.
    pub command: &'static str,
    /// The model's name.
    pub model: String,
    /// State names.
    pub states: Vec<String>,
    /// Input names.
    pub inputs: Vec<String>,
    /// Output names.
    pub outputs: Vec<String>,
    /// Every declared parameter with its interval.
    pub params: Vec<ParamView>,
    /// Names of the parameters that generate vertices, most significant first.
    pub scheduling: Vec<String>,
    /// The derived scheduling variables φ_j(θ) (non-multi-affine functions
    /// of the parameters), after the parameters in the vertex order.
    pub derived: Vec<DerivedView>,
    /// The piecewise cover of the parameter box (absent without a `cover`
    /// statement).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cover: Option<CoverView>,
    /// How many vertices there are and where they come from.
    pub vertex_count: VertexCountView,
    /// The θ-vertices in the documented order.
    pub vertices: Vec<VertexView>,
    /// Whether C or some M_k depend on θ.
    pub output_varies: bool,
    /// The convergence region in both representations.
    pub region: RegionView,
    /// The state bound F as written in the model.
    pub state_bound: StateBoundView,
    /// The model's `design` blocks.
    pub requests: Vec<RequestView>,
}

/// A derived scheduling variable φ_j(θ) and its range.
#[derive(Serialize)]
pub struct DerivedView {
    /// Its name (`let` name, or `phi1`, ...).
    pub name: String,
    /// The function of the parameters.
    pub expression: String,
    /// The matrix entries that use it (`A[1,2]`, `N1[2,3]`, ...).
    pub used_in: Vec<String>,
    /// Lower end of its range (contains φ_j(θ) for every θ ∈ Θ).
    pub lo: f64,
    /// Upper end of its range.
    pub hi: f64,
    /// How the range was obtained, in words.
    pub range_method: String,
    /// The smallest and largest values sampled on Θ while computing it.
    pub sampled: [f64; 2],
}

/// The cover of the parameter box by a grid of equal pieces.
#[derive(Serialize)]
pub struct CoverView {
    /// The parameters cut, first most significant in the piece index.
    pub parameters: Vec<CoverAxisView>,
    /// The pieces in order; piece k (1-based) owns the vertices
    /// (k − 1)·2^s + 1 to k·2^s.
    pub pieces: Vec<PieceView>,
}

/// One parameter of a cover.
#[derive(Serialize)]
pub struct CoverAxisView {
    /// Its name.
    pub name: String,
    /// The number of equal pieces.
    pub pieces: usize,
    /// The breakpoints lo = b_0 < … < b_n = hi (a breakpoint belongs to
    /// the piece above it).
    pub breaks: Vec<f64>,
}

/// One piece of a cover.
#[derive(Serialize)]
pub struct PieceView {
    /// 1-based piece number.
    pub index: usize,
    /// The piece in words (`q2 ∈ [0.2, 0.65]`).
    pub label: String,
    /// [lo, hi] of every declared parameter on the piece.
    pub theta: Vec<[f64; 2]>,
    /// The ranges of the derived scheduling variables on the piece.
    pub derived: Vec<PieceRangeView>,
    /// The first and last vertex of the piece (1-based, inclusive).
    pub vertices: [usize; 2],
}

/// The range of one derived variable on one piece.
#[derive(Serialize)]
pub struct PieceRangeView {
    /// The variable's name.
    pub name: String,
    /// Lower end (contains φ_j(θ) for every θ in the piece).
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// How the range was obtained, in words.
    pub range_method: String,
    /// The smallest and largest values sampled on the piece.
    pub sampled: [f64; 2],
}

/// The vertex count: 2^(parameters + derived variables), times the pieces
/// of a cover.
#[derive(Serialize)]
pub struct VertexCountView {
    /// The number of vertices.
    pub total: usize,
    /// The pieces of the cover (absent without a cover: one box).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pieces: Option<usize>,
    /// Scheduling parameters (each doubles the count).
    pub parameters: usize,
    /// Derived scheduling variables (each doubles the count).
    pub derived: usize,
    /// A warning when the count exceeds 64, naming the derived variables.
    pub warning: Option<String>,
}

/// A declared parameter θ_i ∈ [lo, hi].
#[derive(Serialize)]
pub struct ParamView {
    /// Its name.
    pub name: String,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

/// The matrices at one θ-vertex (rows).
#[derive(Serialize)]
pub struct VertexView {
    /// The full parameter vector at this corner.
    pub theta: Vec<f64>,
    /// A_l.
    #[serde(rename = "A")]
    pub a: Vec<Vec<f64>>,
    /// N_{k,l}, k = 1..nx.
    #[serde(rename = "N")]
    pub n: Vec<Vec<Vec<f64>>>,
    /// B_l (nx × nu).
    #[serde(rename = "B")]
    pub b: Vec<Vec<f64>>,
    /// C_l (ny × nx).
    #[serde(rename = "C")]
    pub c: Vec<Vec<f64>>,
    /// M_{k,l}, k = 1..ny.
    #[serde(rename = "M")]
    pub m: Vec<Vec<Vec<f64>>>,
}

/// The region: vertices x_(i) and facet normals a_k (a_kᵀx ≤ 1).
#[derive(Serialize)]
pub struct RegionView {
    /// One vertex per entry.
    pub vertices: Vec<Vec<f64>>,
    /// One facet normal per entry.
    pub facets: Vec<Vec<f64>>,
}

/// The model's state bound, with the keys of a design report's `state_bound`.
#[derive(Serialize)]
pub struct StateBoundView {
    /// "given", "auto" or "none".
    pub source: &'static str,
    /// Q (rows) of a given bound.
    #[serde(rename = "Q")]
    pub q: Option<Vec<Vec<f64>>>,
    /// The fixed box size of `state_bound auto(h = ...)`.
    pub h: Option<f64>,
}

/// One `design` block, with the keys of a design report.
#[derive(Serialize)]
pub struct RequestView {
    /// A number, or "max".
    pub alpha: Value,
    /// A number, or "search".
    pub gamma: Value,
    /// "sound" or "paper".
    pub mode: &'static str,
    /// "as_written", "symmetric" or "skew_slack".
    pub split: &'static str,
    /// "full" or "decoupled".
    pub conditions: &'static str,
    /// `route` ("double_sum" or "filter") and `filter` (`pole`, `gain`) or null.
    pub output_route: Value,
}

fn rows_of(m: &nalgebra::DMatrix<f64>) -> Vec<Vec<f64>> {
    matrix_to_rows(m)
}

fn region_view(r: &Region) -> RegionView {
    RegionView {
        vertices: r
            .vertices
            .iter()
            .map(|v| v.iter().copied().collect())
            .collect(),
        facets: r
            .facets
            .iter()
            .map(|a| a.iter().copied().collect())
            .collect(),
    }
}

fn request_view(r: &DesignRequest) -> RequestView {
    RequestView {
        alpha: match r.alpha {
            AlphaSpec::Fixed(a) => Value::from(a),
            AlphaSpec::Max => Value::from("max"),
        },
        gamma: match r.gamma {
            GammaSpec::Fixed(g) => Value::from(g),
            GammaSpec::Search => Value::from("search"),
        },
        mode: r.mode.name(),
        split: r.split.name(),
        conditions: r.conditions.name(),
        output_route: match r.output_route {
            OutputRoute::DoubleSum => serde_json::json!({"route": "double_sum", "filter": null}),
            OutputRoute::Filter(f) => serde_json::json!({
                "route": "filter",
                "filter": {"pole": f.pole, "gain": f.gain}
            }),
        },
    }
}

impl VerticesOutput {
    /// The `qpv vertices` document of `p`.
    pub fn new(p: &PolytopicModel) -> Self {
        VerticesOutput {
            schema: SCHEMA,
            command: "vertices",
            model: p.name.clone(),
            states: p.states.clone(),
            inputs: p.inputs.clone(),
            outputs: p.outputs.clone(),
            params: p
                .params
                .iter()
                .map(|q| ParamView {
                    name: q.name.clone(),
                    lo: q.lo,
                    hi: q.hi,
                })
                .collect(),
            scheduling: p
                .scheduling
                .iter()
                .map(|&i| p.params[i].name.clone())
                .collect(),
            derived: p
                .derived
                .iter()
                .map(|d| DerivedView {
                    name: d.name.clone(),
                    expression: d.text.clone(),
                    used_in: d.used_in.clone(),
                    lo: d.lo,
                    hi: d.hi,
                    range_method: d.range.method.clone(),
                    sampled: [d.range.sampled_lo, d.range.sampled_hi],
                })
                .collect(),
            cover: p.cover.as_ref().map(|c| cover_view(p, c)),
            vertex_count: VertexCountView {
                total: p.nv(),
                pieces: p.cover.as_ref().map(|c| c.len()),
                parameters: p.scheduling.len(),
                derived: p.derived.len(),
                warning: count_warning(p),
            },
            vertices: p
                .vertices
                .iter()
                .map(|v| VertexView {
                    theta: v.theta.clone(),
                    a: rows_of(&v.a),
                    n: v.n.iter().map(rows_of).collect(),
                    b: rows_of(&v.b),
                    c: rows_of(&v.c),
                    m: v.m.iter().map(rows_of).collect(),
                })
                .collect(),
            output_varies: p.nv() > 0 && p.output_varies(),
            region: region_view(&p.region),
            state_bound: match &p.state_bound {
                StateBound::None => StateBoundView {
                    source: "none",
                    q: None,
                    h: None,
                },
                StateBound::Given(q) => StateBoundView {
                    source: "given",
                    q: Some(rows_of(q)),
                    h: None,
                },
                StateBound::Auto { h } => StateBoundView {
                    source: "auto",
                    q: None,
                    h: *h,
                },
            },
            requests: p.designs.iter().map(request_view).collect(),
        }
    }
}

/// The JSON view of a model's cover.
fn cover_view(p: &PolytopicModel, c: &qpv_dsl::Cover) -> CoverView {
    let per = p.nv() / c.len().max(1);
    CoverView {
        parameters: c
            .axes
            .iter()
            .map(|a| CoverAxisView {
                name: a.name.clone(),
                pieces: a.breaks.len() - 1,
                breaks: a.breaks.clone(),
            })
            .collect(),
        pieces: c
            .pieces
            .iter()
            .enumerate()
            .map(|(k, piece)| PieceView {
                index: k + 1,
                label: c.label(k),
                theta: piece.theta.iter().map(|&(lo, hi)| [lo, hi]).collect(),
                derived: p
                    .derived
                    .iter()
                    .zip(&piece.phi)
                    .zip(&piece.range)
                    .map(|((d, &(lo, hi)), info)| PieceRangeView {
                        name: d.name.clone(),
                        lo,
                        hi,
                        range_method: info.method.clone(),
                        sampled: [info.sampled_lo, info.sampled_hi],
                    })
                    .collect(),
                vertices: [k * per + 1, (k + 1) * per],
            })
            .collect(),
    }
}

/// Vertex counts above this get a warning in the report.
pub const VERTEX_WARNING: usize = 64;

/// A warning when the model has more than [`VERTEX_WARNING`] vertices,
/// naming the derived variables that cost most (each doubles the count;
/// those used in the most matrix entries first, as the hardest to avoid).
pub fn count_warning(p: &PolytopicModel) -> Option<String> {
    if p.nv() <= VERTEX_WARNING {
        return None;
    }
    let mut d: Vec<&qpv_dsl::Derived> = p.derived.iter().collect();
    d.sort_by_key(|d| std::cmp::Reverse(d.used_in.len()));
    let costly = if d.is_empty() {
        String::new()
    } else {
        format!(
            "; the derived variables each double it: {} (name a recurring function with `let` \
             so it is shared, or narrow a parameter range so fewer functions are needed)",
            d.iter()
                .map(|d| format!(
                    "{} = {} (used in {} entries)",
                    d.name,
                    d.text,
                    d.used_in.len()
                ))
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    let pieces = match &p.cover {
        Some(c) => format!(
            "; the cover multiplies it by its {} pieces (fewer pieces, or cut fewer parameters)",
            c.len()
        ),
        None => String::new(),
    };
    Some(format!(
        "{} vertices (more than {VERTEX_WARNING}): {} parameter(s) and {} derived variable(s){costly}{pieces}",
        p.nv(),
        p.scheduling.len(),
        p.derived.len()
    ))
}
