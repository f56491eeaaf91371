//! A skew-symmetric slack for N_k (optional): the alternation and what it buys.
//!
//! Only the symmetric part of N_k moves the plant, so N_k + K_k with
//! K_k = −K_kᵀ (per θ-vertex, K_k(θ) = Σ_l μ_l K_{k,l}) is the same plant for
//! every choice of K. In the rate LMI K only enters through the e-vertex
//! term: rowsHe(N + K, x) = rowsHe(N, x) and rows(N + K, e) = rows(N, e) +
//! rows(K, e), so (S5) becomes
//!
//! ```text
//!     He{ P(γA_l + R_{l,i,j} − rows(K_l, x_(i))) − Γ_l H_{i,j} } + γαP ≺ 0,
//! ```
//!
//! bilinear in (P, K). [`alternate`] alternates two convex steps from a
//! certified design at a fixed γ:
//!
//! 1. P fixed: the rate LMIs are linear in (Γ_l, K_l, α) jointly (α
//!    multiplies the fixed P), and the region conditions only involve P, so
//!    one SDP maximises α over (Γ, K) ([`max_alpha_fixed_p`]);
//! 2. K fixed: the ordinary α search on the model with N_k + K_k, written as
//!    is (`split = as_written`, which keeps K).
//!
//! Every accepted point is re-checked by the independent certificate on the
//! model with N_k + K_k — a valid representation of the same plant, so the
//! certificate is a certificate for the plant. Sound mode; step 1 imposes
//! the full rate family (every combination of [`crate::conditions::Combo`]
//! at every region-vertex pair), step 2 the request's conditions. Used by
//! `split = skew_slack` (the design driver) and the bench `skew_slack`.

use crate::certificate::{check, Gains};
use crate::error::SolveError;
use crate::lmi::skew::max_alpha_fixed_p;
use crate::model::skew::with_skew;
use crate::report::Design;
use crate::settings::Settings;
use crate::vocab::Candidate;
use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, PolytopicModel, Split};

/// One round of the alternation.
#[derive(Debug, Clone, PartialEq)]
pub struct Round {
    /// Certified α after step 1 (P fixed, (Γ, K) optimised); NaN if the
    /// step's point did not certify.
    pub alpha_fixed_p: f64,
    /// Certified α after step 2 (K fixed, P re-optimised).
    pub alpha: f64,
    /// max_{k,l} ‖K_{k,l}‖_F after the round.
    pub k_norm: f64,
}

/// Result of [`alternate`].
#[derive(Debug, Clone)]
pub struct SkewResult {
    /// γ of the whole alternation.
    pub gamma: f64,
    /// α of the starting design (K = 0).
    pub alpha_start: f64,
    /// Every round, in order.
    pub rounds: Vec<Round>,
    /// The model with N_k + K_k of the best round (the same plant).
    pub model: PolytopicModel,
    /// K_{k,l} of the best round (per θ-vertex l, per k): `model`'s N minus
    /// the start design's representation.
    pub k: Vec<Vec<DMatrix<f64>>>,
    /// The best certified design, on [`SkewResult::model`].
    pub design: Design,
}

impl SkewResult {
    /// The best certified α reached.
    pub fn alpha_best(&self) -> f64 {
        self.design.alpha
    }
}

/// The α search of step 2: the largest certified α of a model for a
/// request (α = max at a fixed γ, as written).
pub type AlphaSearch<'a> =
    dyn FnMut(&PolytopicModel, &DesignRequest) -> Result<Design, SolveError> + 'a;

/// Alternates step 1 and step 2 (module doc) for at most `rounds` rounds,
/// starting from `start` (a certified sound design of `model`; its state
/// bound, output route and split are applied first), at its γ; step 2
/// solves `conditions` with `alpha_search`. Stops when a round gains less
/// than 0.1 %.
pub fn alternate(
    model: &PolytopicModel,
    start: &Design,
    rounds: usize,
    settings: &Settings,
    conditions: Conditions,
    alpha_search: &mut AlphaSearch<'_>,
) -> Result<SkewResult, SolveError> {
    if !start.certifies() {
        return Err(SolveError::SkewNeedsSound);
    }
    let gamma = start.gamma;
    let base = start.observer_model(model)?;
    let mut cur_model = base.clone();
    let mut cur = start.clone();
    let mut best = (cur_model.clone(), cur.clone());
    let mut out = Vec::new();
    for _ in 0..rounds {
        // Step 1: P fixed.
        let p = cur.p_matrix();
        let mut alpha_fixed_p = f64::NAN;
        if let Some((a, gains, dk)) = max_alpha_fixed_p(&cur_model, &p, gamma, settings)? {
            let next_model = with_skew(&cur_model, &dk);
            // certify slightly below the solver's α (its margin is relative)
            let a_c = a * (1.0 - 1e-6);
            let cert = check(
                &next_model,
                &Gains::new(&p, &gains),
                &Candidate::new(a_c, gamma),
                Mode::Sound,
            );
            if cert.passed {
                alpha_fixed_p = a_c;
                cur_model = next_model;
            }
        }
        // Step 2: K fixed, P re-optimised (as written: keeps K).
        let req = DesignRequest {
            alpha: AlphaSpec::Max,
            gamma: GammaSpec::Fixed(gamma),
            mode: Mode::Sound,
            split: Split::AsWritten,
            conditions,
            ..Default::default()
        };
        let d = alpha_search(&cur_model, &req)?;
        let k_norm = skew_of(&cur_model, &base)
            .iter()
            .flatten()
            .map(|k| k.norm())
            .fold(0.0, f64::max);
        let alpha = if d.certifies() { d.alpha } else { f64::NAN };
        out.push(Round {
            alpha_fixed_p,
            alpha,
            k_norm,
        });
        let prev = best.1.alpha;
        if d.certifies() && d.alpha > prev {
            best = (cur_model.clone(), d.clone());
            cur = d;
        } else {
            break;
        }
        if best.1.alpha < prev * 1.001 {
            break;
        }
    }
    Ok(SkewResult {
        gamma,
        alpha_start: start.alpha,
        rounds: out,
        k: skew_of(&best.0, &base),
        model: best.0,
        design: best.1,
    })
}

/// N_{k,l} of `model` minus those of `base` (the slack added to `base`).
fn skew_of(model: &PolytopicModel, base: &PolytopicModel) -> Vec<Vec<DMatrix<f64>>> {
    model
        .vertices
        .iter()
        .zip(&base.vertices)
        .map(|(a, b)| a.n.iter().zip(&b.n).map(|(na, nb)| na - nb).collect())
        .collect()
}
