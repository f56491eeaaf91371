//! Direct assembly of the LMIs into Clarabel's standard form
//! `min ½xᵀPx + qᵀx  s.t.  Ax + s = b, s ∈ K`, and one solve.
//!
//! Variables (scaled, see [`crate::conditions::ConditionSet::scale`]):
//! x = [ P̂_ab (a ≤ b, upper triangle column by column: index b(b+1)/2 + a),
//!       Γ̂_1 (row-major, nx·ny), …, Γ̂_N,
//!       Ẑ_1 (upper triangle like P̂), …, Ẑ_N   (decoupled conditions only) ],
//! with P = s P̂, Γ_l = s Γ̂_l and Z_l = s Ẑ_l.
//! The variables are the plain entries; only the cone slacks use the
//! √2-scaled upper-triangle packing Clarabel's PSD triangle cone expects.
//!
//! Rows, in order (every condition carries a margin, see
//! [`crate::settings::Settings::margin_rel`]):
//! 1. (S1) P̂ − ε I ⪰ 0                                   PSD(nx)
//! 2. sound (S2): 1 − ε − x̂ᵢᵀ P̂ x̂ᵢ ≥ 0 (x̂ = x/ρ)          Nonnegative(p)
//!    paper (13): [1 x̂ᵢᵀ; x̂ᵢ P̂] − ε I ⪰ 0                 p × PSD(nx+1)
//! 3. sound (S3): [1 γâₖᵀ; γâₖ P̂] − ε I ⪰ 0 (â = ρa)      q × PSD(nx+1)
//!    paper (14): [1 γâₖᵀP̂; γP̂âₖ P̂] − ε I ⪰ 0             q × PSD(nx+1)
//! 4. rate, [`Conditions::Full`]: −He{P̂K − Γ̂_l H} − ε κ I ⪰ 0
//!    per (l, i, j)                                         N p² × PSD(nx)
//!    rate, [`Conditions::Decoupled`], per θ-vertex l:      N 2p × PSD(nx)
//!    −(F0_l + G_l(x_i) + Ẑ_l) − ε κ I ⪰ 0   i = 1..p  (the e-vertex blocks)
//!    −(H_l(x_j) − Ẑ_l) ⪰ 0                 j = 1..p  (the x-vertex blocks)
//!
//! The decoupled split of the rate matrix F_{l,i,j} = He{P̂K − Γ̂_l H}
//! (K, H of [`crate::conditions`]; σ = +1 sound, −1 paper):
//!
//! ```text
//!     F0_l     = He{ P̂ (γA_l + (γα/2) I) − γ Γ̂_l C }
//!     G_l(x_i) = He{ −σ P̂ rows(N_l, x_i) + Γ̂_l rows(M, x_i) }      (e-vertex x_i)
//!     H_l(x_j) = He{ σ P̂ rowsHe(N_l, x_j) − Γ̂_l rowsHe(M, x_j) }   (x-vertex x_j)
//! ```
//!
//! so F_{l,i,j} = F0_l + G_l(x_i) + H_l(x_j), and the two decoupled blocks
//! add up to F_{l,i,j} ⪯ −εκ I for every pair (i, j): sufficient for the
//! full family, never necessary. The certificate always re-checks the full
//! p² family.
//!
//! (2)-(3) are the printed blocks after the congruence diag(1, ρ^{±1} I),
//! which changes no sign of any eigenvalue; (4) is the printed LMI divided
//! by s > 0. The objective is ½ w Σ_l ‖Γ̂_l‖_F² (or 0 for pure feasibility).

mod cube;
pub(crate) mod noise;
pub mod poles;
mod sampled;
pub(crate) mod skew;

use crate::backend::builder::{Psd, SdpBuilder};
use crate::backend::{clarabel_settings, ensure_lapack, run_sdp, Sdp, Status};
use crate::conditions::{rate_combos, rows, rows_he, Combo, ConditionSet, PairTerms, RegionForm};
use crate::error::SolveError;
use crate::linalg::svec::{svec_index, svec_len, svec_scale};
use crate::model::noise::NoiseChannels;
use crate::model::{region_radius, validate, StateScaling};
use crate::settings::Settings;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::Conditions;
use qpv_dsl::PolytopicModel;
use std::sync::OnceLock;
use std::time::Instant;

/// The relative step above α at which the global observer's gain objective
/// is solved (see [`Problem::solve_with_metric`]).
pub(crate) const GLOBAL_BACKOFF: f64 = 1e-3;

/// W = M/λ_min(M) (symmetrised) and W^{-1/2}, for a finite positive
/// definite n × n metric M; None otherwise.
fn normalised_metric(m: &DMatrix<f64>, n: usize) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    if m.shape() != (n, n) || !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let sym = (m + m.transpose()) * 0.5;
    let eig = sym.clone().symmetric_eigen();
    let lmin = eig.eigenvalues.min();
    let lmax = eig.eigenvalues.max();
    if !(lmin > 0.0 && lmax / lmin < 1e12) {
        return None;
    }
    let w = &sym / lmin;
    let d = DMatrix::from_diagonal(&eig.eigenvalues.map(|v| (lmin / v).sqrt()));
    let w_inv_half = &eig.eigenvectors * d * eig.eigenvectors.transpose();
    Some((w, w_inv_half))
}

/// The max-margin variable t̂ and its coefficients svec(κW) in a rate block.
struct MarginColumn {
    var: usize,
    coef: Vec<f64>,
}

/// The margins of the rate blocks: `eps` on the blocks that carry the rate
/// (zero for the max-margin objective, whose column `column` sits there
/// instead), `slack_eps` on the cube slack inequalities (always).
struct RateMargins<'a> {
    eps: f64,
    slack_eps: f64,
    column: Option<&'a MarginColumn>,
}

impl RateMargins<'_> {
    /// Adds the max-margin column to the block `blk`, if any.
    fn push_column(&self, out: &mut SdpBuilder, blk: &Psd) {
        if let Some(m) = self.column {
            for (idx, &w) in m.coef.iter().enumerate() {
                out.a(blk.row0 + idx, m.var, w);
            }
        }
    }
}

/// The family of blocks that holds the rate of decay.
#[derive(Debug, Clone, Copy)]
pub(crate) enum RateFamily<'a> {
    /// The decay conditions of the problem's conditions ((S5), its
    /// decoupled or cube relaxation, or the discrete decrease).
    Decay,
    /// The noise blocks on these channels (the bounded-real form of the
    /// rate block, docs/method.md "Noise and disturbances").
    Noise(&'a NoiseChannels),
}

