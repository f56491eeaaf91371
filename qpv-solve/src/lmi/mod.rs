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

mod blocks;
mod cube;
pub(crate) mod noise;
mod objective;
mod poles;
mod rate;
mod region;
pub(crate) mod rms;
mod sampled;
mod sampled_decoupled;
pub(crate) mod skew;
mod solve;

pub(crate) use blocks::RateFamily;
pub use objective::Objective;
pub use solve::SolveResult;

use crate::backend::builder::SdpBuilder;
use crate::backend::Sdp;
use crate::conditions::{rate_combos, rows, rows_he, Combo, ConditionSet, PairTerms};
use crate::error::SolveError;
use crate::linalg::svec::{svec_index, svec_len};
use crate::model::{region_radius, validate, StateScaling};
use crate::settings::Settings;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::Conditions;
use qpv_dsl::PolytopicModel;
use std::sync::OnceLock;

/// One assembled problem in Clarabel's standard form (the backend's [`Sdp`]).
pub(crate) type Assembled = Sdp;

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
    /// The global observer ([`crate::model::ObserverKind`]): no region rows,
    /// P̂ ⪰ I as the normalisation, γ = 1 in the rate blocks.
    global: bool,
    /// Per rate combination: whether its nonlinear terms vanish (N_l = 0
    /// and M_m = 0 for every term), so that its p² vertex-pair blocks are
    /// one block, written once.
    linear: Vec<bool>,
    /// `poles = ...`: the pole regions imposed (see [`Problem::with_poles`]).
    poles: Vec<qpv_dsl::PoleRegion>,
    /// The Jacobian vertex dimensions q of the model
    /// ([`PolytopicModel::gain_shift`]): vertices l and l' share one Γ̂
    /// when l >> q == l' >> q (the gain cannot depend on the unmeasured H).
    tie: usize,
}

