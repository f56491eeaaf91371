//! The condition sets (sound and paper mode, docs/method.md) as data: which families
//! exist, how the rate LMI of one (vertex l, pair i, j) is built, and the
//! helpers `rows` / `rowsHe` shared by the assembly and the certificate.
//!
//! Both modes share one shape. Every rate LMI is
//!
//! ```text
//!     F_{l,i,j}(P, Γ_l) = He{ P K − Γ_l H } ≺ 0,
//!     K = γ A_l + σ R_{l,i,j} + (γα/2) I,     H = γ C + S_{i,j},
//!     R_{l,i,j} = rowsHe(N_l, x_(j)) − rows(N_l, x_(i)),
//!     S_{i,j}   = rowsHe(M, x_(j))   − rows(M, x_(i)),
//! ```
//!
//! with σ = +1 for (S5) (sound) and σ = −1 for the paper's (26) as printed
//! (He{P(γI α/2)} = γαP). The region conditions differ per mode:
//! (S2) xᵢᵀ P xᵢ ≤ 1 and (S3) [1 γaₖᵀ; γaₖ P] ⪰ 0 (sound) versus
//! (13) [1 xᵢᵀ; xᵢ P] ⪰ 0 and (14) [1 γaₖᵀP; γPaₖ P] ⪰ 0 (paper).
//! (S1) P ≻ 0 is imposed in both modes.
//!
//! `conditions = decoupled` writes the rate matrix as
//! F_{l,i,j} = F0_l + G_l(x_i) + H_l(x_j): the terms of the e-vertex x_i
//! (rows(·, x_i), with F0) and those of the x-vertex x_j (rowsHe(·, x_j)),
//! and imposes
//! F0_l + G_l(x_i) + Z_l ≺ 0 and H_l(x_j) ⪯ Z_l with a slack Z_l per
//! θ-vertex ([`crate::lmi`]); the certificate checks F_{l,i,j} itself.
//! `conditions = cube` bounds G_l and H_l over a zonotope region by one
//! pair of slacks per generator ([`cube`]); the certificate checks those
//! slack inequalities.
//!
//! Convention for N_k and M_k: the matrices are used exactly as written in
//! the model (no symmetrisation): row k of rows(T, v) is vᵀ T_k and row k of
//! rowsHe(T, v) is vᵀ (T_k + T_kᵀ).

pub mod cube;
pub mod poles;

use crate::vocab::Family;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{Mode, PolytopicModel};

#[doc(hidden)]
pub use crate::fixtures as reference;
pub use crate::linalg::rows::{rows, rows_he};
pub use crate::model::{
    gamma_max, gamma_max_for, is_double_sum, region_radius, validate, with_split,
};

/// The set of conditions a design uses; all mode differences live here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConditionSet {
    /// (S1)-(S5), the sound conditions.
    Sound,
    /// (S1), (13), (14), (26) exactly as printed in the paper.
    Paper,
}

/// The condition on the region vertices of one mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum VertexForm {
    /// (S2): xᵢᵀ P xᵢ ≤ 1, a scalar per region vertex.
    Quadratic,
    /// (13): [1 xᵢᵀ; xᵢ P] ⪰ 0, an (nx+1)-block per region vertex.
    Schur,
}

/// The condition on the region facets of one mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FacetForm {
    /// (S3): [1 γaₖᵀ; γaₖ P] ⪰ 0, an (nx+1)-block per facet.
    Schur,
    /// (14): [1 γaₖᵀP; γPaₖ P] ⪰ 0, an (nx+1)-block per facet.
    SchurP,
}

impl ConditionSet {
    /// The set for a request mode.
    pub fn from_mode(mode: Mode) -> Self {
        match mode {
            Mode::Sound => ConditionSet::Sound,
            Mode::Paper => ConditionSet::Paper,
        }
    }

    /// The mode it implements.
    pub fn mode(self) -> Mode {
        match self {
            ConditionSet::Sound => Mode::Sound,
            ConditionSet::Paper => Mode::Paper,
        }
    }

