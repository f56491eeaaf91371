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
        Some(g) => match from_gains(o, g)? {
            Ok(n) => n,
            Err(msg) => {
                eprintln!("{msg}\nnothing written: only certified designs are exported");
                return Ok(exit::NOT_CERTIFIED);
            }
        },
        None => {
            let (src, model) = load_model(&o.file, o.model.as_deref())?;
            refuse_targets(o, &src, &model)?;
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
    let (h, c) = write_files(o, &model.name, &files)?;
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

/// The two files `qpv codegen` writes for model `name`: `OUT/<name>.h`
/// and `OUT/<name>.c`.
fn targets(out: &Path, name: &str) -> [PathBuf; 2] {
    [out.join(format!("{name}.h")), out.join(format!("{name}.c"))]
}

/// The device and inode of the file at `path`, symlinks followed (None if
/// there is none).
#[cfg(unix)]
fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

/// Elsewhere: the canonical path stands for the identity.
#[cfg(not(unix))]
fn identity(path: &Path) -> Option<PathBuf> {
    std::fs::canonicalize(path).ok()
}

/// Refuses, before anything is solved or written, a model whose name makes
/// a header that shadows a C standard header (positioned at the model's
/// name), and any target that is (device and inode, symlinks followed, so
/// hard links too) the model file or the gains file, or a directory.
fn refuse_targets(o: &Options, src: &str, model: &Model) -> Result<(), CliError> {
    if let Some(why) = qpv_codegen::c::shadowed_header(&model.name) {
        let e = qpv_dsl::diagnostic::Error::new(src, model.span, why);
        return Err(CliError::Input(format!("{}:{e}", o.file.display())));
    }
    check_targets(o, &model.name)
}

/// Refuses a target that is a directory or (device and inode, symlinks
/// followed, so hard links too) the model file or the gains file.
fn check_targets(o: &Options, name: &str) -> Result<(), CliError> {
    let inputs: Vec<(&Path, &str)> = std::iter::once((o.file.as_path(), "the model file"))
        .chain(o.gains.as_deref().map(|g| (g, "the gains file")))
        .collect();
    for target in targets(&o.out, name) {
        if target.is_dir() {
            return Err(CliError::Input(format!(
                "{} is a directory: nothing written (the export writes {name}.h and {name}.c \
                 there)",
                target.display()
            )));
        }
        let Some(id) = identity(&target) else {
            continue;
        };
        for (input, what) in &inputs {
            if identity(input).as_ref() == Some(&id) {
                return Err(CliError::Input(format!(
                    "{} is {what} {} (the same file): nothing written; choose another --out \
                     or rename the model",
                    target.display(),
                    input.display()
                )));
            }
        }
    }
    Ok(())
}

/// Writes `<name>.h` and `<name>.c` into `o.out` and returns their paths:
/// both are written to temporaries in that directory first and renamed
/// into place only when both are complete, after the targets are checked
/// once more ([`check_targets`]); on any failure the temporaries
/// are removed and no target is touched.
fn write_files(
    o: &Options,
    name: &str,
    files: &qpv_codegen::c::CFiles,
) -> Result<(PathBuf, PathBuf), CliError> {
    let out = &o.out;
    std::fs::create_dir_all(out)
        .map_err(|e| CliError::Input(format!("--out {}: {e}", out.display())))?;
    let [h, c] = targets(out, name);
    let temp = |p: &Path| {
        let file = p.file_name().map(|f| f.to_string_lossy().into_owned());
        out.join(format!(
            ".{}.qpv-{}.tmp",
            file.unwrap_or_default(),
            std::process::id()
        ))
    };
    let (th, tc) = (temp(&h), temp(&c));
    let cleanup = || {
        let _ = std::fs::remove_file(&th);
        let _ = std::fs::remove_file(&tc);
    };
    let written = (|| -> Result<(), CliError> {
        for (path, text) in [(&th, &files.header), (&tc, &files.source)] {
            write_new(path, text).map_err(|e| CliError::Io(format!("{}: {e}", path.display())))?;
        }
        check_targets(o, name)?;
        Ok(())
    })();
    if let Err(e) = written {
        cleanup();
        return Err(e);
    }
    std::fs::rename(&th, &h).map_err(|e| {
        cleanup();
        CliError::Io(format!("{}: {e}", h.display()))
    })?;
    std::fs::rename(&tc, &c).map_err(|e| {
        cleanup();
        CliError::Io(format!(
            "{}: {e} ({} was written)",
            c.display(),
            h.display()
        ))
    })?;
    Ok((h, c))
}

/// Creates `path` (which must not exist) with `text`, flushed to disk.
fn write_new(path: &Path, text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)?;
    f.write_all(text.as_bytes())?;
    f.sync_all()
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
    if let Some(notice) = super::design::slow_notice(&poly, req, index + 1) {
        eprintln!("{notice}");
    }
    let bar = super::design::spinner(format!(
        "designing {} (design block {})",
        model.name,
        index + 1
    ));
    let held =
        qpv_solve::backend::with_iteration_progress(super::design::iteration_message(&bar), || {
            solve_held(&poly, req, &settings, float.unwrap_or(req.float))
        });
    bar.finish_and_clear();
    let Some(design) = held else {
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

/// The model, and the design to export with where it came from.
type Exported = (Model, (Design, Source));

/// The design a gains file (a design report) claims, to be re-certified as
/// `qpv check` does (sound mode; α and γ from the file); `Err` (exported
/// as "not certified") when the file's own verdict is short of certified,
/// which is respected: a report may claim less than its gains achieve.
fn from_gains(o: &Options, gains: &Path) -> Result<Result<Exported, String>, CliError> {
    let (file, model_flag) = (o.file.as_path(), o.model.as_deref());
    if o.design.is_some() {
        return Err(CliError::Input(
            "--design and --gains exclude each other: the gains file is the design".into(),
        ));
    }
    let claim = read_claim(gains, "gains file")?;
    let (src, model) = load_model_for(file, model_flag, gains, claim.model())?;
    refuse_targets(o, &src, &model)?;
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
