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
use nalgebra::DMatrix;
use qpv_codegen::c::{CModel, Float};
use qpv_codegen::{CertifiedDesign, Figures};
use qpv_dsl::{Mode, Model, OutputFilter, OutputRoute, PolytopicModel};
use qpv_solve::conditions::cube::CubeSlacks;
use qpv_solve::model::{ObserverModel, ObserverOptions, StateBoundClaim};
use qpv_solve::noise::NoiseChannels;
use qpv_solve::report::{matrix_to_rows, skew_matrices};
use qpv_solve::Certificate;
use std::path::{Path, PathBuf};

/// The options of `qpv codegen`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The model file (.qpv).
    pub file: PathBuf,
    /// Target language: `c`.
    #[arg(long, default_value = "c")]
    pub lang: String,
    /// Number type of the generated code: `f64` (default) or `f32`.
    #[arg(long)]
    pub float: Option<String>,
    /// The design block to export, 1-based (default: the first sound one).
    #[arg(long)]
    pub design: Option<usize>,
    /// Export these gains (a `qpv design --json` report) instead of
    /// solving; they are re-certified first.
    #[arg(long)]
    pub gains: Option<PathBuf>,
    /// Which model of the file.
    #[arg(long)]
    pub model: Option<String>,
    /// The directory the files are written to.
    #[arg(long)]
    pub out: PathBuf,
}

/// The numbers to bake before the f32 rounding: the model checked, α, γ,
/// P, L_l, the cube slacks the solve certified with, the filter, words on
/// where they came from, and the solver's record.
struct Numbers {
    checked: PolytopicModel,
    plant: PolytopicModel,
    alpha: f64,
    gamma: f64,
    p: DMatrix<f64>,
    ls: Vec<DMatrix<f64>>,
    slacks: Option<CubeSlacks>,
    filter: Option<OutputFilter>,
    request: String,
    origin: String,
    status: String,
    iterations: u32,
    /// The design block's `float` (f64 for a gains file).
    float: qpv_dsl::Float,
    /// `sample = h`: the period the numbers are certified at (S5d).
    sample: Option<f64>,
}

