//! The polytopic model: matrices at the corners of the parameter box and the
//! multilinear weights μ_l(θ).

use crate::cover::Cover;
use crate::model::{DesignRequest, Param, Split, StateBound};
use crate::region::Region;
use nalgebra::DMatrix;
use serde::Serialize;

mod jacobian;
pub use jacobian::s_box;

/// The numeric data at one vertex l of the parameter box.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Vertex {
    /// The full parameter vector at this corner (parameters that generate no
    /// vertex are set to their midpoint, with a cover the midpoint of the
    /// piece's range; they appear in no matrix directly).
    pub theta: Vec<f64>,
    /// A_l.
    pub a: DMatrix<f64>,
    /// N_{k,l}, k = 1..nx.
    pub n: Vec<DMatrix<f64>>,
    /// B_l.
    pub b: DMatrix<f64>,
    /// C_l, ny × nx (the same at every vertex when C is constant).
    pub c: DMatrix<f64>,
    /// M_{k,l}, k = 1..ny, nx × nx (the same at every vertex when M is constant).
    pub m: Vec<DMatrix<f64>>,
}

/// A model in polytopic form: A(θ) = Σ_l μ_l(θ) A_l exactly, and likewise
/// N_k, B, C and M_k (C and M_k are usually constant; when they depend on θ
/// the design uses the double-sum relaxation or an output post-filter).
///
/// Vertex order: corners of the box of the *scheduling* parameters (those that
/// appear in some matrix), first declared parameter most significant, lo
/// before hi; so μ_1 = Π (hi_i − θ_i)/(hi_i − lo_i). A model with derived
/// scheduling variables φ_j(θ) (`derived`) has the corners of the box of
/// (θ, φ) instead, the φ_j after the parameters (less significant); μ then
/// evaluates φ(θ) itself, so callers still pass θ only. A model with a
/// cover (`cover`) repeats this order for every piece, piece after piece.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PolytopicModel {
    /// The model's name.
    pub name: String,
    /// State names.
    pub states: Vec<String>,
    /// Input names.
    pub inputs: Vec<String>,
    /// The declared bound |u_k'| ≤ r of each input (`input u rate r`;
    /// None: not declared). Empty is read as "none declared".
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub input_rates: Vec<Option<f64>>,
    /// The declared range [lo, hi] of each input (`input u in [lo, hi]`;
    /// None: not declared). Empty is read as "none declared".
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub input_ranges: Vec<Option<(f64, f64)>>,
    /// Output names.
    pub outputs: Vec<String>,
    /// All declared parameters.
    pub params: Vec<Param>,
    /// Indices into `params` of the parameters that generate vertices.
    pub scheduling: Vec<usize>,
    /// The vertices in the documented order: 2^(scheduling.len() +
    /// derived.len()) per piece of the cover.
    pub vertices: Vec<Vertex>,
    /// The convergence region.
    pub region: Region,
    /// The state bound F.
    pub state_bound: StateBound,
    /// Design requests.
    pub designs: Vec<DesignRequest>,
    /// Where measurement noise and process disturbances enter.
    pub noise: NoiseDecl,
    /// The derived scheduling variables φ_j(θ) with their ranges (empty for
    /// a model whose entries are multi-affine in θ); each doubles the
    /// vertices. Their ranges are those on the whole box Θ.
    pub derived: Vec<crate::sched::Derived>,
    /// The piecewise cover of Θ (`None`: one box). With a cover the vertices
    /// are the 2^s corners of each piece's box of (θ, φ), piece after piece
    /// (piece k owns vertices k·2^s .. (k+1)·2^s), and μ(θ) is nonzero on
    /// the piece that contains θ only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cover: Option<Cover>,
    /// The unit of the model's time ([`crate::Model::time_unit`]).
    #[serde(
        skip_serializing_if = "crate::time_unit::TimeUnit::is_seconds",
        default
    )]
    pub time_unit: crate::time_unit::TimeUnit,
    /// The nonlinear terms of unmeasured states and, once the vertices are
    /// expanded by their Jacobian box, that box
    /// ([`crate::jacobian`]): every θ-vertex is then repeated at the 2^q
    /// corners of the box, q = [`PolytopicModel::gain_shift`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jacobian: Option<crate::jacobian::Jacobian>,
}

