//! The `qpv!` macro: a QPV model written inline (or `include "file.qpv"`)
//! is parsed, solved and independently certified at build time, and expands
//! to a module of specialised, unrolled, `no_std` observer code.
//!
//! Pipeline: [`input`] (tokens → text + span table) → `qpv_dsl::parse` →
//! polytopic model → `qpv_solve::design` + `qpv_solve::check` (with a
//! [`cache`]) → [`emit`]. Any error becomes one `compile_error!` on the
//! offending token ([`fallback`]).
//!
//! See the `qpv` crate's documentation of `qpv!` for the generated API.

mod cache;
mod emit;
mod expand;
mod fallback;
mod input;

use proc_macro::TokenStream;

/// Builds a certified observer at compile time from a QPV model.
///
/// ```ignore
/// qpv::qpv!(include "examples/paper.qpv");
/// let mut obs = paper_example::Observer::new();
/// obs.step_rk4(1e-3, &y, &[], &theta);
/// ```
///
/// Expands to one module per model (named after it) with the constants
/// `NX, NY, NU, NTHETA, NV, THETA_MIN, THETA_MAX, ALPHA, GAMMA, P, L,
/// CERTIFICATE`, the functions `mu`, `gain`, `clamp_theta`, the `Observer`
/// type and `plant::{derivative, output}`. A model with several `design`
/// blocks gets one submodule per design (`design1`, `design2`, ...); the
/// first is re-exported at the model level. Only certified sound-mode
/// designs are baked: anything else is a compile error on the `design`
/// block that says why and what would be certified.
#[proc_macro]
pub fn qpv(input: TokenStream) -> TokenStream {
    expand::expand(input.into()).into()
}
