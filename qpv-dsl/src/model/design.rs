//! Design requests: the `design { ... }` blocks and the settings they
//! choose (rate, region scaling, condition set, split, vertex conditions,
//! output route).

use super::build::{bad_value, pos, Builder, R};
use crate::ast::{self, Expr, ExprKind, Item};
use crate::diagnostic::fmt_num;
use crate::diagnostic::{suggest, Diag, Span};
use crate::poly::quote;
use crate::region::Region;
use serde::Serialize;

/// Which set of LMI conditions a design uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// The sound conditions (S1)-(S5): the default, and the only mode that certifies.
    #[default]
    Sound,
    /// The paper's printed conditions (13), (14), (26): reproduction only.
    Paper,
}

impl Mode {
    /// Every mode, in the order the language lists them.
    pub const ALL: [Mode; 2] = [Mode::Sound, Mode::Paper];

    /// The name used in the language, reports and the CLI ("sound" or
    /// "paper"); the one table of mode names, which serde's lowercase
    /// renaming matches.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Sound => "sound",
            Mode::Paper => "paper",
        }
    }
}

/// The convergence rate requested by a design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AlphaSpec {
    /// A fixed decay rate α > 0.
    Fixed(f64),
    /// The largest certifiable α (bisection).
    Max,
}

/// The region scaling γ requested by a design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GammaSpec {
    /// A fixed γ in (0, 1).
    Fixed(f64),
    /// Search γ over (0, min(1, γ_max)] maximising α.
    Search,
}

/// What a design does about measurement noise and process disturbances.
///
/// Every certified sound design reports its noise bound σ (the `noise` key
/// of the report); `min` makes σ the design objective instead of the
/// certification margin.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum NoiseObjective {
    /// The ordinary design (largest margin at the requested rate); its σ is
    /// reported, not optimised. The default.
    #[default]
    Free,
    /// Minimise σ in V' + αV ≤ σ(|v|² + |w|²) at the requested fixed α
    /// (and over γ too with `gamma = search`): the smallest certified
    /// error bound per unit noise at that rate.
    Min,
    /// Minimise a certified bound on the steady-state mean-square error for
    /// white output noise (and optional process noise) of the standard
    /// deviations `output_std` (`process_std`), drawn every `noise_period`.
    Rms,
}

impl NoiseObjective {
    /// Every objective: `min` first, the one that changes the design.
    pub const ALL: [NoiseObjective; 3] = [
        NoiseObjective::Min,
        NoiseObjective::Rms,
        NoiseObjective::Free,
    ];

    /// The name used in the language and the CLI ("free" or "min").
    pub fn name(self) -> &'static str {
        match self {
            NoiseObjective::Free => "free",
            NoiseObjective::Min => "min",
            NoiseObjective::Rms => "rms",
        }
    }
}

/// How N_k (and M_k) are represented in the design LMIs.
///
/// Only the symmetric part of N_k moves the plant, but the matrix
/// rows(N_k, e) in the conditions depends on the representation, so the
/// choice changes what can be certified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Split {
    /// N_k and M_k exactly as written (the paper's representation; the
    /// default in paper mode, which reproduces the printed conditions).
    AsWritten,
    /// N_k → (N_k + N_kᵀ)/2 and M_k → (M_k + M_kᵀ)/2: the same plant; the
    /// default in sound mode (measured better on the paper example).
    #[default]
    Symmetric,
    /// The symmetric split plus a skew-symmetric slack K_{k,l} = −K_{k,l}ᵀ
    /// per θ-vertex, searched by alternating solves after the symmetric
    /// design (N_k + K_k is still the same plant). Sound mode only; the
    /// report carries K so the design can be re-checked.
    SkewSlack,
}

impl Split {
    /// Every split, in the order the language lists them.
    pub const ALL: [Split; 3] = [Split::AsWritten, Split::Symmetric, Split::SkewSlack];

    /// The name used in the language, reports and the CLI.
    pub fn name(self) -> &'static str {
        match self {
            Split::AsWritten => "as_written",
            Split::Symmetric => "symmetric",
            Split::SkewSlack => "skew_slack",
        }
    }
}

impl Split {
    /// The default split of a condition set: [`Split::Symmetric`] in sound
    /// mode, [`Split::AsWritten`] in paper mode.
    pub fn default_for(mode: Mode) -> Split {
        match mode {
            Mode::Sound => Split::Symmetric,
            Mode::Paper => Split::AsWritten,
        }
    }
}

/// Which family of rate conditions (S5) is imposed, and how the region
/// enters them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Conditions {
    /// All p² vertex pairs (i, j) per θ-vertex.
    Full,
    /// One slack Z_l per θ-vertex (per rate combination for the double sum):
    /// 2p blocks per θ-vertex (sufficient for
    /// the full family, which certification still re-checks).
    Decoupled,
    /// The matrix-cube relaxation for a box or zonotope region with r
    /// generators: one pair of slacks per generator, 4r + 1 blocks per
    /// θ-vertex whatever the number of region vertices (2r + 1 solved when
    /// N_k and M_k are symmetric: the pair folds into one slack), and (S2)
    /// through a diagonal bound on GᵀPG (sufficient; the certificate checks
    /// the slack inequalities themselves).
    Cube,
    /// Not chosen by the user: the solver picks full, decoupled or cube from
    /// the problem's size (docs/method.md) and says which in the report.
    #[default]
    Auto,
}