/// The noise channels a model declares: which outputs are measured with
/// noise (y_meas = y + v) and the process disturbances w with their matrix
/// B_w,l at every vertex (x' = ... + B_w(θ)w). The default is noise on every
/// output and no disturbance.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct NoiseDecl {
    /// Indices of the noisy outputs; `None`: every output.
    pub outputs: Option<Vec<usize>>,
    /// Disturbance names (empty: none).
    pub disturbances: Vec<String>,
    /// B_w,l per vertex (nx × n_w each), in vertex order; empty without disturbances.
    pub b_w: Vec<DMatrix<f64>>,
}

impl PolytopicModel {
    /// Number of states.
    pub fn nx(&self) -> usize {
        self.states.len()
    }
    /// Number of inputs.
    pub fn nu(&self) -> usize {
        self.inputs.len()
    }
    /// Number of outputs.
    pub fn ny(&self) -> usize {
        self.outputs.len()
    }
    /// Number of declared parameters (length of a θ vector).
    pub fn ntheta(&self) -> usize {
        self.params.len()
    }
    /// Number of vertices.
    pub fn nv(&self) -> usize {
        self.vertices.len()
    }

    /// The weights μ_l(θ) for a full parameter vector `theta` (one entry per
    /// declared parameter). Each scheduling θ_i is clamped into [lo_i, hi_i]
    /// first, so the weights are always ≥ 0 and sum to 1. With a cover, the
    /// weights are the multilinear weights of the box of the piece that
    /// contains the clamped θ ([`Cover::locate`]), zero on every other piece.
    ///
    /// With a Jacobian box (q = [`PolytopicModel::gain_shift`] > 0), each
    /// θ-weight is shared equally by its 2^q corners: the gains of those
    /// corners are equal, so Σ_l μ_l L_l is L(θ), and Σ_l μ_l A_l is
    /// A(θ) plus the middle of the box.
    pub fn mu(&self, theta: &[f64]) -> Vec<f64> {
        let q = self.gain_shift();
        let mu = self.mu_theta(theta);
        if q == 0 {
            return mu;
        }
        let w = 1.0 / (1u64 << q) as f64;
        mu.iter()
            .flat_map(|m| std::iter::repeat(m * w).take(1 << q))
            .collect()
    }

    /// The weights of the θ-vertices (without the Jacobian corners).
    fn mu_theta(&self, theta: &[f64]) -> Vec<f64> {
        let s = self.scheduling.len() + self.derived.len();
        let piece = self
            .cover
            .as_ref()
            .map(|c| (c, c.locate(&self.clamp(theta))));
        let range = |pi: usize| match piece {
            Some((c, k)) => c.pieces[k].theta[pi],
            None => (self.params[pi].lo, self.params[pi].hi),
        };
        let mut w = Vec::with_capacity(s);
        for &pi in &self.scheduling {
            let p = &self.params[pi];
            let (lo, hi) = range(pi);
            let t = theta.get(pi).copied().unwrap_or(p.lo);
            let t = if t.is_nan() { lo } else { t.clamp(lo, hi) };
            w.push((t - lo) / (hi - lo));
        }
        if !self.derived.is_empty() {
            w.extend(self.phi(theta));
            let ns = self.scheduling.len();
            for (j, d) in self.derived.iter().enumerate() {
                let (lo, hi) = match piece {
                    Some((c, k)) => c.pieces[k].phi[j],
                    None => (d.lo, d.hi),
                };
                w[ns + j] = (w[ns + j].clamp(lo, hi) - lo) / (hi - lo);
            }
        }
        let local = (0..1usize << s).map(|l| {
            (0..s)
                .map(|i| {
                    // bit (s-1-i) of l: first scheduling parameter most significant
                    if (l >> (s - 1 - i)) & 1 == 1 {
                        w[i]
                    } else {
                        1.0 - w[i]
                    }
                })
                .product()
        });
        match piece {
            None => local.collect(),
            Some((_, k)) => {
                let mut out = vec![0.0; self.nv() >> self.gain_shift()];
                for (o, v) in out[k << s..].iter_mut().zip(local) {
                    *o = v;
                }
                out
            }
        }
    }

