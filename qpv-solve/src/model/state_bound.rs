//! `state_bound auto;`: computing the state bound F = {x : xᵀQ⁻¹x ≤ 1}
//! instead of taking Q from elsewhere.
//!
//! With W = Q⁻¹, F is searched as an ellipsoid that
//!
//! 1. contains the region: x_iᵀ W x_i ≤ 1 at every region vertex x_i
//!    (Assumption 2, P ⊂ F);
//! 2. lies inside an enclosing box h·B: [1 bᵀ; b W] ⪰ 0 (i.e. bᵀQb ≤ 1)
//!    for every facet b of h·B;
//! 3. is invariant for the plant with u = 0: with V = xᵀWx,
//!    V' = xᵀ He{W (A(θ) + rows(N(θ), x))} x, and the matrix is affine in x
//!    and in the vertex weights μ, so He{W (A_l + rows(N_l, v))} ≺ 0 at the
//!    vertices v of h·B and every θ-vertex l gives V' < 0 on h·B ⊇ F, hence
//!    no trajectory starting in F leaves it;
//!
//! and, among those, one with the largest γ_max of (S4): minimise
//! t ≥ max_k a_kᵀ Q a_k, an LMI through [t a_kᵀ; a_k W] ⪰ 0, so
//! γ_max = 1/√t. The box size h is searched in one dimension (a log-spaced
//! grid starting just above the smallest box any ellipsoid around the region
//! fits in, then golden-section refinement around the best grid point; the
//! search stops early once γ_max reaches the largest value any ellipsoid
//! around the region has), unless the model fixes it
//! (`state_bound auto(h = ...)`).
//!
//! B is the region's bounding box scaled so that its largest half-width is
//! 1: h·B = {x : |x_j| ≤ h β_j}, β_j = r_j / max_i r_i, r_j = max over the
//! region of |x_j|. For a region that is a cube (the paper's example) this
//! is the box |x_j| ≤ h. h must exceed max_j r_j for F to fit between the
//! region and the box.
//!
//! Invariance is for the plant with u = 0 (inputs, if the model has any, are
//! not accounted for; the report says so). It uses the representation of
//! N_k in the model it is given (`rows(N, v)` depends on the split, the
//! plant does not); [`resolve`] tries both the written and the symmetric
//! split and keeps the larger γ_max.
//!
//! The LMIs are solved in box coordinates z = D⁻¹x, D = diag(h β_j), where
//! the box is the unit box and every condition is O(1); every strict
//! inequality carries the margin [`Settings::margin_rel`]. Every solution is
//! re-checked by [`check`] with nalgebra eigenvalues in model units before
//! it is used; an h whose solution does not pass counts as infeasible.

use crate::backend::builder::SdpBuilder;
use crate::backend::{clarabel_settings, run_sdp, SdpRun, Status};
use crate::error::SolveError;
use crate::linalg::matrix_to_rows;
use crate::linalg::rows::rows;
use crate::linalg::svec::svec_index;
use crate::line_search::{Line, Scale, Stage};
use crate::model::{gamma_max, gamma_max_for};
use crate::settings::Settings;
use crate::vocab::BoundSource;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{PolytopicModel, Split, StateBound};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Most states for `state_bound auto` (the box h·B has 2^nx vertices).
pub(crate) const MAX_STATES: usize = 12;

/// Most invariance blocks (box vertices × θ-vertices) per solve (about a
/// minute per solve at this size on one core).
pub(crate) const MAX_BLOCKS: usize = 16_384;

/// How the box size h is searched when the model does not fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundSearch {
    /// Points of the log-spaced grid h = r_max·f, f from `lo_factor` to
    /// `hi_factor` (default 16: neighbouring points differ by 28 %; on the
    /// paper's example the feasible h form an interval of about ±20 %).
    pub grid: usize,
    /// Golden-section evaluations after the grid. Default 12.
    pub refine: usize,
    /// Smallest grid factor (> 1). Default 1.01.
    pub lo_factor: f64,
    /// Largest grid factor. Default 40.
    pub hi_factor: f64,
}

impl Default for BoundSearch {
    fn default() -> Self {
        BoundSearch {
            grid: 16,
            refine: 12,
            lo_factor: 1.01,
            hi_factor: 40.0,
        }
    }
}

