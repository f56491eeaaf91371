//! The independent certificate: every condition recomputed from P and the
//! gains L_l (Γ_l = P L_l) in the model's own units, with dense nalgebra
//! matrices and symmetric eigenvalues — no code shared with the assembly
//! except the two definitions `rows` / `rowsHe`.
//!
//! Margins (positive = satisfied):
//! * "S1": λ_min(P) (P ≻ 0; a non-symmetric P fails).
//! * "S2" (sound): min_i 1 − x_(i)ᵀ P x_(i).
//! * "S3" (sound): min_k λ_min([1 γa_kᵀ; γa_k P]).
//! * "13" (paper): min_i λ_min([1 x_(i)ᵀ; x_(i) P]).
//! * "14" (paper): min_k λ_min([1 γa_kᵀP; γPa_k P]).
//! * "S5" / "26": min over (l, i, j) of −λ_max(He{…} + γαP).
//!
//! A family passes only if its worst margin exceeds a floating-point guard:
//! a conservative bound, 16·(n+1)·ε_mach times the sum of the Frobenius
//! norms of the terms forming the matrix (the error of forming it and of the
//! symmetric eigensolver). Data checks: "S4" max_k γ² a_kᵀQa_k ≤ 1 (required
//! in sound mode, reported as the violated assumption (15) in paper mode)
//! and "region_in_F" max_i x_(i)ᵀQ⁻¹x_(i) ≤ 1 (reported).

pub mod noise;
pub mod noise_sampled;
pub mod poles;
pub mod rounding;
mod sampled;
pub mod sampling;

pub use sampled::{alpha_capacity_sampled, sampled_block};

use crate::conditions::cube::CubeSlacks;
use crate::conditions::{pair_suffix, rate_combos, Combo, ConditionSet};
use crate::linalg::rows::{rows, rows_he};
use crate::model::{is_double_sum, validate, StateScaling};
use crate::vocab::{Candidate, Family};
use nalgebra::{DMatrix, DVector};
use qpv_dsl::{Mode, PolytopicModel, StateBound};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A check on the data alone (no decision variable), e.g. (S4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataCheck {
    /// The checked quantity's worst value, e.g. max_k γ² a_kᵀ Q a_k for "S4".
    pub value: f64,
    /// The bound it must respect (1 for both S4 and region_in_F).
    pub bound: f64,
    /// bound − value: positive = satisfied.
    pub margin: f64,
    /// Whether the check holds (margin ≥ 0).
    pub passed: bool,
    /// Whether the design's claim depends on it (S4 in sound mode). A
    /// failed required check makes the design infeasible.
    pub required: bool,
    /// What is checked, in words.
    pub description: String,
}

/// The worst margin of one condition family.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FamilyMargin {
    /// Family key: "S1","S2","S3","S5" (sound) or "S1","13","14","26" (paper).
    pub name: String,
    /// Worst margin over the family (positive = satisfied): the smallest
    /// eigenvalue of the matrices required ⪰ 0 (resp. −λ_max of those
    /// required ≺ 0), or the scalar slack 1 − xᵀPx for (S2).
    pub margin: f64,
    /// Floating-point guard: the margin must exceed this to count.
    pub guard: f64,
    /// margin > guard.
    pub passed: bool,
    /// Where the worst margin occurs (e.g. "l=2 i=5 j=1", 1-based).
    pub worst_at: String,
    /// Number of conditions in the family.
    pub count: usize,
}

/// Result of [`check`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Certificate {
    /// Mode checked ("sound" / "paper").
    #[serde(with = "crate::vocab::mode_serde")]
    pub mode: Mode,
    /// α checked.
    pub alpha: f64,
    /// γ checked.
    pub gamma: f64,
    /// One entry per condition family.
    pub families: Vec<FamilyMargin>,
    /// Data checks "S4" and "region_in_F" (absent when there is no Q).
    pub data_checks: BTreeMap<String, DataCheck>,
    /// Every family passed and every required data check passed.
    pub passed: bool,
    /// Problems with the input itself (dimensions, non-finite numbers).
    pub input_errors: Vec<String>,
}

impl Certificate {
    /// Family → worst margin (every family of a certificate is named by a
    /// [`Family`], so none is left out).
    pub fn margins(&self) -> BTreeMap<Family, f64> {
        self.families
            .iter()
            .filter_map(|f| Some((Family::from_name(&f.name)?, f.margin)))
            .collect()
    }

    /// The family with this key.
    pub fn family(&self, name: impl AsRef<str>) -> Option<&FamilyMargin> {
        let name = name.as_ref();
        self.families.iter().find(|f| f.name == name)
    }

    /// A failed certificate for gains that could not be checked at all:
    /// `reason` (e.g. a refused state bound) is its input error.
    pub fn refused(mode: Mode, alpha: f64, gamma: f64, reason: String) -> Certificate {
        Certificate {
            mode,
            alpha,
            gamma,
            families: Vec::new(),
            data_checks: BTreeMap::new(),
            passed: false,
            input_errors: vec![reason],
        }
    }

    /// The certificate with the data check of `max_gain = G` (required):
    /// max_l ‖L_l‖₂ ≤ G, computed from the gains `l` as given (see
    /// [`gain_check`]); unchanged when `bound` is None.
    pub(crate) fn with_gain_bound(mut self, l: &[DMatrix<f64>], bound: Option<f64>) -> Certificate {
        if let Some(g) = bound {
            let c = gain_check(l, g);
            self.passed &= c.passed;
            self.data_checks
                .insert(Family::MaxGain.name().to_string(), c);
        }
        self
    }

    /// Whether every condition family passed (ignoring data checks).
    pub fn families_passed(&self) -> bool {
        self.input_errors.is_empty() && self.families.iter().all(|f| f.passed)
    }
}

const GUARD_C: f64 = 16.0 * f64::EPSILON;