impl Conditions {
    /// Every value, in the order the language lists them.
    pub const ALL: [Conditions; 4] = [
        Conditions::Full,
        Conditions::Decoupled,
        Conditions::Cube,
        Conditions::Auto,
    ];

    /// The name used in the language, reports and the CLI ("full",
    /// "decoupled", "cube" or "auto"), matching serde's lowercase renaming.
    pub fn name(self) -> &'static str {
        match self {
            Conditions::Full => "full",
            Conditions::Decoupled => "decoupled",
            Conditions::Cube => "cube",
            Conditions::Auto => "auto",
        }
    }
}

/// How the output map enters the design (see the output routes in docs/method.md).
///
/// With a constant C and M_k both routes are available and `double_sum` is
/// exactly the paper's single sum over θ-vertices. With a θ-dependent
/// C(θ), M_k(θ) the choice matters: the double sum keeps the observer's
/// structure and adds vertex-pair blocks; the filter adds ny states.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum OutputRoute {
    /// C(θ), M_k(θ) enter the rate conditions directly, with the gain
    /// L(θ) = Σ_l μ_l L_l: Σ_l Σ_m μ_l μ_m Ξ_{lm} ≺ 0 is imposed by the
    /// relaxation Ξ_ll ≺ 0, (2/(r−1)) Ξ_ll + Ξ_lm + Ξ_ml ≺ 0 (l ≠ m) of
    /// Tuan et al. (2001). The default.
    #[default]
    DoubleSum,
    /// Output post-filter x_y' = −a x_y + b y (per output), and the observer
    /// of the augmented plant (x, x_y) measures ỹ = x_y: the output matrix
    /// is constant and the θ-dependence moves into the state equation.
    Filter(OutputFilter),
}

/// The output post-filter x_{y,k}' = −pole·x_{y,k} + gain·y_k of
/// [`OutputRoute::Filter`] (A_y = −pole·I Hurwitz, B_y = gain·I diagonal).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OutputFilter {
    /// a > 0: the filter's pole is −a (rad/s).
    pub pole: f64,
    /// b ≠ 0: the filter's input gain (b = a gives unit DC gain).
    pub gain: f64,
}

impl OutputFilter {
    /// The pole used by `output_route = filter;` without options.
    pub const DEFAULT_POLE: f64 = 50.0;
}

impl Default for OutputFilter {
    fn default() -> Self {
        OutputFilter {
            pole: Self::DEFAULT_POLE,
            gain: Self::DEFAULT_POLE,
        }
    }
}

/// One `design { ... }` request of a model.
///
/// Build one with `..Default::default()` so that new settings do not break
/// construction sites: the default is `alpha = max; gamma = search;
/// mode = sound; split = symmetric; conditions = auto; output_route = double_sum;
/// noise = free;`.
/// In paper mode set
/// `split: Split::AsWritten` as well (see [`Split::default_for`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignRequest {
    /// Requested decay rate.
    pub alpha: AlphaSpec,
    /// Requested region scaling.
    pub gamma: GammaSpec,
    /// Condition set.
    pub mode: Mode,
    /// Representation of N_k, M_k in the LMIs.
    pub split: Split,
    /// Full, decoupled or cube rate conditions, or `Auto` (chosen by size).
    pub conditions: Conditions,
    /// How the output map enters the design (matters when C or M_k depend on θ).
    pub output_route: OutputRoute,
    /// Whether the design minimises the noise bound σ (`noise = min`).
    pub noise: NoiseObjective,
    /// `alpha = max(within = t)`: the design returned is the smallest-gain
    /// one certified at α ≥ (1 − t)·α_sup, α_sup the certified supremum
    /// (the last fraction of α is bought with large gains); 0 returns the
    /// fastest point found, as before. Default [`DesignRequest::DEFAULT_WITHIN`].
    pub within: f64,
    /// `max_gain = G`: every ‖L_l‖₂ ≤ G, imposed in the SDP and checked by
    /// the certificate from the reported gains. None: no bound.
    pub max_gain: Option<f64>,
    /// `sample = h`: design at the sample period h (seconds) of an explicit
    /// Euler implementation. The rate condition (S5) is replaced by the
    /// discrete decrease V(e_{k+1}) ≤ (1 − hα)V(e_k) (docs/method.md, "Design
    /// at the sample period"); α stays a rate per unit time. None: a
    /// continuous-time design.
    pub sample: Option<f64>,
    /// `float = f32`: the generated observer computes in single precision
    /// (constants rounded to f32 before the certificate checks them, and a
    /// certified f32 error floor). Default f64.
    pub float: Float,
    /// `poles = disk(..), sector(..), strip(..)`: the regions (intersected)
    /// the eigenvalues of the frozen error dynamics must lie in, imposed with
    /// the design's P and certified (family "D"); empty: none.
    pub poles: Vec<super::poles::PoleRegion>,
    /// `output_std = s` or `s1, s2, ..`: the standard deviation of the white
    /// noise on each noisy output (one value for all), for `noise = rms`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub output_std: Vec<f64>,
    /// `process_std = q` or `q1, ..`: the standard deviation of white process
    /// noise on each state (one value for all; empty: none), for `noise = rms`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub process_std: Vec<f64>,
    /// `noise_period = dt`: the period (in the model's unit of time) at which the noise samples
    /// of `output_std` and `process_std` are drawn and held; the white-noise
    /// intensity is std²·dt. Needed by `noise = rms`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_period: Option<f64>,
    /// The `design` block in the source, for errors about this request.
    pub span: Span,
}

