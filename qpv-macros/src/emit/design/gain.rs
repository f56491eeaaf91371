//! The gain schedule of a certified design: `gain(θ)` = Σ_l μ_l(θ) L_l,
//! unrolled entry by entry with the baked vertex gains as constants (the
//! shared body of [`qpv_codegen::build::observer::gains_body`]).

use super::Shape;
use crate::emit::tokens::{destructure, expr};
use crate::emit::CertifiedDesign;
use proc_macro2::TokenStream;
use quote::{format_ident, quote};

/// The generated `gain` (θ clamped first) and `gains` (from given weights μ).
pub(super) fn items(d: &CertifiedDesign, shape: Shape) -> TokenStream {
    let Shape { ny, nv, .. } = shape;
    let b = qpv_codegen::build::observer::gains_body(d, shape);
    let no_libm = TokenStream::new();
    let g_rows: Vec<TokenStream> = b
        .out
        .chunks(ny.max(1))
        .map(|row| {
            let row = row.iter().map(|e| expr(e, &no_libm));
            quote!([#(#row),*])
        })
        .collect();
    let body = quote!([#(#g_rows),*]);
    let mu = format_ident!("mu");
    let bind = destructure(&mu, "m", nv, &body);
    quote! {
        /// The scheduled gain L(θ) = Σ_l μ_l(θ) L_l (θ clamped into Θ).
        #[inline]
        pub fn gain(theta: &[f64; NTHETA]) -> [[f64; NY]; NZ] {
            gains(&super::mu_clamped(&super::clamp_theta(theta).0))
        }

        #[inline(always)]
        fn gains(mu: &[f64; NV]) -> [[f64; NY]; NZ] {
            #bind
            #body
        }
    }
}