/// One solve of the search in h.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundStep {
    /// The box size tried.
    pub h: f64,
    /// What the solver said.
    pub status: Status,
    /// Clarabel's own status name.
    pub detail: String,
    /// γ_max of the solution if it passed [`check`], else `None`.
    pub gamma_max: Option<f64>,
    /// Wall time of this step (assembly, solve, check), seconds.
    pub seconds: f64,
}

/// The independent check of a state bound W = Q⁻¹ for a box size h. Every
/// quantity is computed from W (and Q = W⁻¹) in model units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundCheck {
    /// λ_min(W) (must be > 0).
    pub w_min_eig: f64,
    /// max_i x_iᵀ W x_i over the region vertices (must be ≤ 1: P ⊂ F).
    pub region: f64,
    /// max_j Q_jj / (h β_j)² (must be ≤ 1: F inside h·B).
    pub in_box: f64,
    /// max over box vertices v and θ-vertices l of
    /// λ_max(He{W (A_l + rows(N_l, v))}) / ‖W‖₂ (must be < 0: invariance).
    pub invariance: f64,
    /// All four hold.
    pub passed: bool,
}

/// A computed state bound.
#[derive(Debug, Clone, PartialEq)]
pub struct AutoBound {
    /// Q (F = {x : xᵀQ⁻¹x ≤ 1}), symmetric positive definite.
    pub q: DMatrix<f64>,
    /// W = Q⁻¹ as certified.
    pub w: DMatrix<f64>,
    /// Box size h of the solution.
    pub h: f64,
    /// Half-widths h β_j of the enclosing box h·B.
    pub half_widths: Vec<f64>,
    /// γ_max = 1 / max_k √(a_kᵀ Q a_k) from (S4).
    pub gamma_max: f64,
    /// The representation of N_k the invariance LMIs used.
    pub split: Split,
    /// The passed check of `w`.
    pub check: BoundCheck,
    /// The solver's estimate of the largest γ_max any ellipsoid containing
    /// the region has (no box, no invariance): the search stops when it is
    /// reached. Not a certified number.
    pub gamma_upper: Option<f64>,
    /// Every solve, in order.
    pub steps: Vec<BoundStep>,
    /// Wall time of the whole computation, seconds.
    pub seconds: f64,
}

/// The state bound entry of a design report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateBoundInfo {
    /// "given" (Q from the model), "auto" (computed here) or "none".
    pub source: BoundSource,
    /// Q as used by the design (rows), if any.
    #[serde(rename = "Q")]
    pub q: Option<Vec<Vec<f64>>>,
    /// Box size h of a computed bound.
    pub h: Option<f64>,
    /// Whether h was fixed by the model (`auto(h = ...)`) rather than searched.
    pub h_fixed: bool,
    /// γ_max = 1 / max_k √(a_kᵀ Q a_k) from (S4), if Q is known.
    pub gamma_max: Option<f64>,
    /// For a computed bound: the solver's estimate of the largest γ_max of
    /// any ellipsoid containing the region (without invariance), for
    /// comparison; not certified.
    #[serde(default)]
    pub gamma_upper: Option<f64>,
    /// Representation of N_k used by the invariance LMIs of a computed bound
    /// ("as_written" or "symmetric").
    #[serde(default, with = "crate::vocab::bound_split_serde")]
    pub split: Option<Split>,
    /// The independent check of a computed bound.
    pub check: Option<BoundCheck>,
    /// Solves of the h search of a computed bound (0 otherwise); each
    /// split tried also runs two small auxiliary solves (the geometric
    /// limits that place the grid and stop the search), not counted here.
    pub solves: usize,
    /// Time to compute the bound, seconds (0 if given).
    pub seconds: f64,
    /// Remarks (e.g. invariance only for u = 0).
    pub notes: Vec<String>,
}

/// The half-widths r_j of the region's bounding box.
fn region_reach(model: &PolytopicModel) -> Vec<f64> {
    let nx = model.nx();
    let mut r = vec![0.0f64; nx];
    for v in &model.region.vertices {
        for (j, rj) in r.iter_mut().enumerate() {
            if let Some(x) = v.get(j) {
                *rj = rj.max(x.abs());
            }
        }
    }
    r
}

