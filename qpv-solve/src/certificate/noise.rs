//! Noise and disturbances: a certified bound on how much measurement noise
//! (and process disturbance) gets through a design, and the design that
//! minimises it.
//!
//! With measurement noise v (y_meas = y + v on the noisy outputs) and a
//! process disturbance w (x' = … + B_w(θ) w) the observer is unchanged and
//! its error obeys e' = F(θ, e, x) e + B_w(θ) w − L(θ) v. A design carries
//! the claim
//!
//! ```text
//!     V' + αV ≤ σ (|w|² + |v|²)     for e ∈ E, x ∈ F, θ ∈ Θ and all w, v,     V = eᵀPe,
//! ```
//!
//! which follows from the block LMI (written like the rate LMI, multiplied by γ)
//!
//! ```text
//!     [ S_{l,i,j}       γ P B_w,l    −γ Γ_l E ]
//!     [ γ B_w,lᵀ P      −γσ I         0       ]  ≺ 0
//!     [ −γ Eᵀ Γ_lᵀ      0            −γσ I    ]
//! ```
//!
//! at every θ-vertex l and region-vertex pair (i, j), S_{l,i,j} being the
//! rate block of (S5) and E the columns of the noisy outputs (the same
//! combinations as the rate family when the output map depends on θ). For
//! fixed P, Γ_l it holds iff S ≺ 0 and σ > γ λ_max(Gᵀ(−S)⁻¹G) with
//! G = [P B_w,l, −Γ_l E] (a Schur complement): [`sigma_for`] computes σ so,
//! maximised over the blocks, with a small relative margin; [`check_noise`]
//! re-checks the block LMI itself by the eigenvalues of the whole block, from
//! the model and the gains only. [`design_noise`] minimises σ over
//! (P, Γ_l, σ) at fixed α (and fixed or searched γ), one SDP per γ, and
//! [`tradeoff`] sweeps α.
//!
//! What σ guarantees, for noise bounded in amplitude |w(t)|² + |v(t)|² ≤ ν²
//! (and x(t) in F, Assumption 2, for the disturbed plant):
//! * E stays invariant while σν² < α: the largest tolerated amplitude is
//!   ν_max = √(α/σ) (`max_amplitude`);
//! * V(t) ≤ e^{−αt}V(0) + (σν²/α)(1 − e^{−αt}), so the error ends in
//!   {V ≤ σν²/α}: ‖e(∞)‖ ≤ ν √(σ/(α λ_min(P))) (`error_bound`, per unit ν)
//!   and |e_k(∞)| ≤ ν √(σ (P⁻¹)_kk / α) (`per_state`).
//!
//! This module is the certificate's side: σ for given gains, the
//! independent check of the block LMI, the bound's figures and the
//! disturbance floor (docs/method.md states the model).

use crate::certificate::combo_lmi;
use crate::conditions::{pair_suffix, rate_combos, Combo};
use crate::model::noise::NoiseChannels;
use crate::model::StateScaling;
use crate::vocab::Candidate;
use nalgebra::DMatrix;
use qpv_dsl::{Mode, PolytopicModel};
use serde::{Deserialize, Serialize};

/// The pieces of one block: the rate matrix S (≺ 0 required), the coupling
/// G = Σ_t w_t [γ P B_w,l_t, −γ Γ_l_t E] and the weight W = Σ_t w_t (the
/// bottom-right block is −γσW I).
struct BlockParts {
    s: DMatrix<f64>,
    g: DMatrix<f64>,
    w: f64,
}

fn block_parts(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    (alpha, gamma): (f64, f64),
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    combo: &Combo,
    (i, j): (usize, usize),
) -> BlockParts {
    let s = combo_lmi(
        model,
        Mode::Sound,
        Candidate::new(alpha, gamma),
        p,
        gammas,
        combo,
        (i, j),
    );
    let outs = channels.noisy_outputs(model.ny());
    let nw = channels.n_w();
    let nx = model.nx();
    let mut g = DMatrix::zeros(nx, nw + outs.len());
    for &(l, _, w) in &combo.terms {
        if let Some(b) = &channels.b_w {
            let pb = p * &b[l] * (gamma * w);
            let mut v = g.view_mut((0, 0), (nx, nw));
            v += pb;
        }
        for (c, &k) in outs.iter().enumerate() {
            for r in 0..nx {
                g[(r, nw + c)] -= gamma * w * gammas[l][(r, k)];
            }
        }
    }
    BlockParts {
        s,
        g,
        w: combo.weight(),
    }
}