    /// Family keys in report order: (P ≻ 0, vertex family, facet family, rate family).
    pub fn families(self) -> [Family; 4] {
        match self {
            ConditionSet::Sound => [Family::S1, Family::S2, Family::S3, Family::S5],
            ConditionSet::Paper => [
                Family::S1,
                Family::Paper13,
                Family::Paper14,
                Family::Paper26,
            ],
        }
    }

    /// The condition on the region vertices.
    pub(crate) fn vertex_form(self) -> VertexForm {
        match self {
            ConditionSet::Sound => VertexForm::Quadratic,
            ConditionSet::Paper => VertexForm::Schur,
        }
    }

    /// The condition on the region facets.
    pub(crate) fn facet_form(self) -> FacetForm {
        match self {
            ConditionSet::Sound => FacetForm::Schur,
            ConditionSet::Paper => FacetForm::SchurP,
        }
    }

    /// σ: sign of the P·R term in the rate LMI (+1 in (S5), −1 in (26)).
    pub fn nonlinear_sign(self) -> f64 {
        match self {
            ConditionSet::Sound => 1.0,
            ConditionSet::Paper => -1.0,
        }
    }

    /// Variable scaling s (P = s P̂, Γ = s Γ̂) that makes the region
    /// conditions O(1): the sound conditions bound xᵀPx, so P ~ 1/ρ²; the
    /// printed ones bound xᵀP⁻¹x, so P ~ ρ² (ρ = largest vertex norm).
    pub fn scale(self, rho: f64) -> f64 {
        match self {
            ConditionSet::Sound => 1.0 / (rho * rho),
            ConditionSet::Paper => rho * rho,
        }
    }

    /// Whether (S4) is part of this set's claim (it is in sound mode; in
    /// paper mode its counterpart (15) is only reported).
    pub(crate) fn requires_s4(self) -> bool {
        matches!(self, ConditionSet::Sound)
    }
}

/// The per-pair nonlinear terms of a model, precomputed once:
/// `nhe[l][j] = rowsHe(N_l, x_(j))`, `nrw[l][i] = rows(N_l, x_(i))`,
/// `mhe[m][j] = rowsHe(M_m, x_(j))`, `mrw[m][i] = rows(M_m, x_(i))`
/// (M_m: the M_k at θ-vertex m, the same at every vertex when M is constant).
#[derive(Debug, Clone)]
pub(crate) struct PairTerms {
    /// rowsHe(N_l, x_(j)), nx × nx.
    pub nhe: Vec<Vec<DMatrix<f64>>>,
    /// rows(N_l, x_(i)), nx × nx.
    pub nrw: Vec<Vec<DMatrix<f64>>>,
    /// rowsHe(M_m, x_(j)), ny × nx.
    pub mhe: Vec<Vec<DMatrix<f64>>>,
    /// rows(M_m, x_(i)), ny × nx.
    pub mrw: Vec<Vec<DMatrix<f64>>>,
}

impl PairTerms {
    /// Precomputes the terms at every region vertex and parameter vertex.
    pub fn new(model: &PolytopicModel) -> Self {
        Self::at(model, &model.region.vertices)
    }

    /// The terms at the points `xs` (indices i, j refer to `xs`) and every
    /// parameter vertex.
    pub fn at(model: &PolytopicModel, xs: &[DVector<f64>]) -> Self {
        let per_vertex = |f: &dyn Fn(&qpv_dsl::Vertex, &DVector<f64>) -> DMatrix<f64>| {
            model
                .vertices
                .iter()
                .map(|v| xs.iter().map(|x| f(v, x)).collect())
                .collect()
        };
        PairTerms {
            nhe: per_vertex(&|v, x| rows_he(&v.n, x)),
            nrw: per_vertex(&|v, x| rows(&v.n, x)),
            mhe: per_vertex(&|v, x| rows_he(&v.m, x)),
            mrw: per_vertex(&|v, x| rows(&v.m, x)),
        }
    }
}