/// The data check of `max_gain = G`: max_l ‖L_l‖₂ (largest singular
/// value, from the gains as given) ≤ G. A non-finite gain or bound fails.
pub fn gain_check(l: &[DMatrix<f64>], bound: f64) -> DataCheck {
    let value = l
        .iter()
        .map(|li| {
            if li.iter().all(|v| v.is_finite()) {
                crate::linalg::norm2(li)
            } else {
                f64::INFINITY
            }
        })
        .fold(0.0, f64::max);
    let passed = bound.is_finite() && bound > 0.0 && value <= bound;
    DataCheck {
        value: finite(value),
        bound: finite(bound),
        margin: finite(bound - value),
        passed,
        required: true,
        description: "max_gain: every ‖L_l‖₂ ≤ G (the design's gain bound)".into(),
    }
}

/// JSON has no NaN/∞: NaN and −∞ become −f64::MAX, +∞ becomes f64::MAX.
fn finite(v: f64) -> f64 {
    if v.is_nan() {
        -f64::MAX
    } else {
        v.clamp(-f64::MAX, f64::MAX)
    }
}

struct Acc {
    name: Family,
    margin: f64,
    guard: f64,
    passed: bool,
    worst_at: String,
    count: usize,
}

impl Acc {
    fn new(name: Family) -> Self {
        Acc {
            name,
            margin: f64::INFINITY,
            guard: 0.0,
            passed: true,
            worst_at: String::new(),
            count: 0,
        }
    }
    fn add(&mut self, margin: f64, guard: f64, at: impl FnOnce() -> String) {
        self.count += 1;
        if margin.is_nan() || margin <= guard {
            self.passed = false;
        }
        let worse =
            self.count == 1 || (margin.is_nan() && !self.margin.is_nan()) || margin < self.margin;
        if worse {
            self.margin = margin;
            self.guard = guard;
            self.worst_at = at();
        }
    }
    fn finish(self) -> FamilyMargin {
        FamilyMargin {
            name: self.name.name().to_string(),
            margin: if self.count == 0 {
                0.0
            } else {
                finite(self.margin)
            },
            guard: self.guard,
            passed: self.passed && self.count > 0,
            worst_at: self.worst_at,
            count: self.count,
        }
    }
}

fn sym_eigs(m: &DMatrix<f64>) -> DVector<f64> {
    m.clone().symmetric_eigenvalues()
}

fn lambda_min(m: &DMatrix<f64>) -> f64 {
    let e = sym_eigs(m);
    if e.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    e.iter().copied().fold(f64::INFINITY, f64::min)
}

fn lambda_max(m: &DMatrix<f64>) -> f64 {
    let e = sym_eigs(m);
    if e.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    e.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// Γ_l = P L_l as the certificate sees them (empty where the sizes do not
/// fit, which the certificate then reports), and ‖L_l‖_F.
fn gammas_of(p: &DMatrix<f64>, l: &[DMatrix<f64>]) -> (Vec<DMatrix<f64>>, Vec<f64>) {
    let gammas = l
        .iter()
        .map(|li| {
            if p.ncols() == li.nrows() {
                p * li
            } else {
                DMatrix::zeros(0, 0)
            }
        })
        .collect();
    (gammas, l.iter().map(|li| li.norm()).collect())
}

/// The gains a certificate judges: P, the gains L_l per θ-vertex (Γ_l =
/// P L_l is recomputed) and, for a `conditions = cube` design, the slacks
/// that witness its rate family.
#[derive(Debug, Clone, Copy)]
pub struct Gains<'a> {
    /// The Lyapunov matrix P.
    pub p: &'a DMatrix<f64>,
    /// L_l, one nx × ny matrix per θ-vertex.
    pub l: &'a [DMatrix<f64>],
    /// The cube slacks (Y, X, D), if the design has them.
    pub cube: Option<&'a CubeSlacks>,
}

impl<'a> Gains<'a> {
    /// P and the L_l, without cube slacks.
    pub fn new(p: &'a DMatrix<f64>, l: &'a [DMatrix<f64>]) -> Self {
        Gains { p, l, cube: None }
    }

    /// The same gains with these cube slacks (None: none).
    pub fn with_cube(self, cube: Option<&'a CubeSlacks>) -> Self {
        Gains { cube, ..self }
    }
}

/// The independent certificate of `gains` at the candidate `at` in `mode`:
/// every condition family recomputed from the model and the gains alone
/// ((S1)–(S5), or the paper's printed conditions), the data checks (S4)
/// and P ⊂ F. The rate family is the one the gains call for: the cube's
/// slack inequalities when they carry cube slacks, the discrete decrease
/// S5d when the candidate has a sample period (sound mode), else the
/// vertex family (S5)/(26) (G5 for the global observer).
pub fn check(model: &PolytopicModel, gains: &Gains, at: &Candidate, mode: Mode) -> Certificate {
    let (rate, balance) = match (gains.cube, at.sample) {
        (Some(_), Some(h)) => {
            return Certificate::refused(
                mode,
                at.alpha,
                at.gamma,
                format!("cube slacks at sample = {h}: a sampled design has no cube form"),
            )
        }
        (Some(c), None) => (RateCheck::Cube(c), balanced(model, mode)),
        (None, Some(h)) if mode == Mode::Sound => {
            (RateCheck::Sampled(h), balanced_for(model, mode, gains.p))
        }
        (None, Some(h)) => {
            return Certificate::refused(
                mode,
                at.alpha,
                at.gamma,
                format!("sample = {h} is a sound-mode condition, not one of the paper's"),
            )
        }
        (None, None) => (RateCheck::Vertex, balanced_for(model, mode, gains.p)),
    };
    check_in_units(model, mode, at, gains, balance, rate)
}