/// What the solve optimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Objective {
    /// None: a pure feasibility problem (the rate LMIs keep their margin).
    Feasibility,
    /// The default: ½ w Σ_l ‖Γ̂_l‖_F² (w = `Settings::gain_weight`), keeping
    /// the gains moderate; rate LMIs ⪯ −ε κ I.
    Gains,
    /// Maximise the common margin t of the rate LMIs: −He{P̂K − Γ̂H} ⪰ κ t̂ W,
    /// t̂ ≤ 1 (t̂ free below, so the problem is feasible whenever the region
    /// conditions are), with W = I or, given a reference P_ref,
    /// W = P̂_ref/λ_max(P̂_ref) (the metric of the generalised eigenvalue
    /// problem in α, which makes the capacity lift of the α search nearly
    /// exact in one step). t̂ < 0 at the optimum means no (P, Γ) satisfies
    /// the rate LMIs at this α.
    MaxMargin,
    /// Minimise a bound κ on every ‖L_l‖₂: the problem is homogenised
    /// (Charnes–Cooper: every right-hand side b becomes c·b with a new
    /// scalar c ≥ 0, so a point (x, c) with c > 0 is a feasible x·c
    /// scaled), normalised by P̂ ⪰ I, and ‖Γ̂_l‖₂ ≤ κ is the block
    /// [κI, Γ̂_lᵀ; Γ̂_l, κI] ⪰ 0. Then ‖L_l‖₂ = ‖P⁻¹Γ_l‖₂ ≤
    /// ‖Γ̂_l‖₂/λ_min(P̂) ≤ κ: the minimum over the design's feasible set of
    /// max_l ‖Γ_l‖₂/λ_min(P), a convex surrogate of the largest gain
    /// (docs/method.md, the practical α = max).
    MinGain,
}

/// One assembled problem in Clarabel's standard form (the backend's [`Sdp`]).
pub(crate) type Assembled = Sdp;

/// The raw result of one solve, unscaled to the model's units.
#[derive(Debug, Clone)]
pub struct SolveResult {
    /// Interpreted status.
    pub status: Status,
    /// Clarabel's status name.
    pub detail: String,
    /// Iterations.
    pub iterations: u32,
    /// Clarabel's solve time, seconds.
    pub solve_seconds: f64,
    /// Assembly time, seconds.
    pub assembly_seconds: f64,
    /// P (model units) if Clarabel returned a point (Solved / AlmostSolved / …).
    pub p: Option<DMatrix<f64>>,
    /// Γ_l (model units).
    pub gammas: Vec<DMatrix<f64>>,
    /// [`Objective::MaxMargin`]: the optimal normalised margin t̂;
    /// [`Objective::MinGain`]: the optimal gain bound κ (the solver's, not
    /// certified); NaN otherwise.
    pub margin: f64,
    /// The slacks of cube conditions (model units), with the point.
    pub cube: Option<crate::conditions::cube::CubeSlacks>,
}

/// The precomputed, (α, γ)-independent part of a design problem.
pub struct Problem<'m> {
    model: &'m PolytopicModel,
    set: ConditionSet,
    conditions: Conditions,
    nx: usize,
    ny: usize,
    nv: usize,
    np: usize,
    /// Region radius ρ.
    pub rho: f64,
    /// Variable scale s.
    pub scale: f64,
    xs_hat: Vec<DVector<f64>>,
    as_hat: Vec<DVector<f64>>,
    /// The vertex-pair terms (full and decoupled conditions only, computed
    /// on first use: a cube problem never enumerates vertex pairs).
    terms: OnceLock<PairTerms>,
    combos: Vec<Combo>,
    max_a_fro: f64,
    /// max ‖R_{l,i,j}‖_F over the vertex pairs (computed on first use).
    max_r_fro: OnceLock<f64>,
    /// Cube conditions: the region's generators (empty otherwise).
    gens: Vec<DVector<f64>>,
    /// Cube conditions: a bound on ‖R‖_F over the region, from the generators.
    cube_r_fro: f64,
    /// Cube conditions with every N_l and M_m symmetric: H_c(g) = −2G_c(g),
    /// so one slack per combination and generator stands for the pair
    /// (see [`Problem::cube_one_slack`]).
    cube_one_slack: bool,
    /// `max_gain = G`: the bound imposed on every ‖L_l‖₂ (see
    /// [`Problem::with_max_gain`]).
    max_gain: Option<f64>,
    /// The change of coordinates x = D z the problem is posed in (see
    /// [`Problem::with_scaling`]); None: the model's own coordinates.
    scaling: Option<StateScaling>,
    /// `sample = h`: the discrete decrease replaces the rate family (see
    /// [`Problem::with_sample`]).
    sample: Option<f64>,
    /// The global observer ([`crate::model::is_global`]): no region rows,
    /// P̂ ⪰ I as the normalisation, γ = 1 in the rate blocks.
    global: bool,
    /// Per rate combination: whether its nonlinear terms vanish (N_l = 0
    /// and M_m = 0 for every term), so that its p² vertex-pair blocks are
    /// one block, written once.
    linear: Vec<bool>,
    /// `poles = ...`: the pole regions imposed (see [`Problem::with_poles`]).
    poles: Vec<qpv_dsl::PoleRegion>,
}

impl<'m> Problem<'m> {
    /// Precomputes everything that does not depend on (α, γ) (the
    /// vertex-pair terms only when full or decoupled conditions need them).
    pub fn new(model: &'m PolytopicModel, set: ConditionSet) -> Result<Self, SolveError> {
        validate(model)?;
        let nx = model.nx();
        let global = crate::model::is_global(model, set.mode());
        let rho = match region_radius(model) {
            r if global || r <= 0.0 => 1.0,
            r => r,
        };
        let combos = rate_combos(model);
        let zero = |ms: &[DMatrix<f64>]| ms.iter().all(|m| m.iter().all(|v| *v == 0.0));
        let linear = combos
            .iter()
            .map(|c| {
                c.terms
                    .iter()
                    .all(|&(l, m, _)| zero(&model.vertices[l].n) && zero(&model.vertices[m].m))
            })
            .collect();
        Ok(Problem {
            global,
            linear,
            model,
            set,
            conditions: Conditions::Full,
            nx,
            ny: model.ny(),
            nv: model.nv(),
            np: svec_len(nx),
            rho,
            scale: set.scale(rho),
            xs_hat: model.region.vertices.iter().map(|x| x / rho).collect(),
            as_hat: model.region.facets.iter().map(|a| a * rho).collect(),
            terms: OnceLock::new(),
            combos,
            max_a_fro: model
                .vertices
                .iter()
                .map(|v| v.a.norm())
                .fold(0.0, f64::max),
            max_r_fro: OnceLock::new(),
            gens: Vec::new(),
            cube_r_fro: 0.0,
            cube_one_slack: false,
            max_gain: None,
            scaling: None,
            sample: None,
            poles: Vec::new(),
        })
    }

    /// The same problem posed in coordinates z = D⁻¹x: `model` (the
    /// problem's own) is the user's model transformed by
    /// [`StateScaling::model`], and every solve maps its point back to the
    /// user's coordinates (P = D⁻¹P_zD⁻¹, Γ_l = D⁻¹Γ_z,l, the cube slacks
    /// like P) and a metric P_ref forward (D P_ref D), so that callers see
    /// the user's units only. A gain bound G is imposed as G / max_i d_i on
    /// L_z = D⁻¹L (sufficient: ‖L‖₂ ≤ max_i d_i ‖L_z‖₂); the certificate
    /// checks the user's ‖L_l‖₂.
    pub fn with_scaling(mut self, scaling: Option<StateScaling>) -> Self {
        self.scaling = scaling.filter(|s| s.len() == self.nx);
        self
    }

    /// The change of coordinates the problem is posed in, if any.
    pub fn scaling(&self) -> Option<&StateScaling> {
        self.scaling.as_ref()
    }

    /// The gain bound in the problem's coordinates.
    fn max_gain_z(&self) -> Option<f64> {
        let g = self.max_gain?;
        Some(match &self.scaling {
            Some(s) => g / s.max(),
            None => g,
        })
    }