/// One member of the rate family: the block Σ_t w_t Ξ_{l_t m_t}(i, j), where
/// Ξ_{lm} is the rate matrix built from A_l, N_l, Γ_l (the gain's vertex)
/// and C_m, M_m (the output map's vertex):
///
/// ```text
///     Ξ_{lm}(i, j) = He{ γ(P A_l − Γ_l C_m) + σ P R_{l,i,j} − Γ_l S_{m,i,j} } + γαP.
/// ```
///
/// With a constant output map there is one combination per θ-vertex,
/// Ξ_{ll} (the spec's single sum). With C(θ), M(θ) the error dynamics carry
/// Σ_l Σ_m μ_l μ_m Ξ_{lm}, which is negative definite for every μ in the
/// simplex if (Tuan, Apkarian, Narikiyo & Yamamoto 2001, Thm 2.2)
///
/// ```text
///     Ξ_{ll} ≺ 0  (l = 1..r),    (2/(r−1)) Ξ_{ll} + Ξ_{lm} + Ξ_{ml} ≺ 0  (l ≠ m).
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Combo {
    /// The terms (l, m, w), 0-based vertex indices.
    pub terms: Vec<(usize, usize, f64)>,
}

impl Combo {
    /// Σ_t w_t: the coefficient of γαP in the block.
    pub fn weight(&self) -> f64 {
        self.terms.iter().map(|t| t.2).sum()
    }

    /// Whether every term (l, m) has N_l = 0 and M_m = 0 exactly: then
    /// R_{l,i,j} and S_{m,i,j} vanish and the p² blocks of the combination
    /// are one (the one definition the assembly and the certificate share).
    pub(crate) fn is_linear(&self, model: &PolytopicModel) -> bool {
        let zero = |ms: &[DMatrix<f64>]| ms.iter().all(|m| m.iter().all(|v| *v == 0.0));
        self.terms
            .iter()
            .all(|&(l, m, _)| zero(&model.vertices[l].n) && zero(&model.vertices[m].m))
    }

    /// The region-vertex pairs (i, j) (0-based) whose blocks the
    /// combination needs: every pair, or the first alone for a linear
    /// combination ([`Combo::is_linear`]: every pair gives the same block).
    pub(crate) fn pairs(&self, model: &PolytopicModel) -> Vec<(usize, usize)> {
        let np = model.region.vertices.len();
        let n = if self.is_linear(model) { np.min(1) } else { np };
        (0..n).flat_map(|i| (0..n).map(move |j| (i, j))).collect()
    }

    /// A 1-based label for reports: "l=2" (single sum), "l=m=2" or "l=2 m=3".
    pub fn label(&self, double: bool) -> String {
        let (l, m, _) = self.terms[0];
        match (double, self.terms.len()) {
            (false, _) => format!("l={}", l + 1),
            (true, 1) => format!("l=m={}", m + 1),
            (true, _) => format!("l={} m={}", l + 1, self.terms[1].1 + 1),
        }
    }
}

/// " i=1 j=3": the region-vertex pair (i, j) (0-based) of a block, for its
/// label; nothing for the global observer's model, whose region is the
/// single point {0} (there are no region vertices to name).
pub(crate) fn pair_suffix(model: &PolytopicModel, i: usize, j: usize) -> String {
    let r = &model.region;
    let global =
        r.vertices.len() == 1 && r.facets.is_empty() && r.vertices[0].iter().all(|x| *x == 0.0);
    if global {
        String::new()
    } else {
        format!(" i={} j={}", i + 1, j + 1)
    }
}

/// The rate family's combinations in report order (see [`Combo`]): one per
/// θ-vertex for a constant output map; for a θ-dependent one the r diagonal
/// blocks then the r(r−1) ordered off-diagonal ones, row by row.
pub fn rate_combos(model: &PolytopicModel) -> Vec<Combo> {
    let r = model.nv();
    if !is_double_sum(model) {
        return (0..r)
            .map(|l| Combo {
                terms: vec![(l, l, 1.0)],
            })
            .collect();
    }
    let w = 2.0 / (r as f64 - 1.0);
    let mut out: Vec<Combo> = (0..r)
        .map(|l| Combo {
            terms: vec![(l, l, 1.0)],
        })
        .collect();
    for l in 0..r {
        for m in 0..r {
            if l != m {
                out.push(Combo {
                    terms: vec![(l, l, w), (l, m, 1.0), (m, l, 1.0)],
                });
            }
        }
    }
    out
}