/// [`check_inner`] in the balanced coordinates `balance` when given and
/// every matrix transforms exactly (P, L_l and, for a cube check, its
/// slacks), else in the model's own: the one place a check chooses its
/// coordinates.
fn check_in_units(
    model: &PolytopicModel,
    mode: Mode,
    at: &Candidate,
    gains: &Gains,
    balance: Option<(PolytopicModel, StateScaling)>,
    rate: RateCheck<'_>,
) -> Certificate {
    let (p, l) = (gains.p, gains.l);
    if let Some((zm, s)) = balance {
        let cube_z = match rate {
            RateCheck::Cube(c) => cube_to_z(&s, c).map(Some),
            _ => Some(None),
        };
        if let (Some(pz), Some(lz), Some(cz)) = (s.p_to_z(p), l_to_z(&s, l), cube_z) {
            let (gammas, lnorm) = gammas_of(&pz, &lz);
            let rate_z = match (&cz, rate) {
                (Some(c), _) => RateCheck::Cube(c),
                (None, r) => r,
            };
            let witness = Witness {
                p: &pz,
                gammas: &gammas,
                lnorm: &lnorm,
            };
            return check_inner(&zm, mode, at, &witness, rate_z);
        }
    }
    let (gammas, lnorm) = gammas_of(p, l);
    let witness = Witness {
        p,
        gammas: &gammas,
        lnorm: &lnorm,
    };
    check_inner(model, mode, at, &witness, rate)
}

/// What [`check_inner`] evaluates: P, Γ_l and the sizes ‖L_l‖ its guards
/// use (‖Γ_l‖/‖P‖ when Γ_l is given directly).
struct Witness<'a> {
    p: &'a DMatrix<f64>,
    gammas: &'a [DMatrix<f64>],
    lnorm: &'a [f64],
}

/// Which rate family [`check_inner`] checks.
#[derive(Clone, Copy)]
enum RateCheck<'a> {
    /// (S5)/(26) at every combination and region-vertex pair.
    Vertex,
    /// The cube's slack inequalities with these slacks: the rate family and
    /// the region's vertex condition are the cube's slack inequalities with
    /// the slacks given (docs/method.md), checked by eigenvalues at a cost
    /// polynomial in nx (no vertex pair is enumerated):
    /// * vertex family ("S2" / "13"): λ_min(D − GᵀPG) (sound) or
    ///   λ_min([D Gᵀ; G P]) (paper), and 1 − Σ D_kk, with D = diag(d);
    /// * rate family ("S5" / "26"): λ_min(Y_{c,k} ∓ G_c(g_k)),
    ///   λ_min(X_{c,k} ∓ H_c(g_k)) and −λ_max(F0_c + Σ_k Y_{c,k} + Σ_k X_{c,k})
    ///   for every rate combination c and generator k.
    ///
    /// The generators are the region's own ([`qpv_dsl::Region::zonotope_generators`]);
    /// (S1), the facets and the data checks are as in [`check`].
    Cube(&'a CubeSlacks),
    /// The discrete decrease (S5d) at the sample period h ([`sampled`]).
    Sampled(f64),
}

/// The model in balanced coordinates x = D z ([`StateScaling`]: sound mode,
/// a badly scaled region, every entry transformed exactly), with D. The
/// certificate evaluates every condition on the user's P and L_l after this
/// congruence (P_z = DPD, L_z = D⁻¹L, exact in floating point): the same
/// inequalities, with the eigenvalues of well-balanced matrices; its
/// margins are those of the balanced matrices.
fn balanced(model: &PolytopicModel, mode: Mode) -> Option<(PolytopicModel, StateScaling)> {
    let s = StateScaling::of(model, mode)?;
    Some((s.model(model)?, s))
}

/// [`balanced`], or for the global observer (which has no region to fix
/// the units) the congruence that balances the P being checked
/// ([`StateScaling::of_p`]: powers of two, exact like every other).
fn balanced_for(
    model: &PolytopicModel,
    mode: Mode,
    p: &DMatrix<f64>,
) -> Option<(PolytopicModel, StateScaling)> {
    if let Some(b) = balanced(model, mode) {
        return Some(b);
    }
    if !crate::model::is_global(model, mode) || p.shape() != (model.nx(), model.nx()) {
        return None;
    }
    let s = StateScaling::of_p(p)?;
    Some((s.model(model)?, s))
}

fn l_to_z(s: &StateScaling, l: &[DMatrix<f64>]) -> Option<Vec<DMatrix<f64>>> {
    l.iter().map(|x| s.l_to_z(x)).collect()
}

fn gammas_to_z(s: &StateScaling, g: &[DMatrix<f64>]) -> Option<Vec<DMatrix<f64>>> {
    g.iter().map(|x| s.gamma_to_z(x)).collect()
}

/// Cube slacks in balanced coordinates: Y_z = DYD, X_z = DXD (D of the
/// generators unchanged: G_zᵀP_zG_z = GᵀPG).
fn cube_to_z(s: &StateScaling, c: &CubeSlacks) -> Option<CubeSlacks> {
    let per = |v: &Vec<Vec<DMatrix<f64>>>| -> Option<Vec<Vec<DMatrix<f64>>>> {
        v.iter()
            .map(|row| row.iter().map(|m| s.p_to_z(m)).collect())
            .collect()
    };
    Some(CubeSlacks {
        y: per(&c.y)?,
        x: per(&c.x)?,
        d: c.d.clone(),
    })
}

/// The generators of the model's zonotope region, if the slacks fit them.
fn cube_input_errors(model: &PolytopicModel, c: &CubeSlacks) -> Result<Vec<DVector<f64>>, String> {
    let Some(gens) = model.region.zonotope_generators() else {
        return Err("cube slacks given, but the region is not a box or zonotope".into());
    };
    let (nx, r, nc) = (model.nx(), gens.len(), rate_combos(model).len());
    let shape_ok = |v: &Vec<Vec<DMatrix<f64>>>| {
        v.len() == nc
            && v.iter().all(|per| {
                per.len() == r
                    && per
                        .iter()
                        .all(|m| m.shape() == (nx, nx) && m.iter().all(|x| x.is_finite()))
            })
    };
    if !shape_ok(&c.y) || !shape_ok(&c.x) {
        return Err(format!(
            "cube slacks: expected {nc} × {r} symmetric {nx} × {nx} matrices Y and X (rate combinations × generators), with finite entries"
        ));
    }
    if c.d.len() != r || !c.d.iter().all(|v| v.is_finite()) {
        return Err(format!("cube slacks: expected {r} finite entries of D"));
    }
    Ok(gens)
}

