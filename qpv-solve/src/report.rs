//! The serialisable result of a design: [`Design`] and its parts.
//!
//! JSON layout (keys exactly as written): `model`, `mode`, `split`,
//! `conditions`, `verdict`, `alpha`, `gamma`, `P` (rows), `Gamma` (one matrix per
//! vertex, rows), `L` (one nx × ny matrix per vertex, rows), `gain_norms`,
//! `margins` (family → worst margin, positive = satisfied), `data_checks`,
//! `solver` {`status`, `detail`, `iterations`, `seconds`, `assembly_seconds`,
//! `certify_seconds`}, `seconds_total`, `search` (every step tried),
//! `notes`, a human `summary` and `state_bound` {`source`, `Q`, `h`,
//! `h_fixed`, `gamma_max`, `split`, `check`, `solves`, `seconds`, `notes`}
//! (see [`crate::model::state_bound::StateBoundInfo`]) and `output_route` {`route`
//! ("double_sum" | "filter"), `output_varies`, `filter` {`pole`, `gain`,
//! `bound`} or null, `states`, `combinations`} (see
//! [`crate::model::output_filter::OutputRouteInfo`]; for the filter route `P` is
//! (nx+ny)² and each `L` has nx + ny rows).
//! On a certified sound-mode design the report also carries `noise`
//! ({`sigma`, `max_amplitude`, `error_bound`, `per_state`, `noisy_outputs`,
//! `disturbances`, `check`}, see [`NoiseBound`]) and
//! `sampling` ({`max_step_euler`, `beta`, `step_estimate_rk4`}, see
//! [`crate::certificate::sampling::Sampling`]). A γ search adds `gamma_search`
//! ({`gamma_lo`, `gamma_hi`, `grid_points`, `points`, `solves`,
//! `local_maxima` [{`gamma`, `alpha`, `refined`}], `continued`}, see
//! [`GammaSearchInfo`]). Matrices are plain `Vec<Vec<f64>>` rows;
//! serde_json writes the shortest round-tripping decimal of every `f64`, so
//! a reloaded design certifies exactly as the written one.

pub mod continuous;
pub mod figures;
mod notes;

pub use notes::{Note, Notes, NOISE_MIN_ADVICE};

use crate::certificate::noise::NoiseBound;
use crate::certificate::{Certificate, Gains};
use crate::error::SolveError;
use crate::model::{ClaimedBound, ObserverKind, ObserverModel, ObserverOptions, StateBoundClaim};
use crate::settings::Settings;
use crate::vocab::{Candidate, Family, Phase, Verdict};
use nalgebra::DMatrix;
use qpv_dsl::{Conditions, Mode, PolytopicModel, Split, StateBound, TimeUnit};

pub use crate::backend::Status;
pub use crate::certificate::DataCheck;
pub use crate::linalg::{matrix_to_rows, rows_to_matrix};
#[doc(hidden)]
pub use crate::vocab::{conditions_serde, mode_serde, split_serde};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Solver statistics of the solve that produced the reported point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolverInfo {
    /// Interpreted status.
    pub status: Status,
    /// Clarabel's own status name (e.g. "Solved", "PrimalInfeasible",
    /// "InsufficientProgress"), or "" when no solve ran.
    pub detail: String,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Clarabel's reported solve time in seconds.
    pub seconds: f64,
    /// Time spent assembling (A, b, cones) for this solve, in seconds.
    pub assembly_seconds: f64,
    /// Time spent in the independent certificate for this solve, in seconds.
    pub certify_seconds: f64,
}

impl Default for SolverInfo {
    fn default() -> Self {
        SolverInfo {
            status: Status::NotRun,
            detail: String::new(),
            iterations: 0,
            seconds: 0.0,
            assembly_seconds: 0.0,
            certify_seconds: 0.0,
        }
    }
}

