//! `qpv codegen`: a certified observer exported as C99 (`<model>.h`,
//! `<model>.c`), printed from the same arithmetic as `qpv!`'s Rust
//! ([`qpv_codegen`]).
//!
//! The numbers baked are always certified here, by the independent
//! certificate, on exactly the values the C holds: either one of the
//! model's `design` blocks is solved and checked, or a gains file (a `qpv
//! design --json` report) is re-checked as `qpv check` does. With `--float
//! f32` the constants are rounded to `float` first and the rounded P and
//! L_l are what is certified; if they fail, nothing is written.

use super::gains::read_claim;
use super::input::{exit, load_model, load_model_for, CliError};
use qpv_codegen::c::{CModel, Float};
use qpv_codegen::CertifiedDesign;
use qpv_dsl::{Mode, Model};
use qpv_solve::export::{self, BakeError, Baked};
use qpv_solve::Design;
use std::path::{Path, PathBuf};

/// The options of `qpv codegen`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The model file (.qpv).
    pub file: PathBuf,
    /// Target language: `c`.
    #[arg(long, value_name = "c", default_value = "c")]
    pub lang: String,
    /// Number type of the generated code: `f64` (default) or `f32`.
    #[arg(long, value_name = "f64|f32")]
    pub float: Option<String>,
    /// The design block to export, 1-based (default: the first sound one).
    #[arg(long, value_name = "N")]
    pub design: Option<usize>,
    /// Export these gains (a `qpv design --json` report) instead of
    /// solving; they are re-certified first.
    #[arg(long, value_name = "REPORT.json")]
    pub gains: Option<PathBuf>,
    /// Which model of the file.
    #[arg(long, value_name = "NAME")]
    pub model: Option<String>,
    /// The directory the files are written to.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// Where the design to export came from, in words, and the solver's record.
struct Source {
    /// Solved in this run (its own certificate holds for its f64 numbers),
    /// rather than read from a gains file (a claim, re-checked).
    solved: bool,
    request: String,
    origin: String,
    status: String,
    iterations: u32,
    /// The design block's `float` (f64 for a gains file).
    float: qpv_dsl::Float,
    /// The design block's α request (a gains file: `Fixed`, its α; the
    /// file's supremum estimate is not exported).
    alpha: qpv_dsl::AlphaSpec,
}

/// Runs `qpv codegen`.
pub fn run(o: &Options) -> Result<i32, CliError> {
    if o.lang != "c" {
        return Err(CliError::Input(format!(
            "--lang {}: the only target language is `c` (Rust observers come from the `qpv!` macro)",
            o.lang
        )));
    }
    let flag = float_flag(o.float.as_deref())?;
    let (model, (design, source)) = match &o.gains {
        Some(g) => match from_gains(&o.file, o.model.as_deref(), g, o.design)? {
            Ok(n) => n,
            Err(msg) => {
                eprintln!("{msg}\nnothing written: only certified designs are exported");
                return Ok(exit::NOT_CERTIFIED);
            }
        },
        None => {
            let (_, model) = load_model(&o.file, o.model.as_deref())?;
            let held = flag.map(|f| match f {
                Float::F32 => qpv_dsl::Float::F32,
                Float::F64 => qpv_dsl::Float::F64,
            });
            match solved(&o.file, &model, o.design, held)? {
                Ok(n) => (model, n),
                Err(msg) => {
                    eprintln!("{msg}\nnothing written: only certified designs are exported");
                    return Ok(exit::NOT_CERTIFIED);
                }
            }
        }
    };
    // --float, else the design block's `float = ...`, else f64
    let float = flag.unwrap_or(match source.float {
        qpv_dsl::Float::F32 => Float::F32,
        qpv_dsl::Float::F64 => Float::F64,
    });
    let held = match float {
        Float::F32 => qpv_dsl::Float::F32,
        Float::F64 => qpv_dsl::Float::F64,
    };
    // The certificate on exactly the numbers the C holds (for f32 the
    // rounded P, L_l and sample period, each exactly representable in f64).
    let plant = model.polytopic();
    let baked = if source.solved {
        Baked::solved(&plant, design, held)
    } else {
        Baked::claimed(&plant, design, held)
    };
    let baked = match baked {
        Ok(b) => b,
        Err(e) => {
            let why = match &e {
                BakeError::Failed(cert) => export::failing_families(cert),
                other => other.to_string(),
            };
            eprintln!(
                "{}: the {} P and L_l of {} do not pass the certificate ({why}); nothing written: \
                 only certified designs are exported",
                o.file.display(),
                match float {
                    Float::F32 => "f32-rounded",
                    Float::F64 => "f64",
                },
                source.origin,
            );
            return Ok(exit::NOT_CERTIFIED);
        }
    };
    let (design, floor_note) = certified_design(&model, &plant.scheduling, &source, &baked);
    let mut notes = vec![format!("numbers: {}", source.origin)];
    notes.push(match float {
        Float::F64 => "float: f64; the certificate checked P and L_l as printed here".into(),
        Float::F32 => format!(
            "float: f32; P and L_l were rounded to float BEFORE the certificate, which \
             checked the rounded values (as printed here). The f32 arithmetic's own rounding \
             is bounded by F32_ERROR_FLOOR (a zero-noise f32 design has a nonzero floor).{floor_note}"
        ),
    });
    let files = qpv_codegen::c::emit(&CModel {
        model: &model,
        scheduling: &plant.scheduling,
        design: &design,
        float,
        notes,
    });
    let (h, c) = write_files(&o.out, &model.name, &files)?;
    let at = design
        .sample_text()
        .map(|t| format!(" at {t}"))
        .unwrap_or_default();
    println!(
        "certified{at} ({}): alpha = {}, gamma = {}, {} vertices, float {}\nwrote {} and {}",
        source.origin,
        design.alpha,
        design.gamma,
        design.l.len(),
        float.name(),
        h.display(),
        c.display()
    );
    Ok(exit::CERTIFIED)
}

