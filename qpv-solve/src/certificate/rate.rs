//! The rate blocks Σ_t w_t Ξ_{l_t m_t}(i, j) from their per-vertex pieces,
//! and the single blocks tests and other checks evaluate.

use crate::conditions::{Combo, ConditionSet, PairTerms};
use crate::vocab::Candidate;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{Mode, PolytopicModel};

/// The per-vertex pieces of the rate matrices Ξ_{lm}(i, j), precomputed once.
pub(super) struct Terms<'a> {
    pub(super) model: &'a PolytopicModel,
    pub(super) p: &'a DMatrix<f64>,
    pub(super) gammas: &'a [DMatrix<f64>],
    /// γ P A_l.
    pa: Vec<DMatrix<f64>>,
    /// rowsHe / rows of N_l and M_m at the points.
    rows: PairTerms,
    /// ‖L_l‖‖P‖ + ‖Γ_l‖ (error size of Γ_l).
    gn: Vec<f64>,
    /// The γ of the blocks.
    pub(super) gamma: f64,
}

/// A pair (i, j) of points (0-based): e = x_(i)/γ, x = x_(j)/γ.
pub(super) type Pair = (usize, usize);

/// ‖L_l‖‖P‖ + ‖Γ_l‖, the error size of each Γ_l (‖L_l‖ = 0 where `lnorm`
/// gives none: Γ_l given directly).
pub(super) fn gain_sizes(p: &DMatrix<f64>, gammas: &[DMatrix<f64>], lnorm: &[f64]) -> Vec<f64> {
    let pn = p.norm();
    let at = |l: usize| lnorm.get(l).copied().unwrap_or(0.0);
    gammas
        .iter()
        .enumerate()
        .map(|(l, g)| at(l) * pn + g.norm())
        .collect()
}

impl<'a> Terms<'a> {
    /// The pieces at the region vertices `xs` (indices i, j below refer to
    /// `xs`): the whole region for a certificate, a single pair for one
    /// block; `lnorm` the ‖L_l‖ (empty: Γ_l given directly).
    pub(super) fn new(
        model: &'a PolytopicModel,
        xs: &[DVector<f64>],
        p: &'a DMatrix<f64>,
        gammas: &'a [DMatrix<f64>],
        lnorm: &[f64],
        gamma: f64,
    ) -> Self {
        Terms {
            model,
            p,
            gammas,
            pa: model.vertices.iter().map(|v| p * &v.a * gamma).collect(),
            rows: PairTerms::at(model, xs),
            gn: gain_sizes(p, gammas, lnorm),
            gamma,
        }
    }

    /// The pieces at the region's pair (x_(i), x_(j)) alone (0-based), as
    /// the points 0 and 1, for Γ_l given directly: one block.
    pub(super) fn pair(
        model: &'a PolytopicModel,
        p: &'a DMatrix<f64>,
        gammas: &'a [DMatrix<f64>],
        gamma: f64,
        (i, j): (usize, usize),
    ) -> Self {
        let xs = &model.region.vertices;
        Terms::new(
            model,
            &[xs[i].clone(), xs[j].clone()],
            p,
            gammas,
            &[],
            gamma,
        )
    }

    /// φ = γ(PA_l − Γ_lC_m) + σP R_{l,i,j} − Γ_l S_{m,i,j} (γ·PF at the
    /// vertex, for σ = +1; He φ is Ξ_{lm}(i, j) without its γαP term), and
    /// the size of its terms (for the guard).
    pub(super) fn phi(
        &self,
        sigma: f64,
        (l, m): (usize, usize),
        (i, j): Pair,
    ) -> (DMatrix<f64>, f64) {
        let (g, gamma) = (&self.gammas[l], self.gamma);
        let (vl, vm) = (&self.model.vertices[l], &self.model.vertices[m]);
        let t = &self.rows;
        let r = &t.nhe[l][j] - &t.nrw[l][i];
        let s = &t.mhe[m][j] - &t.mrw[m][i];
        let x = &self.pa[l] - g * &vm.c * gamma + self.p * &r * sigma - g * &s;
        let pn = self.p.norm();
        let size = gamma * pn * vl.a.norm()
            + gamma * self.gn[l] * vm.c.norm()
            + pn * r.norm()
            + self.gn[l] * s.norm();
        (x, size)
    }