/// One solve tried during a design (fixed point, α-bisection or γ-search).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchStep {
    /// Region scaling γ of this step.
    pub gamma: f64,
    /// Decay rate α tested (or, for a capacity step, certified).
    pub alpha: f64,
    /// What the solver said.
    pub status: Status,
    /// Clarabel's own status name.
    pub detail: String,
    /// Whether the returned point passed the independent certificate at `alpha`.
    pub certified: bool,
    /// If certified: the largest α the *same* (P, Γ_l) certify at this γ
    /// (a lower bound on α_max used to speed up the bisection); else 0.
    pub alpha_certified: f64,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Wall time of this step (assembly + solve + certificate), seconds.
    pub seconds: f64,
    /// Clarabel's own solve time within this step, seconds.
    pub solver_seconds: f64,
    /// What this step was for (serialised as its name: "bisect", "grid",
    /// "refine", "final", ...).
    pub phase: Phase,
}

/// What a report without the `conditions` key was solved with.
fn full_conditions() -> Conditions {
    Conditions::Full
}

/// α or γ of a gains file that does not state it.
fn unstated() -> f64 {
    f64::NAN
}

/// A finished design: the certified observer (or why there is none).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Design {
    /// Model name ("" when a gains file does not name it).
    #[serde(default)]
    pub model: String,
    /// Condition set used ("sound" or "paper"; sound when absent).
    #[serde(default, with = "mode_serde")]
    pub mode: Mode,
    /// Representation of N_k, M_k used in the LMIs and the certificate
    /// ("as_written" or "symmetric"; the same plant either way). Re-check a
    /// reloaded design with [`Design::recheck`], which applies it. Absent
    /// in a gains file: read as symmetric, which a re-check of a gains file
    /// replaces by the default of the mode it checks.
    #[serde(default, with = "split_serde")]
    pub split: Split,
    /// Rate conditions solved ("full": all N p² vertex pairs; "decoupled":
    /// N·2p blocks with one slack Z per rate combination — per θ-vertex, or
    /// per (l, m) combination of the double sum — sufficient). The
    /// certificate (`margins`, `feasible`) always checks the full family.
    /// Reports written before the key existed read as "full".
    #[serde(default = "full_conditions", with = "conditions_serde")]
    pub conditions: Conditions,
    /// What the independent certificate established ([`Verdict`]):
    /// `certified` only if every condition family (and the required data
    /// checks) passed in sound mode, which proves V' ≤ −αV on the certified
    /// set; `reproduction` if the paper's printed conditions hold (paper
    /// mode: certifies nothing); else `not_certified`. Reports written
    /// before the key existed carry `feasible` and `certifies` instead,
    /// read as the same three states ([`crate::vocab::verdict_serde`]).
    #[serde(flatten, with = "crate::vocab::verdict_serde")]
    pub verdict: Verdict,
    /// Decay rate α of the reported point (NaN when a gains file does not
    /// say: the re-check takes it from elsewhere).
    #[serde(default = "unstated")]
    pub alpha: f64,
    /// Region scaling γ of the reported point (NaN when a gains file does
    /// not say).
    #[serde(default = "unstated")]
    pub gamma: f64,
    /// Lyapunov matrix P (rows); empty if the solver returned no point.
    #[serde(rename = "P")]
    pub p: Vec<Vec<f64>>,
    /// Γ_l = P L_l per vertex (rows).
    #[serde(rename = "Gamma", default)]
    pub gamma_l: Vec<Vec<Vec<f64>>>,
    /// Observer gains L_l = P⁻¹ Γ_l per vertex (nx rows of ny; nx + ny rows
    /// for the filter route, see `output_route`).
    #[serde(rename = "L")]
    pub l: Vec<Vec<Vec<f64>>>,
    /// Spectral norms ‖L_l‖₂ per vertex.
    #[serde(default)]
    pub gain_norms: Vec<f64>,
    /// Worst margin per condition family (positive = satisfied), from the
    /// independent certificate: "S1","S2","S3","S5" (sound) or
    /// "S1","13","14","26" (paper).
    #[serde(default)]
    pub margins: BTreeMap<Family, f64>,
    /// Data checks: "S4" (γ² a_kᵀ Q a_k ≤ 1) and "region_in_F" (P ⊂ F).
    #[serde(default)]
    pub data_checks: BTreeMap<String, DataCheck>,
    /// Statistics of the solve that produced the reported point.
    #[serde(default)]
    pub solver: SolverInfo,
    /// Wall time of the whole design call, seconds.
    #[serde(default)]
    pub seconds_total: f64,
    /// Every solve tried, in order.
    #[serde(default)]
    pub search: Vec<SearchStep>,
    /// Warnings and labels (e.g. the paper-mode disclaimer, violated
    /// assumptions), each one sentence ([`Note`]).
    #[serde(default)]
    pub notes: Notes,
    /// A human-readable summary.
    #[serde(default)]
    pub summary: String,
    /// The state bound the design used: its source ("given", "auto" or
    /// "none"), Q, and for a computed bound h, γ_max and its check
    /// ([`crate::model::state_bound`]). Absent in reports written before it existed.
    #[serde(default)]
    pub state_bound: Option<crate::model::state_bound::StateBoundInfo>,
    /// The output route ("double_sum" or "filter" with its pole, gain and
    /// filter-state bound) and the observer's state names: for the filter
    /// route P is (nx+ny)² and each L_l has nx+ny rows (plant states, then
    /// filter states). Absent in reports written before it existed (read as
    /// double sum).
    #[serde(default)]
    pub output_route: Option<crate::model::output_filter::OutputRouteInfo>,
    /// `split = skew_slack`: the skew-symmetric slack K_{k,l} added to the
    /// symmetric N_{k,l} (per θ-vertex l, then per k = 1..n, rows), which
    /// P and L_l were certified with ([`crate::search::skew`]); n is the
    /// observer's state count. Absent otherwise (and when the slack gained
    /// nothing).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skew: Option<Vec<Vec<Vec<Vec<f64>>>>>,
    /// For a design that does not certify: cheap reasons and bounds
    /// computed from the model and request alone ([`crate::model::diagnosis`]:
    /// detectability at the θ-vertices, the (S4) bound on γ, region vertices
    /// outside F). Absent for certified designs and older reports.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub diagnosis: Option<Vec<crate::model::diagnosis::Finding>>,
    /// The certified noise bound σ of V' + αV ≤ σ(|w|² + |v|²) and what it
    /// guarantees ([`NoiseBound`]); only on certified
    /// sound-mode designs whose noise check passed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<NoiseBound>,
    /// `noise = rms`: the certified bound on the time-averaged RMS error
    /// under the request's white noise ([`crate::certificate::rms`]), in
    /// total and per state; [`Design::recheck`] recomputes it from P and L.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rms: Option<crate::certificate::rms::RmsBound>,
    /// The largest safe Euler step and the RK4 step estimate
    /// ([`crate::certificate::sampling::Sampling`]); only on certified sound-mode designs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampling: Option<crate::certificate::sampling::Sampling>,
    /// What a γ search searched ([`GammaSearchInfo`]: the range, the points,
    /// the local maxima of α(γ)); only when γ = search.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gamma_search: Option<GammaSearchInfo>,
    /// `conditions = cube`: the slacks Y_{c,k}, X_{c,k} and the diagonal D
    /// the design was certified with ([`crate::conditions::cube`]);
    /// [`Design::recheck`] checks the slack inequalities with them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cube: Option<crate::conditions::cube::CubeReport>,
    /// `max_gain = G`: the bound on every ‖L_l‖₂ the design claims;
    /// [`Design::recheck`] checks it from the reported L (data check
    /// `max_gain`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_gain: Option<f64>,
    /// The practical `alpha = max` ([`Practical`]): the certified
    /// supremum found and the tolerance below it; only for α = max with
    /// `within` > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub practical: Option<Practical>,
    /// `sample = h`: the design is certified at the sample period h by the
    /// discrete decrease (family "S5d" in place of "S5";
    /// [`crate::certificate::sampling::SampleInfo`]); [`Design::recheck`] checks that
    /// family. Absent for continuous-time designs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample: Option<crate::certificate::sampling::SampleInfo>,
    /// The model's unit of time (`time = hours;`): α is per this unit, h
    /// and every step are in it. Left out for seconds (the default).
    #[serde(default, skip_serializing_if = "TimeUnit::is_seconds")]
    pub time_unit: TimeUnit,
    /// The global observer of an LPV plant (every N_k and M_k zero, sound
    /// mode): the conditions are P ⪰ I and He{P A_l − Γ_l C_m} + αP ≺ 0
    /// (certificate family "G5"), with no region, state bound or γ, and the
    /// decay V' ≤ −αV holds for every e(0) (`gamma` is 1 and unused).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub global: bool,
    /// `poles = ...`: the pole regions the design claims (certificate family
    /// "D", docs/method.md §18); [`Design::recheck`] checks them from P and L.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub poles: Vec<qpv_dsl::PoleRegion>,
    /// With a disk among `poles` on an LPV plant: the bound on every
    /// ‖L_l‖₂ that the certified disk implies through P's condition number
    /// ([`crate::certificate::poles::disk_gain_bound`]); only on certified designs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pole_gain_bound: Option<f64>,
    /// For a certified continuous-time sound design of a QPV plant: the α
    /// the plant's linear part alone (every N_k and M_k zero) certifies
    /// with the global observer, to 1 % (`crate::search::region_cost`):
    /// what the region costs, next to `alpha`. None where it does not
    /// apply or the linear part certifies nothing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_part_alpha: Option<f64>,
    /// As `linear_part_alpha` with every ‖L_l‖₂ bounded by this design's
    /// largest gain (`max_gain`): the linear part's α at the QPV design's
    /// gain level.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_part_alpha_at_gain: Option<f64>,
}