/// Runs `qpv codegen`.
pub fn run(o: &Options) -> Result<i32, CliError> {
    if o.lang != "c" {
        return Err(CliError::Input(format!(
            "--lang {}: the only target language is `c` (Rust observers come from the `qpv!` macro)",
            o.lang
        )));
    }
    let flag = match o.float.as_deref() {
        None => None,
        Some("f64") => Some(Float::F64),
        Some("f32") => Some(Float::F32),
        Some(other) => {
            return Err(CliError::Input(format!(
                "--float {other}: expected `f64` or `f32`"
            )))
        }
    };
    let (model, numbers) = match &o.gains {
        Some(g) => from_gains(&o.file, o.model.as_deref(), g, o.design)?,
        None => {
            let (_, model) = load_model(&o.file, o.model.as_deref())?;
            let n = match solved(&o.file, &model, o.design)? {
                Ok(n) => n,
                Err(msg) => {
                    eprintln!("{msg}\nnothing written: only certified designs are exported");
                    return Ok(exit::NOT_CERTIFIED);
                }
            };
            (model, n)
        }
    };
    // --float, else the design block's `float = ...`, else f64
    let float = flag.unwrap_or(match numbers.float {
        qpv_dsl::Float::F32 => Float::F32,
        qpv_dsl::Float::F64 => Float::F64,
    });
    // With f32 the C steps by the float nearest h: that h is certified.
    let mut numbers = numbers;
    if float == Float::F32 {
        numbers.sample = numbers.sample.map(|h| f64::from(h as f32));
    }
    let (p, ls, f32_note) = match float {
        Float::F64 => (numbers.p.clone(), numbers.ls.clone(), None),
        Float::F32 => {
            let round = |m: &DMatrix<f64>| m.map(|v| f64::from(v as f32));
            let p = round(&numbers.p);
            let ls: Vec<_> = numbers.ls.iter().map(round).collect();
            (p, ls, Some(()))
        }
    };
    // The certificate on exactly the numbers the C holds (for f32 the
    // rounded ones, each exactly representable in f64).
    let mut cert = match numbers.sample {
        // A sampled design: the discrete decrease S5d at its h.
        Some(h) => qpv_solve::certificate::check_sampled(
            &numbers.checked,
            numbers.alpha,
            numbers.gamma,
            h,
            &p,
            &ls,
        ),
        None => qpv_solve::certificate::check_with(
            &numbers.checked,
            Mode::Sound,
            numbers.alpha,
            numbers.gamma,
            &p,
            &ls,
            numbers.slacks.as_ref(),
        ),
    };
    if !cert.passed && numbers.slacks.is_some() && f32_note.is_some() {
        // The cube slacks were found for the f64 numbers: the rounded ones
        // may still hold on the full vertex family.
        cert = qpv_solve::certificate::check_with(
            &numbers.checked,
            Mode::Sound,
            numbers.alpha,
            numbers.gamma,
            &p,
            &ls,
            None,
        );
    }
    let finite = p.iter().chain(ls.iter().flatten()).all(|v| v.is_finite());
    if !cert.passed || !finite {
        eprintln!(
            "{}: the {} P and L_l of {} do not pass the certificate ({}); nothing written: \
             only certified designs are exported",
            o.file.display(),
            if f32_note.is_some() {
                "f32-rounded"
            } else {
                "f64"
            },
            numbers.origin,
            failing(&cert)
        );
        return Ok(exit::NOT_CERTIFIED);
    }
    let scheduling = numbers.plant.scheduling.clone();
    let mut design = CertifiedDesign {
        request: numbers.request.clone(),
        mode: Mode::Sound.name().into(),
        certifies: true,
        alpha: numbers.alpha,
        gamma: numbers.gamma,
        p: matrix_to_rows(&p).concat(),
        l: ls.iter().map(|l| matrix_to_rows(l).concat()).collect(),
        margins: cert
            .families
            .iter()
            .map(|f| (f.name.clone(), f.margin))
            .collect(),
        status: numbers.status.clone(),
        iterations: numbers.iterations,
        float: match float {
            Float::F32 => qpv_dsl::Float::F32,
            Float::F64 => qpv_dsl::Float::F64,
        },
        filter: numbers.filter,
        figures: figures(&numbers, &p, &ls),
        sample: numbers.sample,
    };
    let mut floor_note = String::new();
    if float == Float::F32 {
        match f32_floor(&model, &scheduling, &design, &numbers.checked, &p, &ls) {
            Ok(v) => design.figures.f32_floor = Some(v),
            Err(e) => floor_note = format!(" No f32 error floor is certified: {e}."),
        }
    }
    let mut notes = vec![format!("numbers: {}", numbers.origin)];
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
        scheduling: &scheduling,
        design: &design,
        float,
        notes,
    });
    std::fs::create_dir_all(&o.out)
        .map_err(|e| CliError::Input(format!("--out {}: {e}", o.out.display())))?;
    let write = |name: String, text: &str| -> Result<std::path::PathBuf, CliError> {
        let path = o.out.join(name);
        std::fs::write(&path, text)
            .map_err(|e| CliError::Input(format!("{}: {e}", path.display())))?;
        Ok(path)
    };
    let h = write(format!("{}.h", model.name), &files.header)?;
    let c = write(format!("{}.c", model.name), &files.source)?;
    let at = design
        .sample_text()
        .map(|t| format!(" at {t}"))
        .unwrap_or_default();
    println!(
        "certified{at} ({}): alpha = {}, gamma = {}, {} vertices, float {}\nwrote {} and {}",
        numbers.origin,
        numbers.alpha,
        numbers.gamma,
        design.l.len(),
        float.name(),
        h.display(),
        c.display()
    );
    Ok(exit::CERTIFIED)
}

/// The failing families of a certificate, in words.
fn failing(cert: &Certificate) -> String {
    let mut v: Vec<String> = cert.input_errors.clone();
    v.extend(
        cert.families
            .iter()
            .filter(|f| !f.passed)
            .map(|f| format!("{} margin {:.3e}", f.name, f.margin)),
    );
    v.extend(
        cert.data_checks
            .iter()
            .filter(|(_, c)| c.required && !c.passed)
            .map(|(k, c)| format!("{k} {:.4} > {}", c.value, c.bound)),
    );
    if v.is_empty() {
        "no family failed, but the certificate did not pass".into()
    } else {
        v.join(", ")
    }
}

