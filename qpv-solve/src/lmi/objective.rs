//! What the solve optimises, and the families that come with it: the
//! max-margin column and its t̂ ≤ 1, the min-gain homogenisation and its
//! gain blocks, the `max_gain = G` bound, and the costs.

use super::blocks::MarginColumn;
use super::Problem;
use crate::backend::builder::SdpBuilder;
use crate::linalg::svec::{svec_index, svec_len, svec_scale};
use crate::settings::Settings;
use nalgebra::DMatrix;

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

impl Problem<'_> {
    /// The max-margin column t̂ (the variable after the problem's) with
    /// coefficients svec(κW), W of [`Problem::margin_metric`] (upper
    /// triangle, √2 off the diagonal).
    pub(super) fn margin_column(&self, metric: Option<&DMatrix<f64>>, kappa: f64) -> MarginColumn {
        let nx = self.nx;
        let wm = self.margin_metric(metric);
        let mut coef = vec![0.0; svec_len(nx)];
        for c in 0..nx {
            for r in 0..=c {
                coef[svec_index(r, c)] = svec_scale(r, c) * wm[(r, c)] * kappa;
            }
        }
        MarginColumn {
            var: self.n_vars(),
            coef,
        }
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

    /// `max_gain = G` (if any): P̂ − p̂I ⪰ 0, then
    /// [G'p̂ I_ny, Γ̂_lᵀ; Γ̂_l, G'p̂ I_nx] ⪰ 0 per θ-vertex (see
    /// [`Problem::with_max_gain`]).
    pub(super) fn push_gain_bound(&self, out: &mut SdpBuilder) {
        let Some(g) = self.max_gain_z() else {
            return;
        };
        let nx = self.nx;
        let pvar = self.gain_bound_var();
        // P̂ − p̂ I ⪰ 0.
        let blk = out.psd(nx, 0.0);
        self.push_sym_var(out, &blk, 0, -1.0);
        for d in 0..nx {
            out.entry(&blk, d, d, pvar, 1.0);
        }
        let g = g * (1.0 - 1e-4);
        for l in self.gain_vertices() {
            self.push_gain_block(out, l, (pvar, g), None);
        }
    }

    /// [w·v I_ny, Γ̂_lᵀ T; T Γ̂_l, w·v I_nx] ⪰ 0 for the scalar variable v
    /// and T = `w_inv_half` (None: I): s = −A x with A holding −w on the
    /// diagonal (column v) and −√2 T at the Γ̂_l entries (row ny + r,
    /// column c < ny: packed at (c, ny + r)).
    fn push_gain_block(
        &self,
        out: &mut SdpBuilder,
        l: usize,
        (v, w): (usize, f64),
        w_inv_half: Option<&DMatrix<f64>>,
    ) {
        let (nx, ny) = (self.nx, self.ny);
        let blk = out.psd(nx + ny, 0.0);
        for k in 0..nx + ny {
            out.entry(&blk, k, k, v, -w);
        }
        for k in 0..nx {
            for c in 0..ny {
                for r in 0..nx {
                    let t = w_inv_half.map_or(if r == k { 1.0 } else { 0.0 }, |m| m[(r, k)]);
                    out.entry(&blk, c, ny + r, self.gvar(l, k, c), -t);
                }
            }
        }
    }

    /// The objective's own rows (after every family) and its costs: for
    /// [`Objective::MinGain`] the homogenisation; for
    /// [`Objective::MaxMargin`] t̂ ≤ 1; then the costs.
    pub(super) fn push_objective(
        &self,
        out: &mut SdpBuilder,
        settings: &Settings,
        objective: Objective,
        metric: Option<&DMatrix<f64>>,
    ) {
        match objective {
            Objective::MinGain => self.homogenise_for_min_gain(out, metric),
            Objective::MaxMargin => {
                // t̂ ≤ 1.
                let row = out.nonneg(1);
                out.set_b(row, 1.0);
                out.a(row, self.n_vars(), 1.0);
            }
            Objective::Feasibility | Objective::Gains => {}
        }
        self.costs(out, settings, objective);
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
        let nx = self.nx;
        let (cvar, kvar) = (self.n_vars(), self.n_vars() + 1);
        out.homogenise(cvar);
        // c ≥ 0 (s = c).
        let row = out.nonneg(1);
        out.a(row, cvar, -1.0);
        let w = metric.and_then(|m| normalised_metric(m, nx));
        let Some((w, w_inv_half)) = w else {
            // P̂ − I ⪰ 0, ‖Γ̂_l‖₂ ≤ κ.
            self.push_s1(out, 1.0);
            for l in self.gain_vertices() {
                self.push_gain_block(out, l, (kvar, 1.0), None);
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
        for l in self.gain_vertices() {
            self.push_gain_block(out, l, (kvar, 1.0), Some(&w_inv_half));
        }
    }

    /// The costs: ½ w Σ Γ̂² (diagonal on the Γ̂ columns) for
    /// [`Objective::Gains`], −t̂ for [`Objective::MaxMargin`], κ for
    /// [`Objective::MinGain`].
    fn costs(&self, out: &mut SdpBuilder, settings: &Settings, objective: Objective) {
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
}
