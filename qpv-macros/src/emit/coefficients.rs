//! The generated `Coeffs` struct and `coeffs(θ)`: every interned
//! θ-dependent coefficient ([`qpv_codegen::build::coeffs`]) computed once
//! per evaluation.

use super::tokens::{destructure, destructure_names, expr, lets, uses};
use proc_macro2::{Ident, TokenStream};
use qpv_codegen::build::coeffs::Coeffs;
use quote::{format_ident, quote};

/// The generated `struct Coeffs` (one `f64` field per interned polynomial)
/// and `fn coeffs(θ) -> Coeffs`, for a model with `nth` parameters and
/// `nphi` derived variables (`t<nth + j>` in the coefficients).
pub(super) fn items(coeffs: &Coeffs, nth: usize, nphi: usize, libm: &TokenStream) -> TokenStream {
    let b = coeffs.body();
    let kfields: Vec<Ident> = (0..b.out.len()).map(|i| format_ident!("k{}", i)).collect();
    let kvalues: Vec<TokenStream> = b.out.iter().map(|e| expr(e, libm)).collect();
    let mono_lets = lets(&b.lets, libm);
    let body = quote! { #mono_lets Coeffs { #(#kfields: #kvalues),* } };
    let theta = format_ident!("theta");
    let mut bind = destructure(&theta, "t", nth, &body);
    // the derived scheduling variables φ_j are the variables t<nth + j>
    let phis: Vec<String> = (nth..nth + nphi).map(|i| format!("t{i}")).collect();
    if phis.iter().any(|n| uses(&body, n)) {
        let values = format_ident!("phi_values");
        let phi_bind = destructure_names(&values, &phis, &body);
        bind.extend(quote!(let phi_values = &phi(theta); #phi_bind));
    }
    quote! {
        /// θ-dependent coefficients of the equations, each computed once.
        #[derive(Clone, Copy)]
        struct Coeffs {
            #(#kfields: f64,)*
        }

        #[inline(always)]
        fn coeffs(theta: &[f64; NTHETA]) -> Coeffs {
            #bind
            #body
        }
    }
}