/// Solves design block `n` (1-based; default the first sound one) of the
/// model: the macro's path (the observer's model, the solve, the
/// independent check of the solver's point). `Ok(Err(msg))`: not certified.
fn solved(
    file: &Path,
    model: &Model,
    n: Option<usize>,
) -> Result<Result<Numbers, String>, CliError> {
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
    let observer = match ObserverModel::prepare(
        &poly,
        &ObserverOptions::for_request(req),
        StateBoundClaim::Compute(&settings),
    ) {
        Ok(o) => o,
        Err(e) => return Ok(Err(format!("{here} cannot be attempted: {e}"))),
    };
    let design = match qpv_solve::design(&observer.plant, req, &settings) {
        Ok(d) => d,
        Err(e) => return Ok(Err(format!("{here} cannot be attempted: {e}"))),
    };
    if !(design.feasible && design.certifies) {
        return Ok(Err(format!("{here}: NOT certified by the solve")));
    }
    let checked = match &design.skew {
        Some(k) => match observer.with_skew(&skew_matrices(k)) {
            Ok(m) => m,
            Err(e) => return Ok(Err(format!("{here}: the solver's skew slack: {e}"))),
        },
        None => observer.model.clone(),
    };
    let filter = match req.output_route {
        OutputRoute::Filter(f) => Some(f),
        OutputRoute::DoubleSum => None,
    };
    Ok(Ok(Numbers {
        checked,
        plant: observer.plant.clone(),
        alpha: design.alpha,
        gamma: design.gamma,
        p: design.p_matrix(),
        ls: design.l_matrices(),
        slacks: design.cube.as_ref().map(CubeSlacks::from_report),
        filter,
        request: describe(req),
        origin: format!("{here}, solved and independently re-checked"),
        float: req.float,
        status: design.solver.detail.clone(),
        iterations: design.solver.iterations,
        sample: req.sample,
    }))
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

/// The numbers of a gains file (a design report), re-certified as `qpv
/// check` does (sound mode; α and γ from the file).
fn from_gains(
    file: &Path,
    model_flag: Option<&str>,
    gains: &Path,
    design: Option<usize>,
) -> Result<(Model, Numbers), CliError> {
    if design.is_some() {
        return Err(CliError::Input(
            "--design and --gains exclude each other: the gains file is the design".into(),
        ));
    }
    let claim = read_claim(gains, "gains file")?;
    let (_, model) = load_model_for(file, model_flag, gains, claim.model())?;
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
    // it (split, verified state bound, output route, skew slack).
    let design = claim.at(Mode::Sound, alpha, gamma);
    let filter = match design.route() {
        OutputRoute::Filter(f) => Some(f),
        OutputRoute::DoubleSum => None,
    };
    let (p, ls) = (design.p_matrix(), design.l_matrices());
    let sample = design.sample.as_ref().map(|s| s.h);
    let checked = design
        .observer_model(&model.polytopic())
        .map_err(|e| CliError::Input(format!("{}: {e}", gains.display())))?;
    let plant = model.polytopic();
    Ok((
        model,
        Numbers {
            checked,
            plant,
            alpha,
            gamma,
            p,
            ls,
            slacks: None,
            filter,
            request: format!("gains from {}", gains.display()),
            origin: format!("{}, re-certified", gains.display()),
            status: "gains file".into(),
            iterations: 0,
            float: qpv_dsl::Float::F64,
            sample,
        },
    ))
}

/// The noise bound and sampling figures of the numbers about to be baked
/// (as `qpv!` computes them): each present only if its own check passed.
/// None for a sampled design (docs/method.md §16: the continuous figures
/// say nothing about it).
fn figures(n: &Numbers, p: &DMatrix<f64>, ls: &[DMatrix<f64>]) -> Figures {
    if n.sample.is_some() {
        return Figures::default();
    }
    let plant = &n.plant;
    let channels = NoiseChannels::from_model(plant);
    let channels = match n.filter {
        Some(f) => channels.through_filter(plant.nx(), plant.ny(), plant.nv(), f.gain),
        None => channels,
    };
    let noise = qpv_solve::noise::noise_bound(&n.checked, &channels, n.alpha, n.gamma, p, ls)
        .filter(|b| b.check.passed);
    let sampling = qpv_solve::sampling::sampling(&n.checked, n.alpha, n.gamma, p, ls);
    Figures {
        sigma: noise.as_ref().map(|b| b.sigma),
        error_bound: noise.as_ref().map(|b| b.error_bound),
        max_amplitude: noise.as_ref().map(|b| b.max_amplitude),
        euler: sampling
            .as_ref()
            .filter(|s| s.max_step_euler > 0.0)
            .map(|s| (s.max_step_euler, s.beta)),
        rk4: sampling
            .as_ref()
            .map(|s| s.step_estimate_rk4)
            .filter(|h| *h > 0.0),
        f32_floor: None,
    }
}

/// The certified f32 error floor of the baked numbers (as `qpv!` computes
/// it): the rounding of one evaluation of the generated right-hand side
/// ([`qpv_codegen::rounding::rhs_error`]) as a disturbance entering every
/// state, through the noise bound ([`qpv_solve::noise::disturbance_floor`]).
fn f32_floor(
    model: &Model,
    scheduling: &[usize],
    d: &CertifiedDesign,
    checked: &PolytopicModel,
    p: &DMatrix<f64>,
    ls: &[DMatrix<f64>],
) -> Result<f64, String> {
    if d.filter.is_some() {
        return Err("the f32 floor is not computed for the filter route".into());
    }
    let (plant_state, observer_state) = qpv_solve::noise::observer_boxes(checked, d.gamma, p)
        .ok_or("P is not positive definite")?;
    let nv = qpv_codegen::design::vertex_count(model, scheduling);
    let shape = qpv_codegen::Shape::of(model, nv, d);
    let boxes = qpv_codegen::rounding::Boxes {
        plant_state,
        observer_state,
    };
    let err = qpv_codegen::rounding::rhs_error(model, scheduling, d, shape, &boxes)?;
    let f = qpv_solve::noise::disturbance_floor(checked, d.alpha, d.gamma, p, ls, &err)?;
    Ok(f.error_bound)
}
