//! The piecewise cover of the parameter box (`cover q2 into 4;`).
//!
//! The box of (θ, φ) of a model with derived scheduling variables φ_j(θ)
//! contains points that no θ produces. Cutting Θ into pieces along some
//! parameters and taking the box of (θ, φ) over each piece (every φ range
//! recomputed on the piece with the same interval proof) covers the set
//! {(θ, φ(θ))} by several thinner boxes. The polytopic model then has the
//! corners of every piece's box as vertices, piece after piece, and μ(θ) is
//! the multilinear weight of the box of the piece that contains θ (zero on
//! every other piece): exact for multi-affine entries, as on the whole box.

use crate::sched::RangeInfo;
use serde::Serialize;

/// Most pieces a cover may have (the product of the counts of all its
/// parameters). Each piece adds the 2^s corners of its box to the vertices,
/// and the LMI count and the solve time grow about linearly with them;
/// beyond 64 pieces the design is impractical and a finer cover rarely pays.
pub const MAX_PIECES: usize = 64;

/// A cover of the parameter box by a grid of equal pieces.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cover {
    /// The parameters cut, in the order written (the first is the most
    /// significant in the piece index).
    pub axes: Vec<CoverAxis>,
    /// The pieces in piece-index order; piece k owns the vertices
    /// k·2^s .. (k+1)·2^s of the polytopic model.
    pub pieces: Vec<Piece>,
}

/// One parameter cut into equal pieces.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CoverAxis {
    /// Index of the parameter in the model's declared parameters.
    pub param: usize,
    /// Its name.
    pub name: String,
    /// The n + 1 breakpoints lo = b_0 < b_1 < … < b_n = hi of its n
    /// pieces, b_k = lo + (hi − lo)·k/n.
    pub breaks: Vec<f64>,
}

/// One piece of the cover: a sub-box of Θ and the ranges of the derived
/// scheduling variables on it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Piece {
    /// (lo, hi) of every declared parameter on this piece (the declared
    /// range for the parameters not cut).
    pub theta: Vec<(f64, f64)>,
    /// (lo, hi) of every derived scheduling variable φ_j on this piece:
    /// contains φ_j(θ) for every θ in the piece (interval arithmetic with
    /// outward rounding, as for the whole box).
    pub phi: Vec<(f64, f64)>,
    /// How each range of `phi` was obtained.
    pub range: Vec<RangeInfo>,
}

impl Cover {
    /// Number of pieces.
    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    /// Whether the cover has no piece (never true for a validated model).
    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }

    /// The piece that contains a parameter vector `theta` already clamped
    /// into Θ (one entry per declared parameter). Along each cut parameter
    /// the piece index is the number of inner breakpoints b_1..b_{n−1} that
    /// are ≤ θ_i: a breakpoint belongs to the piece above it, the upper end
    /// of Θ to the last piece, and a NaN to the first.
    pub fn locate(&self, theta: &[f64]) -> usize {
        let mut k = 0;
        for a in &self.axes {
            let n = a.breaks.len().saturating_sub(1).max(1);
            let t = theta.get(a.param).copied().unwrap_or(f64::NAN);
            let i = a
                .breaks
                .iter()
                .skip(1)
                .take(n - 1)
                .filter(|&&b| t >= b)
                .count();
            k = k * n + i;
        }
        k
    }

    /// The index of piece `k` along each cut parameter (first axis first).
    pub fn indices(&self, k: usize) -> Vec<usize> {
        let mut rest = k;
        let mut out = vec![0; self.axes.len()];
        for (a, slot) in self.axes.iter().zip(out.iter_mut()).rev() {
            let n = a.breaks.len().saturating_sub(1).max(1);
            *slot = rest % n;
            rest /= n;
        }
        out
    }

    /// Piece `k` in words: `q2 ∈ [0.2, 0.65]` (one interval per cut parameter).
    pub fn label(&self, k: usize) -> String {
        let idx = self.indices(k);
        self.axes
            .iter()
            .zip(idx)
            .map(|(a, i)| {
                let lo = a.breaks.get(i).copied().unwrap_or(f64::NAN);
                let hi = a.breaks.get(i + 1).copied().unwrap_or(f64::NAN);
                format!(
                    "{} ∈ [{}, {}]",
                    a.name,
                    crate::diagnostic::fmt_num(lo),
                    crate::diagnostic::fmt_num(hi)
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The breakpoints of `n` equal pieces of [lo, hi]: lo + (hi − lo)·k/n, with
/// the ends exactly lo and hi.
pub fn equal_breaks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..=n)
        .map(|k| {
            if k == 0 {
                lo
            } else if k == n {
                hi
            } else {
                lo + (hi - lo) * (k as f64 / n as f64)
            }
        })
        .collect()
}