    /// Σ_t w_t f(φ_t) over the combination's terms at the pair, and
    /// Σ_t |w_t| size_t.
    pub(super) fn weighted(
        &self,
        c: &Combo,
        sigma: f64,
        pair: Pair,
        f: impl Fn(DMatrix<f64>) -> DMatrix<f64>,
    ) -> (DMatrix<f64>, f64) {
        let nx = self.p.nrows();
        let mut out = DMatrix::zeros(nx, nx);
        let mut size = 0.0;
        for &(l, m, w) in &c.terms {
            let (x, s) = self.phi(sigma, (l, m), pair);
            out += f(x) * w;
            size += s * w.abs();
        }
        (out, size)
    }

    /// Σ_t w_t Ξ_{l_t m_t}(i, j) (with its γαP terms) and its size.
    pub(super) fn combo(
        &self,
        c: &Combo,
        sigma: f64,
        alpha: f64,
        pair: Pair,
    ) -> (DMatrix<f64>, f64) {
        let gamma = self.gamma;
        let (mut m, size) = self.combo0(c, sigma, pair);
        m += self.p * (gamma * alpha * c.weight());
        (m, size + gamma * alpha * self.p.norm() * c.weight())
    }

    /// As [`Terms::combo`] without the γαP terms.
    pub(super) fn combo0(&self, c: &Combo, sigma: f64, pair: Pair) -> (DMatrix<f64>, f64) {
        self.weighted(c, sigma, pair, |x| &x + x.transpose())
    }
}

/// The rate LMI matrix Ξ_{ll} of block (l, i, j) (0-based) in model units:
/// He{γ(PA_l − Γ_lC_l) + σ P R_{l,i,j} − Γ_l S_{l,i,j}} + γαP with σ = +1 for
/// (S5) and −1 for (26) — required ≺ 0. For e = x_(i)/γ and x = x_(j)/γ it
/// equals γ·He{P F(θ_l, e, x)} + γαP, F being the error-dynamics matrix.
/// (With a constant output map these are the whole rate family.) `at`
/// gives α and γ; `(l, i, j)` the block.
pub fn rate_lmi(
    model: &PolytopicModel,
    mode: Mode,
    at: Candidate,
    p: &DMatrix<f64>,
    gamma_l: &DMatrix<f64>,
    (l, i, j): (usize, usize, usize),
) -> DMatrix<f64> {
    let mut gammas = vec![DMatrix::zeros(gamma_l.nrows(), gamma_l.ncols()); model.nv()];
    gammas[l] = gamma_l.clone();
    let own = Combo {
        terms: vec![(l, l, 1.0)],
    };
    combo_lmi(model, mode, at, p, &gammas, &own, (i, j))
}

/// The rate block of combination `combo` at the pair (i, j) (0-based):
/// Σ_t w_t Ξ_{l_t m_t}(i, j) in model units, required ≺ 0 (the family the
/// certificate checks; see [`crate::conditions::Combo`]) at the candidate
/// `at` (α, γ).
pub fn combo_lmi(
    model: &PolytopicModel,
    mode: Mode,
    at: Candidate,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    combo: &Combo,
    (i, j): (usize, usize),
) -> DMatrix<f64> {
    let Candidate { alpha, gamma, .. } = at;
    let sigma = ConditionSet::from_mode(mode).nonlinear_sign();
    Terms::pair(model, p, gammas, gamma, (i, j))
        .combo(combo, sigma, alpha, (0, 1))
        .0
}