/// How a practical `alpha = max` chose its design: the fastest certified
/// α found (α_sup), the tolerance, and whether the supremum is reached
/// only through high gains. The figures are the search's: `alpha_sup` is
/// a certified α (its point passed the certificate when found), not
/// re-checked from the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Practical {
    /// The fastest certified α the search found (the certified supremum
    /// estimate), and its γ.
    pub alpha_sup: f64,
    /// γ of `alpha_sup`.
    pub gamma_sup: f64,
    /// The largest gain max_l ‖L_l‖₂ of the design certified at `alpha_sup`.
    pub gain_sup: f64,
    /// The tolerance: the design's α ≥ (1 − within)·alpha_sup, unless
    /// `high_gain` moved it to the knee.
    pub within: f64,
    /// α was still rising at the smallest γ searched while the gains grew:
    /// the supremum is approached only as ‖L‖ → ∞, and the design
    /// returned is the knee of the α–gain curve.
    pub high_gain: bool,
    /// Solves spent on the smallest-gain designs (after the α search).
    pub solves: usize,
    /// `alpha_sup` is the search's cap (`Settings::alpha_cap`), not a
    /// supremum: a larger α may certify.
    #[serde(default)]
    pub capped: bool,
}

/// A local maximum of α(γ) over the γ search's grid: where it is, its
/// (coarse) α, and whether it was refined (it was within reach of the best).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LocalMax {
    /// γ of the maximum (after refinement, if refined).
    pub gamma: f64,
    /// The largest certified α there, to the search's coarse tolerance.
    pub alpha: f64,
    /// Whether golden-section steps refined it.
    pub refined: bool,
}