/// β_j = r_j / max_i r_i: the shape of the enclosing box (see the module doc).
pub(crate) fn box_shape(model: &PolytopicModel) -> Vec<f64> {
    let r = region_reach(model);
    let rmax = r.iter().copied().fold(0.0, f64::max);
    r.iter().map(|x| x / rmax).collect()
}

fn validate(model: &PolytopicModel) -> Result<(), SolveError> {
    crate::model::validate(model)?;
    let nx = model.nx();
    if nx > MAX_STATES {
        return Err(SolveError::StateBoundInput(format!(
            "state_bound auto supports at most {MAX_STATES} states (the enclosing box has 2^nx \
             vertices); the model has {nx}: give Q instead"
        )));
    }
    let blocks = model.nv().saturating_mul(1usize << nx);
    if blocks > MAX_BLOCKS {
        return Err(SolveError::StateBoundInput(format!(
            "the invariance conditions would have {blocks} blocks (2^{nx} box vertices × {} \
             θ-vertices); at most {MAX_BLOCKS} are supported: give Q instead",
            model.nv()
        )));
    }
    if region_reach(model)
        .iter()
        .any(|r| !(*r > 0.0 && r.is_finite()))
    {
        return Err(SolveError::EmptyRegion);
    }
    Ok(())
}

/// Vertex s of the unit box, s ∈ {−1, 1}^nx (bit j of `v` set → +1).
fn unit_vertex(v: usize, nx: usize) -> DVector<f64> {
    DVector::from_fn(nx, |j, _| if (v >> j) & 1 == 1 { 1.0 } else { -1.0 })
}

/// K_{l,v} = A_l + rows(N_l, x_v) at box vertex x_v = D s_v (model units).
fn invariance_matrices(model: &PolytopicModel, half: &[f64]) -> Vec<DMatrix<f64>> {
    let nx = model.nx();
    let mut out = Vec::with_capacity(model.nv() << nx);
    for vert in &model.vertices {
        for v in 0..1usize << nx {
            let s = unit_vertex(v, nx);
            let x = DVector::from_fn(nx, |j, _| s[j] * half[j]);
            out.push(&vert.a + rows(&vert.n, &x));
        }
    }
    out
}

/// Checks W = Q⁻¹ as a state bound with box size `h` (see [`BoundCheck`]),
/// independently of any solver: eigenvalues and quadratic forms in model
/// units.
pub fn check(model: &PolytopicModel, w: &DMatrix<f64>, h: f64) -> BoundCheck {
    let nx = model.nx();
    let fail = BoundCheck {
        w_min_eig: f64::NAN,
        region: f64::NAN,
        in_box: f64::NAN,
        invariance: f64::NAN,
        passed: false,
    };
    if w.shape() != (nx, nx) || !w.iter().all(|x| x.is_finite()) || h.is_nan() || h <= 0.0 {
        return fail;
    }
    let w = (w + w.transpose()) * 0.5;
    let eig = w.clone().symmetric_eigenvalues();
    let w_min_eig = eig.iter().copied().fold(f64::INFINITY, f64::min);
    let w_norm = eig.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let Some(chol) = (w_min_eig > 0.0).then(|| w.clone().cholesky()).flatten() else {
        return BoundCheck { w_min_eig, ..fail };
    };
    let q = chol.inverse();
    let region = model
        .region
        .vertices
        .iter()
        .map(|x| x.dot(&(&w * x)))
        .fold(f64::NEG_INFINITY, f64::max);
    let half: Vec<f64> = box_shape(model).iter().map(|b| b * h).collect();
    let in_box = (0..nx)
        .map(|j| q[(j, j)] / (half[j] * half[j]))
        .fold(f64::NEG_INFINITY, f64::max);
    let invariance = invariance_matrices(model, &half)
        .iter()
        .map(|k| {
            let m = &w * k;
            let he = &m + m.transpose();
            he.symmetric_eigenvalues()
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max)
                / w_norm
        })
        .fold(f64::NEG_INFINITY, f64::max);
    let passed = w_min_eig > 0.0 && region <= 1.0 && in_box <= 1.0 && invariance < 0.0;
    BoundCheck {
        w_min_eig,
        region,
        in_box,
        invariance,
        passed,
    }
}

/// Index of Ŵ_rc (either order) among the variables.
#[inline]
fn wvar(r: usize, c: usize) -> usize {
    let (r, c) = if r <= c { (r, c) } else { (c, r) };
    svec_index(r, c)
}

