//! Model and certified design → bodies of the [`crate::ir`] language.
//!
//! [`equations`]: the plant's rows as monomial → θ-polynomial maps;
//! [`coeffs`]: the interned θ-dependent coefficients; [`weights`]: φ(θ),
//! the cover's piece and μ(θ); [`observer`]: the scheduled gain, the
//! observer's right-hand side and the plant's derivative and output.
//!
//! Names the bodies read (bound by the printers): `t<i>` θ_i (clamped for
//! μ and the coefficients), `f<j>` φ_j(θ), `m<l>` μ_l, `x<i>` the state
//! (x̂ in the observer), `zh<k>`, `zm<k>` the filter states, `y<o>`, `u<j>`,
//! `g<k>_<o>` the scheduled gain, `c.k<i>` ([`crate::ir::Expr::Coef`]) the
//! θ-coefficients.

pub mod coeffs;
pub mod equations;
pub mod observer;
pub mod weights;