impl<'m> Problem<'m> {
    /// Precomputes everything that does not depend on (α, γ) (the
    /// vertex-pair terms only when full or decoupled conditions need them).
    pub fn new(model: &'m PolytopicModel, set: ConditionSet) -> Result<Self, SolveError> {
        validate(model)?;
        let nx = model.nx();
        let global = crate::model::ObserverKind::of(model, set.mode()).is_global();
        let rho = match region_radius(model) {
            r if global || r <= 0.0 => 1.0,
            r => r,
        };
        let combos = rate_combos(model);
        let linear = combos.iter().map(|c| c.is_linear(model)).collect();
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
            tie: model.gain_shift(),
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
            let mut max_r_fro: f64 = 0.0;
            for site in blocks::sites(self.nv, self.xs_hat.len(), |_| false) {
                let Some((i, j)) = site.pair else { continue };
                let (h, w) = (&terms.nhe[site.c][j], &terms.nrw[site.c][i]);
                let acc: f64 = h.iter().zip(w.iter()).map(|(h, w)| (h - w) * (h - w)).sum();
                max_r_fro = max_r_fro.max(acc.sqrt());
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
        self.np + (self.nv >> self.tie) * self.nx * self.ny
    }

    /// One vertex per gain: the first of each group that shares its Γ̂.
    pub(super) fn gain_vertices(&self) -> impl Iterator<Item = usize> {
        (0..self.nv).step_by(1 << self.tie)
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
    /// ([`crate::model::ObserverKind`]).
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
        self.np + (l >> self.tie) * self.nx * self.ny + r * self.ny + c
    }

    /// Variable of Ẑ_c's packed upper-triangle entry `idx` (decoupled only).
    #[inline]
    fn zvar(&self, c: usize, idx: usize) -> usize {
        self.gains_end() + c * self.np + idx
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
    /// The families in row order: the region (or the global observer's
    /// normalisation), the rate family, the pole regions, the gain bound,
    /// then the objective's own rows.
    pub(crate) fn assemble_family(
        &self,
        (alpha, gamma): (f64, f64),
        settings: &Settings,
        objective: Objective,
        metric: Option<&DMatrix<f64>>,
        family: RateFamily,
    ) -> Assembled {
        let max_margin = objective == Objective::MaxMargin;
        // The global observer's blocks are homogeneous: γ plays no role.
        let gamma = if self.global { 1.0 } else { gamma };
        let kappa = self.rate_scale(alpha, gamma);
        let eps = settings.margin_rel;
        let margin = max_margin.then(|| self.margin_column(metric, kappa));
        let rate = blocks::RateMargins {
            eps: if max_margin { 0.0 } else { eps * kappa },
            slack_eps: eps * kappa,
            column: margin.as_ref(),
        };
        let mut out = self.builder(objective);
        let noise = matches!(family, RateFamily::Noise(_));
        self.push_region(&mut out, (gamma, eps), max_margin, noise);
        self.push_rate(&mut out, (alpha, gamma), family, &rate);
        self.push_poles(&mut out, gamma, eps, max_margin);
        self.push_gain_bound(&mut out);
        self.push_objective(&mut out, settings, objective, metric);
        out.finish()
    }

    /// A builder with the problem's variables declared, in the order of
    /// [`Problem::n_vars`]: P̂, Γ̂_l, the slacks of the conditions, the
    /// gain bound's p̂; then t̂ (max margin) or c and κ (min gain).
    fn builder(&self, objective: Objective) -> SdpBuilder {
        let mut out = SdpBuilder::new();
        out.sym_var("P", self.nx);
        out.vars("Gamma", (self.nv >> self.tie) * self.nx * self.ny);
        out.vars("slacks", self.n_slack_vars());
        if self.max_gain.is_some() {
            out.var("gain_bound");
        }
        if objective == Objective::MaxMargin {
            out.var("margin");
        }
        if objective == Objective::MinGain {
            out.var("homogeniser");
            out.var("gain_norm");
        }
        out
    }

    /// Unpacks a solution vector into (P, Γ_l) in model units.
    pub fn unpack(&self, x: &[f64]) -> (DMatrix<f64>, Vec<DMatrix<f64>>) {
        let s = self.scale;
        let gammas = (0..self.nv)
            .map(|l| DMatrix::from_fn(self.nx, self.ny, |r, c| s * x[self.gvar(l, r, c)]))
            .collect();
        (self.sym_at(x, 0), gammas)
    }

    /// The symmetric nx × nx matrix (model units) whose scaled upper
    /// triangle starts at variable `first` of `x`.
    fn sym_at(&self, x: &[f64], first: usize) -> DMatrix<f64> {
        let mut m = DMatrix::zeros(self.nx, self.nx);
        for c in 0..self.nx {
            for r in 0..=c {
                let v = self.scale * x[first + svec_index(r, c)];
                m[(r, c)] = v;
                m[(c, r)] = v;
            }
        }
        m
    }

    /// Writes the upper triangle of `m` (model units) scaled into `x` from
    /// variable `first` on (the inverse of [`Problem::sym_at`]).
    fn put_sym(&self, x: &mut [f64], first: usize, m: &DMatrix<f64>) {
        for c in 0..self.nx {
            for r in 0..=c {
                x[first + svec_index(r, c)] = m[(r, c)] / self.scale;
            }
        }
    }

    /// Packs (P, Γ_l) in model units into a scaled variable vector (the
    /// inverse of [`Problem::unpack`]; used by tests).
    pub fn pack(&self, p: &DMatrix<f64>, gammas: &[DMatrix<f64>]) -> Vec<f64> {
        let mut x = vec![0.0; self.n_vars()];
        self.put_sym(&mut x, 0, p);
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
        (0..self.combos.len())
            .map(|l| self.sym_at(x, self.zvar(l, 0)))
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
            self.put_sym(x, self.zvar(l, 0), zl);
        }
    }
}