    /// The same problem with ‖L_l‖₂ ≤ G imposed at every θ-vertex (None:
    /// no bound): a variable p̂ with P̂ − p̂I ⪰ 0 and
    /// [G'p̂ I, Γ̂_lᵀ; Γ̂_l, G'p̂ I] ⪰ 0, G' = G(1 − 10⁻⁴) (room for the
    /// solver's tolerance), so that ‖L_l‖₂ ≤ ‖Γ̂_l‖₂/λ_min(P̂) ≤ G' —
    /// linear, and exact up to the surrogate's ‖P⁻¹Γ‖ ≤ ‖Γ‖/λ_min(P).
    pub fn with_max_gain(mut self, max_gain: Option<f64>) -> Self {
        self.max_gain = max_gain.filter(|g| g.is_finite() && *g > 0.0);
        self
    }

    /// The gain bound imposed, if any.
    pub fn max_gain(&self) -> Option<f64> {
        self.max_gain
    }

    /// The vertex-pair terms, computed on first use.
    fn terms(&self) -> &PairTerms {
        self.terms.get_or_init(|| PairTerms::new(self.model))
    }

    /// max over (l, i, j) of ‖R_{l,i,j}‖_F, computed on first use.
    fn max_r_fro(&self) -> f64 {
        *self.max_r_fro.get_or_init(|| {
            let terms = self.terms();
            let (nx, np) = (self.nx, self.model.region.vertices.len());
            let mut max_r_fro: f64 = 0.0;
            for l in 0..self.nv {
                for i in 0..np {
                    for j in 0..np {
                        let mut acc = 0.0;
                        let (h, w) = (&terms.nhe[l][j], &terms.nrw[l][i]);
                        for k in 0..nx * nx {
                            let d = h[k] - w[k];
                            acc += d * d;
                        }
                        max_r_fro = max_r_fro.max(acc.sqrt());
                    }
                }
            }
            max_r_fro
        })
    }

    /// The same problem with the given family of rate conditions (the
    /// default of [`Problem::new`] is [`Conditions::Full`]). `Cube` needs a
    /// region that is a zonotope ([`crate::conditions::cube::generators`]);
    /// `Auto` must be resolved first ([`crate::model::size::choose`]).
    pub fn with_conditions(mut self, conditions: Conditions) -> Result<Self, SolveError> {
        match conditions {
            Conditions::Auto => {
                return Err(SolveError::Unsupported(
                    "conditions = auto must be resolved to full, decoupled or cube before assembly"
                        .into(),
                ))
            }
            Conditions::Cube => {
                let Some(gens) = crate::conditions::cube::generators(self.model) else {
                    return Err(SolveError::Unsupported(format!(
                        "conditions = cube needs a region that is a box, a parallelotope or a zonotope; this one ({} vertices, {} facets) is none of them",
                        self.model.region.vertices.len(),
                        self.model.region.facets.len()
                    )));
                };
                self.cube_r_fro = self
                    .model
                    .vertices
                    .iter()
                    .map(|v| {
                        gens.iter()
                            .map(|g| rows_he(&v.n, g).norm() + rows(&v.n, g).norm())
                            .sum::<f64>()
                    })
                    .fold(0.0, f64::max);
                self.gens = gens;
                self.cube_one_slack = self.cube_pairs_fold();
                self.as_hat = cube::one_of_each_opposite_pair(&self.as_hat);
            }
            Conditions::Full | Conditions::Decoupled => {}
        }
        self.conditions = conditions;
        Ok(self)
    }

    /// The family of rate conditions assembled.
    pub fn conditions(&self) -> Conditions {
        self.conditions
    }

    /// Number of decision variables (P̂, Γ̂_l and, for decoupled conditions,
    /// Ẑ_l, for cube ones the slacks of [`Problem::n_slack_vars`] and D; the
    /// margin variable of [`Objective::MaxMargin`] comes after them).
    pub fn n_vars(&self) -> usize {
        self.gains_end() + self.n_slack_vars() + usize::from(self.max_gain.is_some())
    }

    /// The variable p̂ ≤ λ_min(P̂) of the gain bound (after the slacks).
    fn gain_bound_var(&self) -> usize {
        self.gains_end() + self.n_slack_vars()
    }

    /// One past the last Γ̂ variable (the first Ẑ variable).
    fn gains_end(&self) -> usize {
        self.np + self.nv * self.nx * self.ny
    }

    /// Number of slack variables: Ẑ_c, one per rate combination
    /// ([`crate::conditions::Combo`]) of nx(nx+1)/2 entries when decoupled;
    /// for cube conditions the lower slacks Ŝ_{c,k}, Ŝ'_{c,k} per combination
    /// and generator (one Ŝ_{c,k} with [`Problem::cube_one_slack`]) and the
    /// r entries of D; else 0.
    pub fn n_slack_vars(&self) -> usize {
        match self.conditions {
            Conditions::Full | Conditions::Auto => 0,
            Conditions::Decoupled => self.combos.len() * self.np,
            Conditions::Cube => self.cube_slack_vars(),
        }
    }

    /// Number of rate LMI blocks assembled: c p² (full), c·2p (decoupled)
    /// or c(4r + 1) (cube, r generators; c(2r + 1) with one slack per
    /// generator, [`Problem::cube_one_slack`]), with c combinations (c = N
    /// for a constant output map, N² for the double sum).
    pub fn n_rate_blocks(&self) -> usize {
        let p = self.model.region.vertices.len();
        match self.conditions {
            Conditions::Full | Conditions::Auto => self.n_full_rate_blocks(),
            Conditions::Decoupled => self.combos.len() * 2 * p,
            Conditions::Cube => {
                self.combos.len() * (2 * self.cube_slacks_per_generator() * self.gens.len() + 1)
            }
        }
    }

    /// Number of blocks of the full family (c p²), which the certificate
    /// checks for full and decoupled conditions (for cube ones it checks the
    /// slack inequalities instead).
    pub fn n_full_rate_blocks(&self) -> usize {
        let p = self.model.region.vertices.len();
        self.linear
            .iter()
            .map(|&lin| if lin { 1 } else { p * p })
            .sum()
    }

    /// Number of blocks of the full family without the de-duplication of
    /// linear combinations (c p²: what was assembled before a combination
    /// whose N and M vanish was written once).
    pub fn n_pair_rate_blocks(&self) -> usize {
        let p = self.model.region.vertices.len();
        self.combos.len() * p * p
    }

    /// Whether this is the global observer of an LPV plant
    /// ([`crate::model::is_global`]).
    pub fn is_global(&self) -> bool {
        self.global
    }

    /// Whether combination `c`'s nonlinear terms vanish (its blocks are one).
    pub fn combo_is_linear(&self, c: usize) -> bool {
        self.linear[c]
    }

    /// The rate family's combinations (see [`crate::conditions::Combo`]).
    pub fn combos(&self) -> &[Combo] {
        &self.combos
    }

    /// The condition set.
    pub fn set(&self) -> ConditionSet {
        self.set
    }

    /// κ: the data size of the rate LMIs used to scale their margin.
    pub fn rate_scale(&self, alpha: f64, gamma: f64) -> f64 {
        let r = match self.conditions {
            Conditions::Cube => self.cube_r_fro,
            _ => self.max_r_fro(),
        };
        let gamma = if self.global { 1.0 } else { gamma };
        gamma * (alpha + self.max_a_fro) + r
    }

