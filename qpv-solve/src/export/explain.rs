//! Why a design is not certified, as one structured account with a
//! `Display`: what failed (the required data checks and the condition
//! families with their margins, or the solver's status), then the best
//! certified alternative (inside the request's own search; or what the
//! model's data admit, when a data check failed; or the best sound design
//! of the model, by a full search), and for `noise = min` the best
//! certified point of the rate–noise trade-off at lower rates.
//!
//! The searches these alternatives need are run here ([`explain`],
//! [`best_sound_design`]), so every front end words a failure the same way
//! and none of them runs searches of its own.

use crate::backend::Status;
use crate::model::gamma_max_for;
use crate::model::noise::NoiseChannels;
use crate::report::Design;
use crate::search::noise::design_noise;
use crate::settings::Settings;
use qpv_dsl::{AlphaSpec, DesignRequest, Mode, NoiseObjective, PolytopicModel, StateBound};
use std::fmt;

/// Why a design is not certified (or, in paper mode, does not satisfy the
/// printed conditions), and the best certified alternative found.
#[derive(Debug, Clone, PartialEq)]
pub struct Explanation {
    /// The mode of the design.
    pub mode: Mode,
    /// The required data checks and the condition families that failed
    /// (margin ≤ 0), in that order.
    pub failing: Vec<Failing>,
    /// The solver's status and Clarabel's own status name, for a design
    /// with nothing failing to show (no point was returned).
    pub solver: (Status, String),
    /// The best certified alternative.
    pub best: Best,
    /// For a `noise = min` request whose search certified nothing: the
    /// best certified point of the rate–noise trade-off at lower rates.
    pub tradeoff: Option<Tradeoff>,
}

/// A failed data check or condition family.
#[derive(Debug, Clone, PartialEq)]
pub struct Failing {
    /// Its key ("S4", "S5", ...).
    pub name: String,
    /// What a data check checks, in words (None for a condition family).
    pub description: Option<String>,
    /// Its worst margin (positive = satisfied).
    pub margin: f64,
}

/// The best certified alternative to a design that is not certified.
#[derive(Debug, Clone, PartialEq)]
pub enum Best {
    /// The best certified point of the request's own search (largest α).
    OwnSearch {
        /// Certified decay rate.
        alpha: f64,
        /// Its region scaling.
        gamma: f64,
    },
    /// A required data check failed, a property of the model and the
    /// request that no solver point changes: the γ the state bound admits
    /// by (S4) when the requested γ is above it, else None.
    Data {
        /// γ_max, when the requested γ exceeds it.
        gamma_max: Option<f64>,
    },
    /// The best certified sound design of the model.
    Sound(SoundDesign),
}

/// The outcome of a full sound design (α = max, γ = search, the default
/// split and conditions) of a model.
#[derive(Debug, Clone, PartialEq)]
pub enum SoundDesign {
    /// Certified at this (α, γ).
    Certified {
        /// Certified decay rate.
        alpha: f64,
        /// Its region scaling.
        gamma: f64,
    },
    /// The search certified nothing.
    NoneCertified,
    /// The design cannot be attempted; the reason.
    CannotAttempt(String),
}

/// The best certified point of the rate–noise trade-off below a `noise =
/// min` request's α (the same γ request, α halved up to three times).
#[derive(Debug, Clone, PartialEq)]
pub enum Tradeoff {
    /// A certified noise-optimal design.
    Point {
        /// Its α.
        alpha: f64,
        /// Its γ.
        gamma: f64,
        /// Its certified σ.
        sigma: f64,
        /// Its error bound per unit noise amplitude.
        error_bound: f64,
    },
    /// Nothing certified down to this α.
    NoneDownTo(f64),
    /// No noise-optimal design could be attempted at the lower rates; the
    /// last reason.
    CannotAttempt(String),
}

/// Three significant digits for messages (stable across solver versions).
pub(crate) fn sig(v: f64) -> String {
    format!("{}", format!("{v:.2e}").parse::<f64>().unwrap_or(v))
}

/// Why `design` (the result of `request` on `model`) is not certified,
/// with the best certified alternative: the request's own search if it
/// certified a point; else what the data admit if a required data check
/// failed (no search); else a full sound design of the model; plus, for
/// `noise = min`, the trade-off at lower rates. The searches use
/// `settings`.
pub fn explain(
    model: &PolytopicModel,
    request: &DesignRequest,
    design: &Design,
    settings: &Settings,
) -> Explanation {
    let mut failing: Vec<Failing> = design
        .data_checks
        .iter()
        .filter(|(_, c)| c.required && !c.passed)
        .map(|(name, c)| Failing {
            name: name.clone(),
            description: Some(c.description.clone()),
            margin: c.margin,
        })
        .collect();
    failing.extend(
        design
            .margins
            .iter()
            .filter(|(_, m)| **m <= 0.0)
            .map(|(name, m)| Failing {
                name: name.to_string(),
                description: None,
                margin: *m,
            }),
    );
    let data_failed = design.data_checks.values().any(|c| c.required && !c.passed);
    let own = design
        .search
        .iter()
        .filter(|s| s.certified)
        .map(|s| (s.alpha_certified.max(s.alpha), s.gamma))
        .fold(None, |best: Option<(f64, f64)>, p| match best {
            Some(b) if b.0 >= p.0 => Some(b),
            _ => Some(p),
        });
    let best = match own {
        Some((alpha, gamma)) => Best::OwnSearch { alpha, gamma },
        None if data_failed => Best::Data {
            gamma_max: state_bound_gamma_max(model, design)
                .filter(|g| g.is_finite() && *g > 0.0 && design.gamma > *g),
        },
        None => Best::Sound(best_sound_design(model, settings)),
    };
    let tradeoff = (request.noise == NoiseObjective::Min
        && !design.search.iter().any(|s| s.certified))
    .then(|| best_tradeoff_point(model, request, settings))
    .flatten();
    Explanation {
        mode: design.mode,
        failing,
        solver: (design.solver.status, design.solver.detail.clone()),
        best,
        tradeoff,
    }
}

