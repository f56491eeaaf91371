//! Units: a diagonal change of state coordinates x = D z that brings every
//! state of a badly scaled model to an extent of order one.
//!
//! Every sound condition family is covariant under x = D z (D diagonal,
//! positive): with A_z = D⁻¹AD, N_z,k = D N_k D / d_k (row k of the
//! quadratic term), B_z = D⁻¹B, C_z = CD, M_z,k = D M_k D, the region's
//! vertices D⁻¹x_(i) and facets D a_k, Q_z = D⁻¹QD⁻¹, the unknowns map as
//! P_z = DPD, Γ_z = DΓ, L_z = D⁻¹L, and every matrix of (S1)–(S5) (and of the
//! cube and decoupled conditions) is the congruence of its x-coordinate
//! matrix by D or diag(1, D): the same inequality. (The paper's printed
//! conditions are not covariant — (13) reads P⁻¹, (26) reads P — so
//! reproduction mode is never scaled.)
//!
//! D is a power of two per state (2^round(log₂ w_i), w_i the half-width of
//! the region's bounding box along state i), so that every entry of the
//! transformed data is the original times a power of two: *exact* in
//! floating point (each transformation is verified by its inverse, entry by
//! entry, and refused if any entry would overflow or lose bits). A model
//! whose half-widths all lie in [2⁻⁸, 2⁸] is left alone ([`StateScaling::of`]
//! returns None), so well-scaled models are solved and certified exactly as
//! written.
//!
//! The solver ([`crate::lmi::Problem::with_scaling`]) solves in z and maps P,
//! Γ_l and the cube slacks back; the certificate ([`crate::certificate`])
//! evaluates every condition on the user's P and L_l after this exact
//! congruence, so its eigenvalues are those of well-balanced matrices.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{PolytopicModel, Region, StateBound};

/// Half-widths inside [1/BAND, BAND] need no scaling.
const BAND: f64 = 256.0;

/// A diagonal change of state coordinates x = D z, D = diag(d), every d_i
/// a power of two.
#[derive(Debug, Clone, PartialEq)]
pub struct StateScaling {
    /// The diagonal of D (powers of two).
    pub d: Vec<f64>,
}

/// x·f, if exact (finite, and recovered by the division back).
fn mul_exact(x: f64, f: f64) -> Option<f64> {
    let y = x * f;
    (y.is_finite() && y / f == x).then_some(y)
}

/// The matrix with entry (r, c) multiplied by `f(r, c)` (a power of two),
/// if every product is exact.
fn map_exact(m: &DMatrix<f64>, f: impl Fn(usize, usize) -> f64) -> Option<DMatrix<f64>> {
    let mut out = m.clone();
    for c in 0..m.ncols() {
        for r in 0..m.nrows() {
            out[(r, c)] = mul_exact(m[(r, c)], f(r, c))?;
        }
    }
    Some(out)
}

fn vec_exact(v: &DVector<f64>, f: impl Fn(usize) -> f64) -> Option<DVector<f64>> {
    map_exact(
        &DMatrix::from_column_slice(v.len(), 1, v.as_slice()),
        |r, _| f(r),
    )
    .map(|m| DVector::from_column_slice(m.as_slice()))
}

/// 2^round(log₂ w), for a positive finite w (1 otherwise).
fn pow2_near(w: f64) -> f64 {
    if w.is_finite() && w > 0.0 {
        2f64.powi(w.log2().round() as i32)
    } else {
        1.0
    }
}

impl StateScaling {
    /// The half-width of the region's bounding box along every state (the
    /// largest |x_(i),k| over its vertices; from the generators when no
    /// vertex is listed).
    pub fn half_widths(region: &Region, nx: usize) -> Vec<f64> {
        let mut w = vec![0.0f64; nx];
        if region.vertices.is_empty() {
            for g in &region.generators {
                for (k, v) in g.iter().enumerate().take(nx) {
                    w[k] += v.abs();
                }
            }
        }
        for x in &region.vertices {
            for (k, v) in x.iter().enumerate().take(nx) {
                w[k] = w[k].max(v.abs());
            }
        }
        w
    }

    /// The scaling a model needs in `mode` (sound mode only): None when
    /// every state's half-width lies in [2⁻⁸, 2⁸] (or is zero, as the
    /// filter states of the output post-filter), else d_i = 2^round(log₂ w_i)
    /// for every state with w_i > 0 (1 for the others).
    pub fn of(model: &PolytopicModel, mode: qpv_dsl::Mode) -> Option<StateScaling> {
        if mode != qpv_dsl::Mode::Sound {
            return None;
        }
        let w = Self::half_widths(&model.region, model.nx());
        let off = w
            .iter()
            .any(|&v| v.is_finite() && v > 0.0 && !(1.0 / BAND..=BAND).contains(&v));
        off.then(|| StateScaling {
            d: w.into_iter().map(pow2_near).collect(),
        })
    }