    #[inline]
    fn gvar(&self, l: usize, r: usize, c: usize) -> usize {
        self.np + l * self.nx * self.ny + r * self.ny + c
    }

    /// Variable of Ẑ_c's packed upper-triangle entry `idx` (decoupled only).
    #[inline]
    fn zvar(&self, c: usize, idx: usize) -> usize {
        self.gains_end() + c * self.np + idx
    }

    /// K and the gain terms H_l of combination `c` at the e-vertex `e`
    /// and/or the x-vertex `x`, so that the block is He{P̂K − Σ_l Γ̂_l H_l}:
    /// for each term (l, m, w) the e-part adds w(γA_l + (γα/2)I − σ rows(N_l, x_e))
    /// to K and w(γC_m − rows(M_m, x_e)) to H_l; the x-part adds
    /// wσ rowsHe(N_l, x_x) to K and w rowsHe(M_m, x_x) to H_l.
    fn combo_kh(
        &self,
        alpha: f64,
        gamma: f64,
        c: usize,
        e: Option<usize>,
        x: Option<usize>,
    ) -> (DMatrix<f64>, Vec<(usize, DMatrix<f64>)>) {
        self.combo_kh_parts(alpha, gamma, c, e.is_some(), e, x)
    }

    /// As [`Problem::combo_kh`] with the linear part (γA_l + (γα/2)I and
    /// γC_m) added when `linear` holds, whether or not an e-vertex is given.
    fn combo_kh_parts(
        &self,
        alpha: f64,
        gamma: f64,
        c: usize,
        linear: bool,
        e: Option<usize>,
        x: Option<usize>,
    ) -> (DMatrix<f64>, Vec<(usize, DMatrix<f64>)>) {
        let sigma = self.set.nonlinear_sign();
        let terms = self.terms();
        let mut k = DMatrix::zeros(self.nx, self.nx);
        let mut hs: Vec<(usize, DMatrix<f64>)> = Vec::new();
        for &(l, m, w) in &self.combos[c].terms {
            let mut h = DMatrix::zeros(self.ny, self.nx);
            if linear {
                k += &self.model.vertices[l].a * (gamma * w);
                for d in 0..self.nx {
                    k[(d, d)] += 0.5 * gamma * alpha * w;
                }
                h += &self.model.vertices[m].c * (gamma * w);
            }
            if let Some(i) = e {
                k -= &terms.nrw[l][i] * (sigma * w);
                h -= &terms.mrw[m][i] * w;
            }
            if let Some(j) = x {
                k += &terms.nhe[l][j] * (sigma * w);
                h += &terms.mhe[m][j] * w;
            }
            match hs.iter_mut().find(|(g, _)| *g == l) {
                Some((_, acc)) => *acc += h,
                None => hs.push((l, h)),
            }
        }
        hs.sort_by_key(|(g, _)| *g);
        (k, hs)
    }

    /// K and the gain terms of the rate block (combination c, pair i, j) in
    /// scaled form (see [`crate::conditions::Combo`]); for a constant output
    /// map combination c is θ-vertex c and this is He{P̂K − Γ̂_c H} with
    /// K = γA_c + σR_{c,i,j} + (γα/2)I, H = γC + S_{i,j}.
    pub fn rate_kh(
        &self,
        alpha: f64,
        gamma: f64,
        c: usize,
        i: usize,
        j: usize,
    ) -> (DMatrix<f64>, Vec<(usize, DMatrix<f64>)>) {
        self.combo_kh(alpha, gamma, c, Some(i), Some(j))
    }

    /// K and the gain terms of the one block of a linear combination c
    /// ([`Problem::combo_is_linear`]): K = γA + (γα/2)I, H = γC, the block
    /// every vertex pair of c shares.
    pub(crate) fn linear_kh(
        &self,
        alpha: f64,
        gamma: f64,
        c: usize,
    ) -> (DMatrix<f64>, Vec<(usize, DMatrix<f64>)>) {
        self.combo_kh_parts(alpha, gamma, c, true, None, None)
    }

    /// The e-vertex part F0_c + G_c(x_i) of the decoupled conditions (module
    /// doc of [`crate::conditions`]).
    pub fn decoupled_e_kh(
        &self,
        alpha: f64,
        gamma: f64,
        c: usize,
        i: usize,
    ) -> (DMatrix<f64>, Vec<(usize, DMatrix<f64>)>) {
        self.combo_kh(alpha, gamma, c, Some(i), None)
    }

    /// The x-vertex part H_c(x_j) of the decoupled conditions. With
    /// [`Problem::decoupled_e_kh`] at (c, i) it adds up to
    /// [`Problem::rate_kh`] at (c, i, j).
    pub(crate) fn decoupled_x_kh(
        &self,
        c: usize,
        j: usize,
    ) -> (DMatrix<f64>, Vec<(usize, DMatrix<f64>)>) {
        self.combo_kh(0.0, 0.0, c, None, Some(j))
    }

    /// Pushes the coefficients of He{P̂K − Σ_l Γ̂_l H_l} (svec, √2 off the
    /// diagonal) into the block starting at `row0`; `df` is scratch of nx².
    fn push_he_block(
        &self,
        out: &mut SdpBuilder,
        blk: &Psd,
        k: &DMatrix<f64>,
        hs: &[(usize, DMatrix<f64>)],
        df: &mut [f64],
    ) {
        let nx = self.nx;
        // P̂ variables.
        for pc in 0..nx {
            for pr in 0..=pc {
                let v = svec_index(pr, pc);
                // W = E K; ∂F = W + Wᵀ, computed on the upper triangle.
                df.iter_mut().for_each(|x| *x = 0.0);
                for cc in 0..nx {
                    for rr in 0..=cc {
                        let mut w = 0.0;
                        if pr == pc {
                            if rr == pr {
                                w += k[(pr, cc)];
                            }
                            if cc == pr {
                                w += k[(pr, rr)];
                            }
                        } else {
                            if rr == pr {
                                w += k[(pc, cc)];
                            }
                            if rr == pc {
                                w += k[(pr, cc)];
                            }
                            if cc == pr {
                                w += k[(pc, rr)];
                            }
                            if cc == pc {
                                w += k[(pr, rr)];
                            }
                        }
                        df[svec_index(rr, cc)] = w;
                    }
                }
                for cc in 0..nx {
                    for rr in 0..=cc {
                        out.entry(blk, rr, cc, v, df[svec_index(rr, cc)]);
                    }
                }
            }
        }
        // Γ̂_l variables: ∂F/∂Γ_rc = −(E_rc H + Hᵀ E_rcᵀ),
        // entry (a, b) = −([a==r] H[c,b] + [b==r] H[c,a]).
        for (l, h) in hs {
            self.push_gain_columns(out, blk, *l, h);
        }
    }