/// What a γ search searched (the report's `gamma_search` key), so that a
/// reader can judge the "best" it reports: α_max(γ) need not be unimodal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GammaSearchInfo {
    /// Lowest γ searched: of the logarithmic grid (below γ_hi / span if the
    /// grid was extended downwards), or where the continuation ended.
    pub gamma_lo: f64,
    /// Highest γ searched (γ_hi).
    pub gamma_hi: f64,
    /// Grid points (including downward extensions).
    pub grid_points: usize,
    /// γ values evaluated in all (grid, refinement and continuation), each
    /// to the coarse tolerance.
    pub points: usize,
    /// Solves the search made (grid, refinement and the final α search at
    /// the best γ; not the final regularised solve).
    pub solves: usize,
    /// The local maxima of α(γ) over the grid, best first (the best one
    /// where the continuation below a cliff ended, if it moved).
    pub local_maxima: Vec<LocalMax>,
    /// γ values evaluated by the continuation below a cliff (0: the best
    /// point was not at one). Absent from reports written before it.
    #[serde(default)]
    pub continued: usize,
}

impl GammaSearchInfo {
    /// One sentence: "best over γ ∈ [a, b], n grid points (m evaluated, s
    /// solves); local maxima at γ = .. (α = ..), ...".
    pub fn statement(&self) -> String {
        let maxima: Vec<String> = self
            .local_maxima
            .iter()
            .map(|m| {
                format!(
                    "γ = {:.5} (α ≈ {:.4}{})",
                    m.gamma,
                    m.alpha,
                    if m.refined { "" } else { ", not refined" }
                )
            })
            .collect();
        let walk = if self.continued > 0 {
            format!(
                "; continued below a cliff of the grid ({} of those γ values)",
                self.continued
            )
        } else {
            String::new()
        };
        format!(
            "γ search: best over γ ∈ [{}, {}], {} log-spaced grid points ({} γ values evaluated, {} solver calls){walk}; local maxima at {}",
            qpv_dsl::fmt_sig(self.gamma_lo, 5),
            qpv_dsl::fmt_sig(self.gamma_hi, 6),
            self.grid_points,
            self.points,
            self.solves,
            if maxima.is_empty() {
                "none (nothing certified)".to_string()
            } else {
                maxima.join(", ")
            }
        )
    }
}