/// The floating-point type of a design's generated observer (`float = f32`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum Float {
    /// Double precision (the default).
    #[default]
    F64,
    /// Single precision: every value, literal and operation of the
    /// generated observer is `f32`.
    F32,
}

impl Float {
    /// `"f64"` or `"f32"`, as written in a design block.
    pub fn name(self) -> &'static str {
        match self {
            Float::F64 => "f64",
            Float::F32 => "f32",
        }
    }
}

impl Default for DesignRequest {
    fn default() -> Self {
        DesignRequest {
            alpha: AlphaSpec::Max,
            gamma: GammaSpec::Search,
            mode: Mode::Sound,
            split: Split::default_for(Mode::Sound),
            conditions: Conditions::Auto,
            output_route: OutputRoute::DoubleSum,
            noise: NoiseObjective::Free,
            within: DesignRequest::DEFAULT_WITHIN,
            max_gain: None,
            sample: None,
            float: Float::F64,
            poles: Vec::new(),
            output_std: Vec::new(),
            process_std: Vec::new(),
            noise_period: None,
            span: Span::default(),
        }
    }
}

impl DesignRequest {
    /// The default tolerance of `alpha = max`: 1 % below the certified supremum.
    pub const DEFAULT_WITHIN: f64 = 0.01;
    /// The largest tolerance accepted (half the supremum).
    pub const MAX_WITHIN: f64 = 0.5;

    /// The first pair of settings of this request that cannot be combined,
    /// if any: the one table of these rules, checked by the language (at
    /// the key [`Clash::key`] names), the solver and the command line (a
    /// request its flags were applied to).
    pub fn validate(&self) -> Result<(), Clash> {
        let sound = self.mode == Mode::Sound;
        let skew = self.split == Split::SkewSlack;
        let noise_min = self.noise == NoiseObjective::Min;
        if let Some(c) = self.rms_clash() {
            return Err(c);
        }
        let clash = if skew && !sound {
            Some(Clash::SkewSlackPaper)
        } else if noise_min && !sound {
            Some(Clash::NoiseMinPaper)
        } else if noise_min && self.alpha == AlphaSpec::Max {
            Some(Clash::NoiseMinAlphaMax)
        } else if noise_min && skew {
            Some(Clash::NoiseMinSkewSlack)
        } else if self.max_gain.is_some() && noise_min {
            Some(Clash::MaxGainNoiseMin)
        } else if self.max_gain.is_some() && skew {
            Some(Clash::MaxGainSkewSlack)
        } else if self.max_gain.is_some() && !sound {
            Some(Clash::MaxGainPaper)
        } else if !self.poles.is_empty() && !sound {
            Some(Clash::PolesPaper)
        } else if !self.poles.is_empty() && noise_min {
            Some(Clash::PolesNoiseMin)
        } else if !self.poles.is_empty() && skew {
            Some(Clash::PolesSkewSlack)
        } else if !self.poles.is_empty() && self.sample.is_some() {
            Some(Clash::PolesSample)
        } else if self.sample.is_none() {
            None
        } else if !sound {
            Some(Clash::SamplePaper)
        } else if self.conditions == Conditions::Cube {
            Some(Clash::SampleCube)
        } else if skew {
            Some(Clash::SampleSkewSlack)
        } else {
            None
        };
        clash.map_or(Ok(()), Err)
    }
}

impl DesignRequest {
    /// The first clash of `noise = rms` (or of its keys without it), if any.
    fn rms_clash(&self) -> Option<Clash> {
        let rms = self.noise == NoiseObjective::Rms;
        let keys = !self.output_std.is_empty()
            || !self.process_std.is_empty()
            || self.noise_period.is_some();
        if !rms {
            return keys.then_some(Clash::RmsKeysWithoutRms);
        }
        if self.mode != Mode::Sound {
            Some(Clash::RmsPaper)
        } else if self.split == Split::SkewSlack {
            Some(Clash::RmsSkewSlack)
        } else if self.max_gain.is_some() {
            Some(Clash::RmsMaxGain)
        } else if !self.poles.is_empty() {
            Some(Clash::RmsPoles)
        } else if self.sample.is_some() {
            Some(Clash::RmsSample)
        } else if self.output_std.is_empty() {
            Some(Clash::RmsNoOutputStd)
        } else if self.noise_period.is_none() {
            Some(Clash::RmsNoPeriod)
        } else {
            None
        }
    }
}