    /// The Γ̂_l columns of one block: −He{Γ̂_l H}.
    fn push_gain_columns(&self, out: &mut SdpBuilder, blk: &Psd, l: usize, h: &DMatrix<f64>) {
        let (nx, ny) = (self.nx, self.ny);
        for gr in 0..nx {
            for gc in 0..ny {
                let v = self.gvar(l, gr, gc);
                for cc in 0..nx {
                    for rr in 0..=cc {
                        let mut w = 0.0;
                        if rr == gr {
                            w += h[(gc, cc)];
                        }
                        if cc == gr {
                            w += h[(gc, rr)];
                        }
                        if w != 0.0 {
                            out.entry(blk, rr, cc, v, -w);
                        }
                    }
                }
            }
        }
    }

    /// Assembles the problem at (α, γ) with the given objective.
    pub fn assemble(
        &self,
        alpha: f64,
        gamma: f64,
        settings: &Settings,
        objective: Objective,
    ) -> Assembled {
        self.assemble_with_metric(alpha, gamma, settings, objective, None)
    }

    /// As [`Problem::assemble`]; `metric` (P_ref in model units) sets W of
    /// [`Objective::MaxMargin`] (ignored otherwise). The rows, in order:
    /// (S1), the region's vertex condition, its facets, the rate family of
    /// the chosen conditions, and t̂ ≤ 1 for the max-margin objective.
    pub fn assemble_with_metric(
        &self,
        alpha: f64,
        gamma: f64,
        settings: &Settings,
        objective: Objective,
        metric: Option<&DMatrix<f64>>,
    ) -> Assembled {
        self.assemble_family(
            (alpha, gamma),
            settings,
            objective,
            metric,
            RateFamily::Decay,
        )
    }

    /// As [`Problem::assemble_with_metric`] with the rate family chosen:
    /// the decay conditions of the problem's conditions, or the noise
    /// blocks in their place (with σ̂ after the other variables, minimised).
    pub(crate) fn assemble_family(
        &self,
        (alpha, gamma): (f64, f64),
        settings: &Settings,
        objective: Objective,
        metric: Option<&DMatrix<f64>>,
        family: RateFamily,
    ) -> Assembled {
        let max_margin = objective == Objective::MaxMargin;
        let min_gain = objective == Objective::MinGain;
        // The global observer's blocks are homogeneous: γ plays no role.
        let gamma = if self.global { 1.0 } else { gamma };
        // Extra variables after the problem's: t̂ (max margin), or c and κ
        // (min gain).
        let n = self.n_vars() + usize::from(max_margin) + 2 * usize::from(min_gain);
        let tvar = self.n_vars();
        let kappa = self.rate_scale(alpha, gamma);
        let eps = settings.margin_rel;
        let eps_rate = if max_margin { 0.0 } else { eps * kappa };
        let margin = max_margin.then(|| MarginColumn {
            var: tvar,
            coef: self.margin_column(metric, kappa),
        });
        let mut out = self.builder(max_margin, min_gain);
        debug_assert_eq!(out.n_vars(), n);
        let sigma = matches!(family, RateFamily::Noise(_)).then(|| out.var("sigma"));
        if self.global && sigma.is_some() {
            self.push_global_noise_normalisation(&mut out);
        } else if self.global {
            self.push_global_normalisation(&mut out, eps, max_margin);
        } else {
            self.push_s1(&mut out, eps);
            match self.conditions {
                Conditions::Cube => self.push_cube_region(&mut out, eps),
                _ => self.push_region_vertices(&mut out, eps),
            }
            self.push_region_facets(&mut out, gamma, eps);
        }
        let rate = RateMargins {
            eps: eps_rate,
            slack_eps: eps * kappa,
            column: margin.as_ref(),
        };
        match (family, sigma) {
            (RateFamily::Noise(channels), Some(svar)) => {
                match self.sample {
                    Some(h) => {
                        let fam = sampled::SampledNoiseFamily {
                            channels,
                            svar,
                            eps: rate.eps,
                        };
                        self.push_rate_noise_sampled(&mut out, (alpha, gamma, h), &fam);
                    }
                    None => {
                        self.push_rate_noise(&mut out, (alpha, gamma), channels, svar, rate.eps)
                    }
                }
                out.cost(svar, 1.0);
            }
            _ => match self.conditions {
                Conditions::Full | Conditions::Auto => match self.sample {
                    Some(h) => self.push_rate_sampled(&mut out, alpha, gamma, h, &rate),
                    None => self.push_rate_full(&mut out, alpha, gamma, &rate),
                },
                Conditions::Decoupled => self.push_rate_decoupled(&mut out, alpha, gamma, &rate),
                Conditions::Cube => self.push_rate_cube(&mut out, alpha, gamma, &rate),
            },
        }
        self.push_poles(&mut out, gamma, eps, max_margin);
        if let Some(g) = self.max_gain_z() {
            self.push_gain_bound(&mut out, g);
        }
        if min_gain {
            self.homogenise_for_min_gain(&mut out, metric);
        }
        if max_margin {
            // t̂ ≤ 1.
            let row = out.nonneg(1);
            out.set_b(row, 1.0);
            out.a(row, tvar, 1.0);
        }
        self.objective(&mut out, settings, objective);
        out.finish()
    }

    /// The noise block family in place of the rate family: one block per
    /// rate combination and region-vertex pair (see [`noise::NoiseBlock`]),
    /// with margin `eps` (ε κ) and σ̂ the variable `svar`.
    fn push_rate_noise(
        &self,
        out: &mut SdpBuilder,
        (alpha, gamma): (f64, f64),
        channels: &NoiseChannels,
        svar: usize,
        eps: f64,
    ) {
        let outs = channels.noisy_outputs(self.ny);
        let block = noise::NoiseBlock {
            nx: self.nx,
            ny: self.ny,
            nw: channels.n_w(),
            outs: &outs,
            svar,
            gamma,
            eps,
        };
        let np = self.xs_hat.len();
        for (c, combo) in self.combos.iter().enumerate() {
            // B_w of the combination, and the weight of each Γ̂_l in −γΓ̂E.
            let mut cn = noise::ComboNoise {
                bw: DMatrix::zeros(block.nx, block.nw),
                wl: vec![0.0; self.nv],
                wsum: combo.weight(),
            };
            for &(l, _, w) in &combo.terms {
                if let Some(bb) = &channels.b_w {
                    cn.bw += &bb[l] * w;
                }
                cn.wl[l] += w;
            }
            for i in 0..np {
                for j in 0..np {
                    let (kk, hs) = self.rate_kh(alpha, gamma, c, i, j);
                    block.push(out, (&kk, &hs), &cn, |l, r, c| self.gvar(l, r, c));
                }
            }
        }
    }

    /// A builder with the problem's variables declared, in the order of
    /// [`Problem::n_vars`]: P̂, Γ̂_l, the slacks of the conditions, the
    /// gain bound's p̂; then t̂ (max margin) or c and κ (min gain).
    fn builder(&self, max_margin: bool, min_gain: bool) -> SdpBuilder {
        let mut out = SdpBuilder::new();
        out.sym_var("P", self.nx);
        out.vars("Gamma", self.nv * self.nx * self.ny);
        out.vars("slacks", self.n_slack_vars());
        if self.max_gain.is_some() {
            out.var("gain_bound");
        }
        if max_margin {
            out.var("margin");
        }
        if min_gain {
            out.var("homogeniser");
            out.var("gain_norm");
        }
        out
    }