/// γ_max of (S4) for the state bound the design used: the model's Q, or
/// the one the design computed for `state_bound auto`.
fn state_bound_gamma_max(model: &PolytopicModel, design: &Design) -> Option<f64> {
    match &model.state_bound {
        StateBound::Given(q) => Some(gamma_max_for(model, q)),
        _ => design.state_bound_q().map(|q| gamma_max_for(model, &q)),
    }
}

/// The best certified sound design of a model: a full α = max, γ = search
/// run with the default split and conditions.
pub fn best_sound_design(model: &PolytopicModel, settings: &Settings) -> SoundDesign {
    match crate::search::design(model, &DesignRequest::default(), settings) {
        Ok(d) if d.certifies() => SoundDesign::Certified {
            alpha: d.alpha,
            gamma: d.gamma,
        },
        Ok(_) => SoundDesign::NoneCertified,
        Err(e) => SoundDesign::CannotAttempt(e.to_string()),
    }
}

/// For a `noise = min` request with a fixed α: the first certified
/// noise-optimal design at α/2, α/4, α/8 (the same γ request), or why
/// there is none. None for α = max.
fn best_tradeoff_point(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
) -> Option<Tradeoff> {
    let AlphaSpec::Fixed(alpha) = request.alpha else {
        return None;
    };
    let channels = NoiseChannels::from_model(model);
    let mut last_err = None;
    for k in 1..=3 {
        let r = DesignRequest {
            alpha: AlphaSpec::Fixed(alpha / f64::from(1u32 << k)),
            ..request.clone()
        };
        match design_noise(model, &r, &channels, settings) {
            Ok(d) if d.certifies() => {
                if let Some(nb) = d.noise.as_ref() {
                    return Some(Tradeoff::Point {
                        alpha: d.alpha,
                        gamma: d.gamma,
                        sigma: nb.sigma,
                        error_bound: nb.error_bound,
                    });
                }
            }
            Ok(_) => {}
            Err(e) => last_err = Some(e.to_string()),
        }
    }
    Some(match last_err {
        Some(e) => Tradeoff::CannotAttempt(e),
        None => Tradeoff::NoneDownTo(alpha / 8.0),
    })
}

impl fmt::Display for Failing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.description {
            Some(d) if d.contains(self.name.as_str()) => write!(f, "{d}"),
            Some(d) => write!(f, "{} ({d})", self.name),
            None => write!(f, "{}", self.name),
        }?;
        write!(f, ", margin {}", sig(self.margin))
    }
}

impl fmt::Display for SoundDesign {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SoundDesign::Certified { alpha, gamma } => write!(
                f,
                "the best certified sound design of this model is alpha = {}, gamma = {}",
                sig(*alpha),
                sig(*gamma)
            ),
            SoundDesign::NoneCertified => {
                f.write_str("no sound design of this model could be certified")
            }
            SoundDesign::CannotAttempt(e) => {
                write!(f, "a sound design of this model cannot be attempted: {e}")
            }
        }
    }
}

impl fmt::Display for Best {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Best::OwnSearch { alpha, gamma } => write!(
                f,
                "best certified for this request: alpha = {}, gamma = {}",
                sig(*alpha),
                sig(*gamma)
            ),
            Best::Data { gamma_max: Some(g) } => write!(
                f,
                "this fails on the model's data alone: with this state bound, (S4) admits \
                 gamma up to {} only",
                sig(*g)
            ),
            Best::Data { gamma_max: None } => {
                f.write_str("this fails on the model's data alone, whatever the solver finds")
            }
            Best::Sound(s) => write!(f, "{s}"),
        }
    }
}

impl fmt::Display for Tradeoff {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tradeoff::Point {
                alpha,
                gamma,
                sigma,
                error_bound,
            } => write!(
                f,
                "the best certified trade-off point found is alpha = {}, gamma = {} \
                 (sigma = {}, error bound {} per unit noise)",
                sig(*alpha),
                sig(*gamma),
                sig(*sigma),
                sig(*error_bound)
            ),
            Tradeoff::NoneDownTo(a) => write!(
                f,
                "no noise-optimal design was certified down to alpha = {} either",
                sig(*a)
            ),
            Tradeoff::CannotAttempt(e) => write!(
                f,
                "no noise-optimal design could be attempted at lower rates: {e}"
            ),
        }
    }
}

/// "is not certified: failing: ...; <best>[; <trade-off>]" (for paper mode
/// "does not satisfy the paper's printed conditions: ..."), to follow the
/// request's name.
impl fmt::Display for Explanation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let verdict = match self.mode {
            Mode::Sound => "is not certified",
            Mode::Paper => "does not satisfy the paper's printed conditions",
        };
        write!(f, "{verdict}: ")?;
        if self.failing.is_empty() {
            let (status, detail) = &self.solver;
            write!(f, "the solver found no certified point (status: {status}")?;
            if !detail.is_empty() {
                write!(f, ", {detail}")?;
            }
            f.write_str(")")?;
        } else {
            let failing: Vec<String> = self.failing.iter().map(Failing::to_string).collect();
            write!(f, "failing: {}", failing.join("; "))?;
        }
        write!(f, "; {}", self.best)?;
        if let Some(t) = &self.tradeoff {
            write!(f, "; {t}")?;
        }
        Ok(())
    }
}