fn input_errors(
    model: &PolytopicModel,
    set: ConditionSet,
    alpha: f64,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> Vec<String> {
    let nx = model.nx();
    let ny = model.ny();
    let mut errs = Vec::new();
    if let Err(e) = validate(model) {
        errs.push(format!("model: {e}"));
        return errs;
    }
    if p.shape() != (nx, nx) {
        errs.push(format!("P is {:?}, expected ({nx}, {nx})", p.shape()));
    }
    if gammas.len() != model.nv() {
        errs.push(format!(
            "{} gains given, the model has {} vertices",
            gammas.len(),
            model.nv()
        ));
    }
    for (i, g) in gammas.iter().enumerate() {
        if g.shape() != (nx, ny) {
            errs.push(format!(
                "gain {} has the wrong shape (expected {nx} × {ny})",
                i + 1
            ));
        }
    }
    if !p.iter().all(|v| v.is_finite()) || !gammas.iter().all(|g| g.iter().all(|v| v.is_finite())) {
        errs.push("non-finite entries in P or the gains".into());
    }
    if !(alpha.is_finite() && alpha > 0.0) {
        errs.push(format!("α = {alpha} is not a positive finite number"));
    }
    // The caller's condition set decides, as in the check itself: paper
    // mode has no global observer.
    let mode = match set {
        ConditionSet::Sound => Mode::Sound,
        ConditionSet::Paper => Mode::Paper,
    };
    let global = crate::model::is_global(model, mode);
    let gamma_ok = gamma.is_finite() && gamma > 0.0 && gamma < 1.0;
    if !(global || gamma_ok) {
        errs.push(format!("γ = {gamma} is not in (0, 1)"));
    }
    errs
}

/// The data checks (S4) and P ⊂ F at this γ (empty without Q).
pub fn data_checks(model: &PolytopicModel, mode: Mode, gamma: f64) -> BTreeMap<String, DataCheck> {
    let mut out = BTreeMap::new();
    let StateBound::Given(q) = &model.state_bound else {
        return out;
    };
    let set = ConditionSet::from_mode(mode);
    let s4 = model
        .region
        .facets
        .iter()
        .map(|a| gamma * gamma * a.dot(&(q * a)))
        .fold(f64::NEG_INFINITY, f64::max);
    let s4_desc = match set {
        ConditionSet::Sound => "(S4) max_k γ² a_kᵀ Q a_k ≤ 1: the state bound F lies in P/γ",
        ConditionSet::Paper => {
            "(15)/(S4) max_k γ² a_kᵀ Q a_k ≤ 1: assumed by the paper, not enforced by (13),(14),(26)"
        }
    };
    out.insert(
        Family::S4.name().to_string(),
        DataCheck {
            value: finite(s4),
            bound: 1.0,
            margin: finite(1.0 - s4),
            passed: s4 <= 1.0,
            required: set.requires_s4(),
            description: s4_desc.to_string(),
        },
    );
    let inf = match q.clone().cholesky() {
        Some(ch) => model
            .region
            .vertices
            .iter()
            .map(|x| x.dot(&ch.solve(x)))
            .fold(f64::NEG_INFINITY, f64::max),
        None => f64::INFINITY,
    };
    out.insert(
        Family::RegionInF.name().to_string(),
        DataCheck {
            value: finite(inf),
            bound: 1.0,
            margin: finite(1.0 - inf),
            passed: inf <= 1.0,
            required: false,
            description:
                "max_i x_(i)ᵀ Q⁻¹ x_(i) ≤ 1: the region P lies in the state bound F (Assumption 2)"
                    .to_string(),
        },
    );
    out
}

/// The conditions of one check: the model and γ the blocks use (for the
/// global observer its region-free model and γ = 1), the condition set, the
/// witness, the rate family and the cube's generators.
struct Stage<'a> {
    model: &'a PolytopicModel,
    set: ConditionSet,
    global: bool,
    alpha: f64,
    gamma: f64,
    w: &'a Witness<'a>,
    ps: DMatrix<f64>,
    rate: RateCheck<'a>,
    gens: Vec<DVector<f64>>,
}