/// Two settings of a design request that cannot be combined
/// ([`DesignRequest::validate`]). `Display` says why, in the language's
/// words (`noise = min`, `alpha = max`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clash {
    /// `split = skew_slack` in paper mode.
    SkewSlackPaper,
    /// `noise = min` with `alpha = max`.
    NoiseMinAlphaMax,
    /// `noise = min` in paper mode.
    NoiseMinPaper,
    /// `noise = min` with `split = skew_slack`.
    NoiseMinSkewSlack,
    /// `max_gain` with `noise = min`.
    MaxGainNoiseMin,
    /// `max_gain` with `split = skew_slack`.
    MaxGainSkewSlack,
    /// `max_gain` in paper mode.
    MaxGainPaper,
    /// `poles` in paper mode.
    PolesPaper,
    /// `poles` with `noise = min`.
    PolesNoiseMin,
    /// `poles` with `split = skew_slack`.
    PolesSkewSlack,
    /// `poles` with `sample`.
    PolesSample,
    /// `sample` in paper mode.
    SamplePaper,
    /// `sample` with `conditions = cube`.
    SampleCube,
    /// `sample` with `split = skew_slack`.
    SampleSkewSlack,
    /// `output_std`, `process_std` or `noise_period` without `noise = rms`.
    RmsKeysWithoutRms,
    /// `noise = rms` in paper mode.
    RmsPaper,
    /// `noise = rms` with `split = skew_slack`.
    RmsSkewSlack,
    /// `noise = rms` with `max_gain`.
    RmsMaxGain,
    /// `noise = rms` with `poles`.
    RmsPoles,
    /// `noise = rms` with `sample` (not implemented yet).
    RmsSample,
    /// `noise = rms` without `output_std`.
    RmsNoOutputStd,
    /// `noise = rms` without `noise_period`.
    RmsNoPeriod,
}

impl Clash {
    /// The setting a message about the clash points at (a key of the
    /// `design` block).
    pub fn key(self) -> &'static str {
        match self {
            Clash::SkewSlackPaper => "split",
            Clash::NoiseMinAlphaMax => "noise",
            Clash::NoiseMinPaper | Clash::SamplePaper => "mode",
            Clash::NoiseMinSkewSlack | Clash::SampleSkewSlack => "split",
            Clash::MaxGainNoiseMin | Clash::MaxGainSkewSlack | Clash::MaxGainPaper => "max_gain",
            Clash::SampleCube => "conditions",
            Clash::PolesPaper
            | Clash::PolesNoiseMin
            | Clash::PolesSkewSlack
            | Clash::PolesSample => "poles",
            Clash::RmsKeysWithoutRms
            | Clash::RmsNoOutputStd
            | Clash::RmsNoPeriod
            | Clash::RmsPaper
            | Clash::RmsSkewSlack
            | Clash::RmsMaxGain
            | Clash::RmsPoles
            | Clash::RmsSample => "noise",
        }
    }
}

impl std::fmt::Display for Clash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Clash::SkewSlackPaper => {
                "`split = skew_slack` needs `mode = sound`: the paper's printed conditions \
                 are reproduced as written, with no slack"
            }
            Clash::NoiseMinAlphaMax => {
                "`noise = min` needs a fixed `alpha` (e.g. `alpha = 5;`): `alpha = max` is \
                 the fastest certified design, not a noise trade-off; pick a rate below it"
            }
            Clash::NoiseMinPaper => {
                "`noise = min` needs `mode = sound`: the paper's printed conditions certify \
                 nothing, so they give no noise bound"
            }
            Clash::NoiseMinSkewSlack => {
                "`noise = min` does not search the skew slack: use `split = symmetric` or \
                 `split = as_written`"
            }
            Clash::MaxGainNoiseMin => {
                "`max_gain` cannot be combined with `noise = min` (its SDP has no gain bound)"
            }
            Clash::MaxGainSkewSlack => {
                "`max_gain` cannot be combined with `split = skew_slack` (the slack search \
                 has no gain bound)"
            }
            Clash::MaxGainPaper => {
                "`max_gain` cannot be combined with `mode = paper` (the printed conditions \
                 certify nothing)"
            }
            Clash::PolesPaper => {
                "`poles` needs `mode = sound`: the paper's printed conditions certify nothing"
            }
            Clash::PolesNoiseMin => {
                "`poles` cannot be combined with `noise = min` (its SDP has no pole-region \
                 blocks)"
            }
            Clash::PolesSkewSlack => {
                "`poles` cannot be combined with `split = skew_slack` (the slack search has no \
                 pole-region blocks)"
            }
            Clash::PolesSample => {
                "`poles` is a continuous-time condition (eigenvalues of the error dynamics): \
                 it cannot be combined with `sample`"
            }
            Clash::SamplePaper => {
                "`sample` needs `mode = sound`: the paper's printed conditions have no \
                 discrete-time form and certify nothing"
            }
            Clash::SampleCube => {
                "`sample` is designed with the full or the decoupled vertex family \
                 (`conditions = full`, `decoupled` or `auto`): the matrix-cube relaxation \
                 of `conditions = cube` has no discrete-time form in qpv yet"
            }
            Clash::SampleSkewSlack => {
                "`split = skew_slack` searches its slack with the continuous rate \
                 conditions: use `split = symmetric` or `as_written` with `sample`"
            }
            Clash::RmsKeysWithoutRms => {
                "`output_std`, `process_std` and `noise_period` describe the white noise of \
                 `noise = rms`: add `noise = rms;` or remove them"
            }
            Clash::RmsPaper => {
                "`noise = rms` needs `mode = sound`: the paper's printed conditions certify \
                 nothing, so they give no RMS bound"
            }
            Clash::RmsSkewSlack => {
                "`noise = rms` does not search the skew slack: use `split = symmetric` or \
                 `split = as_written`"
            }
            Clash::RmsMaxGain => {
                "`max_gain` cannot be combined with `noise = rms` (its SDP has no gain bound)"
            }
            Clash::RmsPoles => {
                "`poles` cannot be combined with `noise = rms` (its SDP has no pole-region \
                 blocks)"
            }
            Clash::RmsSample => {
                "`noise = rms` is a continuous-time design: its sampled form (`sample = h`) \
                 is not implemented yet"
            }
            Clash::RmsNoOutputStd => {
                "`noise = rms` needs the output noise: `output_std = s;` (one standard \
                 deviation per noisy output, in its units, or one value for all)"
            }
            Clash::RmsNoPeriod => {
                "`noise = rms` needs `noise_period = dt;`: the period (in the model's unit \
                 of time) at which the noise samples are drawn and held (the white-noise \
                 intensity is std²·dt)"
            }
        })
    }
}

