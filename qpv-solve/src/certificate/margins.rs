//! What a certificate says: the margins of its condition families and data
//! checks, the accumulator that finds each family's worst margin, and the
//! eigenvalue helpers every check uses.

use crate::vocab::Family;
use nalgebra::DMatrix;
use qpv_dsl::Mode;
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

/// Result of [`check`](super::check).
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

pub(super) const GUARD_C: f64 = 16.0 * f64::EPSILON;

/// The data check of `max_gain = G`: max_l ‖L_l‖₂ (largest singular
/// value, from the gains as given) ≤ G. A non-finite gain or bound fails.
pub(super) fn gain_check(l: &[DMatrix<f64>], bound: f64) -> DataCheck {
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
    let desc = "max_gain: every ‖L_l‖₂ ≤ G (the design's gain bound)";
    DataCheck {
        passed: bound.is_finite() && bound > 0.0 && value <= bound,
        ..DataCheck::at_most(value, bound, true, desc)
    }
}

impl DataCheck {
    /// The check value ≤ bound (JSON-safe numbers, see [`finite`]).
    pub(super) fn at_most(value: f64, bound: f64, required: bool, description: &str) -> Self {
        DataCheck {
            value: finite(value),
            bound: finite(bound),
            margin: finite(bound - value),
            passed: value <= bound,
            required,
            description: description.to_string(),
        }
    }
}

/// JSON has no NaN/∞: NaN and −∞ become −f64::MAX, +∞ becomes f64::MAX.
pub(super) fn finite(v: f64) -> f64 {
    if v.is_nan() {
        -f64::MAX
    } else {
        v.clamp(-f64::MAX, f64::MAX)
    }
}

pub(super) struct Acc {
    pub(super) name: Family,
    pub(super) margin: f64,
    pub(super) guard: f64,
    pub(super) passed: bool,
    pub(super) worst_at: String,
    pub(super) count: usize,
}

impl Acc {
    pub(super) fn new(name: Family) -> Self {
        Acc {
            name,
            margin: f64::INFINITY,
            guard: 0.0,
            passed: true,
            worst_at: String::new(),
            count: 0,
        }
    }
    pub(super) fn add(&mut self, margin: f64, guard: f64, at: impl FnOnce() -> String) {
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
    pub(super) fn finish(self) -> FamilyMargin {
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

/// The guard of an n × n block required ≺ 0 or ⪰ 0 whose terms have size
/// `size`.
pub(super) fn block_guard(n: usize, size: f64, m: &DMatrix<f64>) -> f64 {
    GUARD_C * (n as f64 + 1.0) * 2.0 * (size + m.norm())
}

/// The smallest eigenvalue of the symmetric `m` (NaN if any is NaN).
pub(super) fn lambda_min(m: &DMatrix<f64>) -> f64 {
    extreme(m, f64::INFINITY, f64::min)
}

/// The largest eigenvalue of the symmetric `m` (NaN if any is NaN).
pub(super) fn lambda_max(m: &DMatrix<f64>) -> f64 {
    extreme(m, f64::NEG_INFINITY, f64::max)
}

fn extreme(m: &DMatrix<f64>, start: f64, pick: fn(f64, f64) -> f64) -> f64 {
    let e = m.clone().symmetric_eigenvalues();
    if e.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    e.iter().copied().fold(start, pick)
}
