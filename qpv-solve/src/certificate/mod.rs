//! The independent certificate: every condition recomputed from P and the
//! gains L_l (Γ_l = P L_l) in the model's own units, with dense nalgebra
//! matrices and symmetric eigenvalues — no code shared with the assembly
//! except the two definitions `rows` / `rowsHe`.
//!
//! Margins (positive = satisfied):
//! * "S1": λ_min(P) (P ≻ 0; a non-symmetric P fails).
//! * "S2" (sound): min_i 1 − x_(i)ᵀ P x_(i).
//! * "S3" (sound): min_k λ_min([1 γa_kᵀ; γa_k P]).
//! * "13" (paper): min_i λ_min([1 x_(i)ᵀ; x_(i) P]).
//! * "14" (paper): min_k λ_min([1 γa_kᵀP; γPa_k P]).
//! * "S5" / "26": min over (l, i, j) of −λ_max(He{…} + γαP).
//!
//! A family passes only if its worst margin exceeds a floating-point guard:
//! a conservative bound, 16·(n+1)·ε_mach times the sum of the Frobenius
//! norms of the terms forming the matrix (the error of forming it and of the
//! symmetric eigensolver). Data checks: "S4" max_k γ² a_kᵀQa_k ≤ 1 (required
//! in sound mode, reported as the violated assumption (15) in paper mode)
//! and "region_in_F" max_i x_(i)ᵀQ⁻¹x_(i) ≤ 1 (reported).

mod capacity;
mod cube;
mod families;
mod inputs;
mod jacobian;
mod margins;
pub mod measured;
pub mod noise;
pub mod noise_sampled;
pub mod poles;
mod rate;
pub mod rms;
pub mod rounding;
mod sampled;
pub mod sampling;
mod units;

pub use capacity::alpha_capacity;
pub(crate) use capacity::alpha_capacity_cube;
pub use inputs::data_checks;
pub use margins::{Certificate, DataCheck, FamilyMargin};
pub use rate::{combo_lmi, rate_lmi};
pub use sampled::alpha_capacity_sampled;

use crate::conditions::cube::CubeSlacks;
use crate::conditions::ConditionSet;
use crate::model::StateScaling;
use crate::vocab::{Candidate, Family};
use families::Stage;
use inputs::check_inputs;
use nalgebra::DMatrix;
use qpv_dsl::{Mode, PolytopicModel};
use std::collections::BTreeMap;
use units::{balanced, balanced_for, block_model, cube_to_z, gammas_of, l_to_z};

/// The gains a certificate judges: P, the gains L_l per θ-vertex (Γ_l =
/// P L_l is recomputed) and, for a `conditions = cube` design, the slacks
/// that witness its rate family.
#[derive(Debug, Clone, Copy)]
pub struct Gains<'a> {
    /// The Lyapunov matrix P.
    pub p: &'a DMatrix<f64>,
    /// L_l, one nx × ny matrix per θ-vertex.
    pub l: &'a [DMatrix<f64>],
    /// The cube slacks (Y, X, D), if the design has them.
    pub cube: Option<&'a CubeSlacks>,
}

impl<'a> Gains<'a> {
    /// P and the L_l, without cube slacks.
    pub fn new(p: &'a DMatrix<f64>, l: &'a [DMatrix<f64>]) -> Self {
        Gains { p, l, cube: None }
    }

    /// The same gains with these cube slacks (None: none).
    pub fn with_cube(self, cube: Option<&'a CubeSlacks>) -> Self {
        Gains { cube, ..self }
    }
}

/// The independent certificate of `gains` at the candidate `at` in `mode`:
/// every condition family recomputed from the model and the gains alone
/// ((S1)–(S5), or the paper's printed conditions), the data checks (S4)
/// and P ⊂ F. The rate family is the one the gains call for: the cube's
/// slack inequalities when they carry cube slacks, the discrete decrease
/// S5d when the candidate has a sample period (sound mode), else the
/// vertex family (S5)/(26) (G5 for the global observer).
///
/// A model with nonlinear terms of unmeasured states is checked on its
/// vertices expanded by the Jacobian box recomputed here from the terms
/// (at the candidate's γ when the box is on the set S), with the gains of
/// every θ-vertex's corners required to be equal.
pub fn check(model: &PolytopicModel, gains: &Gains, at: &Candidate, mode: Mode) -> Certificate {
    let rebuilt = match jacobian::recompute(model, at.gamma) {
        Ok(m) => m,
        Err(e) => return Certificate::refused(mode, at.alpha, at.gamma, e),
    };
    let model = rebuilt.as_ref().unwrap_or(model);
    if let Err(e) = jacobian::tied(model, gains.l) {
        return Certificate::refused(mode, at.alpha, at.gamma, e);
    }
    let (rate, balance) = match (gains.cube, at.sample) {
        (Some(_), Some(h)) => {
            return Certificate::refused(
                mode,
                at.alpha,
                at.gamma,
                format!("cube slacks at sample = {h}: a sampled design has no cube form"),
            )
        }
        (Some(c), None) => (RateCheck::Cube(c), balanced(model, mode)),
        (None, Some(h)) if mode == Mode::Sound => {
            (RateCheck::Sampled(h), balanced_for(model, mode, gains.p))
        }
        (None, Some(h)) => {
            return Certificate::refused(
                mode,
                at.alpha,
                at.gamma,
                format!("sample = {h} is a sound-mode condition, not one of the paper's"),
            )
        }
        (None, None) => (RateCheck::Vertex, balanced_for(model, mode, gains.p)),
    };
    measured::attach(model, check_in_units(model, mode, at, gains, balance, rate))
}