impl Stage<'_> {
    fn cube(&self) -> Option<&CubeSlacks> {
        match self.rate {
            RateCheck::Cube(c) => Some(c),
            _ => None,
        }
    }

    /// (S1) P ≻ 0, P symmetric.
    fn s1(&self, family: Family) -> FamilyMargin {
        let (p, nx) = (self.w.p, self.model.nx());
        let pn = p.norm();
        let mut s1 = Acc::new(family);
        let asym = (p - p.transpose()).norm();
        if asym > 4.0 * f64::EPSILON * pn {
            s1.add(-asym, 0.0, || {
                format!("P is not symmetric (‖P − Pᵀ‖_F = {asym:e})")
            });
        } else {
            s1.add(
                lambda_min(&self.ps),
                GUARD_C * (nx as f64 + 1.0) * pn,
                || "P".into(),
            );
        }
        s1.finish()
    }

    /// The region's vertex family (for cube slacks: through D).
    fn vertices(&self, family: Family) -> FamilyMargin {
        let (nx, pn, ps) = (self.model.nx(), self.w.p.norm(), &self.ps);
        let mut sv = Acc::new(family);
        if let Some(c) = self.cube() {
            cube_region(&mut sv, self.set, ps, &self.gens, &c.d);
        }
        let xs: &[DVector<f64>] = match self.cube() {
            Some(_) => &[],
            None => &self.model.region.vertices,
        };
        for (i, x) in xs.iter().enumerate() {
            match self.set {
                ConditionSet::Sound => {
                    let v = 1.0 - x.dot(&(ps * x));
                    let g = GUARD_C * (nx as f64 + 1.0) * (1.0 + pn * x.norm_squared());
                    sv.add(v, g, || format!("i={}", i + 1));
                }
                ConditionSet::Paper => {
                    let m = bordered(1.0, x, ps);
                    let g = GUARD_C * (nx as f64 + 2.0) * m.norm();
                    sv.add(lambda_min(&m), g, || format!("i={}", i + 1));
                }
            }
        }
        sv.finish()
    }

    /// The region's facet family.
    fn facets(&self, family: Family) -> FamilyMargin {
        let (nx, pn, ps, gamma) = (self.model.nx(), self.w.p.norm(), &self.ps, self.gamma);
        let mut sf = Acc::new(family);
        for (k, a) in self.model.region.facets.iter().enumerate() {
            let off: DVector<f64> = match self.set {
                ConditionSet::Sound => a * gamma,
                ConditionSet::Paper => (ps * a) * gamma,
            };
            let m = bordered(1.0, &off, ps);
            let g = GUARD_C * (nx as f64 + 2.0) * (m.norm() + gamma * pn * a.norm());
            sf.add(lambda_min(&m), g, || format!("k={}", k + 1));
        }
        sf.finish()
    }

    /// The rate family: Σ_t w_t Ξ_{l_t m_t}(i, j) ≺ 0 for every combination
    /// (conditions::Combo), Ξ_{lm} = He{γ(PA_l − Γ_lC_m) + σP R_l − Γ_l S_m}
    /// + γαP; or the cube's slack inequalities; or the discrete decrease.
    fn rate(&self, family: Family) -> FamilyMargin {
        let (model, nx, set) = (self.model, self.model.nx(), self.set);
        let (alpha, gamma) = (self.alpha, self.gamma);
        let double = is_double_sum(model);
        let mut sr = Acc::new(family);
        if let Some(c) = self.cube() {
            let at = Candidate::new(alpha, gamma);
            let ct = CubeTerms::new(model, &self.ps, self.w.gammas, self.w.lnorm, set, at);
            for (ci, combo) in rate_combos(model).iter().enumerate() {
                ct.check(&mut sr, (combo, ci, double), &self.gens, c);
            }
        }
        let xs: &[DVector<f64>] = match self.cube() {
            Some(_) => &[],
            None => &model.region.vertices,
        };
        let terms = Terms::new(model, xs, &self.ps, self.w.gammas, self.w.lnorm, gamma);
        if let RateCheck::Sampled(h) = self.rate {
            sampled::check_family(&mut sr, &terms, model, alpha, gamma, h);
        }
        let vertex = matches!(self.rate, RateCheck::Vertex | RateCheck::Cube(_));
        for combo in rate_combos(model).into_iter().filter(|_| vertex) {
            if !xs.is_empty() && combo_is_linear(model, &combo) {
                // N and M vanish in every term: every pair (i, j) gives this
                // same block (rows(0, x) = 0 exactly), so it is checked once.
                let (m, size) = terms.combo(&combo, sigma(set), alpha, gamma, 0, 0);
                let guard = GUARD_C * (nx as f64 + 1.0) * 2.0 * (size + m.norm());
                sr.add(-lambda_max(&m), guard, || {
                    if self.global {
                        combo.label(double)
                    } else {
                        format!("{} (every pair: N = M = 0)", combo.label(double))
                    }
                });
                continue;
            }
            for i in 0..xs.len() {
                for j in 0..xs.len() {
                    let (m, size) = terms.combo(&combo, sigma(set), alpha, gamma, i, j);
                    let guard = GUARD_C * (nx as f64 + 1.0) * 2.0 * (size + m.norm());
                    sr.add(-lambda_max(&m), guard, || {
                        format!("{}{}", combo.label(double), pair_suffix(model, i, j))
                    });
                }
            }
        }
        sr.finish()
    }
}

/// [s vᵀ; v M]: the bordered matrices of the region's vertex and facet
/// conditions.
fn bordered(s: f64, v: &DVector<f64>, m: &DMatrix<f64>) -> DMatrix<f64> {
    let n = m.nrows();
    let mut out = DMatrix::zeros(n + 1, n + 1);
    out[(0, 0)] = s;
    for r in 0..n {
        out[(0, r + 1)] = v[r];
        out[(r + 1, 0)] = v[r];
    }
    out.view_mut((1, 1), (n, n)).copy_from(m);
    out
}

/// The input errors of a check (shapes, finiteness, α, γ, the sample
/// period, the cube slacks), and the cube's generators when they fit.
fn check_inputs(
    model: &PolytopicModel,
    set: ConditionSet,
    at: &Candidate,
    w: &Witness,
    rate: RateCheck<'_>,
) -> (Vec<String>, Vec<DVector<f64>>) {
    let mut errs = input_errors(model, set, at.alpha, at.gamma, w.p, w.gammas);
    if let RateCheck::Sampled(h) = rate {
        errs.extend(sampled::input_errors(set, at.alpha, h));
    }
    let gens = match rate {
        RateCheck::Cube(c) if errs.is_empty() => match cube_input_errors(model, c) {
            Ok(g) => g,
            Err(e) => {
                errs.push(e);
                Vec::new()
            }
        },
        _ => Vec::new(),
    };
    (errs, gens)
}

fn check_inner(
    model: &PolytopicModel,
    mode: Mode,
    at: &Candidate,
    w: &Witness,
    rate: RateCheck<'_>,
) -> Certificate {
    let (alpha, gamma) = (at.alpha, at.gamma);
    let set = ConditionSet::from_mode(mode);
    let global = crate::model::is_global(model, mode);
    let global_model = crate::model::global_model(model);
    // The global observer: the region is the point {0} (its one pair has
    // no nonlinear terms), no state bound, and γ = 1 in the rate blocks.
    let (model, gamma_blocks): (&PolytopicModel, f64) = if global {
        (&global_model, 1.0)
    } else {
        (model, gamma)
    };
    let (errs, gens) = check_inputs(model, set, at, w, rate);
    let data = if global {
        BTreeMap::new()
    } else if errs.is_empty() || w.p.nrows() == model.nx() {
        data_checks(model, mode, gamma.clamp(0.0, 1.0))
    } else {
        BTreeMap::new()
    };
    if !errs.is_empty() {
        return Certificate {
            mode,
            alpha,
            gamma,
            families: Vec::new(),
            data_checks: data,
            passed: false,
            input_errors: errs,
        };
    }
    let [f1, fv, ff, fr] = set.families();
    let fr = match rate {
        RateCheck::Sampled(_) => Family::S5d,
        _ if global => Family::G5,
        _ => fr,
    };
    let stage = Stage {
        model,
        set,
        global,
        alpha,
        gamma: gamma_blocks,
        w,
        ps: (w.p + w.p.transpose()) * 0.5,
        rate,
        gens,
    };
    let families = if global {
        vec![stage.s1(f1), stage.rate(fr)]
    } else {
        vec![
            stage.s1(f1),
            stage.vertices(fv),
            stage.facets(ff),
            stage.rate(fr),
        ]
    };
    let passed = families.iter().all(|f| f.passed)
        && data.values().filter(|d| d.required).all(|d| d.passed)
        && (global || !set.requires_s4() || data.contains_key(Family::S4.name()));
    Certificate {
        mode,
        alpha,
        gamma,
        families,
        data_checks: data,
        passed,
        input_errors: Vec::new(),
    }
}