/// P, Γ_l and L_l as a report writes them (rows), with ‖L_l‖₂: the part of
/// a [`Design`] that comes from the point it shows (empty without one).
#[derive(Debug, Clone, Default)]
pub(crate) struct ReportedMatrices {
    pub p: Vec<Vec<f64>>,
    pub gamma_l: Vec<Vec<Vec<f64>>>,
    pub l: Vec<Vec<Vec<f64>>>,
    pub gain_norms: Vec<f64>,
}

impl ReportedMatrices {
    /// The rows of P, Γ_l, L_l and the spectral norms of the L_l.
    pub(crate) fn of(p: &DMatrix<f64>, gammas: &[DMatrix<f64>], l: &[DMatrix<f64>]) -> Self {
        ReportedMatrices {
            p: matrix_to_rows(p),
            gamma_l: gammas.iter().map(matrix_to_rows).collect(),
            l: l.iter().map(matrix_to_rows).collect(),
            gain_norms: l.iter().map(crate::linalg::norm2).collect(),
        }
    }
}

impl Design {
    /// The conditions of the design's mode hold (certified, or in paper
    /// mode a reproduction): [`Verdict::feasible`].
    pub fn feasible(&self) -> bool {
        self.verdict.feasible()
    }

    /// max_l ‖L_l‖₂ of the reported gains (0 without gains): the one
    /// reading of `gain_norms` every summary, note and sweep uses.
    pub fn max_gain_norm(&self) -> f64 {
        self.gain_norms.iter().copied().fold(0.0, f64::max)
    }

    /// The observer this design's mode builds on `model` as it is now
    /// ([`ObserverKind::of`]): recomputed from the model, never read from
    /// the report's `global` key (a claim, like everything in a file).
    pub fn kind_on(&self, model: &PolytopicModel) -> ObserverKind {
        ObserverKind::of(model, self.mode)
    }

