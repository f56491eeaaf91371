//! The condition sets (spec §5 sound, §6 paper) as data: which families
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
//! `conditions = decoupled` (issue 6 §3) writes the rate matrix as
//! F_{l,i,j} = F0_l + G_l(x_i) + H_l(x_j): the terms of the e-vertex x_i
//! (rows(·, x_i), with F0) and those of the x-vertex x_j (rowsHe(·, x_j)),
//! and imposes
//! F0_l + G_l(x_i) + Z_l ≺ 0 and H_l(x_j) ⪯ Z_l with a slack Z_l per
//! θ-vertex ([`crate::sdp`]); the certificate checks F_{l,i,j} itself.
//!
//! Convention for N_k and M_k: the matrices are used exactly as written in
//! the model (no symmetrisation): row k of rows(T, v) is vᵀ T_k and row k of
//! rowsHe(T, v) is vᵀ (T_k + T_kᵀ).

use crate::search::SolveError;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{Mode, PolytopicModel, Split, StateBound};

/// rows(T, v): the matrix whose row k is vᵀ T_k (one row per T_k).
pub fn rows(t: &[DMatrix<f64>], v: &DVector<f64>) -> DMatrix<f64> {
    let n = v.len();
    let mut out = DMatrix::zeros(t.len(), n);
    for (k, tk) in t.iter().enumerate() {
        for c in 0..n {
            let mut acc = 0.0;
            for r in 0..n {
                acc += v[r] * tk[(r, c)];
            }
            out[(k, c)] = acc;
        }
    }
    out
}

/// rowsHe(T, v): the matrix whose row k is vᵀ (T_k + T_kᵀ).
pub fn rows_he(t: &[DMatrix<f64>], v: &DVector<f64>) -> DMatrix<f64> {
    let n = v.len();
    let mut out = DMatrix::zeros(t.len(), n);
    for (k, tk) in t.iter().enumerate() {
        for c in 0..n {
            let mut acc = 0.0;
            for r in 0..n {
                acc += v[r] * (tk[(r, c)] + tk[(c, r)]);
            }
            out[(k, c)] = acc;
        }
    }
    out
}

/// The set of conditions a design uses; all mode differences live here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConditionSet {
    /// (S1)-(S5), spec §5.
    Sound,
    /// (S1), (13), (14), (26) exactly as printed, spec §6.
    Paper,
}