/// The cube's vertex condition: D ⪰ GᵀPG (sound) or [D Gᵀ; G P] ⪰ 0
/// (paper), and Σ D_kk ≤ 1.
fn cube_region(
    acc: &mut Acc,
    set: ConditionSet,
    ps: &DMatrix<f64>,
    gens: &[DVector<f64>],
    d: &[f64],
) {
    let (nx, r) = (ps.nrows(), gens.len());
    let g = DMatrix::from_columns(gens);
    let dm = DMatrix::from_diagonal(&DVector::from_column_slice(d));
    let pn = ps.norm();
    match set {
        ConditionSet::Sound => {
            let gpg = g.transpose() * ps * &g;
            let m = &dm - &gpg;
            let guard =
                GUARD_C * (r as f64 + nx as f64 + 1.0) * 2.0 * (dm.norm() + pn * g.norm_squared());
            acc.add(lambda_min(&m), guard, || "D ⪰ GᵀPG".into());
        }
        ConditionSet::Paper => {
            let mut m = DMatrix::zeros(r + nx, r + nx);
            m.view_mut((0, 0), (r, r)).copy_from(&dm);
            m.view_mut((r, 0), (nx, r)).copy_from(&g);
            m.view_mut((0, r), (r, nx)).copy_from(&g.transpose());
            m.view_mut((r, r), (nx, nx)).copy_from(ps);
            let guard = GUARD_C * (r as f64 + nx as f64 + 2.0) * m.norm();
            acc.add(lambda_min(&m), guard, || "[D Gᵀ; G P] ⪰ 0".into());
        }
    }
    let tr: f64 = d.iter().sum();
    let guard = GUARD_C * (r as f64 + 1.0) * (1.0 + d.iter().map(|v| v.abs()).sum::<f64>());
    acc.add(1.0 - tr, guard, || "trace D ≤ 1".into());
}

/// The pieces of the cube's rate inequalities, in model units.
struct CubeTerms<'a> {
    model: &'a PolytopicModel,
    p: &'a DMatrix<f64>,
    gammas: &'a [DMatrix<f64>],
    /// ‖L_l‖‖P‖ + ‖Γ_l‖ (error size of Γ_l).
    gn: Vec<f64>,
    sigma: f64,
    gamma: f64,
    /// The α the slack inequalities are checked at.
    alpha: f64,
}

impl<'a> CubeTerms<'a> {
    /// The pieces at the candidate `at` (its α is used by
    /// [`CubeTerms::check`] only).
    fn new(
        model: &'a PolytopicModel,
        p: &'a DMatrix<f64>,
        gammas: &'a [DMatrix<f64>],
        lnorm: &[f64],
        set: ConditionSet,
        at: Candidate,
    ) -> Self {
        let pn = p.norm();
        CubeTerms {
            model,
            p,
            gammas,
            gn: gammas
                .iter()
                .enumerate()
                .map(|(l, g)| lnorm.get(l).copied().unwrap_or(0.0) * pn + g.norm())
                .collect(),
            sigma: sigma(set),
            gamma: at.gamma,
            alpha: at.alpha,
        }
    }

    /// F0_c = Σ_t w_t (He{γ(PA_l − Γ_l C_m)} + γαP), G_c(g) = Σ_t w_t
    /// He{−σP rows(N_l, g) + Γ_l rows(M_m, g)} and H_c(g) = Σ_t w_t
    /// He{σP rowsHe(N_l, g) − Γ_l rowsHe(M_m, g)}: which = 0, 1, 2; with the
    /// size of their terms (for the guard).
    fn part(&self, c: &Combo, alpha: f64, which: u8, g: &DVector<f64>) -> (DMatrix<f64>, f64) {
        let nx = self.p.nrows();
        let pn = self.p.norm();
        let mut out = DMatrix::zeros(nx, nx);
        let mut size = 0.0;
        for &(l, m, w) in &c.terms {
            let (vl, vm, gl) = (
                &self.model.vertices[l],
                &self.model.vertices[m],
                &self.gammas[l],
            );
            let (x, sz) = match which {
                0 => {
                    let x = (self.p * &vl.a - gl * &vm.c) * self.gamma
                        + self.p * (0.5 * self.gamma * alpha);
                    let sz =
                        self.gamma * (pn * vl.a.norm() + self.gn[l] * vm.c.norm() + alpha * pn);
                    (x, sz)
                }
                1 => {
                    let (rn, rm) = (rows(&vl.n, g), rows(&vm.m, g));
                    let x = self.p * &rn * (-self.sigma) + gl * &rm;
                    (x, pn * rn.norm() + self.gn[l] * rm.norm())
                }
                _ => {
                    let (rn, rm) = (rows_he(&vl.n, g), rows_he(&vm.m, g));
                    let x = self.p * &rn * self.sigma - gl * &rm;
                    (x, pn * rn.norm() + self.gn[l] * rm.norm())
                }
            };
            out += (&x + x.transpose()) * w;
            size += 2.0 * sz * w.abs();
        }
        (out, size)
    }

