//! The arithmetic of a generated observer as data, printed by two emitters:
//! the `qpv!` proc-macro prints it as Rust tokens, [`c`] prints it as C99
//! (`qpv codegen --lang c`).
//!
//! [`ir`] is the expression language (numbers, names, folded sums,
//! products, selections, the scheduling functions' calls); [`build`] turns
//! a validated model and a certified design into bodies of that language:
//! the plant's equations, the interned θ-coefficients, the derived
//! scheduling variables φ(θ), the vertex weights μ(θ), the scheduled gain
//! and the observer's right-hand side. Both printers print exactly these
//! bodies, so the Rust and the C observer compute the same unrolled,
//! constant-folded sums in the same order. [`design`] holds the certified
//! numbers the emitters bake.
//!
//! [`rounding`] bounds the f32 rounding error of those bodies as generated.
//!
//! [`measured`] computes θ from y for parameters computed from a measured
//! output.
//!
//! Layers: `ir`, `design` and `measured` (0), `build` (1), `c` and
//! `rounding` (2).

pub mod build;
pub mod c;
pub mod design;
pub mod ir;
pub mod measured;
pub mod rounding;

pub use design::{CertifiedDesign, Figures, Shape};