/// The region conditions of one mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegionForm {
    /// (S2): xᵢᵀ P xᵢ ≤ 1, a scalar per region vertex.
    VertexQuadratic,
    /// (13): [1 xᵢᵀ; xᵢ P] ⪰ 0, an (nx+1)-block per region vertex.
    VertexSchur,
    /// (S3): [1 γaₖᵀ; γaₖ P] ⪰ 0, an (nx+1)-block per facet.
    FacetSchur,
    /// (14): [1 γaₖᵀP; γPaₖ P] ⪰ 0, an (nx+1)-block per facet.
    FacetSchurP,
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
    pub fn families(self) -> [&'static str; 4] {
        match self {
            ConditionSet::Sound => ["S1", "S2", "S3", "S5"],
            ConditionSet::Paper => ["S1", "13", "14", "26"],
        }
    }

    /// The condition on the region vertices.
    pub fn vertex_form(self) -> RegionForm {
        match self {
            ConditionSet::Sound => RegionForm::VertexQuadratic,
            ConditionSet::Paper => RegionForm::VertexSchur,
        }
    }

    /// The condition on the region facets.
    pub fn facet_form(self) -> RegionForm {
        match self {
            ConditionSet::Sound => RegionForm::FacetSchur,
            ConditionSet::Paper => RegionForm::FacetSchurP,
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
    pub fn requires_s4(self) -> bool {
        matches!(self, ConditionSet::Sound)
    }
}

/// The per-pair nonlinear terms of a model, precomputed once:
/// `nhe[l][j] = rowsHe(N_l, x_(j))`, `nrw[l][i] = rows(N_l, x_(i))`,
/// `mhe[m][j] = rowsHe(M_m, x_(j))`, `mrw[m][i] = rows(M_m, x_(i))`
/// (M_m: the M_k at θ-vertex m, the same at every vertex when M is constant).
#[derive(Debug, Clone)]
pub struct PairTerms {
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
        let xs = &model.region.vertices;
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

    /// R_{l,i,j} = rowsHe(N_l, x_(j)) − rows(N_l, x_(i)).
    pub fn r(&self, l: usize, i: usize, j: usize) -> DMatrix<f64> {
        &self.nhe[l][j] - &self.nrw[l][i]
    }

    /// S_{m,i,j} = rowsHe(M_m, x_(j)) − rows(M_m, x_(i)).
    pub fn s(&self, m: usize, i: usize, j: usize) -> DMatrix<f64> {
        &self.mhe[m][j] - &self.mrw[m][i]
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

/// Whether the rate family of `model` is the double sum (its output map
/// depends on θ) rather than the single sum over θ-vertices.
pub fn is_double_sum(model: &PolytopicModel) -> bool {
    model.nv() > 1 && model.output_varies()
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

/// The model with the requested representation of N_k and M_k: as written
/// (borrowed, no copy), or symmetrised (N_{k,l} → (N_{k,l} + N_{k,l}ᵀ)/2,
/// M_k → (M_k + M_kᵀ)/2, by [`PolytopicModel::with_split`]).
/// Both describe the same plant (xᵀTx only sees the symmetric part of T),
/// so a certificate for either is a certificate for the plant; they differ
/// in the LMIs, through rows(N, e).
pub fn with_split(model: &PolytopicModel, split: Split) -> std::borrow::Cow<'_, PolytopicModel> {
    match split {
        Split::AsWritten => std::borrow::Cow::Borrowed(model),
        _ => std::borrow::Cow::Owned(model.with_split(split)),
    }
}

/// Largest Euclidean norm of a region vertex (ρ).
pub fn region_radius(model: &PolytopicModel) -> f64 {
    model
        .region
        .vertices
        .iter()
        .map(|x| x.norm())
        .fold(0.0, f64::max)
}

/// γ_max = 1 / max_k sqrt(a_kᵀ Q a_k) from (S4), if Q is given.
pub fn gamma_max(model: &PolytopicModel) -> Option<f64> {
    let StateBound::Given(q) = &model.state_bound else {
        return None;
    };
    Some(gamma_max_for(model, q))
}

/// γ_max = 1 / max_k sqrt(a_kᵀ Q a_k) of (S4) for a given Q (the state
/// bound of the model or a candidate one, e.g. a computed `state_bound auto`).
pub fn gamma_max_for(model: &PolytopicModel, q: &DMatrix<f64>) -> f64 {
    let worst = model
        .region
        .facets
        .iter()
        .map(|a| a.dot(&(q * a)))
        .fold(0.0, f64::max);
    1.0 / worst.sqrt()
}

/// Checks that the model data have consistent dimensions and a usable region.
pub fn validate(model: &PolytopicModel) -> Result<(), SolveError> {
    let nx = model.nx();
    let ny = model.ny();
    let bad = |s: String| Err(SolveError::Dimensions(s));
    if nx == 0 {
        return bad("the model has no state".into());
    }
    if ny == 0 {
        return bad("the model has no output".into());
    }
    if model.vertices.is_empty() {
        return Err(SolveError::NoVertices);
    }
    if model.region.vertices.is_empty() || model.region.facets.is_empty() {
        return Err(SolveError::EmptyRegion);
    }
    for (l, v) in model.vertices.iter().enumerate() {
        if v.c.shape() != (ny, nx) {
            return bad(format!(
                "C at vertex {} is {:?}, expected ({ny}, {nx})",
                l + 1,
                v.c.shape()
            ));
        }
        if v.m.len() != ny || v.m.iter().any(|m| m.shape() != (nx, nx)) {
            return bad(format!(
                "vertex {}: expected {ny} matrices M_k of {nx} × {nx}",
                l + 1
            ));
        }
        if v.a.shape() != (nx, nx) {
            return bad(format!("A at vertex {} is {:?}", l + 1, v.a.shape()));
        }
        if v.n.len() != nx || v.n.iter().any(|m| m.shape() != (nx, nx)) {
            return bad(format!(
                "vertex {}: expected {nx} matrices N_k of {nx} × {nx}",
                l + 1
            ));
        }
    }
    if model.region.vertices.iter().any(|x| x.len() != nx)
        || model.region.facets.iter().any(|a| a.len() != nx)
    {
        return bad(format!("region vertices and facets must have {nx} entries"));
    }
    if let StateBound::Given(q) = &model.state_bound {
        if q.shape() != (nx, nx) {
            return bad(format!("Q is {:?}, expected ({nx}, {nx})", q.shape()));
        }
    }
    let all_finite = model.vertices.iter().all(|v| {
        v.a.iter().all(|x| x.is_finite())
            && v.c.iter().all(|x| x.is_finite())
            && v.n
                .iter()
                .chain(&v.m)
                .all(|m| m.iter().all(|x| x.is_finite()))
    }) && model
        .region
        .vertices
        .iter()
        .all(|x| x.iter().all(|v| v.is_finite()))
        && model
            .region
            .facets
            .iter()
            .all(|x| x.iter().all(|v| v.is_finite()));
    if !all_finite {
        return bad("non-finite entries in the model data".into());
    }
    if region_radius(model) <= 0.0 {
        return Err(SolveError::EmptyRegion);
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    #[test]
    fn rows_and_rows_he_match_quadratic_forms() {
        // row k of rows(T, v) v = vᵀ T_k v; rowsHe(T, x) e = eᵀ He{T_k} x.
        let t = vec![
            DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 3.0, 4.0]),
            DMatrix::from_row_slice(2, 2, &[0.0, -1.0, 5.0, 0.5]),
        ];
        let v = DVector::from_vec(vec![0.3, -0.7]);
        let e = DVector::from_vec(vec![1.1, 0.2]);
        let r = rows(&t, &v);
        let rh = rows_he(&t, &v);
        for k in 0..2 {
            let q = v.dot(&(&t[k] * &v));
            assert!(((&r * &v)[k] - q).abs() < 1e-14);
            let he = &t[k] + t[k].transpose();
            let q2 = e.dot(&(&he * &v));
            assert!(((&rh * &e)[k] - q2).abs() < 1e-14);
        }
    }
}

/// Ready-made models: the paper's example (spec §7), built by hand, and a
/// synthetic scale family for benchmarks.
pub mod reference {
    use nalgebra::{DMatrix, DVector};
    use qpv_dsl::{Param, PolytopicModel, Region, Span, StateBound, Vertex};

    /// Names `prefix1` .. `prefix<n>` (states, outputs of a hand-built model).
    pub fn names(prefix: &str, n: usize) -> Vec<String> {
        (1..=n).map(|i| format!("{prefix}{i}")).collect()
    }

    /// A parameter `name ∈ [lo, hi]` without a source position.
    pub fn param(name: &str, lo: f64, hi: f64) -> Param {
        Param {
            name: name.to_string(),
            lo,
            hi,
            span: Span::default(),
        }
    }

    /// The box |x_i| ≤ h in R^n: 2^n vertices (first coordinate most
    /// significant, − before +) and 2n facets ±e_i/h.
    pub fn box_region(n: usize, h: f64) -> Region {
        let vertices = (0..1usize << n)
            .map(|v| DVector::from_fn(n, |i, _| if (v >> (n - 1 - i)) & 1 == 1 { h } else { -h }))
            .collect();
        let mut facets = Vec::with_capacity(2 * n);
        for i in 0..n {
            for s in [1.0, -1.0] {
                let mut a = DVector::zeros(n);
                a[i] = s / h;
                facets.push(a);
            }
        }
        Region { vertices, facets }
    }

    /// A(θ) of the paper's example.
    pub fn paper_a(t1: f64, t2: f64) -> DMatrix<f64> {
        DMatrix::from_row_slice(
            3,
            3,
            &[
                -4.0 - t1,
                10.0,
                2.0 + 2.0 * t2, //
                -1.0,
                -1.0 - t2,
                1.5 + 2.0 * t1, //
                1.0,
                1.0,
                -4.0 - 3.0 * t1,
            ],
        )
    }

    /// N_1(θ), N_2(θ), N_3(θ) of the paper's example, as printed.
    pub fn paper_n(t1: f64, t2: f64) -> Vec<DMatrix<f64>> {
        vec![
            DMatrix::from_row_slice(
                3,
                3,
                &[0.5, 1.0 + t1, 0.0, 0.0, 0.0, -t2, 0.0, 1.0 + t2, 0.0],
            ),
            DMatrix::from_row_slice(
                3,
                3,
                &[-0.4, 0.0, 1.0 - t1, 1.5, 0.0, 1.0 + t2, 2.0 + t2, 0.0, 0.0],
            ),
            DMatrix::from_row_slice(
                3,
                3,
                &[1.5, -0.5 - t1, 0.0, 3.0 + t1, 0.0, 0.0, 0.0, 2.0 - t2, 0.0],
            ),
        ]
    }

    /// The paper's Q.
    pub fn paper_q() -> DMatrix<f64> {
        DMatrix::from_row_slice(
            3,
            3,
            &[
                0.0112, 0.0017, 0.0006, 0.0017, 0.0025, -0.0022, 0.0006, -0.0022, 0.0061,
            ],
        )
    }

    /// The paper's example (spec §7) in polytopic form: 4 vertices in the
    /// order μ1 = (1−θ1)(1−θ2), μ2 = (1−θ1)θ2, μ3 = θ1(1−θ2), μ4 = θ1θ2;
    /// the box |x_i| ≤ 0.02; the paper's Q. No design requests.
    pub fn paper_model() -> PolytopicModel {
        let corners = [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)];
        let mut m1 = DMatrix::zeros(3, 3);
        m1[(1, 2)] = 1.0;
        let mut m2 = DMatrix::zeros(3, 3);
        m2[(0, 2)] = 1.0;
        let vertices = corners
            .iter()
            .map(|&(t1, t2)| Vertex {
                theta: vec![t1, t2],
                a: paper_a(t1, t2),
                n: paper_n(t1, t2),
                b: DMatrix::zeros(3, 0),
                c: DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]),
                m: vec![m1.clone(), m2.clone()],
            })
            .collect();
        PolytopicModel {
            name: "paper".to_string(),
            states: names("x", 3),
            inputs: vec![],
            outputs: names("y", 2),
            params: vec![param("theta1", 0.0, 1.0), param("theta2", 0.0, 1.0)],
            scheduling: vec![0, 1],
            vertices,
            region: box_region(3, 0.02),
            state_bound: StateBound::Given(paper_q()),
            designs: vec![],
        }
    }

    /// A synthetic scale model: nx states, 2 outputs (x_1, x_2), two
    /// parameters in [0, 1] (4 vertices), a stable chain-like A(θ) with
    /// θ-dependent couplings, small quadratic terms, the box |x_i| ≤ h = 0.02
    /// and Q = 1.5·nx·h²·I (so P ⊂ F and γ_max = 1/√(1.5·nx)). Deterministic.
    pub fn synthetic_model(nx: usize) -> PolytopicModel {
        assert!(nx >= 2);
        let ny = 2;
        let h = 0.02;
        let c = DMatrix::from_fn(ny, nx, |r, c| if r == c { 1.0 } else { 0.0 });
        let m = (0..ny)
            .map(|k| {
                DMatrix::from_fn(nx, nx, |r, c| {
                    if r == (k + 1) % nx && c == nx - 1 {
                        0.5
                    } else {
                        0.0
                    }
                })
            })
            .collect::<Vec<_>>();
        let corners = [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)];
        let vertices = corners
            .iter()
            .map(|&(t1, t2)| {
                let a = DMatrix::from_fn(nx, nx, |r, c| {
                    if r == c {
                        -2.0 - 0.5 * t1 - 0.1 * r as f64
                    } else if c == r + 1 {
                        1.0 + 0.5 * t2
                    } else if r == c + 1 {
                        -0.5 + 0.3 * t1
                    } else {
                        0.0
                    }
                });
                let n = (0..nx)
                    .map(|k| {
                        DMatrix::from_fn(nx, nx, |r, c| {
                            let v = ((k + 2 * r + 3 * c) % 5) as f64 - 2.0;
                            0.2 * v * (1.0 + 0.5 * if (r + c) % 2 == 0 { t1 } else { t2 })
                        })
                    })
                    .collect();
                Vertex {
                    theta: vec![t1, t2],
                    a,
                    n,
                    b: DMatrix::zeros(nx, 0),
                    c: c.clone(),
                    m: m.clone(),
                }
            })
            .collect();
        PolytopicModel {
            name: format!("synthetic{nx}"),
            states: names("x", nx),
            inputs: vec![],
            outputs: names("y", ny),
            params: vec![param("theta1", 0.0, 1.0), param("theta2", 0.0, 1.0)],
            scheduling: vec![0, 1],
            vertices,
            region: box_region(nx, h),
            state_bound: StateBound::Given(DMatrix::identity(nx, nx) * (1.5 * h * h * nx as f64)),
            designs: vec![],
        }
    }
}
