//! Cheap reasons why a design fails, computed from the model and the
//! request alone (no solve): what a user should change next.
//!
//! * **Detectability** at every θ-vertex (the PBH rank test): a mode λ of
//!   A_l with Re λ ≥ −α/2 that the outputs cannot see (rank [A_l − λI; C_l]
//!   < nx) stays an eigenvalue of A_l − L C_l for every gain, so the rate
//!   condition (S5) fails at that vertex for this α whatever the solver
//!   does: averaging (S5) over the region's vertices with the weights that
//!   give x = e = 0 leaves He{P(A_l − L_l C_l)} + αP ≺ 0.
//!   Stable undetectable modes bound α from above (α < −2 Re λ).
//! * **(S4)**: γ ≤ γ_max = 1 / max_k √(a_kᵀ Q a_k), from Q and the facets.
//! * **Region too large for this Q**: a region vertex outside
//!   F = {xᵀQ⁻¹x ≤ 1}, with the factor the region must shrink by.
//!
//! * **Wide ranges of the scheduling functions**: a model with derived
//!   scheduling variables φ_j(θ) and no cover treats φ as independent of θ
//!   over the whole box of their ranges; when cutting one parameter's range
//!   into pieces would shrink those ranges markedly (measured by sampling
//!   φ on a grid, [`cover_estimate`]), the finding proposes `cover θ into n`.
//!
//! [`diagnose`] is a pure function; `design` attaches its findings to a
//! report that does not certify ([`crate::Design::diagnosis`]).

use crate::vocab::Family;
use nalgebra::{Complex, DMatrix};
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, PolytopicModel, StateBound};
use serde::{Deserialize, Serialize};

/// Relative rank tolerance of the PBH test: σ_min([A − λI; C]) below this
/// times the matrix's size (its largest singular value, at least 1) counts
/// as rank deficient.
pub(crate) const PBH_REL_TOL: f64 = 1e-8;

/// One reason a design fails (or a bound it must respect).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Finding {
    /// What was tested: "detectability", "S4" or "region_in_F".
    pub kind: String,
    /// Whether the finding alone rules out a certified design for this
    /// request (an undetectable mode too slow for α, a fixed γ above
    /// γ_max); otherwise it is a bound or a hint.
    pub blocking: bool,
    /// What was found and what to change, in words.
    pub message: String,
}

/// An undetectable mode of one θ-vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct UndetectableMode {
    /// Vertex index (0-based, the model's vertex order).
    pub vertex: usize,
    /// The eigenvalue λ of A_l.
    pub lambda: Complex<f64>,
    /// The state (index) where the mode's eigenvector is largest.
    pub state: usize,
    /// σ_min / scale of [A_l − λI; C_l].
    pub rank_gap: f64,
}

/// The modes of A_l with Re λ ≥ `re_min` that fail the PBH test, at every
/// θ-vertex l (C_l the vertex's output map; the quadratic terms vanish at
/// e = x = 0 and do not help).
pub fn undetectable_modes(model: &PolytopicModel, re_min: f64) -> Vec<UndetectableMode> {
    let nx = model.nx();
    let mut out = Vec::new();
    for (l, v) in model.vertices.iter().enumerate() {
        if v.a.shape() != (nx, nx) || v.c.ncols() != nx || !v.a.iter().all(|x| x.is_finite()) {
            continue;
        }
        let eig = v.a.clone().complex_eigenvalues();
        let ny = v.c.nrows();
        let mut seen: Vec<Complex<f64>> = Vec::new();
        for &lambda in eig.iter() {
            if lambda.re < re_min || seen.iter().any(|s| (s - lambda).norm() < 1e-12) {
                continue;
            }
            seen.push(lambda);
            let m = DMatrix::from_fn(nx + ny, nx, |r, c| {
                if r < nx {
                    let d = if r == c {
                        lambda
                    } else {
                        Complex::new(0.0, 0.0)
                    };
                    Complex::new(v.a[(r, c)], 0.0) - d
                } else {
                    Complex::new(v.c[(r - nx, c)], 0.0)
                }
            });
            let svd = m.svd(false, true);
            let s = &svd.singular_values;
            let (smin_idx, smin) =
                s.iter().enumerate().fold(
                    (0, f64::INFINITY),
                    |acc, (i, &x)| if x < acc.1 { (i, x) } else { acc },
                );
            let scale = s.max().max(1.0);
            if smin <= PBH_REL_TOL * scale {
                let state = svd
                    .v_t
                    .as_ref()
                    .map(|vt| {
                        (0..nx)
                            .max_by(|&a, &b| {
                                vt[(smin_idx, a)]
                                    .norm()
                                    .total_cmp(&vt[(smin_idx, b)].norm())
                            })
                            .unwrap_or(0)
                    })
                    .unwrap_or(0);
                out.push(UndetectableMode {
                    vertex: l,
                    lambda,
                    state,
                    rank_gap: smin / scale,
                });
            }
        }
    }
    out
}