/// `--float`: `f64`, `f32` or absent.
fn float_flag(flag: Option<&str>) -> Result<Option<Float>, CliError> {
    match flag {
        None => Ok(None),
        Some("f64") => Ok(Some(Float::F64)),
        Some("f32") => Ok(Some(Float::F32)),
        Some(other) => Err(CliError::Input(format!(
            "--float {other}: expected `f64` or `f32`"
        ))),
    }
}

/// The numbers to emit for a baked design ([`Baked::certified_design`],
/// as `qpv!` emits them, with the record of where they came from) and, for
/// an f32 design, the sentence on its error floor (how the rounding bound
/// splits, or why none is certified).
fn certified_design(
    model: &Model,
    scheduling: &[usize],
    source: &Source,
    baked: &Baked,
) -> (CertifiedDesign, String) {
    let (mut design, floor) =
        baked.certified_design(model, scheduling, &source.request, source.alpha);
    design.status = source.status.clone();
    design.iterations = source.iterations;
    let floor_note = match floor {
        None => String::new(),
        Some(Ok(f)) => format!(
            " The rounding is d0 + d1*rho per state (rho = sqrt(e'Pe)): D0 = {:.3e}, \
             D1 = {:.3e} in P-norm, so the rate drops to alpha - 2*D1 = {:.6e} and the \
             constant part ends in lim sup |e| <= {:.3e} ({} bound).",
            f.constant,
            f.proportional,
            design.alpha - 2.0 * f.proportional,
            f.error_bound,
            f.via
        ),
        Some(Err(e)) => format!(" No f32 error floor is certified: {e}."),
    };
    (design, floor_note)
}

/// Writes `<name>.h` and `<name>.c` into `out` and returns their paths.
fn write_files(
    out: &Path,
    name: &str,
    files: &qpv_codegen::c::CFiles,
) -> Result<(PathBuf, PathBuf), CliError> {
    std::fs::create_dir_all(out)
        .map_err(|e| CliError::Input(format!("--out {}: {e}", out.display())))?;
    let write = |name: String, text: &str| -> Result<std::path::PathBuf, CliError> {
        let path = out.join(name);
        std::fs::write(&path, text)
            .map_err(|e| CliError::Input(format!("{}: {e}", path.display())))?;
        Ok(path)
    };
    let h = write(format!("{}.h", name), &files.header)?;
    let c = write(format!("{}.c", name), &files.source)?;
    Ok((h, c))
}

/// Solves design block `n` (1-based; default the first sound one) of the
/// model, as `qpv!` does, for the numbers held in `float` (default: the
/// block's): for f32, again with larger margins while the rounded numbers
/// fail. `Ok(Err(msg))`: not certified, and why ([`export::explain`]).
fn solved(
    file: &Path,
    model: &Model,
    n: Option<usize>,
    float: Option<qpv_dsl::Float>,
) -> Result<Result<(Design, Source), String>, CliError> {
    let index = match n {
        Some(0) => {
            return Err(CliError::Input(
                "--design 0: design blocks are numbered from 1".into(),
            ))
        }
        Some(i) if i > model.designs.len() => {
            return Err(CliError::Input(format!(
                "--design {i}: model `{}` in {} has {} design block(s)",
                model.name,
                file.display(),
                model.designs.len()
            )))
        }
        Some(i) => i - 1,
        None => model
            .designs
            .iter()
            .position(|d| d.mode == Mode::Sound)
            .ok_or_else(|| {
                CliError::Input(format!(
                    "{}: model `{}` has no sound-mode design block to export (add e.g. \
                     `design {{ alpha = max; gamma = search; }}`, or pass --gains REPORT.json)",
                    file.display(),
                    model.name
                ))
            })?,
    };
    let req = &model.designs[index];
    let (line, _) = qpv_dsl::diagnostic::line_col(
        &std::fs::read_to_string(file).unwrap_or_default(),
        req.span.start,
    );
    let here = format!("{}:{line}: design block {}", file.display(), index + 1);
    if req.mode == Mode::Paper {
        return Err(CliError::Input(format!(
            "{here} is a paper-mode reproduction: it certifies nothing and is never exported"
        )));
    }
    let settings = qpv_solve::Settings::default();
    let poly = model.polytopic();
    let Some(design) = solve_held(&poly, req, &settings, float.unwrap_or(req.float)) else {
        return Ok(Err(format!("{here}: nothing solved")));
    };
    let design = match design {
        Ok(d) => d,
        Err(why) => return Ok(Err(format!("{here} {why}"))),
    };
    let source = Source {
        request: describe(req),
        origin: format!("{here}, solved and independently re-checked"),
        float: req.float,
        status: design.solver.detail.clone(),
        iterations: design.solver.iterations,
        solved: true,
        alpha: req.alpha,
    };
    Ok(Ok((design, source)))
}