    /// The global observer's normalisation in place of the region rows
    /// (its conditions are homogeneous in (P, Γ_l)): P̂ − I ⪰ 0; for the
    /// max-margin objective P̂ − εI ⪰ 0 and I − P̂ ⪰ 0 instead, which bound
    /// P̂ so that the optimal margin measures the depth of the point rather
    /// than the size of P̂ (any strictly feasible (P̂, Γ̂) scaled into
    /// εI ⪯ P̂ ⪯ I is feasible for it).
    fn push_global_normalisation(&self, out: &mut SdpBuilder, eps: f64, max_margin: bool) {
        if !max_margin {
            self.push_s1(out, 1.0);
            return;
        }
        self.push_s1(out, eps);
        // I − P̂ ⪰ 0: s = svec(I) − svec(P̂) ⇒ b = svec(I), A = svec(E_v).
        let blk = out.psd(self.nx, -1.0);
        self.push_sym_var(out, &blk, 0, 1.0);
    }

    /// The global observer's normalisation for the noise objective: P ⪰ cI
    /// in the model's own coordinates (P̂_z ⪰ cD² in balanced ones, P =
    /// D⁻¹P̂_zD⁻¹). The noise block is homogeneous in (P, Γ_l, σ), so with
    /// λ_min(P) ≥ 1 the smallest σ is the smallest certified error bound
    /// √(σ/(α λ_min(P))) per unit noise (docs/method.md §17).
    fn push_global_noise_normalisation(&self, out: &mut SdpBuilder) {
        let blk = out.psd(self.nx, 0.0);
        self.push_sym_var(out, &blk, 0, -1.0);
        // The blocks are homogeneous, so P ⪰ cI for any c > 0 gives the
        // same smallest bound; c = 1/max_i d_i² keeps P̂_z ⪰ D²c ⪯ I.
        let dmax = self.scaling.as_ref().map_or(1.0, |s| s.max());
        for d in 0..self.nx {
            let di = self.scaling.as_ref().map_or(1.0, |s| s.d[d]) / dmax;
            out.rhs(&blk, d, d, -di * di / self.scale);
        }
    }

    /// `max_gain = G`: P̂ − p̂I ⪰ 0, then [G'p̂ I_ny, Γ̂_lᵀ; Γ̂_l, G'p̂ I_nx] ⪰ 0
    /// per θ-vertex (see [`Problem::with_max_gain`]).
    fn push_gain_bound(&self, out: &mut SdpBuilder, g: f64) {
        let nx = self.nx;
        let pvar = self.gain_bound_var();
        // P̂ − p̂ I ⪰ 0.
        let blk = out.psd(nx, 0.0);
        self.push_sym_var(out, &blk, 0, -1.0);
        for d in 0..nx {
            out.entry(&blk, d, d, pvar, 1.0);
        }
        let g = g * (1.0 - 1e-4);
        for l in 0..self.nv {
            self.push_gain_block(out, l, pvar, g);
        }
    }

    /// [w·v I_ny, Γ̂_lᵀ; Γ̂_l, w·v I_nx] ⪰ 0 for the scalar variable v:
    /// s = −A x with A holding −w on the diagonal (column v) and −√2 at
    /// the Γ̂_l entries (row ny + r, column c < ny: packed at (c, ny + r)).
    fn push_gain_block(&self, out: &mut SdpBuilder, l: usize, v: usize, w: f64) {
        let (nx, ny) = (self.nx, self.ny);
        let blk = out.psd(nx + ny, 0.0);
        for k in 0..nx + ny {
            out.entry(&blk, k, k, v, -w);
        }
        for r in 0..nx {
            for c in 0..ny {
                out.entry(&blk, c, ny + r, self.gvar(l, r, c), -1.0);
            }
        }
    }

    /// [`Objective::MinGain`]: every row so far becomes homogeneous (its
    /// right-hand side b moves into the column of c: A x − c b + s = 0),
    /// then c ≥ 0, P̂ − W ⪰ 0 and the blocks ‖W^{-1/2} Γ̂_l‖₂ ≤ κ, with
    /// W = I or, given a usable `metric` P_ref (a certified point's P, in
    /// the problem's coordinates), W = P_ref/λ_min(P_ref) ⪰ I: then
    /// ‖P̂⁻¹Γ̂‖₂ ≤ ‖W^{-1/2}‖ ‖W^{-1/2}Γ̂‖₂ ≤ κ as well (Γ̂ᵀP̂⁻¹Γ̂ ⪯ Γ̂ᵀW⁻¹Γ̂),
    /// and the normalisation follows the shape of a P that certifies,
    /// where P̂ ⪰ I alone leaves the solver a badly scaled problem.
    fn homogenise_for_min_gain(&self, out: &mut SdpBuilder, metric: Option<&DMatrix<f64>>) {
        let (nx, ny) = (self.nx, self.ny);
        let (cvar, kvar) = (self.n_vars(), self.n_vars() + 1);
        out.homogenise(cvar);
        // c ≥ 0 (s = c).
        let row = out.nonneg(1);
        out.a(row, cvar, -1.0);
        let w = metric.and_then(|m| normalised_metric(m, nx));
        let Some((w, w_inv_half)) = w else {
            // P̂ − I ⪰ 0, ‖Γ̂_l‖₂ ≤ κ.
            self.push_s1(out, 1.0);
            for l in 0..self.nv {
                self.push_gain_block(out, l, kvar, 1.0);
            }
            return;
        };
        // P̂ − W ⪰ 0: s = svec(P̂) − svec(W).
        let blk = out.psd(nx, 0.0);
        for c in 0..nx {
            for r in 0..=c {
                out.rhs(&blk, r, c, -w[(r, c)]);
                out.entry(&blk, r, c, svec_index(r, c), -1.0);
            }
        }
        // [κ I, Γ̂_lᵀ W^{-1/2}; W^{-1/2} Γ̂_l, κ I] ⪰ 0.
        let d = nx + ny;
        for l in 0..self.nv {
            let blk = out.psd(d, 0.0);
            for k in 0..d {
                out.entry(&blk, k, k, kvar, -1.0);
            }
            for k in 0..nx {
                for c in 0..ny {
                    for r in 0..nx {
                        out.entry(&blk, c, ny + r, self.gvar(l, k, c), -w_inv_half[(r, k)]);
                    }
                }
            }
        }
    }

    /// svec(W)·κ, the coefficients of the max-margin column t̂ in a rate
    /// block (upper triangle, √2 off the diagonal), W of [`Problem::margin_metric`].
    fn margin_column(&self, metric: Option<&DMatrix<f64>>, kappa: f64) -> Vec<f64> {
        let nx = self.nx;
        let wm = self.margin_metric(metric);
        let mut w = vec![0.0; svec_len(nx)];
        for c in 0..nx {
            for r in 0..=c {
                w[svec_index(r, c)] = svec_scale(r, c) * wm[(r, c)] * kappa;
            }
        }
        w
    }

    /// W of the max-margin objective: P_ref/λ_max(P_ref) for a usable
    /// `metric`, else I.
    fn margin_metric(&self, metric: Option<&DMatrix<f64>>) -> DMatrix<f64> {
        let nx = self.nx;
        let m = metric
            .filter(|m| m.shape() == (nx, nx) && m.iter().all(|v| v.is_finite()))
            .map(|m| (m + m.transpose()) * 0.5);
        let lmax = m
            .as_ref()
            .map(|m| m.clone().symmetric_eigenvalues().max())
            .unwrap_or(0.0);
        match m {
            Some(m) if lmax > 0.0 => m / lmax,
            _ => DMatrix::identity(nx, nx),
        }
    }