    /// A certified sound-mode design: [`Verdict::certifies`].
    pub fn certifies(&self) -> bool {
        self.verdict.certifies()
    }

    /// The candidate the design claims: (α, γ) and its sample period.
    pub fn candidate(&self) -> Candidate {
        Candidate::new(self.alpha, self.gamma).at_sample(self.sample.as_ref().map(|s| s.h))
    }

    /// P as a matrix (0 × 0 if absent).
    pub fn p_matrix(&self) -> DMatrix<f64> {
        rows_to_matrix(&self.p)
    }
    /// L_l as matrices.
    pub fn l_matrices(&self) -> Vec<DMatrix<f64>> {
        self.l.iter().map(|g| rows_to_matrix(g)).collect()
    }
    /// The Q of the state bound this design used (given or computed), if any.
    pub fn state_bound_q(&self) -> Option<DMatrix<f64>> {
        self.state_bound
            .as_ref()
            .and_then(|s| s.q.as_ref())
            .map(|q| rows_to_matrix(q))
    }
    /// The output route of this design (double sum for old reports).
    pub fn route(&self) -> qpv_dsl::OutputRoute {
        self.output_route
            .as_ref()
            .map(|r| r.output_route())
            .unwrap_or_default()
    }

    /// The state bound this design claims for a `state_bound auto` model:
    /// its Q, box size h and the split of its invariance check.
    pub(crate) fn state_bound_claim(&self) -> Option<ClaimedBound> {
        let info = self.state_bound.as_ref()?;
        Some(ClaimedBound {
            q: rows_to_matrix(info.q.as_ref()?),
            h: info.h,
            split: info.split,
        })
    }

    /// These gains as a claim at the sample period `h` and rate `alpha`
    /// (the `sample` key set). The discrete decrease has no cube form, so
    /// cube slacks are dropped and the claim is checked on the full vertex
    /// family, which is the discrete certificate for any gains
    /// (docs/method.md §16).
    pub fn at_sample(&self, h: f64, alpha: f64) -> Design {
        let mut d = self.clone();
        d.alpha = alpha;
        d.sample = Some(crate::certificate::sampling::SampleInfo::new(h, alpha));
        if d.cube.take().is_some() {
            d.conditions = Conditions::Full;
        }
        d
    }

    /// The model this design's P and L_l belong to, built from the plant
    /// `model` by [`ObserverModel::prepare`]: for `state_bound auto` the Q
    /// this design claims, verified against `model` as it is now (a stale or
    /// tampered Q is an error saying what failed), then the design's output
    /// route, split and skew slack. Check, simulate and falsify the gains
    /// against it.
    pub fn observer_model(&self, model: &PolytopicModel) -> Result<PolytopicModel, SolveError> {
        let route = self.route();
        let skew = self.skew.as_ref().map(|k| skew_matrices(k));
        let options = ObserverOptions {
            output_route: &route,
            split: self.split,
            skew: skew.as_deref(),
        };
        let claim = self.state_bound_claim();
        let defaults = Settings::default();
        let bound = match (&model.state_bound, &claim) {
            (_, Some(c)) => StateBoundClaim::Claimed(c),
            (StateBound::Auto { .. }, None) => {
                return Err(SolveError::StateBound(
                    "the model has `state_bound auto` and the report carries no Q".into(),
                ))
            }
            // a given Q or none: the model's own, nothing is computed
            (_, None) => StateBoundClaim::Compute(&defaults),
        };
        let obs = ObserverModel::prepare(model, &options, bound)?.model;
        // A Jacobian box on the set S = F ⊕ (−P/γ) grows as γ falls: the
        // design's figures and checks use the box at its own γ.
        if obs.jacobian_needs_set() && self.gamma.is_finite() && self.gamma > 0.0 {
            return crate::model::jacobian::expand(obs, Some(self.gamma));
        }
        Ok(obs)
    }