/// Solves `req` for numbers held in `float`: as `qpv!` does, an f32 export
/// whose rounded numbers fail is solved again with the strict
/// inequalities' margin 10 and 100 times larger. `Err(why)`: not certified
/// ([`export::explain`]); `None`: nothing was solved.
fn solve_held(
    poly: &qpv_dsl::PolytopicModel,
    req: &qpv_dsl::DesignRequest,
    settings: &qpv_solve::Settings,
    float: qpv_dsl::Float,
) -> Option<Result<Design, String>> {
    let tries = if float == qpv_dsl::Float::F32 { 3 } else { 1 };
    let mut design = None;
    for k in 0..tries {
        let s = qpv_solve::Settings {
            margin_rel: settings.margin_rel * 10f64.powi(k),
            ..settings.clone()
        };
        let d = match qpv_solve::design(poly, req, &s) {
            Ok(d) => d,
            Err(e) => return Some(Err(format!("cannot be attempted: {e}"))),
        };
        if !(d.feasible() && d.certifies()) {
            return Some(Err(export::explain(poly, req, &d, settings).to_string()));
        }
        let bakes = !matches!(
            Baked::solved(poly, d.clone(), float),
            Err(BakeError::Failed(_))
        );
        design = Some(Ok(d));
        if bakes {
            break;
        }
    }
    design
}

/// The request in words (as `qpv!` describes it, in short).
fn describe(req: &qpv_dsl::DesignRequest) -> String {
    let alpha = match req.alpha {
        qpv_dsl::AlphaSpec::Fixed(a) => format!("{a}"),
        qpv_dsl::AlphaSpec::Max => "max".into(),
    };
    let gamma = match req.gamma {
        qpv_dsl::GammaSpec::Fixed(g) => format!("{g}"),
        qpv_dsl::GammaSpec::Search => "search".into(),
    };
    let sample = req
        .sample
        .map(|h| format!("; sample = {h}"))
        .unwrap_or_default();
    format!(
        "alpha = {alpha}; gamma = {gamma}; mode = sound; conditions = {}{sample}",
        req.conditions.name()
    )
}

/// The design a gains file (a design report) claims, to be re-certified as
/// `qpv check` does (sound mode; α and γ from the file); `Err` (exported
/// as "not certified") when the file's own verdict is short of certified,
/// which is respected: a report may claim less than its gains achieve.
fn from_gains(
    file: &Path,
    model_flag: Option<&str>,
    gains: &Path,
    design: Option<usize>,
) -> Result<Result<(Model, (Design, Source)), String>, CliError> {
    if design.is_some() {
        return Err(CliError::Input(
            "--design and --gains exclude each other: the gains file is the design".into(),
        ));
    }
    let claim = read_claim(gains, "gains file")?;
    let (_, model) = load_model_for(file, model_flag, gains, claim.model())?;
    if claim.certifies == Some(false) && claim.mode != Some(Mode::Paper) {
        return Ok(Err(format!(
            "{}: the report's verdict is not `certified`; a verdict short of certified is \
             respected (a report may claim less than its gains achieve)",
            gains.display()
        )));
    }
    if claim.mode == Some(Mode::Paper) {
        return Err(CliError::Input(format!(
            "{}: a paper-mode report certifies nothing and is never exported",
            gains.display()
        )));
    }
    let need = |v: Option<f64>, key: &str| {
        v.ok_or_else(|| {
            CliError::Input(format!(
                "{}: `{key}` missing: the gains file must say which alpha and gamma it certifies",
                gains.display()
            ))
        })
    };
    let (alpha, gamma) = (need(claim.alpha, "alpha")?, need(claim.gamma, "gamma")?);
    // The observer model the claim belongs to, built as `qpv check` builds
    // it (split, verified state bound, output route, skew slack): a file
    // that does not fit the model is bad input.
    let design = claim.at(Mode::Sound, alpha, gamma);
    design
        .observer_model(&model.polytopic())
        .map_err(|e| CliError::Input(format!("{}: {e}", gains.display())))?;
    let source = Source {
        solved: false,
        request: format!("gains from {}", gains.display()),
        origin: format!("{}, re-certified", gains.display()),
        status: "gains file".into(),
        iterations: 0,
        float: qpv_dsl::Float::F64,
        alpha: qpv_dsl::AlphaSpec::Fixed(0.0),
    };
    Ok(Ok((model, (design, source))))
}