    /// (S1): P̂ − εI ⪰ 0: s = svec(P̂) − ε svec(I) ⇒ b = −ε svec(I), A = −svec(E_v).
    fn push_s1(&self, out: &mut SdpBuilder, eps: f64) {
        let blk = out.psd(self.nx, eps);
        self.push_sym_var(out, &blk, 0, -1.0);
    }

    /// The region vertices: (S2) 1 − ε − x̂ᵀP̂x̂ ≥ 0 per vertex (one
    /// nonnegative cone), or (13) [1 x̂ᵀ; x̂ P̂] − εI ⪰ 0 per vertex.
    fn push_region_vertices(&self, out: &mut SdpBuilder, eps: f64) {
        let nx = self.nx;
        match self.set.vertex_form() {
            RegionForm::VertexQuadratic => {
                // 1 − ε − x̂ᵀP̂x̂ ≥ 0: b = 1 − ε, A[v] = x̂ᵀ E_v x̂.
                let row0 = out.nonneg(self.xs_hat.len());
                for (i, x) in self.xs_hat.iter().enumerate() {
                    out.set_b(row0 + i, 1.0 - eps);
                    for c in 0..nx {
                        for r in 0..=c {
                            let v = if r == c {
                                x[r] * x[r]
                            } else {
                                2.0 * x[r] * x[c]
                            };
                            out.a(row0 + i, svec_index(r, c), v);
                        }
                    }
                }
            }
            RegionForm::VertexSchur => {
                // [1 x̂ᵀ; x̂ P̂] − εI ⪰ 0 (indices: 0 = the scalar, 1.. = P̂).
                for x in &self.xs_hat {
                    let blk = out.psd(nx + 1, eps);
                    out.rhs(&blk, 0, 0, 1.0 - eps);
                    for c in 0..nx {
                        out.rhs(&blk, 0, c + 1, x[c]);
                    }
                    for c in 0..nx {
                        for r in 0..=c {
                            out.entry(&blk, r + 1, c + 1, svec_index(r, c), -1.0);
                        }
                    }
                }
            }
            _ => unreachable!("vertex form"),
        }
    }

    /// The region facets: (S3) [1 γâₖᵀ; γâₖ P̂] − εI ⪰ 0 or (14)
    /// [1 γâₖᵀP̂; γP̂âₖ P̂] − εI ⪰ 0 per facet.
    fn push_region_facets(&self, out: &mut SdpBuilder, gamma: f64, eps: f64) {
        let nx = self.nx;
        let facet_form = self.set.facet_form();
        for a in &self.as_hat {
            let blk = out.psd(nx + 1, eps);
            out.rhs(&blk, 0, 0, 1.0 - eps);
            match facet_form {
                RegionForm::FacetSchur => {
                    for c in 0..nx {
                        out.rhs(&blk, 0, c + 1, gamma * a[c]);
                    }
                    for c in 0..nx {
                        for r in 0..=c {
                            out.entry(&blk, r + 1, c + 1, svec_index(r, c), -1.0);
                        }
                    }
                }
                RegionForm::FacetSchurP => {
                    // Off-diagonal block row 0, column m+1: γ (P̂ â)_m, linear in P̂.
                    // ∂(P̂â)_m/∂P̂_rc = [m==r] a_c + [m==c] a_r (r≠c); [m==r] a_r (r==c).
                    for c in 0..nx {
                        for r in 0..=c {
                            let v = svec_index(r, c);
                            // Entries (0, m+1) for m ∈ {r, c}, and (r+1, c+1).
                            if r == c {
                                out.entry(&blk, 0, r + 1, v, -gamma * a[r]);
                            } else {
                                out.entry(&blk, 0, r + 1, v, -gamma * a[c]);
                                out.entry(&blk, 0, c + 1, v, -gamma * a[r]);
                            }
                            out.entry(&blk, r + 1, c + 1, v, -1.0);
                        }
                    }
                }
                _ => unreachable!("facet form"),
            }
        }
    }

    /// Full rate family: −He{P̂K − Γ̂H} − ε κ I ⪰ 0 per (combination, i, j):
    /// b = −ε_rate svec(I), A[v] = svec(∂F/∂v).
    fn push_rate_full(&self, out: &mut SdpBuilder, alpha: f64, gamma: f64, rate: &RateMargins) {
        let p_reg = self.xs_hat.len();
        let mut df = vec![0.0; self.nx * self.nx];
        for c in 0..self.combos.len() {
            if self.linear[c] {
                // N and M vanish: every pair (i, j) has the same block.
                let (k, hs) = self.linear_kh(alpha, gamma, c);
                let blk = out.psd(self.nx, rate.eps);
                self.push_he_block(out, &blk, &k, &hs, &mut df);
                rate.push_column(out, &blk);
                continue;
            }
            for i in 0..p_reg {
                for j in 0..p_reg {
                    let (k, hs) = self.rate_kh(alpha, gamma, c, i, j);
                    let blk = out.psd(self.nx, rate.eps);
                    self.push_he_block(out, &blk, &k, &hs, &mut df);
                    rate.push_column(out, &blk);
                }
            }
        }
    }

    /// Decoupled rate family, per combination c: F0_c + G_c(x_i) + Ẑ_c ⪯ −ε κ I
    /// (the margin, and the max-margin column, sit here), then
    /// H_c(x_j) − Ẑ_c ⪯ 0.
    fn push_rate_decoupled(
        &self,
        out: &mut SdpBuilder,
        alpha: f64,
        gamma: f64,
        rate: &RateMargins,
    ) {
        let p_reg = self.xs_hat.len();
        let mut df = vec![0.0; self.nx * self.nx];
        for c in 0..self.combos.len() {
            for i in 0..p_reg {
                let (k, hs) = self.decoupled_e_kh(alpha, gamma, c, i);
                let blk = out.psd(self.nx, rate.eps);
                self.push_he_block(out, &blk, &k, &hs, &mut df);
                self.push_sym_var(out, &blk, self.zvar(c, 0), 1.0);
                rate.push_column(out, &blk);
            }
            for j in 0..p_reg {
                let (k, hs) = self.decoupled_x_kh(c, j);
                let blk = out.psd(self.nx, 0.0);
                self.push_he_block(out, &blk, &k, &hs, &mut df);
                self.push_sym_var(out, &blk, self.zvar(c, 0), -1.0);
            }
        }
    }

    /// The columns of ±Ŝ in an nx-block, Ŝ a symmetric variable whose upper
    /// triangle starts at variable `first`: ∂(±Ŝ)/∂Ŝ_rc = ±E_rc, svec entry
    /// ±1 (diagonal) or ±√2.
    fn push_sym_var(&self, out: &mut SdpBuilder, blk: &Psd, first: usize, sign: f64) {
        for c in 0..self.nx {
            for r in 0..=c {
                out.entry(blk, r, c, first + svec_index(r, c), sign);
            }
        }
    }

