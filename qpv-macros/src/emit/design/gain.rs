//! The gain schedule of a certified design: `gain(θ)` = Σ_l μ_l(θ) L_l,
//! unrolled entry by entry with the baked vertex gains as constants.

use super::{gain_entry, Shape};
use crate::emit::tokens::{destructure, Sum};
use crate::emit::CertifiedDesign;
use proc_macro2::TokenStream;
use quote::{format_ident, quote};

/// The generated `gain` (θ clamped first) and `gains` (from given weights μ).
pub(super) fn items(d: &CertifiedDesign, shape: Shape) -> TokenStream {
    let Shape { ny, nv, nz, .. } = shape;
    // gain entries g_ko(μ) = Σ_l μ_l L_l[k][o], k over the design's nz states
    let g_rows: Vec<TokenStream> = (0..nz)
        .map(|k| {
            let row = (0..ny).map(|o| {
                let mut s = Sum::default();
                if nv == 1 {
                    s.push(gain_entry(d, ny, 0, k, o), None);
                } else {
                    for l in 0..nv {
                        let ml = format_ident!("m{}", l);
                        s.push(gain_entry(d, ny, l, k, o), Some(quote!(#ml)));
                    }
                }
                s.render()
            });
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