    /// The independent certificate of this design's P and L_l against
    /// `model` (through [`Design::observer_model`]: the design's verified Q,
    /// output route, split and skew slack applied), at its α and γ, by
    /// [`Design::recheck_on`]. A model the design cannot be applied to (a
    /// refused Q, a route that does not fit) gives a failed certificate
    /// with the reason.
    ///
    /// This is the one re-check of a report's claim (`qpv check` and
    /// `qpv simulate` both use it): nothing the report says about its own
    /// margins, data checks or verdict is read.
    pub fn recheck(&self, model: &PolytopicModel) -> Certificate {
        match self.observer_model(model) {
            Ok(m) => self.recheck_on(&m),
            Err(e) => Certificate::refused(
                self.mode,
                self.alpha,
                self.gamma,
                format!("observer's model: {e}"),
            ),
        }
    }

    /// The independent certificate of this design's P and L_l on `obs`, the
    /// observer model [`Design::observer_model`] built: with the design's
    /// cube slacks (the `cube` key) the slack inequalities of
    /// [`crate::certificate::check_cube`], else every region-vertex pair.
    /// Refused (a failed certificate saying why, nothing computed) when
    /// that is more than [`crate::model::size::CERTIFICATE_BUDGET`] rate blocks,
    /// the budget of a design's own certificate.
    pub fn recheck_on(&self, obs: &PolytopicModel) -> Certificate {
        let slacks = self
            .cube
            .as_ref()
            .map(crate::conditions::cube::CubeSlacks::from_report);
        let blocks = recheck_blocks(obs, slacks.is_some());
        // Each pole region adds its blocks per rate block.
        let pole_blocks: usize = self.poles.iter().map(|r| r.n_blocks()).sum();
        let total = blocks * (1.0 + pole_blocks as f64);
        if total > crate::model::size::CERTIFICATE_BUDGET {
            let combos = combinations(obs);
            return Certificate::refused(
                self.mode,
                self.alpha,
                self.gamma,
                format!(
                    "too large to re-check: {combos} rate combination(s) × {}² region-vertex pairs \
                     = {blocks:.3e} blocks{}, more than the certificate's budget of {:.3e}{}",
                    obs.region.vertices.len(),
                    if pole_blocks > 0 {
                        format!(
                            ", each with {pole_blocks} pole-region block(s) of its {} region(s): \
                             {total:.3e} in all",
                            self.poles.len()
                        )
                    } else {
                        String::new()
                    },
                    crate::model::size::CERTIFICATE_BUDGET,
                    if obs.region.zonotope_generators().is_some() {
                        "; a `conditions = cube` report carries slacks (its `cube` key) that are \
                         re-checked without enumerating the pairs"
                    } else {
                        "; a region with fewer vertices would fit"
                    }
                ),
            );
        }
        let l = self.l_matrices();
        let p = self.p_matrix();
        let gains = Gains::new(&p, &l).with_cube(slacks.as_ref());
        let at = self.candidate();
        let mut cert = crate::certificate::check(obs, &gains, &at, self.mode)
            .with_gain_bound(&l, self.max_gain)
            .with_poles(obs, &gains, &at, &self.poles);
        if let Some(claimed) = &self.rms {
            let c = crate::certificate::rms::rms_check(obs, claimed, self.gamma, &p, &l);
            cert.passed &= c.passed;
            cert.data_checks.insert("rms".to_string(), c);
        }
        cert
    }