/// [`check_inner`] in the balanced coordinates `balance` when given and
/// every matrix transforms exactly (P, L_l and, for a cube check, its
/// slacks), else in the model's own: the one place a check chooses its
/// coordinates.
fn check_in_units(
    model: &PolytopicModel,
    mode: Mode,
    at: &Candidate,
    gains: &Gains,
    balance: Option<(PolytopicModel, StateScaling)>,
    rate: RateCheck<'_>,
) -> Certificate {
    let (p, l) = (gains.p, gains.l);
    if let Some((zm, s)) = balance {
        let cube_z = match rate {
            RateCheck::Cube(c) => cube_to_z(&s, c).map(Some),
            _ => Some(None),
        };
        if let (Some(pz), Some(lz), Some(cz)) = (s.p_to_z(p), l_to_z(&s, l), cube_z) {
            let (gammas, lnorm) = gammas_of(&pz, &lz);
            let rate_z = match (&cz, rate) {
                (Some(c), _) => RateCheck::Cube(c),
                (None, r) => r,
            };
            let witness = Witness {
                p: &pz,
                gammas: &gammas,
                lnorm: &lnorm,
            };
            return check_inner(&zm, mode, at, &witness, rate_z);
        }
    }
    let (gammas, lnorm) = gammas_of(p, l);
    let witness = Witness {
        p,
        gammas: &gammas,
        lnorm: &lnorm,
    };
    check_inner(model, mode, at, &witness, rate)
}

/// What [`check_inner`] evaluates: P, Γ_l and the sizes ‖L_l‖ its guards
/// use (‖Γ_l‖/‖P‖ when Γ_l is given directly).
struct Witness<'a> {
    p: &'a DMatrix<f64>,
    gammas: &'a [DMatrix<f64>],
    lnorm: &'a [f64],
}

/// Which rate family [`check_inner`] checks.
#[derive(Clone, Copy)]
enum RateCheck<'a> {
    /// (S5)/(26) at every combination and region-vertex pair.
    Vertex,
    /// The cube's slack inequalities with these slacks: the rate family and
    /// the region's vertex condition are the cube's slack inequalities with
    /// the slacks given (docs/method.md), checked by eigenvalues at a cost
    /// polynomial in nx (no vertex pair is enumerated):
    /// * vertex family ("S2" / "13"): λ_min(D − GᵀPG) (sound) or
    ///   λ_min([D Gᵀ; G P]) (paper), and 1 − Σ D_kk, with D = diag(d);
    /// * rate family ("S5" / "26"): λ_min(Y_{c,k} ∓ G_c(g_k)),
    ///   λ_min(X_{c,k} ∓ H_c(g_k)) and −λ_max(F0_c + Σ_k Y_{c,k} + Σ_k X_{c,k})
    ///   for every rate combination c and generator k.
    ///
    /// The generators are the region's own ([`qpv_dsl::Region::zonotope_generators`]);
    /// (S1), the facets and the data checks are as in [`check`].
    Cube(&'a CubeSlacks),
    /// The discrete decrease (S5d) at the sample period h ([`sampled`]).
    Sampled(f64),
}

fn check_inner(
    model: &PolytopicModel,
    mode: Mode,
    at: &Candidate,
    w: &Witness,
    rate: RateCheck<'_>,
) -> Certificate {
    let (alpha, gamma) = (at.alpha, at.gamma);
    let set = ConditionSet::from_mode(mode);
    // The global observer: the region is the point {0}, no state bound,
    // and γ = 1 in the rate blocks.
    let (model, gamma_blocks, global) = block_model(model, mode, gamma);
    let model = &*model;
    let (errs, gens) = check_inputs(model, set, at, w, rate);
    let data = if !global && (errs.is_empty() || w.p.nrows() == model.nx()) {
        data_checks(model, mode, gamma.clamp(0.0, 1.0))
    } else {
        BTreeMap::new()
    };
    let families = if errs.is_empty() {
        let stage = Stage {
            model,
            set,
            global,
            alpha,
            gamma: gamma_blocks,
            w,
            ps: (w.p + w.p.transpose()) * 0.5,
            rate,
            gens,
        };
        stage.families()
    } else {
        Vec::new()
    };
    let passed = errs.is_empty()
        && families.iter().all(|f| f.passed)
        && data.values().filter(|d| d.required).all(|d| d.passed)
        && (global || !set.requires_s4() || data.contains_key(Family::S4.name()));
    Certificate {
        mode,
        alpha,
        gamma,
        families,
        data_checks: data,
        passed,
        input_errors: errs,
    }
}