/// The SDP at one box size, in box coordinates z = D⁻¹x: the variables
/// Ŵ (svec order) and t, on the crate's one builder.
struct Lmi {
    out: SdpBuilder,
    tvar: usize,
}

impl Lmi {
    /// An empty problem with Ŵ (nx × nx) and t declared.
    fn new(nx: usize) -> Self {
        let mut out = SdpBuilder::new();
        out.sym_var("W", nx);
        let tvar = out.var("t");
        Lmi { out, tvar }
    }

    /// Appends a PSD block F(x) = F0 + Σ_k x_k F_k ⪰ 0 of size n, where
    /// `lin(r, c)` lists (variable, coefficient) of entry (r, c), r ≤ c.
    fn psd(&mut self, f0: &DMatrix<f64>, lin: impl Fn(usize, usize) -> Vec<(usize, f64)>) {
        let blk = self.out.psd(f0.nrows(), 0.0);
        self.out.rhs_matrix(&blk, f0);
        for c in 0..f0.nrows() {
            for r in 0..=c {
                for (k, coef) in lin(r, c) {
                    self.out.entry(&blk, r, c, k, -coef);
                }
            }
        }
    }
}

/// Solves the state-bound SDP at box size `h` (in model units) and checks
/// the result. Returns the step record and, if the solution passed
/// [`check`], the bound.
pub(crate) fn solve_at(
    model: &PolytopicModel,
    h: f64,
    settings: &Settings,
) -> Result<(BoundStep, Option<AutoBound>), SolveError> {
    validate(model)?;
    let t0 = Instant::now();
    let nx = model.nx();
    let half: Vec<f64> = box_shape(model).iter().map(|b| b * h).collect();
    let run = solve_lmi(model, &half, settings, Kind::Full)?;
    let mut found = None;
    if let Some(x) = &run.x {
        // W = D⁻¹ Ŵ D⁻¹
        let w = DMatrix::from_fn(nx, nx, |r, c| x[wvar(r, c)] / (half[r] * half[c]));
        let chk = check(model, &w, h);
        if chk.passed {
            let q = w
                .clone()
                .cholesky()
                .map(|c| c.inverse())
                .map(|q| (&q + q.transpose()) * 0.5);
            if let Some(q) = q {
                found = Some(AutoBound {
                    gamma_max: gamma_max_for(model, &q),
                    q,
                    w,
                    h,
                    half_widths: half.clone(),
                    split: Split::AsWritten,
                    check: chk,
                    gamma_upper: None,
                    steps: Vec::new(),
                    seconds: 0.0,
                });
            }
        }
    }
    let step = BoundStep {
        h,
        status: run.status,
        detail: run.detail,
        gamma_max: found.as_ref().map(|b| b.gamma_max),
        seconds: t0.elapsed().as_secs_f64(),
    };
    Ok((step, found))
}

/// The largest γ_max any ellipsoid containing the region can have (only
/// P ⊂ F, no box, no invariance): the search stops once it is reached. A
/// solver estimate, used only as a stopping rule (never as a claim).
fn geometric_bound(model: &PolytopicModel, settings: &Settings) -> Result<Option<f64>, SolveError> {
    let r = region_reach(model);
    let run = solve_lmi(model, &r, settings, Kind::Geometric)?;
    let nw = model.nx() * (model.nx() + 1) / 2;
    Ok(match (run.status, run.x) {
        (Status::Solved, Some(x)) if x[nw] > 0.0 => Some(1.0 / x[nw].sqrt()),
        _ => None,
    })
}

/// The smallest h for which some ellipsoid containing the region fits in
/// h·B (no invariance): the h search starts just above it. A solver
/// estimate, used only to place the grid.
fn smallest_box(model: &PolytopicModel, settings: &Settings) -> Result<Option<f64>, SolveError> {
    let shape = box_shape(model);
    let run = solve_lmi(model, &shape, settings, Kind::MinBox)?;
    let nw = model.nx() * (model.nx() + 1) / 2;
    Ok(match (run.status, run.x) {
        (Status::Solved, Some(x)) if x[nw] > 0.0 => Some(x[nw].sqrt()),
        _ => None,
    })
}