    /// Adds every slack inequality of combination `c` (index `ci`; labelled
    /// for a double sum if `double`) to `acc`.
    fn check(
        &self,
        acc: &mut Acc,
        (c, ci, double): (&Combo, usize, bool),
        gens: &[DVector<f64>],
        slacks: &CubeSlacks,
    ) {
        let alpha = self.alpha;
        let nx = self.p.nrows();
        let g0 = DVector::zeros(nx);
        let guard =
            |size: f64, m: &DMatrix<f64>| GUARD_C * (nx as f64 + 1.0) * 2.0 * (size + m.norm());
        let sym = |m: &DMatrix<f64>| (m + m.transpose()) * 0.5;
        let (mut sum, mut size) = self.part(c, alpha, 0, &g0);
        for (k, g) in gens.iter().enumerate() {
            for (which, name, s) in [(1u8, "Y", &slacks.y[ci][k]), (2u8, "X", &slacks.x[ci][k])] {
                let s = sym(s);
                let (part, psize) = self.part(c, alpha, which, g);
                for sign in [1.0, -1.0] {
                    let m = &s - &part * sign;
                    let sz = psize + s.norm();
                    acc.add(lambda_min(&m), guard(sz, &m), || {
                        format!(
                            "{} {name} k={} {}",
                            c.label(double),
                            k + 1,
                            if sign > 0.0 { "⪰ +" } else { "⪰ −" }
                        )
                    });
                }
                sum += &s;
                size += s.norm();
            }
        }
        acc.add(-lambda_max(&sum), guard(size, &sum), || {
            format!("{} F0 + ΣY + ΣX", c.label(double))
        });
    }

    /// The largest α with F0_c(α) + ΣY + ΣX ≺ 0 for these (P, Γ_l) and slacks.
    fn capacity(&self, c: &Combo, ci: usize, linv: &DMatrix<f64>, slacks: &CubeSlacks) -> f64 {
        let nx = self.p.nrows();
        let (mut m0, _) = self.part(c, 0.0, 0, &DVector::zeros(nx));
        for k in 0..slacks.y[ci].len() {
            m0 += (&slacks.y[ci][k] + slacks.y[ci][k].transpose()) * 0.5;
            m0 += (&slacks.x[ci][k] + slacks.x[ci][k].transpose()) * 0.5;
        }
        let w = linv * m0 * linv.transpose();
        -lambda_max(&w) / (self.gamma * c.weight())
    }
}

/// Whether every term (l, m) of `combo` has N_l = 0 and M_m = 0 exactly:
/// then R_{l,i,j} and S_{m,i,j} vanish and the p² blocks are one.
pub fn combo_is_linear(model: &PolytopicModel, combo: &Combo) -> bool {
    let zero = |ms: &[DMatrix<f64>]| ms.iter().all(|m| m.iter().all(|v| *v == 0.0));
    combo
        .terms
        .iter()
        .all(|&(l, m, _)| zero(&model.vertices[l].n) && zero(&model.vertices[m].m))
}

fn sigma(set: ConditionSet) -> f64 {
    set.nonlinear_sign()
}

/// The per-vertex pieces of the rate matrices Ξ_{lm}(i, j), precomputed once.
struct Terms<'a> {
    model: &'a PolytopicModel,
    p: &'a DMatrix<f64>,
    gammas: &'a [DMatrix<f64>],
    /// γ P A_l.
    pa: Vec<DMatrix<f64>>,
    /// rowsHe(N_l, x_j), rows(N_l, x_i).
    nhe: Vec<Vec<DMatrix<f64>>>,
    nrw: Vec<Vec<DMatrix<f64>>>,
    /// rowsHe(M_m, x_j), rows(M_m, x_i).
    mhe: Vec<Vec<DMatrix<f64>>>,
    mrw: Vec<Vec<DMatrix<f64>>>,
    /// ‖L_l‖‖P‖ + ‖Γ_l‖ (error size of Γ_l).
    gn: Vec<f64>,
}

impl<'a> Terms<'a> {
    /// The pieces at the region vertices `xs` (indices i, j below refer to
    /// `xs`): the whole region for a certificate, a single pair for one block.
    fn new(
        model: &'a PolytopicModel,
        xs: &[DVector<f64>],
        p: &'a DMatrix<f64>,
        gammas: &'a [DMatrix<f64>],
        lnorm: &[f64],
        gamma: f64,
    ) -> Self {
        let per = |f: &dyn Fn(&qpv_dsl::Vertex, &DVector<f64>) -> DMatrix<f64>| {
            model
                .vertices
                .iter()
                .map(|v| xs.iter().map(|x| f(v, x)).collect())
                .collect()
        };
        let pn = p.norm();
        Terms {
            model,
            p,
            gammas,
            pa: model.vertices.iter().map(|v| p * &v.a * gamma).collect(),
            nhe: per(&|v, x| rows_he(&v.n, x)),
            nrw: per(&|v, x| rows(&v.n, x)),
            mhe: per(&|v, x| rows_he(&v.m, x)),
            mrw: per(&|v, x| rows(&v.m, x)),
            gn: gammas
                .iter()
                .enumerate()
                .map(|(l, g)| lnorm.get(l).copied().unwrap_or(0.0) * pn + g.norm())
                .collect(),
        }
    }

    /// Ξ_{lm}(i, j) without its γαP term, and the size of its terms (for the guard).
    fn xi0(
        &self,
        sigma: f64,
        gamma: f64,
        l: usize,
        m: usize,
        i: usize,
        j: usize,
    ) -> (DMatrix<f64>, f64) {
        let (x, size) = self.phi(sigma, gamma, l, m, i, j);
        (&x + x.transpose(), size)
    }

