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
//! [`diagnose`] is a pure function; `design` attaches its findings to a
//! report that does not certify ([`crate::Design::diagnosis`]).

use crate::vocab::Family;
use nalgebra::{Complex, DMatrix};
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, PolytopicModel, StateBound};
use serde::{Deserialize, Serialize};

/// Relative rank tolerance of the PBH test: σ_min([A − λI; C]) below this
/// times the matrix's size (its largest singular value, at least 1) counts
/// as rank deficient.
pub const PBH_REL_TOL: f64 = 1e-8;

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
    out
}
