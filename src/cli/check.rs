//! `qpv check`: certify externally supplied P and L_l.
//!
//! Exit 0 means certified: sound mode, every condition family and every
//! required data check holds. The mode comes from `--mode` or the gains
//! file's `mode` key and is sound otherwise, never from the model's
//! `design` blocks; a paper-mode check whose conditions hold exits 3
//! (a reproduction, not a certificate).

use super::gains::read_claim;
use super::input::by_name;
use super::input::{check_json_target, emit_json, exit, load_model_for, print_text, CliError};
use super::schema::CheckOutput;
use qpv_dsl::diagnostic::fmt_num;
use qpv_dsl::{AlphaSpec, GammaSpec, Mode, Model, OutputRoute, StateBound};
use qpv_solve::report::Design;
use qpv_solve::{Certificate, SolveError};
use std::path::{Path, PathBuf};

/// The options of `qpv check`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The model file (.qpv).
    pub file: PathBuf,
    /// JSON file with `P` (rows) and `L` (per vertex, NX rows of NY).
    #[arg(long, value_name = "GAINS.json")]
    pub gains: PathBuf,
    /// Which model of the file.
    #[arg(long, value_name = "NAME")]
    pub model: Option<String>,
    /// Condition set to check: sound or paper (default: the gains
    /// file's `mode`, else sound; never the model's design blocks).
    /// Paper mode certifies nothing: it exits 3 when its conditions hold.
    #[arg(long, value_name = "sound|paper", value_parser = by_name(&Mode::ALL, Mode::name))]
    pub mode: Option<Mode>,
    /// Decay rate to check (default: the gains file's `alpha`, else the
    /// first of the model's design blocks of the checked mode that fixes it).
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    pub alpha: Option<f64>,
    /// Region scaling to check (default: the gains file's `gamma`, else
    /// the first of the model's design blocks of the checked mode that fixes it).
    #[arg(long, value_name = "G", allow_hyphen_values = true)]
    pub gamma: Option<f64>,
    /// Check the gains at the sample period H seconds: the discrete
    /// decrease S5d of the Euler-stepped observer in place of S5
    /// (default: the gains file's `sample.h`, else continuous time).
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub sample: Option<f64>,
    /// Write the JSON report to this file (`-` for stdout).
    #[arg(long, value_name = "OUT")]
    pub json: Option<String>,
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
                "--{name} {}: expected {expected}",
                fmt_num(v)
            )))
        };
    }
    if let Some(v) = from_gains {
        return if valid(v) {
            Ok((v, "gains file".into()))
        } else {
            Err(CliError::Input(format!(
                "{}: the gains file's `{name}` is {}: expected {expected}",
                path.display(),
                fmt_num(v)
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

/// γ of a global design (an LPV plant in sound mode): unused, reported as 1.
fn unit_interval_or_one(g: f64) -> bool {
    g > 0.0 && g <= 1.0
}

/// The certificate of `design` on `model` by [`Design::recheck_on`] (the
/// re-check `qpv simulate` uses too), on the observer model
/// [`Design::observer_model`] builds: the split, the state bound, the output
/// route, the skew slack and the cube slacks the gains file claims. A
/// refused state bound claim is a failed certificate saying why (exit 1:
/// not certified, not an input error); a claim that does not fit the model
/// at all (a slack of the wrong shape) is bad input.
fn recheck(model: &Model, design: &Design, gains: &Path) -> Result<Certificate, CliError> {
    let plant = model.polytopic();
    let n = model.nx();
    let has_q = design
        .state_bound
        .as_ref()
        .and_then(|b| b.q.as_ref())
        .is_some_and(|q| q.len() == n && q.iter().all(|r| r.len() == n));
    if matches!(plant.state_bound, StateBound::Auto { .. }) && !has_q {
        return Err(CliError::Input(format!(
            "{}: the model has `state_bound auto`, so the gains file must carry the \
             design's state bound (`state_bound.Q`, {n}×{n}; a `qpv design --json` report does)",
            gains.display()
        )));
    }
    match design.observer_model(&plant) {
        Ok(observer) => {
            if let OutputRoute::Filter(f) = &design.route() {
                eprintln!(
                    "output filter route (pole {}, gain {}): checking against the augmented plant ({})",
                    f.pole,
                    f.gain,
                    observer.states.join(", ")
                );
            }
            if design.skew.is_some() {
                eprintln!(
                    "skew-symmetric slack K_k (from the gains file) added to N_k: the same plant"
                );
            }
            Ok(design.recheck_on(&observer))
        }
        Err(e @ SolveError::StateBound(_)) => Ok(Certificate::refused(
            design.mode,
            design.alpha,
            design.gamma,
            format!("state bound: {e}"),
        )),
        Err(e) => Err(CliError::Input(format!("{}: {e}", gains.display()))),
    }
}

/// The sample period to check at and where it came from: `--sample`, else
/// the gains file's `sample.h`, else none (continuous time).
fn choose_sample(
    flag: Option<f64>,
    claimed_h: Option<f64>,
    gains: &Path,
) -> Result<Option<(f64, &'static str)>, CliError> {
    match (flag, claimed_h) {
        (Some(h), _) if !positive(h) => Err(CliError::Input(format!(
            "--sample {}: expected a positive sample period in seconds",
            fmt_num(h)
        ))),
        (Some(h), _) => Ok(Some((h, "--sample"))),
        (None, Some(h)) if !positive(h) => Err(CliError::Input(format!(
            "{}: the gains file's `sample.h` is {}: expected a positive sample period in seconds",
            gains.display(),
            fmt_num(h)
        ))),
        (None, Some(h)) => Ok(Some((h, "gains file"))),
        (None, None) => Ok(None),
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
pub fn run(o: &Options) -> Result<i32, CliError> {
    let (gains, json) = (o.gains.as_path(), o.json.as_deref());
    check_json_target(json, &[&o.file, gains])?;
    let claim = read_claim(gains, "gains file")?;
    let (_, model) = load_model_for(&o.file, o.model.as_deref(), gains, claim.model())?;
    let (mode, mode_source) = match (o.mode, claim.mode) {
        (Some(m), _) => (m, "--mode"),
        (None, Some(m)) => (m, "gains file"),
        (None, None) => (Mode::Sound, "default"),
    };
    if mode == Mode::Paper && !model.polytopic().has_region() {
        // The printed conditions live on a region, which an LPV plant's
        // design does not have: say so before any value is judged by them.
        return Err(CliError::Input(format!(
            "model `{}` ({}): paper mode ({mode_source}) checks the paper's printed conditions on a \
             region, and this plant has none; the sound design of an LPV plant (every N_k and \
             M_k zero) is the global observer: check it in sound mode (docs/method.md §17)",
            model.name,
            o.file.display()
        )));
    }
    let (alpha, alpha_source) = choose_value(
        "alpha",
        o.alpha,
        claim.alpha,
        from_blocks(&model, mode, |d| match d.alpha {
            AlphaSpec::Fixed(a) => Some(a),
            AlphaSpec::Max => None,
        }),
        gains,
        (positive, "a positive finite number"),
    )?;
    let (gamma, gamma_source) = choose_value(
        "gamma",
        o.gamma,
        claim.gamma,
        from_blocks(&model, mode, |d| match d.gamma {
            GammaSpec::Fixed(g) => Some(g),
            GammaSpec::Search => None,
        }),
        gains,
        if model.is_lpv() && mode == Mode::Sound {
            (
                unit_interval_or_one as fn(f64) -> bool,
                "a number in (0, 1] (unused by the global observer of an LPV plant)",
            )
        } else {
            (unit_interval, "a number in (0, 1)")
        },
    )?;
    // The same plant either way; the conditions are checked in the
    // representation the gains were designed with (default: the mode's).
    let mut design = claim.at(mode, alpha, gamma);
    let split = design.split;
    let claimed_h = design.sample.as_ref().map(|s| s.h);
    let sample = choose_sample(o.sample, claimed_h, gains)?;
    if let Some((h, h_source)) = sample {
        if mode != Mode::Sound {
            // Say where the mode and the period came from: either may be
            // the file's, not a flag.
            let mode_from = match mode_source {
                "--mode" => "--mode paper".to_string(),
                _ => format!("the gains file's `mode: paper` ({})", gains.display()),
            };
            return Err(CliError::Input(format!(
                "a sample period (from {h_source}) checks the discrete decrease, a sound-mode \
                 condition, and {mode_from} asks for the paper's reproduction: check the \
                 sampled claim in sound mode{}",
                if mode_source == "--mode" {
                    " (drop --mode paper)"
                } else {
                    " (--mode sound), or drop the period"
                }
            )));
        }
        design = design.at_sample(h, alpha);
    }
    let cert = recheck(&model, &design, gains)?;
    let code = match (cert.passed, mode) {
        (true, Mode::Sound) => exit::CERTIFIED,
        (true, Mode::Paper) => exit::REPRODUCTION,
        (false, _) => exit::NOT_CERTIFIED,
    };
    let mut s = report_text(
        &cert,
        code,
        gains,
        (mode, mode_source),
        (alpha, &alpha_source),
        (gamma, &gamma_source),
        sample.map(|(h, source)| (h, source, model.time_unit)),
    );
    if let Some((h, _)) = sample {
        s.push_str(&sampled_lines(&model, &design, h, cert.passed));
    }
    print_text(json, &s);
    emit_json(
        json,
        &CheckOutput::new(&model.name, gains, mode_source, split, &cert, code),
    )?;
    Ok(code)
}

/// The text report of `qpv check`: what was checked against what, the
/// margin of every family and data check, the verdict and, where every
/// family holds without a verdict, the missing assumption.
fn report_text(
    cert: &Certificate,
    code: i32,
    gains: &Path,
    (mode, mode_source): (Mode, &str),
    (alpha, alpha_source): (f64, &str),
    (gamma, gamma_source): (f64, &str),
    sample: Option<(f64, &str, qpv_dsl::TimeUnit)>,
) -> String {
    let mut s = format!(
        "check of {} against {} mode ({}) at alpha = {} ({alpha_source}), gamma = {} ({gamma_source}):\n",
        gains.display(),
        match mode {
            Mode::Sound => mode.name().to_string(),
            Mode::Paper => format!("{} (reproduction: certifies nothing)", mode.name()),
        },
        match mode_source {
            "default" => "the default; --mode paper checks a reproduction",
            "--mode" => "from --mode",
            _ => "from the gains file's `mode`",
        },
        fmt_num(alpha),
        fmt_num(gamma)
    );
    if let Some((h, source, unit)) = sample {
        s.push_str(&format!(
            "  sampled at {} ({source}): the observer stepped by explicit Euler, V(e_k+1) <= {} V(e_k) (family S5d in place of S5)\n",
            unit.describe_period(h),
            fmt_num(1.0 - h * alpha)
        ));
    }
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
        exit::CERTIFIED if sample.is_some() => {
            "  => certified at the sample period: all conditions hold (sound mode)\n"
        }
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
    s
}

/// What the gains certify at the sample period h beyond the discrete
/// family (docs/method.md §16), recomputed from the model and the gains:
/// the continuous-plant bound when the check passed (or why it is not
/// computed), and the largest α the gains reach at h when it failed.
fn sampled_lines(model: &Model, design: &Design, h: f64, passed: bool) -> String {
    let claim = qpv_solve::report::continuous::sampled_claim(&model.polytopic(), design, h);
    if !passed {
        return if claim.capacity > 0.0 {
            format!(
                "     at this h the gains satisfy the discrete family up to alpha = {:.6} (its capacity for these P, L_l)\n",
                claim.capacity
            )
        } else {
            "     at this h the gains satisfy the discrete family at no alpha > 0 (the Euler step itself does not contract V)\n".into()
        };
    }
    match &claim.bound {
        Ok(b) => super::design::continuous_line(h, Some(b)).replace(
            "continuous plant sampled at h:",
            "continuous plant sampled at h (recomputed):",
        ),
        Err(why) => format!("  continuous plant sampled at h: no bound ({why})\n"),
    }
}