impl std::fmt::Display for DesignRequest {
    /// The request as the settings of a `design` block: `alpha = 5; gamma =
    /// search; mode = sound; split = symmetric; conditions = auto`, then
    /// the output route, `noise`, `alpha = max`'s `within`, `max_gain`,
    /// `sample` and `float` where they differ from the default.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.alpha {
            AlphaSpec::Fixed(a) => write!(f, "alpha = {a}")?,
            AlphaSpec::Max => f.write_str("alpha = max")?,
        }
        if self.alpha == AlphaSpec::Max && self.within != DesignRequest::DEFAULT_WITHIN {
            write!(f, "(within = {})", self.within)?;
        }
        match self.gamma {
            GammaSpec::Fixed(g) => write!(f, "; gamma = {g}")?,
            GammaSpec::Search => f.write_str("; gamma = search")?,
        }
        write!(
            f,
            "; mode = {}; split = {}; conditions = {}",
            self.mode.name(),
            self.split.name(),
            self.conditions.name()
        )?;
        if let OutputRoute::Filter(o) = self.output_route {
            write!(
                f,
                "; output_route = filter(pole = {}, gain = {})",
                o.pole, o.gain
            )?;
        }
        if self.noise != NoiseObjective::Free {
            write!(f, "; noise = {}", self.noise.name())?;
        }
        write_list(f, "output_std", &self.output_std)?;
        write_list(f, "process_std", &self.process_std)?;
        if let Some(dt) = self.noise_period {
            write!(f, "; noise_period = {dt}")?;
        }
        if let Some(g) = self.max_gain {
            write!(f, "; max_gain = {g}")?;
        }
        if let Some(h) = self.sample {
            write!(f, "; sample = {h}")?;
        }
        if self.float != Float::F64 {
            write!(f, "; float = {}", self.float.name())?;
        }
        for (k, r) in self.poles.iter().enumerate() {
            write!(f, "{}{r}", if k == 0 { "; poles = " } else { ", " })?;
        }
        Ok(())
    }
}

/// `; key = v1, v2` for a non-empty list.
fn write_list(f: &mut std::fmt::Formatter<'_>, key: &str, v: &[f64]) -> std::fmt::Result {
    for (k, x) in v.iter().enumerate() {
        write!(
            f,
            "{}{x}",
            if k == 0 {
                format!("; {key} = ")
            } else {
                ", ".into()
            }
        )?;
    }
    Ok(())
}

/// The keys of a `design { ... }` block.
const DESIGN_KEYS: [&str; 14] = [
    "alpha",
    "gamma",
    "mode",
    "split",
    "conditions",
    "output_route",
    "noise",
    "max_gain",
    "sample",
    "float",
    "poles",
    "output_std",
    "process_std",
    "noise_period",
];