/// The smallest σ for which the block LMI holds at every block for these
/// (P, Γ_l), by the Schur complement: max over blocks of
/// λ_max(Gᵀ(−S)⁻¹G)/(γW) (no margin). `None` if some S is not negative
/// definite (no σ works) or the input is malformed.
pub(crate) fn sigma_min_for(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> Option<f64> {
    channels.validate(model).ok()?;
    if gammas.len() != model.nv() || p.shape() != (model.nx(), model.nx()) {
        return None;
    }
    let np = model.region.vertices.len();
    let mut worst: f64 = 0.0;
    for combo in rate_combos(model) {
        for i in 0..np {
            for j in 0..np {
                let b = block_parts(model, channels, (alpha, gamma), p, gammas, &combo, (i, j));
                let neg = -&b.s;
                let ch = neg.cholesky()?;
                let y = ch.l().solve_lower_triangular(&b.g)?;
                let m = y.transpose() * &y;
                let lmax = m.symmetric_eigenvalues().max();
                if !lmax.is_finite() {
                    return None;
                }
                worst = worst.max(lmax / (gamma * b.w));
            }
        }
    }
    Some(worst)
}

/// σ for these (P, Γ_l) with the margin the independent check needs:
/// [`sigma_min_for`] times (1 + δ), δ = 1e-6 raised tenfold (to 1e-2 at
/// most) until [`check_noise`] passes; `None` if it never does. A global
/// observer's blocks are checked in balanced coordinates
/// ([`BalancedGlobal`]) and, failing that, in the model's own (the two are
/// exactly congruent: either check proves the claim).
pub(crate) fn sigma_for(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> Option<(f64, NoiseCheck)> {
    BalancedGlobal::of(model, channels, p, gammas)
        .and_then(|z| sigma_for_plain(&z.model, &z.channels, alpha, gamma, &z.p, &z.gammas))
        .or_else(|| sigma_for_plain(model, channels, alpha, gamma, p, gammas))
}

/// The global observer's noise check in balanced coordinates: its P may
/// span many orders of magnitude (docs/method.md §17, "Units"), and the
/// eigenvalues of the block are read in z = D⁻¹x with D from P
/// ([`StateScaling::of_p`], powers of two): the block there is
/// diag(D, I)·block·diag(D, I), exactly, so its sign (and σ) is the same.
pub(crate) struct BalancedGlobal {
    pub(crate) model: PolytopicModel,
    pub(crate) channels: NoiseChannels,
    pub(crate) p: DMatrix<f64>,
    pub(crate) gammas: Vec<DMatrix<f64>>,
}

impl BalancedGlobal {
    /// The balanced inputs, if `model` is a global observer's model and
    /// P balances exactly (None: check in the model's own coordinates).
    pub(crate) fn of(
        model: &PolytopicModel,
        channels: &NoiseChannels,
        p: &DMatrix<f64>,
        gammas: &[DMatrix<f64>],
    ) -> Option<BalancedGlobal> {
        if !is_global_model(model) || p.shape() != (model.nx(), model.nx()) {
            return None;
        }
        let s = StateScaling::of_p(p)?;
        Some(BalancedGlobal {
            model: s.model(model)?,
            channels: channels.in_z(&s),
            p: s.p_to_z(p)?,
            gammas: gammas
                .iter()
                .map(|g| s.gamma_to_z(g))
                .collect::<Option<_>>()?,
        })
    }
}

/// [`sigma_for`] in the coordinates given.
fn sigma_for_plain(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> Option<(f64, NoiseCheck)> {
    let s0 = sigma_min_for(model, channels, alpha, gamma, p, gammas)?;
    let base = s0.max(f64::MIN_POSITIVE);
    let mut delta = 1e-6;
    while delta <= 1.01e-2 {
        let sigma = base * (1.0 + delta);
        let c = check_noise(model, channels, alpha, gamma, p, gammas, sigma);
        if c.passed {
            return Some((sigma, c));
        }
        delta *= 10.0;
    }
    None
}

/// The independent check of the noise claim: the whole block matrix
///
/// ```text
///     [ S        G      ]
///     [ Gᵀ   −γσW I     ]
/// ```
///
/// (S the rate block, G the noise coupling, see the module doc) at every
/// rate combination and region-vertex pair, by its largest eigenvalue —
/// not by the Schur formula. It reads only the model, P, Γ_l = P L_l and σ.
pub fn check_noise(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    sigma: f64,
) -> NoiseCheck {
    let mut out = NoiseCheck {
        margin: f64::INFINITY,
        guard: 0.0,
        passed: true,
        worst_at: String::new(),
        count: 0,
    };
    let fail = |why: String| NoiseCheck {
        margin: -f64::MAX,
        guard: 0.0,
        passed: false,
        worst_at: why,
        count: 0,
    };
    if let Err(e) = channels.validate(model) {
        return fail(e.to_string());
    }
    if let Err(e) = crate::conditions::validate(model) {
        return fail(e.to_string());
    }
    if gammas.len() != model.nv()
        || p.shape() != (model.nx(), model.nx())
        || gammas.iter().any(|g| g.shape() != (model.nx(), model.ny()))
    {
        return fail("P or the gains do not fit the model".into());
    }
    if !(sigma.is_finite() && sigma > 0.0 && alpha.is_finite() && gamma_in_range(model, gamma)) {
        return fail(format!(
            "σ = {sigma}, α = {alpha}, γ = {gamma} out of range"
        ));
    }
    let nx = model.nx();
    let double = crate::conditions::is_double_sum(model);
    let np = model.region.vertices.len();
    for combo in rate_combos(model) {
        for i in 0..np {
            for j in 0..np {
                let b = block_parts(model, channels, (alpha, gamma), p, gammas, &combo, (i, j));
                let k = b.g.ncols();
                let n = nx + k;
                let mut m = DMatrix::zeros(n, n);
                m.view_mut((0, 0), (nx, nx)).copy_from(&b.s);
                m.view_mut((0, nx), (nx, k)).copy_from(&b.g);
                m.view_mut((nx, 0), (k, nx)).copy_from(&b.g.transpose());
                for d in 0..k {
                    m[(nx + d, nx + d)] = -gamma * sigma * b.w;
                }
                let e = m.clone().symmetric_eigenvalues();
                let lmax = if e.iter().any(|v| v.is_nan()) {
                    f64::NAN
                } else {
                    e.max()
                };
                let margin = -lmax;
                let guard = 32.0 * f64::EPSILON * (n as f64 + 1.0) * m.norm();
                out.record(margin, guard, || {
                    format!("{}{}", combo.label(double), pair_suffix(model, i, j))
                });
            }
        }
    }
    out.passed &= out.count > 0;
    out
}

/// Whether γ is a γ of a noise claim on `model`: in (0, 1), or exactly 1 on
/// the global observer's model of an LPV plant (its blocks carry no region
/// terms, docs/method.md §17).
pub(crate) fn gamma_in_range(model: &PolytopicModel, gamma: f64) -> bool {
    gamma > 0.0 && (gamma < 1.0 || (is_global_model(model) && gamma == 1.0))
}

/// Whether `model` is the global observer's model of an LPV plant
/// ([`crate::model::global_model`]: no N_k or M_k, the region the point
/// {0}): its noise claim holds for every e, so no amplitude limits it.
pub(crate) fn is_global_model(model: &PolytopicModel) -> bool {
    model.is_lpv()
        && model
            .region
            .vertices
            .iter()
            .all(|v| v.iter().all(|&c| c == 0.0))
}

/// The noise bound of a design with Lyapunov matrix `p` and gains L_l
/// (Γ_l = P L_l recomputed): σ from [`sigma_for`] (checked by
/// [`check_noise`]) and the derived amplitudes. `None` if the block LMI
/// cannot be certified for any σ (e.g. the rate LMIs themselves fail).
pub fn noise_bound(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
) -> Option<NoiseBound> {
    noise_bound_or_why(model, channels, alpha, gamma, p, l).ok()
}

/// [`noise_bound`], or why there is none, in words: the gains do not fit
/// P, the channels do not fit the model, a rate block S is not negative
/// definite in floating point at α (then no σ exists), the independent
/// check fails up to 1 % above the smallest σ (the rate condition leaves
/// too little room at α for a finite σ to be verified), or P is not
/// positive definite.
pub(crate) fn noise_bound_or_why(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    l: &[DMatrix<f64>],
) -> Result<NoiseBound, String> {
    if l.iter().any(|li| li.nrows() != p.ncols()) {
        return Err("the gains do not fit P".into());
    }
    let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| p * li).collect();
    let Some((sigma, check)) = sigma_for(model, channels, alpha, gamma, p, &gammas) else {
        return Err(no_sigma_reason(model, channels, (alpha, gamma), p, &gammas));
    };
    bound_from(model, channels, alpha, p, sigma, check)
        .ok_or_else(|| "P is not positive definite".into())
}

/// Why [`sigma_for`] found no σ for these (P, Γ_l), in words.
fn no_sigma_reason(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    (alpha, gamma): (f64, f64),
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> String {
    if let Err(e) = channels.validate(model) {
        return format!("the noise channels do not fit the model ({e})");
    }
    if gammas.len() != model.nv() || p.shape() != (model.nx(), model.nx()) {
        return "P or the gains do not fit the model".into();
    }
    let double = crate::conditions::is_double_sum(model);
    let np = model.region.vertices.len();
    for combo in rate_combos(model) {
        for i in 0..np {
            for j in 0..np {
                let b = block_parts(model, channels, (alpha, gamma), p, gammas, &combo, (i, j));
                if (-&b.s).cholesky().is_none() {
                    let top = b.s.symmetric_eigenvalues().max();
                    return format!(
                        "the decay block at {}{} is not negative definite in floating point \
                         (largest eigenvalue {top:.3e}): the rate condition holds at alpha = {} \
                         with no room there, so no finite sigma is certified",
                        combo.label(double),
                        pair_suffix(model, i, j),
                        fmt_alpha(alpha)
                    );
                }
            }
        }
    }
    match sigma_min_for(model, channels, alpha, gamma, p, gammas) {
        Some(s0) => format!(
            "the smallest sigma the Schur complement gives is {s0:.3e}, but the independent \
             eigenvalue check fails up to 1 % above it: the rate condition leaves too little \
             room at alpha = {} for a finite sigma to be verified",
            fmt_alpha(alpha)
        ),
        None => "the noise blocks are not finite for these P and gains".into(),
    }
}

/// α in the reports' short form.
fn fmt_alpha(alpha: f64) -> String {
    format!("{alpha:.6}")
        .trim_end_matches('0')
        .trim_end_matches('.')
        .to_string()
}

pub(crate) fn bound_from(
    model: &PolytopicModel,
    channels: &NoiseChannels,
    alpha: f64,
    p: &DMatrix<f64>,
    sigma: f64,
    check: NoiseCheck,
) -> Option<NoiseBound> {
    let ps = (p + p.transpose()) * 0.5;
    let lmin = ps.clone().symmetric_eigenvalues().min();
    let pinv = ps.cholesky()?.inverse();
    if lmin.is_nan() || lmin <= 0.0 {
        return None;
    }
    Some(NoiseBound {
        sigma,
        max_amplitude: if is_global_model(model) {
            f64::INFINITY
        } else {
            (alpha / sigma).sqrt()
        },
        error_bound: (sigma / (alpha * lmin)).sqrt(),
        per_state: (0..p.nrows())
            .map(|k| (sigma * pinv[(k, k)] / alpha).sqrt())
            .collect(),
        noisy_outputs: channels
            .noisy_outputs(model.ny())
            .iter()
            .map(|&k| model.outputs[k].clone())
            .collect(),
        disturbances: channels.n_w(),
        check,
    })
}

/// A box, one interval [lo, hi] per state.
pub type Boxes = Vec<(f64, f64)>;

/// Boxes of the plant state x and of the estimate x̂ = x − e over which a
/// certified design's observer runs: x ∈ F (its state bound Q, |x_k| ≤
/// √Q_kk) ⊂ P̃ (the region scaled by 1/γ), e ∈ E = {eᵀPe ≤ 1}, |e_k| ≤
/// √((P⁻¹)_kk). Returns (box of x, box of x̂); None if P is not positive
/// definite.
pub(crate) fn observer_boxes(
    model: &PolytopicModel,
    gamma: f64,
    p: &DMatrix<f64>,
) -> Option<(Boxes, Boxes)> {
    let n = model.nx();
    let ps = (p + p.transpose()) * 0.5;
    let pinv = ps.cholesky()?.inverse();
    let vs = &model.region.vertices;
    let q = match &model.state_bound {
        qpv_dsl::StateBound::Given(q) if q.nrows() == n => Some(q),
        _ => None,
    };
    let mut xs = Vec::with_capacity(n);
    let mut xh = Vec::with_capacity(n);
    for k in 0..n {
        let lo = vs.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min) / gamma;
        let hi = vs.iter().map(|v| v[k]).fold(f64::NEG_INFINITY, f64::max) / gamma;
        let (lo, hi) = match q {
            Some(q) => {
                let r = q[(k, k)].max(0.0).sqrt();
                (lo.max(-r), hi.min(r))
            }
            None => (lo, hi),
        };
        let e = pinv[(k, k)].max(0.0).sqrt();
        xs.push((lo, hi));
        xh.push((lo - e, hi + e));
    }
    Some((xs, xh))
}

/// The independent check of the noise block LMI at every combination and
/// region-vertex pair (positive margin = satisfied).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseCheck {
    /// −λ_max of the worst block.
    pub margin: f64,
    /// The floating-point guard the margin must exceed.
    pub guard: f64,
    /// margin > guard at every block.
    pub passed: bool,
    /// Where the worst margin occurs (1-based, like the rate family).
    pub worst_at: String,
    /// Number of blocks checked.
    pub count: usize,
}

impl NoiseCheck {
    /// Counts one block of margin `margin` (NaN fails) against its
    /// floating-point `guard`, keeping it (and where it is, `at`) if it is
    /// the worst so far.
    pub(crate) fn record(&mut self, margin: f64, guard: f64, at: impl FnOnce() -> String) {
        self.count += 1;
        if margin.is_nan() || margin <= guard {
            self.passed = false;
        }
        if self.count == 1 || margin.is_nan() || margin < self.margin {
            self.margin = if margin.is_nan() { -f64::MAX } else { margin };
            self.guard = guard;
            self.worst_at = at();
        }
    }
}

/// The certified noise bound of a design (the report's `noise` key).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseBound {
    /// σ of V' + αV ≤ σ(|w|² + |v|²), checked by [`check_noise`].
    pub sigma: f64,
    /// ν_max = √(α/σ): up to this noise amplitude E stays invariant.
    /// Unlimited (∞, `null` in a report) for the global observer of an LPV
    /// plant, whose claim holds for every e (docs/method.md §17).
    #[serde(with = "unlimited")]
    pub max_amplitude: f64,
    /// ‖e(∞)‖ per unit noise amplitude: √(σ/(α λ_min(P))).
    pub error_bound: f64,
    /// |e_k(∞)| per unit noise amplitude, per state: √(σ (P⁻¹)_kk / α).
    pub per_state: Vec<f64>,
    /// Names of the outputs with measurement noise.
    pub noisy_outputs: Vec<String>,
    /// Number of process-disturbance inputs.
    pub disturbances: usize,
    /// The independent check of the block LMI at `sigma`.
    pub check: NoiseCheck,
}

/// Serde of an amplitude that may be unlimited: ∞ is written `null` (JSON
/// has no infinity) and read back from it.
mod unlimited {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_infinite() && *v > 0.0 {
            s.serialize_none()
        } else {
            s.serialize_some(v)
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
    }
}
