//! Parameters computed from a measured output, as data: [`Measured`] (what
//! a `param p = y1` parameter is computed from, its interval's origin, the
//! terms rewritten onto it) and the records of the rewrite of terms of
//! degree 3 or more whose extra factors are measured (the rewrite itself is
//! the model builder's, `model::measured`).
//!
//! A state that an output measures directly (y_k = a·x_i, a constant a ≠ 0)
//! is replaced in such a term by the parameter computed from that output
//! (x_i = p/a with p = y_k), every such factor while a state remains
//! (x1²·x2 → p²·x2 with y = x1; a power of p is a derived variable). The
//! rewrite is exact (p equals the output at every instant), recorded, and
//! reported with the model.

use crate::diagnostic::{fmt_num, Span};
use serde::Serialize;

/// Where a measured parameter's interval comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MeasuredOrigin {
    /// `param p = y1 in [lo, hi];`: declared.
    Declared,
    /// `param p = y1;`: derived from the output's range over F.
    Derived,
    /// Added to schedule a term of degree 3 on a measured factor, its
    /// interval derived from F.
    Automatic,
}

/// A parameter computed from a measured output.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measured {
    /// The output's index.
    pub output: usize,
    /// The output's name.
    pub output_name: String,
    /// The output as a row c of constants: y = cᵀx.
    pub row: Vec<f64>,
    /// Declared, derived, or added by a rewrite.
    pub origin: MeasuredOrigin,
    /// The terms scheduled on it ("`x1^2*x2` at 5:20 as `y1^2*x2`").
    pub rewrites: Vec<String>,
    /// The model's given state bound Q (row-major), kept for the designs
    /// whose own model drops it (the global observer of an LPV plant);
    /// `None` for `state_bound auto` (the design's computed F is used).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bound: Option<Vec<f64>>,
}

impl Measured {
    /// The output's range over F = {xᵀQ⁻¹x ≤ 1}: √(cᵀQc) (Q row-major,
    /// nx × nx); NaN if Q has the wrong size.
    pub fn reach(&self, q: &[f64]) -> f64 {
        let n = self.row.len();
        if q.len() != n * n {
            return f64::NAN;
        }
        let mut s = 0.0;
        for i in 0..n {
            for j in 0..n {
                s += self.row[i] * q[i * n + j] * self.row[j];
            }
        }
        s.max(0.0).sqrt()
    }

    /// A sentence for reports: what the parameter is and why its interval
    /// holds (`q`: the design's F, row-major).
    pub fn describe(&self, name: &str, lo: f64, hi: f64, q: Option<&[f64]>) -> String {
        let origin = match self.origin {
            MeasuredOrigin::Declared => "declared",
            MeasuredOrigin::Derived => "derived from the state bound F",
            MeasuredOrigin::Automatic => {
                "added to schedule terms on a measured factor, derived from F"
            }
        };
        let mut s = format!(
            "parameter `{name}` is computed from the measured output {} (the observer reads it \
             from y): interval [{}, {}] ({origin})",
            self.output_name,
            fmt_num(lo),
            fmt_num(hi)
        );
        if let Some(q) = q {
            let r = self.reach(q);
            s.push_str(&format!(
                "; {} ranges over [{}, {}] on F",
                self.output_name,
                fmt_num(-r),
                fmt_num(r)
            ));
        }
        if !self.rewrites.is_empty() {
            s.push_str(&format!("; rewritten: {}", self.rewrites.join(", ")));
        }
        s
    }
}

/// A state measured directly: output `output` is `scale`·x_`state`.
#[derive(Clone, Debug)]
pub(crate) struct MeasuredState {
    pub state: usize,
    pub output: usize,
    pub scale: f64,
    /// The bit of the parameter computed from the output, if the model has
    /// one (a declared `param p = y`, or one added for a rewrite).
    pub param: Option<usize>,
}

/// One term rewritten onto a measured parameter.
#[derive(Clone, Debug)]
pub(crate) struct Rewrite {
    /// The parameter's bit.
    pub param: usize,
    /// The expression the term came from.
    pub span: Span,
    /// The term as written (`x1^2*x2`) and as scheduled (`y1*x1*x2`).
    pub from: String,
    pub to: String,
    /// The degree of the term as written.
    pub degree: usize,
}

/// A term of degree 3 or more wanted a measured factor that has no
/// parameter yet: the output, where, and the term's text.
#[derive(Clone, Debug)]
pub(crate) struct Wanted {
    pub output: usize,
    pub span: Span,
    pub term: String,
    /// The term's degree in the states, the measured state, and the term
    /// as it would be scheduled on a parameter `p`.
    pub degree: usize,
    pub state: usize,
    pub scheduled: String,
}