    /// Every parameter clamped into its declared range (NaN to the lower bound).
    fn clamp(&self, theta: &[f64]) -> Vec<f64> {
        self.params
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let t = theta.get(i).copied().unwrap_or(p.lo);
                if t.is_nan() {
                    p.lo
                } else {
                    t.clamp(p.lo, p.hi)
                }
            })
            .collect()
    }

    /// Number of pieces of the cover (1 without a cover).
    pub fn pieces(&self) -> usize {
        self.cover.as_ref().map_or(1, |c| c.len())
    }

    /// The piece of the cover that vertex `l` belongs to (0 without a cover).
    pub fn piece_of(&self, l: usize) -> usize {
        l >> (self.scheduling.len() + self.derived.len() + self.gain_shift())
    }

    /// The derived scheduling variables φ_j(θ) for a full parameter vector,
    /// with every parameter clamped into its range first (NaN to its lower
    /// bound) and each φ_j clamped into its range (which contains it up to
    /// rounding), as [`Self::mu`] uses them.
    pub fn phi(&self, theta: &[f64]) -> Vec<f64> {
        let clamped = self.clamp(theta);
        self.derived
            .iter()
            .map(|d| {
                let v = d.expr.eval(&clamped);
                if v.is_nan() {
                    d.lo
                } else {
                    v.clamp(d.lo, d.hi)
                }
            })
            .collect()
    }
}

impl PolytopicModel {
    /// Σ_l μ_l(θ) X_l for the vertex matrix `pick` selects (rows × cols).
    fn weighted(
        &self,
        theta: &[f64],
        (rows, cols): (usize, usize),
        pick: impl Fn(&Vertex) -> &DMatrix<f64>,
    ) -> DMatrix<f64> {
        let mu = self.mu(theta);
        let mut s = DMatrix::zeros(rows, cols);
        // In place: a model with derived variables can have thousands of
        // vertices, and `X_l * w` would allocate a matrix for each.
        for (w, v) in mu.iter().zip(&self.vertices) {
            if *w != 0.0 {
                for (a, b) in s.as_mut_slice().iter_mut().zip(pick(v).as_slice()) {
                    *a += w * b;
                }
            }
        }
        s
    }

    /// Σ_l μ_l(θ) A_l (equals A(θ) inside the parameter box).
    pub fn a_at(&self, theta: &[f64]) -> DMatrix<f64> {
        self.weighted(theta, (self.nx(), self.nx()), |v| &v.a)
    }

    /// Σ_l μ_l(θ) N_{k,l}, k = 1..nx.
    pub fn n_at(&self, theta: &[f64]) -> Vec<DMatrix<f64>> {
        (0..self.nx())
            .map(|k| self.weighted(theta, (self.nx(), self.nx()), |v| &v.n[k]))
            .collect()
    }

    /// Σ_l μ_l(θ) B_l.
    pub fn b_at(&self, theta: &[f64]) -> DMatrix<f64> {
        self.weighted(theta, (self.nx(), self.nu()), |v| &v.b)
    }

    /// Σ_l μ_l(θ) C_l (equals C(θ) inside the parameter box).
    pub fn c_at(&self, theta: &[f64]) -> DMatrix<f64> {
        self.weighted(theta, (self.ny(), self.nx()), |v| &v.c)
    }

    /// Σ_l μ_l(θ) M_{k,l}, k = 1..ny.
    pub fn m_at(&self, theta: &[f64]) -> Vec<DMatrix<f64>> {
        (0..self.ny())
            .map(|k| self.weighted(theta, (self.nx(), self.nx()), |v| &v.m[k]))
            .collect()
    }

    /// The output map at the first vertex, C_1 and M_{k,1}: *the* output map
    /// when it is constant ([`PolytopicModel::output_varies`] is false).
    pub fn c0(&self) -> (&DMatrix<f64>, &[DMatrix<f64>]) {
        let v = &self.vertices[0];
        (&v.c, &v.m)
    }

    /// Whether the plant is LPV: every N_{k,l} and M_{k,l} is zero, so the
    /// error dynamics e' = (A(θ) − L(θ)C(θ))e are linear and the observer's
    /// guarantee is global (no region, state bound or γ; docs/method.md,
    /// "The global observer").
    /// Nonlinear terms whose Jacobian has a global bound keep the plant
    /// LPV in this sense (their box is a vertex dimension); others need
    /// the region.
    pub fn is_lpv(&self) -> bool {
        !self.jacobian_needs_set()
            && self
                .vertices
                .iter()
                .all(|v| v.n.iter().chain(&v.m).all(|m| m.iter().all(|x| *x == 0.0)))
    }

    /// Whether the model has a region (an LPV plant may omit it).
    pub fn has_region(&self) -> bool {
        !self.region.vertices.is_empty()
    }

    /// Whether C or some M_k differs between vertices (depends on θ).
    pub fn output_varies(&self) -> bool {
        let (c, m) = (&self.vertices[0].c, &self.vertices[0].m);
        self.vertices[1..].iter().any(|v| &v.c != c || &v.m != m)
    }