impl Builder<'_> {
    /// Every `design { ... }` block, in source order.
    pub(super) fn designs(&self, region: &Region) -> R<Vec<DesignRequest>> {
        let mut out = Vec::new();
        for item in &self.ast.items {
            let Item::Design(block) = item else { continue };
            out.push(self.design_block(block, region)?);
        }
        Ok(out)
    }

    /// One design block: each key at most once, then the split default of
    /// its mode and the settings it cannot combine.
    fn design_block(&self, block: &ast::DesignBlock, region: &Region) -> R<DesignRequest> {
        let mut req = DesignRequest {
            span: block.span,
            ..Default::default()
        };
        let mut split: Option<Split> = None;
        let mut seen = Seen {
            keys: Vec::new(),
            block: block.span,
        };
        for entry in &block.entries {
            self.design_entry(entry, &seen, &mut req, &mut split)?;
            seen.keys.push((entry.key.name.as_str(), entry.key.span));
        }
        req.split = split.unwrap_or(Split::default_for(req.mode));
        if req.conditions == Conditions::Cube && region.zonotope_generators().is_none() {
            return Err(Diag::new(
                seen.at("conditions"),
                format!(
                    "`conditions = cube` needs a region that is a box, a parallelotope or a \
                     zonotope (`region zonotope [...]`); this region has {} vertices and {} \
                     facets and is none of them: use `conditions = full` or `decoupled`",
                    region.vertices.len(),
                    region.facets.len()
                ),
            ));
        }
        if let Err(clash) = req.validate() {
            return Err(Diag::new(seen.at(clash.key()), clash.to_string()));
        }
        Ok(req)
    }

    /// One `key = value` of a design block into `req` (`split` aside: its
    /// default depends on the mode); an error for a key set twice, options
    /// on a key that takes none, or an unknown key.
    fn design_entry(
        &self,
        entry: &ast::DesignEntry,
        seen: &Seen<'_>,
        req: &mut DesignRequest,
        split: &mut Option<Split>,
    ) -> R<()> {
        let key = entry.key.name.as_str();
        if let Some((_, prev)) = seen.keys.iter().find(|(k, _)| *k == key) {
            return Err(Diag::new(
                entry.key.span,
                format!(
                    "`{key}` is set twice in this design block (first at {})",
                    pos(self.src, *prev)
                ),
            ));
        }
        let list = matches!(key, "poles" | "output_std" | "process_std");
        if let (Some((v, _)), false) = (entry.more.first(), list) {
            return Err(Diag::new(
                v.span,
                format!(
                    "`{key}` takes one value (only `poles`, `output_std` and `process_std` \
                     take a list: `poles = disk(..), sector(..)`)"
                ),
            ));
        }
        if let (Some((_, ospan)), false) = (
            &entry.options,
            key == "output_route" || key == "alpha" || key == "poles",
        ) {
            return Err(Diag::new(
                *ospan,
                format!(
                    "`{key}` takes no options in parentheses (only `alpha = max(within = ..)`, \
                     `output_route = filter(...)` and the regions of `poles` do)"
                ),
            ));
        }
        match key {
            "alpha" => {
                req.alpha = self.alpha_value(&entry.value)?;
                if let Some((opts, ospan)) = &entry.options {
                    if req.alpha != AlphaSpec::Max {
                        return Err(Diag::new(
                            *ospan,
                            "only `alpha = max` takes options (`max(within = 0.01)`): a \
                             fixed alpha is designed as given",
                        ));
                    }
                    req.within = self.within_option(opts)?;
                }
            }
            "max_gain" => req.max_gain = Some(self.max_gain_value(&entry.value)?),
            "sample" => req.sample = Some(self.sample_value(&entry.value)?),
            "gamma" => req.gamma = self.gamma_value(&entry.value)?,
            "mode" => req.mode = self.mode_value(&entry.value)?,
            "split" => *split = Some(self.split_value(&entry.value)?),
            "conditions" => req.conditions = self.conditions_value(&entry.value)?,
            "output_route" => req.output_route = self.output_route_value(entry)?,
            "noise" => req.noise = self.noise_value(&entry.value)?,
            "float" => req.float = self.float_value(&entry.value)?,
            "poles" => req.poles = self.poles_value(entry)?,
            "output_std" => req.output_std = self.std_values(entry, "output_std")?,
            "process_std" => req.process_std = self.std_values(entry, "process_std")?,
            "noise_period" => req.noise_period = Some(self.noise_period_value(&entry.value)?),
            _ => {
                let hint = suggest(key, DESIGN_KEYS)
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                return Err(Diag::new(
                    entry.key.span,
                    format!(
                        "unknown design setting `{key}`: expected `alpha`, `gamma`, `mode`, \
                         `split`, `conditions`, `output_route`, `noise`, `max_gain`, `sample`, `float`, `poles`, `output_std`, `process_std` or `noise_period`{hint}"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// `output_std` / `process_std`: one or more standard deviations, each
    /// positive and finite (options in parentheses are refused).
    fn std_values(&self, entry: &ast::DesignEntry, key: &str) -> R<Vec<f64>> {
        let mut out = Vec::new();
        let values = std::iter::once((&entry.value, &entry.options))
            .chain(entry.more.iter().map(|(v, o)| (v, o)));
        for (v, opts) in values {
            if let Some((_, ospan)) = opts {
                return Err(Diag::new(
                    *ospan,
                    format!("`{key}` takes numbers, without options"),
                ));
            }
            let s = self.constant(v, "a noise standard deviation")?;
            if !(s.is_finite() && s > 0.0) {
                return Err(bad_value(
                    v.span,
                    key,
                    "a positive standard deviation (in the units of the output or state), or a \
                     list of them",
                    &fmt_num(s),
                ));
            }
            out.push(s);
        }
        Ok(out)
    }

    /// `noise_period = dt`: seconds, positive and finite.
    fn noise_period_value(&self, v: &Expr) -> R<f64> {
        let h = self.constant(v, "the noise period `noise_period`")?;
        if !(h.is_finite() && h > 0.0) {
            return Err(bad_value(
                v.span,
                "noise_period",
                "a positive period in seconds (e.g. `noise_period = 1e-3` for noise samples \
                 drawn at 1 kHz)",
                &fmt_num(h),
            ));
        }
        Ok(h)
    }

    /// `sample = h`: the sample period in seconds, positive and finite.
    fn sample_value(&self, v: &Expr) -> R<f64> {
        let h = self.constant(v, "the sample period `sample`")?;
        if !(h.is_finite() && h > 0.0) {
            return Err(bad_value(
                v.span,
                "sample",
                "a positive sample period in seconds (e.g. `sample = 1e-4` for 10 kHz)",
                &fmt_num(h),
            ));
        }
        Ok(h)
    }

    /// The options of `alpha = max(...)`: `within = t`, 0 ≤ t ≤ 0.5.
    fn within_option(&self, options: &[ast::DesignEntry]) -> R<f64> {
        let mut within = None;
        for entry in options {
            let key = entry.key.name.as_str();
            if key != "within" {
                let hint = suggest(key, ["within"])
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                return Err(Diag::new(
                    entry.key.span,
                    format!(
                        "unknown option `{key}` of `alpha = max`: expected `within` (the \
                         fraction of the certified supremum α may give up for smaller gains, \
                         e.g. `within = 0.01`){hint}"
                    ),
                ));
            }
            if within.is_some() {
                return Err(Diag::new(entry.key.span, "`within` is set twice"));
            }
            let t = self.constant(&entry.value, "the tolerance `within`")?;
            if !(0.0..=DesignRequest::MAX_WITHIN).contains(&t) {
                return Err(bad_value(
                    entry.value.span,
                    "within",
                    "a fraction from 0 (the fastest point found) to 0.5, e.g. 0.01 for 1 %",
                    &fmt_num(t),
                ));
            }
            within = Some(t);
        }
        Ok(within.unwrap_or(DesignRequest::DEFAULT_WITHIN))
    }

    /// `max_gain = G`, G > 0 finite.
    fn max_gain_value(&self, v: &Expr) -> R<f64> {
        let g = self.constant(v, "the gain bound max_gain")?;
        if !(g.is_finite() && g > 0.0) {
            return Err(bad_value(
                v.span,
                "max_gain",
                "a positive number (the bound on every ‖L_l‖₂)",
                &fmt_num(g),
            ));
        }
        Ok(g)
    }

    /// `noise = free | min`.
    fn noise_value(&self, v: &Expr) -> R<NoiseObjective> {
        let w = word(v);
        match NoiseObjective::ALL
            .into_iter()
            .find(|x| Some(x.name()) == w)
        {
            Some(x) => Ok(x),
            None => Err(bad_value(
                v.span,
                "noise",
                "`free` (the default), `min` or `rms`",
                &self.found(v),
            )),
        }
    }

    /// `float = f64 | f32`.
    fn float_value(&self, v: &Expr) -> R<Float> {
        match word(v) {
            Some("f64") => Ok(Float::F64),
            Some("f32") => Ok(Float::F32),
            _ => Err(bad_value(
                v.span,
                "float",
                "`f64` (the default) or `f32`",
                &self.found(v),
            )),
        }
    }

    /// The source text of a value, for "found `...`" in messages.
    fn found(&self, v: &Expr) -> String {
        quote(self.src, v.span).replace('`', "")
    }

    /// `alpha = max` or a positive constant.
    fn alpha_value(&self, v: &Expr) -> R<AlphaSpec> {
        const WANT: &str = "a positive number or `max`";
        match word(v) {
            Some("max") => Ok(AlphaSpec::Max),
            Some(w) => Err(bad_value(v.span, "alpha", WANT, w)),
            None => {
                let a = self.constant(v, "the design value of alpha")?;
                if a <= 0.0 {
                    return Err(bad_value(v.span, "alpha", WANT, &fmt_num(a)));
                }
                Ok(AlphaSpec::Fixed(a))
            }
        }
    }

    /// `gamma = search` or a constant strictly between 0 and 1.
    fn gamma_value(&self, v: &Expr) -> R<GammaSpec> {
        const WANT: &str = "a number strictly between 0 and 1 or `search`";
        match word(v) {
            Some("search") => Ok(GammaSpec::Search),
            Some(w) => Err(bad_value(v.span, "gamma", WANT, w)),
            None => {
                let g = self.constant(v, "the design value of gamma")?;
                if !(g > 0.0 && g < 1.0) {
                    return Err(bad_value(v.span, "gamma", WANT, &fmt_num(g)));
                }
                Ok(GammaSpec::Fixed(g))
            }
        }
    }

    /// `mode = sound | paper`.
    fn mode_value(&self, v: &Expr) -> R<Mode> {
        let w = word(v);
        match Mode::ALL.into_iter().find(|x| Some(x.name()) == w) {
            Some(x) => Ok(x),
            None => Err(bad_value(
                v.span,
                "mode",
                "`sound` or `paper`",
                &self.found(v),
            )),
        }
    }

    /// `split = as_written | symmetric | skew_slack`.
    fn split_value(&self, v: &Expr) -> R<Split> {
        let w = word(v);
        match Split::ALL.into_iter().find(|x| Some(x.name()) == w) {
            Some(x) => Ok(x),
            None => Err(bad_value(
                v.span,
                "split",
                "`as_written`, `symmetric` or `skew_slack`",
                &self.found(v),
            )),
        }
    }

    /// `conditions = full | decoupled | cube | auto`.
    fn conditions_value(&self, v: &Expr) -> R<Conditions> {
        let w = word(v);
        match Conditions::ALL.into_iter().find(|x| Some(x.name()) == w) {
            Some(x) => Ok(x),
            None => Err(bad_value(
                v.span,
                "conditions",
                "`full`, `decoupled`, `cube` or `auto`",
                &self.found(v),
            )),
        }
    }

    /// `output_route = double_sum | filter | filter(pole = .., gain = ..)`.
    fn output_route_value(&self, entry: &ast::DesignEntry) -> R<OutputRoute> {
        let v = &entry.value;
        match word(v) {
            Some("double_sum") => {
                if let Some((_, ospan)) = &entry.options {
                    return Err(Diag::new(
                        *ospan,
                        "`double_sum` takes no options (only `filter(pole = .., \
                             gain = ..)` does)",
                    ));
                }
                Ok(OutputRoute::DoubleSum)
            }
            Some("filter") => Ok(OutputRoute::Filter(
                self.filter_options(
                    entry
                        .options
                        .as_ref()
                        .map(|(o, _)| o.as_slice())
                        .unwrap_or(&[]),
                )?,
            )),
            _ => Err(bad_value(
                v.span,
                "output_route",
                "`double_sum` or `filter` (optionally `filter(pole = .., gain = ..)`)",
                &self.found(v),
            )),
        }
    }

    /// `filter(pole = .., gain = ..)`: both optional; gain defaults to pole
    /// (unit DC gain), pole to [`OutputFilter::DEFAULT_POLE`].
    fn filter_options(&self, options: &[ast::DesignEntry]) -> R<OutputFilter> {
        let mut pole = None;
        let mut gain = None;
        for entry in options {
            let key = entry.key.name.as_str();
            let slot = match key {
                "pole" => &mut pole,
                "gain" => &mut gain,
                _ => {
                    let hint = suggest(key, ["pole", "gain"])
                        .map(|s| format!(" (did you mean `{s}`?)"))
                        .unwrap_or_default();
                    return Err(Diag::new(
                        entry.key.span,
                        format!(
                            "unknown filter option `{key}`: expected `pole` (a > 0, the filter is \
                             x_y' = -a x_y + b y) or `gain` (b ≠ 0){hint}"
                        ),
                    ));
                }
            };
            if let Some((_, prev)) = slot {
                return Err(Diag::new(
                    entry.key.span,
                    format!("`{key}` is set twice (first at {})", pos(self.src, *prev)),
                ));
            }
            let v = &entry.value;
            let value = self.constant(v, &format!("the filter option {key}"))?;
            let ok = value.is_finite()
                && if key == "pole" {
                    value > 0.0
                } else {
                    value != 0.0
                };
            if !ok {
                let want = if key == "pole" {
                    "a positive number (the filter pole is -pole)"
                } else {
                    "a nonzero number"
                };
                return Err(bad_value(v.span, key, want, &fmt_num(value)));
            }
            *slot = Some((value, entry.key.span));
        }
        let pole = pole.map(|p| p.0).unwrap_or(OutputFilter::DEFAULT_POLE);
        Ok(OutputFilter {
            pole,
            gain: gain.map(|g| g.0).unwrap_or(pole),
        })
    }
}

/// The keys of one design block read so far, with their spans: an error
/// about a combination of settings points at the key that clashes.
struct Seen<'a> {
    keys: Vec<(&'a str, Span)>,
    /// The whole block, where such an error points when the key is absent.
    block: Span,
}

impl Seen<'_> {
    /// Where `key` was set, else the block.
    fn at(&self, key: &str) -> Span {
        self.keys
            .iter()
            .find(|(k, _)| *k == key)
            .map_or(self.block, |(_, s)| *s)
    }
}

/// The bare word of a value (`max`, `paper`), if it is one.
fn word(v: &Expr) -> Option<&str> {
    match &v.kind {
        ExprKind::Name(n) => Some(n.as_str()),
        _ => None,
    }
}