    /// The scaling that balances a Lyapunov matrix: d_i = 2^round(log₂
    /// P_ii^{−1/2}), so that P_z = DPD has a diagonal within a factor 2 of
    /// 1 (used by the global observer, whose P has no region to fix its
    /// units); None when every d_i is 1 or P's diagonal is not positive
    /// and finite.
    pub fn of_p(p: &DMatrix<f64>) -> Option<StateScaling> {
        Self::of_p_relative(p, None)
    }

    /// [`StateScaling::of_p`] with the overall scale fixed at state `unit`
    /// (d_unit = 1; only the ratios of the d_i matter to homogeneous
    /// conditions, while the size of C D = the output map in z depends on
    /// the overall scale).
    pub fn of_p_relative(p: &DMatrix<f64>, unit: Option<usize>) -> Option<StateScaling> {
        let mut d: Vec<f64> = (0..p.nrows())
            .map(|i| {
                let v = p[(i, i)];
                (v.is_finite() && v > 0.0).then(|| pow2_near(1.0 / v.sqrt()))
            })
            .collect::<Option<_>>()?;
        if let Some(k) = unit.filter(|&k| k < d.len()) {
            let base = d[k];
            d.iter_mut().for_each(|v| *v /= base);
        }
        d.iter().any(|&v| v != 1.0).then_some(StateScaling { d })
    }

    /// The number of states.
    pub fn len(&self) -> usize {
        self.d.len()
    }

    /// Whether there are no states.
    pub fn is_empty(&self) -> bool {
        self.d.is_empty()
    }

    /// The model in z coordinates (see the module documentation), if every
    /// entry transforms exactly and the sizes fit.
    pub fn model(&self, m: &PolytopicModel) -> Option<PolytopicModel> {
        let d = &self.d;
        let n = d.len();
        // Nonlinear terms are bounded in the model's own units.
        if m.nx() != n || m.jacobian.is_some() {
            return None;
        }
        let mut out = m.clone();
        for v in &mut out.vertices {
            if v.a.shape() != (n, n) || v.b.nrows() != n || v.c.ncols() != n {
                return None;
            }
            v.a = map_exact(&v.a, |r, c| d[c] / d[r])?;
            for (k, nk) in v.n.iter_mut().enumerate() {
                *nk = map_exact(nk, |r, c| d[r] * d[c] / d[k])?;
            }
            v.b = map_exact(&v.b, |r, _| 1.0 / d[r])?;
            v.c = map_exact(&v.c, |_, c| d[c])?;
            for mk in &mut v.m {
                *mk = map_exact(mk, |r, c| d[r] * d[c])?;
            }
        }
        let reg = &m.region;
        let vx = |x: &DVector<f64>| vec_exact(x, |r| 1.0 / d[r]);
        out.region = Region {
            vertices: reg.vertices.iter().map(vx).collect::<Option<_>>()?,
            facets: reg
                .facets
                .iter()
                .map(|a| vec_exact(a, |r| d[r]))
                .collect::<Option<_>>()?,
            generators: reg.generators.iter().map(vx).collect::<Option<_>>()?,
        };
        if let StateBound::Given(q) = &m.state_bound {
            out.state_bound = StateBound::Given(map_exact(q, |r, c| 1.0 / (d[r] * d[c]))?);
        }
        out.noise.b_w = m
            .noise
            .b_w
            .iter()
            .map(|b| map_exact(b, |r, _| 1.0 / d[r]))
            .collect::<Option<_>>()?;
        Some(out)
    }

    /// P_z = D P D (also the slacks Y, X, Z of the rate conditions), if exact.
    pub fn p_to_z(&self, p: &DMatrix<f64>) -> Option<DMatrix<f64>> {
        let d = &self.d;
        (p.shape() == (d.len(), d.len())).then_some(())?;
        map_exact(p, |r, c| d[r] * d[c])
    }

    /// P = D⁻¹ P_z D⁻¹ (also the slacks Y, X, Z).
    pub fn p_from_z(&self, pz: &DMatrix<f64>) -> DMatrix<f64> {
        let d = &self.d;
        DMatrix::from_fn(pz.nrows(), pz.ncols(), |r, c| pz[(r, c)] / (d[r] * d[c]))
    }

    /// Γ_z = D Γ, if exact.
    pub fn gamma_to_z(&self, g: &DMatrix<f64>) -> Option<DMatrix<f64>> {
        (g.nrows() == self.d.len()).then_some(())?;
        map_exact(g, |r, _| self.d[r])
    }

    /// Γ = D⁻¹ Γ_z.
    pub fn gamma_from_z(&self, gz: &DMatrix<f64>) -> DMatrix<f64> {
        DMatrix::from_fn(gz.nrows(), gz.ncols(), |r, c| gz[(r, c)] / self.d[r])
    }

    /// L_z = D⁻¹ L, if exact.
    pub fn l_to_z(&self, l: &DMatrix<f64>) -> Option<DMatrix<f64>> {
        (l.nrows() == self.d.len()).then_some(())?;
        map_exact(l, |r, _| 1.0 / self.d[r])
    }

    /// The largest d_i (‖L‖₂ = ‖D L_z‖₂ ≤ max_i d_i ‖L_z‖₂).
    pub fn max(&self) -> f64 {
        self.d.iter().copied().fold(0.0, f64::max)
    }
}