fn fmt_lambda(z: Complex<f64>) -> String {
    if z.im.abs() < 1e-12 {
        format!("{:.6}", z.re)
    } else {
        format!(
            "{:.6} {} {:.6}i",
            z.re,
            if z.im < 0.0 { "-" } else { "+" },
            z.im.abs()
        )
    }
}

fn vertex_label(model: &PolytopicModel, l: usize) -> String {
    if l >= model.vertices.len() {
        return format!("vertex {}", l + 1);
    }
    // the corner in the scheduling parameters and the derived scheduling
    // variables φ_j (at an end of their ranges), so a failing corner of
    // (cos q2, 1/det M) is named
    let corner: Vec<String> = model
        .corner(l)
        .into_iter()
        .map(|(name, value)| format!("{name} = {value}"))
        .collect();
    // with a cover, the piece the corner belongs to
    let piece = match &model.cover {
        Some(c) => {
            let k = model.piece_of(l);
            format!(" of piece {} ({})", k + 1, c.label(k))
        }
        None => String::new(),
    };
    if corner.is_empty() {
        format!("vertex {}{piece}", l + 1)
    } else {
        format!("vertex {} ({}){piece}", l + 1, corner.join(", "))
    }
}

/// Pieces of the cover that [`diagnose`] proposes.
pub const COVER_PIECES: usize = 4;

/// A cover's ratio below which the whole-box ranges count as wide.
const WIDE_RATIO: f64 = 0.6;

/// What cutting one parameter's range into equal pieces does to the ranges
/// of the derived scheduling variables, measured by sampling.
#[derive(Debug, Clone, PartialEq)]
pub struct CoverEstimate {
    /// The parameter cut (index into the model's parameters).
    pub param: usize,
    /// The number of pieces.
    pub pieces: usize,
    /// The sampled width of φ_j on a piece over its sampled width on the
    /// whole box, averaged over the pieces and the φ_j that vary.
    pub ratio: f64,
}

/// For every parameter with a range, the ratio of [`CoverEstimate`] for a
/// cut into `pieces`; the best (smallest) one. φ_j is evaluated on a grid
/// of the parameter box (at most about 4096 points per piece, at least 3
/// per parameter), so the ratio is an estimate; None without derived
/// scheduling variables or when no φ_j varies.
pub fn cover_estimate(model: &PolytopicModel, pieces: usize) -> Option<CoverEstimate> {
    let np = model.params.len();
    if model.derived.is_empty() || np == 0 || pieces < 2 {
        return None;
    }
    let free: Vec<usize> = (0..np)
        .filter(|&i| {
            let p = &model.params[i];
            p.lo.is_finite() && p.hi.is_finite() && p.hi > p.lo
        })
        .collect();
    if free.is_empty() {
        return None;
    }
    let per = ((4096f64).powf(1.0 / free.len() as f64).floor() as usize).clamp(3, 33);
    // The widths of every φ_j on the grid of the box `lo..hi` (per parameter).
    let widths = |lo: &[f64], hi: &[f64]| -> Vec<f64> {
        let mut mins = vec![f64::INFINITY; model.derived.len()];
        let mut maxs = vec![f64::NEG_INFINITY; model.derived.len()];
        let total = per.checked_pow(free.len() as u32).unwrap_or(usize::MAX);
        let mut theta: Vec<f64> = model.params.iter().map(|p| 0.5 * (p.lo + p.hi)).collect();
        for mut idx in 0..total.min(1 << 16) {
            for &i in &free {
                let t = (idx % per) as f64 / (per - 1) as f64;
                idx /= per;
                theta[i] = lo[i] + t * (hi[i] - lo[i]);
            }
            for (j, d) in model.derived.iter().enumerate() {
                let v = d.expr.eval(&theta);
                if v.is_finite() {
                    mins[j] = mins[j].min(v);
                    maxs[j] = maxs[j].max(v);
                }
            }
        }
        mins.iter()
            .zip(&maxs)
            .map(|(a, b)| (b - a).max(0.0))
            .collect()
    };
    let lo: Vec<f64> = model.params.iter().map(|p| p.lo).collect();
    let hi: Vec<f64> = model.params.iter().map(|p| p.hi).collect();
    let whole = widths(&lo, &hi);
    let varying: Vec<usize> = (0..whole.len())
        .filter(|&j| {
            whole[j] > 1e-12 * (1.0 + model.derived[j].lo.abs().max(model.derived[j].hi.abs()))
        })
        .collect();
    if varying.is_empty() {
        return None;
    }
    let mut best: Option<CoverEstimate> = None;
    for &i in &free {
        let mut sum = 0.0;
        for k in 0..pieces {
            let (mut plo, mut phi) = (lo.clone(), hi.clone());
            let w = (hi[i] - lo[i]) / pieces as f64;
            plo[i] = lo[i] + w * k as f64;
            phi[i] = if k + 1 == pieces {
                hi[i]
            } else {
                lo[i] + w * (k + 1) as f64
            };
            let part = widths(&plo, &phi);
            sum += varying.iter().map(|&j| part[j] / whole[j]).sum::<f64>();
        }
        let ratio = sum / (pieces * varying.len()) as f64;
        if best.as_ref().map_or(true, |b| ratio < b.ratio) {
            best = Some(CoverEstimate {
                param: i,
                pieces,
                ratio,
            });
        }
    }
    best
}