    /// The output y = C(θ)x + M(θ,x)x (θ clamped into the box as in [`Self::mu`]).
    pub fn output(&self, x: &nalgebra::DVector<f64>, theta: &[f64]) -> nalgebra::DVector<f64> {
        let mut y = self.c_at(theta) * x;
        for (k, mk) in self.m_at(theta).iter().enumerate() {
            y[k] += x.dot(&(mk * x));
        }
        y
    }

    /// The same model with N_{k,l} and M_k represented by `split`:
    /// [`Split::Symmetric`] (and [`Split::SkewSlack`], whose slack the
    /// solver adds) replaces each by its symmetric part (N + Nᵀ)/2,
    /// [`Split::AsWritten`] returns an unchanged copy. The plant (and the
    /// output map) is the same either way, since xᵀ N x = xᵀ (N + Nᵀ)/2 x;
    /// only the matrix rows(N, e) of the design conditions changes.
    pub fn with_split(&self, split: Split) -> PolytopicModel {
        let mut out = self.clone();
        if split != Split::AsWritten {
            let sym = |m: &mut DMatrix<f64>| *m = (&*m + m.transpose()) * 0.5;
            for v in &mut out.vertices {
                v.n.iter_mut().for_each(sym);
                v.m.iter_mut().for_each(sym);
            }
        }
        out
    }

    /// The parameter vector of corner `l` restricted to the scheduling
    /// parameters, followed by the derived variables at their corner of the
    /// box (of the piece of the cover that owns vertex `l`), as
    /// `(name, value)` pairs (for reports).
    /// With a Jacobian box, its entries at vertex `l`'s corner follow.
    pub fn corner(&self, l: usize) -> Vec<(&str, f64)> {
        let nd = self.derived.len();
        let k = self.piece_of(l);
        let q = self.gain_shift();
        let (lq, l) = (l, l >> q);
        let mut out: Vec<(&str, f64)> = self
            .scheduling
            .iter()
            .map(|&i| (self.params[i].name.as_str(), self.vertices[l].theta[i]))
            .collect();
        for (j, d) in self.derived.iter().enumerate() {
            let (lo, hi) = match &self.cover {
                Some(c) => c.pieces[k].phi[j],
                None => (d.lo, d.hi),
            };
            let up = (l >> (nd - 1 - j)) & 1 == 1;
            out.push((d.name.as_str(), if up { hi } else { lo }));
        }
        if let Some(b) = self.jacobian.as_ref().and_then(|j| j.bound.as_ref()) {
            for (d, &e) in b.dims.iter().enumerate() {
                let e = &b.entries[e];
                let up = (lq >> (q - 1 - d)) & 1 == 1;
                out.push((e.name.as_str(), if up { e.hi } else { e.lo }));
            }
        }
        out
    }
}

impl crate::model::Model {
    /// The polytopic form: the matrices at the 2^s corners of the box of the
    /// s scheduling parameters (those appearing in A, N_k, B, C or M_k) and
    /// derived variables, in the documented order (first parameter most
    /// significant, lo before hi). Exact because every entry is multi-affine
    /// in (θ, φ): the multilinear interpolation Σ_l μ_l(θ) A_l reproduces
    /// A(θ) on the whole box. With a cover, the corners of every piece's box
    /// (its parameter ranges and φ ranges), piece after piece.
    pub fn polytopic(&self) -> PolytopicModel {
        let scheduling = self.scheduling();
        let whole: Vec<(f64, f64)> = self.params.iter().map(|p| (p.lo, p.hi)).collect();
        let whole_phi: Vec<(f64, f64)> = self.derived.iter().map(|d| (d.lo, d.hi)).collect();
        // (parameter ranges, φ ranges) of each box: the whole box, or every piece
        type Ranges<'a> = &'a [(f64, f64)];
        let boxes: Vec<(Ranges<'_>, Ranges<'_>)> = match &self.cover {
            None => vec![(&whole, &whole_phi)],
            Some(c) => c
                .pieces
                .iter()
                .map(|p| (p.theta.as_slice(), p.phi.as_slice()))
                .collect(),
        };
        let mut b_w = Vec::with_capacity(self.nv());
        let mut vertices = Vec::with_capacity(self.nv());
        for (theta_box, phi_box) in boxes {
            self.box_corners(&scheduling, theta_box, phi_box, &mut vertices, &mut b_w);
        }
        let mut out = PolytopicModel {
            name: self.name.clone(),
            states: self.states.clone(),
            inputs: self.inputs.clone(),
            input_rates: self.input_rates.clone(),
            input_ranges: self.input_ranges.clone(),
            outputs: self.outputs.clone(),
            params: self.params.clone(),
            scheduling,
            vertices,
            region: self.region.clone(),
            state_bound: self.state_bound.clone(),
            designs: self.designs.clone(),
            noise: NoiseDecl {
                outputs: self.noise_outputs.clone(),
                disturbances: self.disturbances.clone(),
                b_w: if self.disturbances.is_empty() {
                    Vec::new()
                } else {
                    b_w
                },
            },
            derived: self.derived.clone(),
            cover: self.cover.clone(),
            time_unit: self.time_unit,
            jacobian: None,
        };
        out.jacobian = jacobian::of_model(self);
        // A global bound does not depend on the design: expanded here.
        match out.jacobian.as_ref().and_then(|j| j.global.as_ref()) {
            Some(_) => out.with_jacobian(None).unwrap_or(out),
            None => out,
        }
    }