/// Which SDP [`solve_lmi`] builds; every kind minimises t.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// The state-bound SDP: region, box, invariance, t ≥ max_k âₖᵀQ̂âₖ.
    Full,
    /// Region and t ≥ max_k âₖᵀQ̂âₖ only ([`geometric_bound`]).
    Geometric,
    /// Region and Q̂_jj ≤ t only ([`smallest_box`]).
    MinBox,
}

/// The data of the SDP in box coordinates z = D⁻¹x, D = diag(half).
struct BoxData {
    /// The region's vertices zᵢ.
    zs: Vec<DVector<f64>>,
    /// The region's facets âₖ.
    a_hat: Vec<DVector<f64>>,
    /// The invariance matrices K̂ (for [`Kind::Full`] only; else empty).
    k_hat: Vec<DMatrix<f64>>,
}

impl BoxData {
    fn new(model: &PolytopicModel, half: &[f64], kind: Kind) -> Self {
        let nx = model.nx();
        let zs = model
            .region
            .vertices
            .iter()
            .map(|x| DVector::from_fn(nx, |j, _| x[j] / half[j]))
            .collect();
        let a_hat = model
            .region
            .facets
            .iter()
            .map(|a| DVector::from_fn(nx, |j, _| a[j] * half[j]))
            .collect();
        let k_hat = if kind == Kind::Full {
            invariance_matrices(model, half)
        } else {
            Vec::new()
        }
        .into_iter()
        .map(|k| DMatrix::from_fn(nx, nx, |r, c| k[(r, c)] * half[c] / half[r]))
        .collect();
        BoxData { zs, a_hat, k_hat }
    }
}

impl Lmi {
    /// Region: 1 − ε − zᵢᵀŴzᵢ ≥ 0 for every vertex zᵢ.
    fn region(&mut self, zs: &[DVector<f64>], eps: f64) {
        let nx = zs.first().map_or(0, |z| z.len());
        let row0 = self.out.nonneg(zs.len());
        for (i, z) in zs.iter().enumerate() {
            let row = row0 + i;
            self.out.set_b(row, 1.0 - eps);
            for c in 0..nx {
                for r in 0..=c {
                    let coef = if r == c {
                        z[r] * z[r]
                    } else {
                        2.0 * z[r] * z[c]
                    };
                    self.out.a(row, wvar(r, c), coef);
                }
            }
        }
    }

    /// A block [s vᵀ; v Ŵ] + F0 ⪰ 0 bordered by Ŵ: `corner` is the variable
    /// s (t), or `None` when the corner is a constant held in `f0`.
    fn bordered(&mut self, f0: &DMatrix<f64>, corner: Option<usize>) {
        self.psd(f0, |r, c| match (r, c, corner) {
            (0, 0, Some(t)) => vec![(t, 1.0)],
            (0, _, _) => vec![],
            _ => vec![(wvar(r - 1, c - 1), 1.0)],
        });
    }

    /// Invariance: −He{Ŵ K̂} − ε κ I ⪰ 0; entry (r, c) of He{ŴK̂} is
    /// Σ_m Ŵ_rm K̂_mc + Σ_m Ŵ_cm K̂_mr.
    fn invariance(&mut self, k: &DMatrix<f64>, eps_kappa: f64) {
        let nx = k.nrows();
        let f0 = -DMatrix::identity(nx, nx) * eps_kappa;
        self.psd(&f0, |r, c| {
            let mut v = Vec::with_capacity(2 * nx);
            for m in 0..nx {
                v.push((wvar(r, m), -k[(m, c)]));
                v.push((wvar(c, m), -k[(m, r)]));
            }
            v
        });
    }

    /// Minimises t subject to the blocks (one solver call, read by the
    /// crate's one rule, see [`run_sdp`]).
    fn minimise(mut self, settings: &Settings) -> Result<SdpRun, SolveError> {
        self.out.cost(self.tvar, 1.0);
        run_sdp(self.out.finish(), clarabel_settings(settings))
    }
}