/// The finding on wide ranges of the scheduling functions, if any (a model
/// with derived scheduling variables and no cover, whose ranges a cover
/// into [`COVER_PIECES`] would shrink below [`WIDE_RATIO`] of their width).
fn wide_phi_finding(model: &PolytopicModel) -> Option<Finding> {
    if model.cover.is_some() {
        return None;
    }
    let est = cover_estimate(model, COVER_PIECES)?;
    if est.ratio > WIDE_RATIO {
        return None;
    }
    let name = &model.params[est.param].name;
    let ranges: Vec<String> = model
        .derived
        .iter()
        .map(|d| format!("{} in [{:.4}, {:.4}]", d.name, d.lo, d.hi))
        .collect();
    Some(Finding {
        kind: "cover".into(),
        blocking: false,
        message: format!(
            "the scheduling functions' ranges over the whole parameter box are wide ({}): the \
             polytopic model treats them as independent of the parameters, which is conservative; \
             cut the range with `cover {name} into {n};` (measured on a grid: on each piece their \
             ranges shrink to {:.0} % of their width on average; {n}× the vertices)",
            ranges.join(", "),
            100.0 * est.ratio,
            n = est.pieces,
        ),
    })
}

/// The findings for `request` on `model` (the plant with its state bound
/// resolved). `alpha_floor` stands in for α when the request searches α
/// (the smallest α a search tries).
pub fn diagnose(model: &PolytopicModel, request: &DesignRequest, alpha_floor: f64) -> Vec<Finding> {
    let mut out = Vec::new();
    let alpha = match request.alpha {
        AlphaSpec::Fixed(a) if a.is_finite() && a > 0.0 => a,
        _ => alpha_floor.max(0.0),
    };
    // Detectability, for this α and in general (Re λ ≥ 0 rules out every α).
    let modes = undetectable_modes(model, -alpha / 2.0);
    for m in &modes {
        let state = model
            .states
            .get(m.state)
            .cloned()
            .unwrap_or_else(|| format!("state {}", m.state + 1));
        let blocking_all = m.lambda.re >= 0.0;
        let message = if blocking_all {
            format!(
                "not detectable at {}: the mode lambda = {} of A (mainly state {state}) is not \
                 seen by the outputs (PBH rank test of [A - lambda I; C]) and does not decay, so \
                 no observer gain makes the error converge; measure {state} (or a state it \
                 drives), or change the model",
                vertex_label(model, m.vertex),
                fmt_lambda(m.lambda)
            )
        } else {
            format!(
                "not detectable at {}: the mode lambda = {} of A (mainly state {state}) is not \
                 seen by the outputs (PBH rank test); the error cannot decay faster than it, so \
                 alpha < {:.6}; ask for a smaller alpha or measure {state}",
                vertex_label(model, m.vertex),
                fmt_lambda(m.lambda),
                -2.0 * m.lambda.re
            )
        };
        out.push(Finding {
            kind: "detectability".into(),
            blocking: true,
            message,
        });
    }
    if let StateBound::Given(q) = &model.state_bound {
        if q.shape() == (model.nx(), model.nx()) && !model.region.facets.is_empty() {
            let gmax = crate::model::gamma_max_for(model, q);
            let (blocking, extra) = match request.gamma {
                GammaSpec::Fixed(g) if g > gmax => (
                    true,
                    format!("; the requested gamma = {g} is above it: use gamma <= {gmax:.6} or gamma = search"),
                ),
                _ => (false, String::new()),
            };
            out.push(Finding {
                kind: Family::S4.name().into(),
                blocking,
                message: format!(
                    "(S4) bounds gamma <= gamma_max = 1/max_k sqrt(a_k^T Q a_k) = {gmax:.6} for this Q and region{extra}"
                ),
            });
            if let Some(qi) = q.clone().try_inverse() {
                let worst = model
                    .region
                    .vertices
                    .iter()
                    .enumerate()
                    .map(|(i, x)| (i, x.dot(&(&qi * x))))
                    .fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
                if worst.1 > 1.0 + 1e-9 {
                    out.push(Finding {
                        kind: Family::RegionInF.name().into(),
                        blocking: false,
                        message: format!(
                            "region too large for this Q: vertex {} of the region has x^T Q^-1 x = {:.4} > 1 \
                             (outside F); shrink the region by a factor {:.4} or enlarge Q",
                            worst.0 + 1,
                            worst.1,
                            1.0 / worst.1.sqrt()
                        ),
                    });
                }
            }
        }
    }
    out.extend(wide_phi_finding(model));
    out
}