    /// The objective: ½ w Σ Γ̂² (diagonal on the Γ̂ columns) for
    /// [`Objective::Gains`], −t̂ for [`Objective::MaxMargin`], κ for
    /// [`Objective::MinGain`].
    fn objective(&self, out: &mut SdpBuilder, settings: &Settings, objective: Objective) {
        if objective == Objective::Gains && settings.gain_weight > 0.0 {
            for v in self.np..self.gains_end() {
                out.quadratic(v, settings.gain_weight);
            }
        }
        match objective {
            Objective::MaxMargin => out.cost(self.n_vars(), -1.0),
            Objective::MinGain => out.cost(self.n_vars() + 1, 1.0),
            Objective::Feasibility | Objective::Gains => {}
        }
    }

    /// Unpacks a solution vector into (P, Γ_l) in model units.
    pub fn unpack(&self, x: &[f64]) -> (DMatrix<f64>, Vec<DMatrix<f64>>) {
        let nx = self.nx;
        let s = self.scale;
        let mut p = DMatrix::zeros(nx, nx);
        for c in 0..nx {
            for r in 0..=c {
                let v = s * x[svec_index(r, c)];
                p[(r, c)] = v;
                p[(c, r)] = v;
            }
        }
        let gammas = (0..self.nv)
            .map(|l| DMatrix::from_fn(nx, self.ny, |r, c| s * x[self.gvar(l, r, c)]))
            .collect();
        (p, gammas)
    }

    /// Packs (P, Γ_l) in model units into a scaled variable vector (the
    /// inverse of [`Problem::unpack`]; used by tests).
    pub fn pack(&self, p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> Vec<f64> {
        let mut x = vec![0.0; self.n_vars()];
        for c in 0..self.nx {
            for r in 0..=c {
                x[svec_index(r, c)] = p[(r, c)] / self.scale;
            }
        }
        for (l, g) in gammas.iter().enumerate() {
            for r in 0..self.nx {
                for c in 0..self.ny {
                    x[self.gvar(l, r, c)] = g[(r, c)] / self.scale;
                }
            }
        }
        x
    }

    /// The slacks Z_l (model units, symmetric) of a decoupled solution
    /// vector; empty for full conditions.
    pub fn unpack_z(&self, x: &[f64]) -> Vec<DMatrix<f64>> {
        if self.conditions == Conditions::Full {
            return Vec::new();
        }
        let nx = self.nx;
        (0..self.combos.len())
            .map(|l| {
                let mut z = DMatrix::zeros(nx, nx);
                for c in 0..nx {
                    for r in 0..=c {
                        let v = self.scale * x[self.zvar(l, svec_index(r, c))];
                        z[(r, c)] = v;
                        z[(c, r)] = v;
                    }
                }
                z
            })
            .collect()
    }

    /// Writes the slacks Z_l (model units; upper triangles used) into a
    /// variable vector from [`Problem::pack`] (decoupled only; used by tests).
    pub fn pack_z(&self, x: &mut [f64], z: &[DMatrix<f64>]) {
        assert_eq!(
            self.conditions,
            Conditions::Decoupled,
            "only decoupled problems have slacks"
        );
        for (l, zl) in z.iter().enumerate() {
            for c in 0..self.nx {
                for r in 0..=c {
                    x[self.zvar(l, svec_index(r, c))] = zl[(r, c)] / self.scale;
                }
            }
        }
    }

    /// Assembles and solves at (α, γ).
    pub fn solve(
        &self,
        alpha: f64,
        gamma: f64,
        settings: &Settings,
        objective: Objective,
    ) -> Result<SolveResult, SolveError> {
        self.solve_with_metric(alpha, gamma, settings, objective, None)
    }

    /// As [`Problem::solve`] with the [`Objective::MaxMargin`] metric P_ref.
    pub fn solve_with_metric(
        &self,
        alpha: f64,
        gamma: f64,
        settings: &Settings,
        objective: Objective,
        metric: Option<&DMatrix<f64>>,
    ) -> Result<SolveResult, SolveError> {
        ensure_lapack();
        // The global observer's conditions bound P̂ from below only (P̂ ⪰
        // I): ½ Σ‖Γ̂_l‖² may be approached only as P̂ grows without bound
        // along some direction, and the solver does not stop. Its gain
        // objective is the min-gain one (homogeneous, normalised, bounded).
        // The min-gain point lies on the boundary of the rate conditions
        // (its margin ε κ is tiny against gains of the size this objective
        // often has to accept), so it is solved at α(1 + GLOBAL_BACKOFF):
        // at α it then holds with the margin of that step, γ-free.
        let (objective, alpha) = if self.global && objective == Objective::Gains {
            (Objective::MinGain, alpha * (1.0 + GLOBAL_BACKOFF))
        } else {
            (objective, alpha)
        };
        let t0 = Instant::now();
        let metric_z = match (&self.scaling, metric) {
            (Some(s), Some(m)) if m.shape() == (self.nx, self.nx) => {
                Some(DMatrix::from_fn(self.nx, self.nx, |r, c| {
                    m[(r, c)] * s.d[r] * s.d[c]
                }))
            }
            _ => None,
        };
        let metric = metric_z.as_ref().or(metric);
        let prob = self.assemble_with_metric(alpha, gamma, settings, objective, metric);
        let assembly_seconds = t0.elapsed().as_secs_f64();
        let mut cs = clarabel_settings(settings);
        if objective == Objective::MaxMargin {
            // Search steps only need a good interior point: the certificate
            // and the capacity are computed independently of the solver's
            // accuracy, and these problems are always feasible.
            cs.tol_gap_abs = cs.tol_gap_abs.max(settings.search_tol);
            cs.tol_gap_rel = cs.tol_gap_rel.max(settings.search_tol);
            cs.tol_feas = cs.tol_feas.max(settings.search_tol);
        }
        let mut run = run_sdp(prob, cs)?;
        let mut margin = f64::NAN;
        if objective == Objective::MinGain {
            // Divide the homogenised point by c (no point without c > 0).
            let nv = self.n_vars();
            run.x = run.x.take().and_then(|x| {
                let c = x[nv];
                (c.is_finite() && c > 0.0).then(|| {
                    margin = x[nv + 1];
                    x[..nv].iter().map(|v| v / c).collect()
                })
            });
        }
        let (p, gammas, cube) = match &run.x {
            Some(x) => {
                let (p, g) = self.unpack(x);
                (Some(p), g, self.unpack_cube(x))
            }
            None => (None, Vec::new(), None),
        };
        if let Some(x) = run.x.as_ref().filter(|_| objective == Objective::MaxMargin) {
            margin = x[self.n_vars()];
        }
        let (p, gammas, cube) = match &self.scaling {
            // Back to the user's coordinates.
            Some(s) => (
                p.map(|p| s.p_from_z(&p)),
                gammas.iter().map(|g| s.gamma_from_z(g)).collect(),
                cube.map(|c| crate::conditions::cube::CubeSlacks {
                    y: c.y
                        .iter()
                        .map(|r| r.iter().map(|m| s.p_from_z(m)).collect())
                        .collect(),
                    x: c.x
                        .iter()
                        .map(|r| r.iter().map(|m| s.p_from_z(m)).collect())
                        .collect(),
                    d: c.d,
                }),
            ),
            None => (p, gammas, cube),
        };
        Ok(SolveResult {
            status: run.status,
            detail: run.detail,
            iterations: run.iterations,
            solve_seconds: run.solve_seconds,
            assembly_seconds,
            p,
            gammas,
            margin,
            cube,
        })
    }
}