/// Builds and solves the SDP in box coordinates z = D⁻¹x, D = diag(half):
/// returns the solver's answer (status and point, if any) for the blocks of
/// `kind`.
fn solve_lmi(
    model: &PolytopicModel,
    half: &[f64],
    settings: &Settings,
    kind: Kind,
) -> Result<SdpRun, SolveError> {
    let nx = model.nx();
    let eps = settings.margin_rel;
    let data = BoxData::new(model, half, kind);
    let kappa = 1.0 + data.k_hat.iter().map(|k| k.norm()).fold(0.0, f64::max);

    let mut lmi = Lmi::new(nx);
    let tvar = lmi.tvar;
    // Ŵ − ε I ⪰ 0
    let w_entry = |r: usize, c: usize| vec![(wvar(r, c), 1.0)];
    lmi.psd(&(-DMatrix::identity(nx, nx) * eps), w_entry);
    lmi.region(&data.zs, eps);
    // in the box: [1 e_jᵀ; e_j Ŵ] − ε I ⪰ 0
    for j in (0..nx).filter(|_| kind == Kind::Full) {
        let mut f0 = -DMatrix::identity(nx + 1, nx + 1) * eps;
        f0[(0, 0)] += 1.0;
        f0[(0, j + 1)] = 1.0;
        f0[(j + 1, 0)] = 1.0;
        lmi.bordered(&f0, None);
    }
    // smallest box: [t e_jᵀ; e_j Ŵ] ⪰ 0, i.e. Q̂_jj ≤ t
    for j in (0..nx).filter(|_| kind == Kind::MinBox) {
        let mut f0 = DMatrix::zeros(nx + 1, nx + 1);
        f0[(0, j + 1)] = 1.0;
        f0[(j + 1, 0)] = 1.0;
        lmi.bordered(&f0, Some(tvar));
    }
    for k in &data.k_hat {
        lmi.invariance(k, eps * kappa);
    }
    // objective epigraph: [t âₖᵀ; âₖ Ŵ] ⪰ 0
    for a in data.a_hat.iter().filter(|_| kind != Kind::MinBox) {
        let mut f0 = DMatrix::zeros(nx + 1, nx + 1);
        for j in 0..nx {
            f0[(0, j + 1)] = a[j];
            f0[(j + 1, 0)] = a[j];
        }
        lmi.bordered(&f0, Some(tvar));
    }
    lmi.minimise(settings)
}

/// Computes the state bound of `model` (N_k as represented in `model`):
/// at the fixed box size `h` if given, else searching h (see
/// [`BoundSearch`]). Fails if no h gives a checked invariant ellipsoid.
pub fn compute(
    model: &PolytopicModel,
    h: Option<f64>,
    settings: &Settings,
    search: &BoundSearch,
) -> Result<AutoBound, SolveError> {
    validate(model)?;
    let t0 = Instant::now();
    let rmax = region_reach(model).iter().copied().fold(0.0, f64::max);
    let mut steps = Vec::new();
    let mut best: Option<AutoBound> = None;
    let upper = match h {
        Some(_) => None,
        None => geometric_bound(model, settings)?,
    };
    // stop searching once a checked bound is within 1e-4 of the upper estimate
    let enough = upper.map_or(f64::INFINITY, |u| u * (1.0 - 1e-4));
    let mut eval = |h: f64, steps: &mut Vec<BoundStep>| -> Result<f64, SolveError> {
        let (step, found) = solve_at(model, h, settings)?;
        steps.push(step);
        let g = found.as_ref().map_or(0.0, |b| b.gamma_max);
        if let Some(f) = found {
            if best.as_ref().map_or(true, |b| f.gamma_max > b.gamma_max) {
                best = Some(f);
            }
        }
        Ok(g)
    };
    match h {
        Some(h) => {
            if !(h > rmax && h.is_finite()) {
                return Err(SolveError::StateBoundInput(format!(
                    "h = {} must exceed the region's largest |x_j| = {}",
                    qpv_dsl::diagnostic::fmt_num(h),
                    qpv_dsl::diagnostic::fmt_num(rmax)
                )));
            }
            eval(h, &mut steps)?;
        }
        None => {
            // start just above the smallest box any ellipsoid around the region fits in
            let floor = smallest_box(model, settings)?.unwrap_or(0.0) / rmax * (1.0 + 1e-3);
            let lo_factor = search.lo_factor.max(1.0 + 1e-9).max(floor);
            let hi_factor = search.hi_factor.max(lo_factor * 2.0);
            let hs = Scale::Log.grid(rmax * lo_factor, rmax * hi_factor, search.grid);
            // golden section on ln h between the neighbours of the best point,
            // the classic two-point start (at least two evaluations)
            let line = Line {
                refine: if search.refine > 0 {
                    search.refine.max(2)
                } else {
                    0
                },
                probe_first: true,
                below: Some(rmax * lo_factor / (1.0 + 1e-3)),
                above: hs.last().map(|h| h * 1.5),
                goal: Some(enough),
                ..Line::default()
            };
            let mut gamma_at =
                |hv: f64, _: Stage| eval(hv, &mut steps).map(|g| (g > 0.0).then_some(g));
            line.maximise(&hs, &mut gamma_at, &|| false)?;
        }
    }
    let Some(mut bound) = best else {
        let tried: Vec<String> = steps
            .iter()
            .map(|s| format!("h = {:.4e}: {}", s.h, s.detail))
            .collect();
        return Err(SolveError::StateBound(format!(
            "no invariant ellipsoid containing the region was found inside any box h·B tried ({}); \
             the plant may not be stable on the region, or give Q instead",
            tried.join(", ")
        )));
    };
    bound.steps = steps;
    bound.gamma_upper = upper;
    bound.seconds = t0.elapsed().as_secs_f64();
    Ok(bound)
}