    /// The vertices (and B_w,l) at the corners of one box of (θ, φ): the
    /// ranges `theta_box` of the parameters and `phi_box` of the derived
    /// variables; parameters that generate no vertex sit at the middle of
    /// their range.
    fn box_corners(
        &self,
        scheduling: &[usize],
        theta_box: &[(f64, f64)],
        phi_box: &[(f64, f64)],
        vertices: &mut Vec<Vertex>,
        b_w: &mut Vec<DMatrix<f64>>,
    ) {
        let np = self.ntheta();
        let s = scheduling.len();
        let nd = self.derived.len();
        let base: Vec<f64> = theta_box.iter().map(|&(lo, hi)| 0.5 * (lo + hi)).collect();
        for l in 0..1usize << (s + nd) {
            let mut theta = base.clone();
            for (i, &pi) in scheduling.iter().enumerate() {
                let (lo, hi) = theta_box[pi];
                theta[pi] = if (l >> (s + nd - 1 - i)) & 1 == 1 {
                    hi
                } else {
                    lo
                };
            }
            // the corner of the (θ, φ) box: φ_j at an end of its range
            let mut ext = theta.clone();
            for (j, &(lo, hi)) in phi_box.iter().enumerate() {
                ext.push(if (l >> (nd - 1 - j)) & 1 == 1 { hi } else { lo });
            }
            debug_assert_eq!(ext.len(), np + nd);
            b_w.push(self.b_w.eval(&ext));
            vertices.push(Vertex {
                a: self.a.eval(&ext),
                n: self.n.iter().map(|m| m.eval(&ext)).collect(),
                b: self.b.eval(&ext),
                c: self.c.eval(&ext),
                m: self.m.iter().map(|m| m.eval(&ext)).collect(),
                theta,
            });
        }
    }
}

impl crate::model::Model {
    /// The same model on a smaller parameter box `theta` (one `(lo, hi)` per
    /// declared parameter, each inside the declared range): the parameter
    /// ranges replaced and every derived scheduling variable's range
    /// recomputed on the smaller box, with the same proof (interval
    /// arithmetic with outward rounding). The pieces of a partition of Θ
    /// cover the curve {(θ, φ(θ))} by several small boxes instead of one
    /// large one, which is how a tighter cover than the box of (θ, φ) is
    /// measured. A cover of the model is dropped (its pieces belong to the
    /// whole box). Errors name the parameter or the function that does not fit.
    pub fn restricted(&self, theta: &[(f64, f64)]) -> Result<crate::model::Model, String> {
        if theta.len() != self.params.len() {
            return Err(format!(
                "{} ranges for {} parameters",
                theta.len(),
                self.params.len()
            ));
        }
        let mut out = self.clone();
        out.cover = None;
        for (p, &(lo, hi)) in out.params.iter_mut().zip(theta) {
            if !(lo.is_finite() && hi.is_finite() && p.lo <= lo && lo < hi && hi <= p.hi) {
                return Err(format!(
                    "[{lo}, {hi}] is not a non-empty part of the range [{}, {}] of {}",
                    p.lo, p.hi, p.name
                ));
            }
            p.lo = lo;
            p.hi = hi;
        }
        let names: Vec<String> = self.params.iter().map(|p| p.name.clone()).collect();
        for d in &mut out.derived {
            let (lo, hi, info) = crate::sched::range(&d.expr, theta, &names)
                .map_err(|e| format!("`{}`: {}", d.text, e.message))?;
            d.lo = lo;
            d.hi = hi;
            d.range = info;
        }
        Ok(out)
    }
}