    /// A design that holds only the claim of a gains file: P and L_l (rows)
    /// to be checked in `mode` at (`alpha`, `gamma`) for model `model`, not
    /// certified by anything yet (`feasible` and `certifies` false, no
    /// margins, no search). The caller sets what else the file claims
    /// (split, state bound, output route, skew and cube slacks), then
    /// [`Design::recheck`] judges it.
    pub fn claimed(
        model: &str,
        mode: Mode,
        alpha: f64,
        gamma: f64,
        p: Vec<Vec<f64>>,
        l: Vec<Vec<Vec<f64>>>,
    ) -> Design {
        Design {
            model: model.to_string(),
            mode,
            split: Split::default_for(mode),
            conditions: Conditions::Full,
            verdict: Verdict::NotCertified,
            alpha,
            gamma,
            p,
            gamma_l: Vec::new(),
            l,
            gain_norms: Vec::new(),
            margins: BTreeMap::new(),
            data_checks: BTreeMap::new(),
            solver: SolverInfo::default(),
            seconds_total: 0.0,
            search: Vec::new(),
            notes: Notes::default(),
            summary: String::new(),
            state_bound: None,
            output_route: None,
            skew: None,
            diagnosis: None,
            noise: None,
            rms: None,
            sampling: None,
            gamma_search: None,
            cube: None,
            max_gain: None,
            practical: None,
            sample: None,
            time_unit: TimeUnit::Seconds,
            global: false,
            poles: Vec::new(),
            pole_gain_bound: None,
            linear_part_alpha: None,
            linear_part_alpha_at_gain: None,
        }
    }

    /// The part of a report a re-check reads: P, L_l, α, γ, the mode, the
    /// model's name and the representation the gains were designed in
    /// (split, conditions, skew and cube slacks, the state bound's Q with
    /// its h and split, output route, `max_gain`, the sample period, the claimed RMS bound of a
    /// `noise = rms` design, which the re-check recomputes).
    /// Everything the report says about itself (verdict, margins, data
    /// checks, σ and sampling figures, search, notes) is dropped, to be
    /// recomputed from the model as it is now (docs/schema.md, "What a
    /// report may claim").
    pub fn into_claim(self) -> Design {
        let sample = self
            .sample
            .map(|s| crate::certificate::sampling::SampleInfo::new(s.h, self.alpha));
        let mut d = Design::claimed(
            &self.model,
            self.mode,
            self.alpha,
            self.gamma,
            self.p,
            self.l,
        );
        d.split = self.split;
        d.conditions = self.conditions;
        d.skew = self.skew;
        d.cube = self.cube;
        d.max_gain = self.max_gain;
        d.poles = self.poles;
        d.rms = self.rms;
        d.output_route = self.output_route;
        d.sample = sample;
        d.state_bound = self
            .state_bound
            .map(|b| crate::model::state_bound::StateBoundInfo {
                source: crate::vocab::BoundSource::Auto,
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
        d
    }

    /// JSON text (pretty-printed).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a Design always serialises")
    }
    /// Parses a design written by [`Design::to_json`].
    pub fn from_json(text: &str) -> Result<Design, serde_json::Error> {
        serde_json::from_str(text)
    }
}

/// The rate combinations of `obs`: r θ-vertices, or r² for the double sum.
fn combinations(obs: &PolytopicModel) -> f64 {
    let r = obs.nv() as f64;
    if crate::model::is_double_sum(obs) {
        r * r
    } else {
        r
    }
}

/// The rate blocks the certificate of a design on `obs` checks: c·(4r + 1)
/// with cube slacks (r generators), else c·p² (p region vertices), for c
/// rate combinations (as f64: it may exceed any integer type).
fn recheck_blocks(obs: &PolytopicModel, cube: bool) -> f64 {
    let c = combinations(obs);
    match obs.region.zonotope_generators() {
        Some(g) if cube => c * (4.0 * g.len() as f64 + 1.0),
        _ => {
            let p = obs.region.vertices.len() as f64;
            c * p * p
        }
    }
}

/// The `skew` key of a report (per θ-vertex, per k, rows) as matrices.
pub(crate) fn skew_matrices(k: &[Vec<Vec<Vec<f64>>>]) -> Vec<Vec<DMatrix<f64>>> {
    k.iter()
        .map(|kl| kl.iter().map(|kk| rows_to_matrix(kk)).collect())
        .collect()
}