    /// γ(PA_l − Γ_lC_m) + σP R_{l,i,j} − Γ_l S_{m,i,j} (γ·PF at the vertex,
    /// for σ = +1), whose He is [`Terms::xi0`], and the size of its terms.
    fn phi(
        &self,
        sigma: f64,
        gamma: f64,
        l: usize,
        m: usize,
        i: usize,
        j: usize,
    ) -> (DMatrix<f64>, f64) {
        let g = &self.gammas[l];
        let (vl, vm) = (&self.model.vertices[l], &self.model.vertices[m]);
        let r = &self.nhe[l][j] - &self.nrw[l][i];
        let s = &self.mhe[m][j] - &self.mrw[m][i];
        let x = &self.pa[l] - g * &vm.c * gamma + self.p * &r * sigma - g * &s;
        let pn = self.p.norm();
        let size = gamma * pn * vl.a.norm()
            + gamma * self.gn[l] * vm.c.norm()
            + pn * r.norm()
            + self.gn[l] * s.norm();
        (x, size)
    }

    /// Σ_t w_t Ξ_{l_t m_t}(i, j) (with its γαP terms) and its size.
    fn combo(
        &self,
        c: &Combo,
        sigma: f64,
        alpha: f64,
        gamma: f64,
        i: usize,
        j: usize,
    ) -> (DMatrix<f64>, f64) {
        let (mut m, size) = self.combo0(c, sigma, gamma, i, j);
        m += self.p * (gamma * alpha * c.weight());
        (m, size + gamma * alpha * self.p.norm() * c.weight())
    }

    /// As [`Terms::combo`] without the γαP terms.
    fn combo0(&self, c: &Combo, sigma: f64, gamma: f64, i: usize, j: usize) -> (DMatrix<f64>, f64) {
        let nx = self.p.nrows();
        let mut out = DMatrix::zeros(nx, nx);
        let mut size = 0.0;
        for &(l, m, w) in &c.terms {
            let (x, s) = self.xi0(sigma, gamma, l, m, i, j);
            out += x * w;
            size += s * w.abs();
        }
        (out, size)
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
    let set = ConditionSet::from_mode(mode);
    let lnorm = vec![0.0; gammas.len()];
    let pair = [
        model.region.vertices[i].clone(),
        model.region.vertices[j].clone(),
    ];
    Terms::new(model, &pair, p, gammas, &lnorm, gamma)
        .combo(combo, sigma(set), alpha, gamma, 0, 1)
        .0
}

/// The largest α at which the *same* (P, Γ_l) satisfy every rate LMI at
/// this γ (exactly: −λ_max(L⁻¹ M₀ L⁻ᵀ)/γ minimised over the blocks, with
/// P = LLᵀ and M₀ the rate LMI without its γαP term). Returns 0 if P is not
/// positive definite or not even α → 0⁺ works. The region conditions do not
/// depend on α.
pub fn alpha_capacity(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> f64 {
    if let Some((zm, s)) = balanced_for(model, mode, p) {
        if let (Some(pz), Some(gz)) = (s.p_to_z(p), gammas_to_z(&s, gammas)) {
            return capacity_inner(&zm, mode, gamma, &pz, &gz);
        }
    }
    capacity_inner(model, mode, gamma, p, gammas)
}

fn capacity_inner(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
) -> f64 {
    let set = ConditionSet::from_mode(mode);
    let global_model = crate::model::global_model(model);
    let (model, gamma) = if crate::model::is_global(model, mode) {
        (&*global_model, 1.0)
    } else {
        (model, gamma)
    };
    let ps = (p + p.transpose()) * 0.5;
    let Some(ch) = ps.clone().cholesky() else {
        return 0.0;
    };
    let linv = match ch.l().try_inverse() {
        Some(li) => li,
        None => return 0.0,
    };
    let xs = &model.region.vertices;
    let lnorm = vec![0.0; gammas.len()];
    let terms = Terms::new(model, xs, &ps, gammas, &lnorm, gamma);
    let mut worst = f64::INFINITY;
    for combo in rate_combos(model) {
        let n = if combo_is_linear(model, &combo) {
            xs.len().min(1)
        } else {
            xs.len()
        };
        for i in 0..n {
            for j in 0..n {
                let (m0, _) = terms.combo0(&combo, sigma(set), gamma, i, j);
                let w = &linv * m0 * linv.transpose();
                let a = -lambda_max(&w) / (gamma * combo.weight());
                if a.is_nan() {
                    return 0.0;
                }
                worst = worst.min(a);
            }
        }
    }
    worst.max(0.0)
}

/// [`alpha_capacity`] for a design of `conditions = cube`: the largest α
/// at which F0_c(α) + Σ_k Y_{c,k} + Σ_k X_{c,k} ≺ 0 for the same (P, Γ_l) and
/// slacks (the slack inequalities and the region conditions do not depend
/// on α; [`check_cube`] checks them). 0 if P is not positive definite.
pub(crate) fn alpha_capacity_cube(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    slacks: &CubeSlacks,
) -> f64 {
    if let Some((zm, s)) = balanced(model, mode) {
        if let (Some(pz), Some(gz), Some(cz)) =
            (s.p_to_z(p), gammas_to_z(&s, gammas), cube_to_z(&s, slacks))
        {
            return capacity_cube_inner(&zm, mode, gamma, &pz, &gz, &cz);
        }
    }
    capacity_cube_inner(model, mode, gamma, p, gammas, slacks)
}

fn capacity_cube_inner(
    model: &PolytopicModel,
    mode: Mode,
    gamma: f64,
    p: &DMatrix<f64>,
    gammas: &[DMatrix<f64>],
    slacks: &CubeSlacks,
) -> f64 {
    let set = ConditionSet::from_mode(mode);
    let ps = (p + p.transpose()) * 0.5;
    let Some(ch) = ps.clone().cholesky() else {
        return 0.0;
    };
    let Some(linv) = ch.l().try_inverse() else {
        return 0.0;
    };
    let combos = rate_combos(model);
    if slacks.y.len() != combos.len() || slacks.x.len() != combos.len() {
        return 0.0;
    }
    let lnorm = vec![0.0; gammas.len()];
    let ct = CubeTerms::new(model, &ps, gammas, &lnorm, set, Candidate::new(0.0, gamma));
    let mut worst = f64::INFINITY;
    for (ci, combo) in combos.iter().enumerate() {
        let a = ct.capacity(combo, ci, &linv, slacks);
        if a.is_nan() {
            return 0.0;
        }
        worst = worst.min(a);
    }
    worst.max(0.0)
}