/// The state bound a design uses: for `StateBound::Auto` the bound is
/// computed ([`compute`] with the written and with the symmetric split of
/// N_k; the larger γ_max is kept) and the returned model has
/// `StateBound::Given(Q)`; a given Q or no bound is passed through. The
/// [`StateBoundInfo`] describes the result for the report.
pub fn resolve(
    model: &PolytopicModel,
    settings: &Settings,
) -> Result<(PolytopicModel, StateBoundInfo), SolveError> {
    let mut info = StateBoundInfo {
        source: BoundSource::None,
        q: None,
        h: None,
        h_fixed: false,
        gamma_max: None,
        gamma_upper: None,
        split: None,
        check: None,
        solves: 0,
        seconds: 0.0,
        notes: Vec::new(),
    };
    match &model.state_bound {
        StateBound::None => Ok((model.clone(), info)),
        StateBound::Given(q) => {
            info.source = BoundSource::Given;
            info.q = Some(matrix_to_rows(q));
            info.gamma_max = gamma_max(model);
            Ok((model.clone(), info))
        }
        StateBound::Auto { h } => {
            let t0 = Instant::now();
            let search = BoundSearch::default();
            let mut best: Option<AutoBound> = None;
            let mut solves = 0;
            let mut last_err = None;
            for split in [Split::Symmetric, Split::AsWritten] {
                let m = model.with_split(split);
                if split == Split::AsWritten && model.with_split(Split::Symmetric) == m {
                    continue; // already symmetric: nothing new to try
                }
                let reached = best.as_ref().is_some_and(|b| {
                    b.gamma_upper
                        .is_some_and(|u| b.gamma_max >= u * (1.0 - 1e-4))
                });
                if reached {
                    continue; // no ellipsoid containing the region does better
                }
                match compute(&m, *h, settings, &search) {
                    Ok(mut b) => {
                        b.split = split;
                        solves += b.steps.len();
                        if best.as_ref().map_or(true, |x| b.gamma_max > x.gamma_max) {
                            best = Some(b);
                        }
                    }
                    Err(e @ SolveError::StateBound(_)) => last_err = Some(e),
                    Err(e) => return Err(e),
                }
            }
            let Some(b) = best else {
                return Err(last_err.unwrap_or_else(|| {
                    SolveError::StateBound("no invariant ellipsoid was found".into())
                }));
            };
            let mut out = model.clone();
            out.state_bound = StateBound::Given(b.q.clone());
            info.source = BoundSource::Auto;
            info.q = Some(matrix_to_rows(&b.q));
            info.h = Some(b.h);
            info.h_fixed = h.is_some();
            info.gamma_max = Some(b.gamma_max);
            info.gamma_upper = b.gamma_upper;
            info.split = Some(b.split);
            info.check = Some(b.check.clone());
            info.solves = solves;
            info.seconds = t0.elapsed().as_secs_f64();
            if model.nu() > 0 {
                info.notes.push(
                    "F is invariant for the plant with u = 0 only; inputs are not accounted for"
                        .into(),
                );
            }
            Ok((out, info))
        }
    }
}
