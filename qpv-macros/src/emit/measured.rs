//! Parameters computed from a measured output (`param p = y1`): the
//! generated `NTHETA_IN` (the parameters the observer's steppers take) and
//! `theta_of(y, θ_in)`, the full θ from the measurement as given and the
//! caller's parameters; [`Theta`] is what the steppers' signatures and
//! schedules become.

use proc_macro2::TokenStream;
use qpv_codegen::measured::{any, given, sources};
use qpv_dsl::Model;
use quote::{format_ident, quote};

/// `NTHETA_IN` and `theta_of` for a model with parameters computed from an
/// output (nothing otherwise).
pub(super) fn items(m: &Model) -> TokenStream {
    if !any(m) {
        return quote!();
    }
    let n_in = super::tokens::usize_lit(given(m));
    let srcs = sources(m);
    let y_pats = (0..m.ny()).map(|k| {
        if srcs.contains(&Ok(k)) {
            let id = format_ident!("y{}", k);
            quote!(#id)
        } else {
            quote!(_)
        }
    });
    let t_pats = (0..given(m)).map(|j| {
        let id = format_ident!("t{}", j);
        quote!(#id)
    });
    let full = srcs.iter().map(|s| match s {
        Ok(k) => {
            let id = format_ident!("y{}", k);
            quote!(#id)
        }
        Err(j) => {
            let id = format_ident!("t{}", j);
            quote!(#id)
        }
    });
    let names: Vec<String> = m
        .params
        .iter()
        .filter_map(|p| {
            p.measured
                .as_ref()
                .map(|meas| format!("`{}` = {}", p.name, meas.output_name))
        })
        .collect();
    let doc = format!(
        "The full θ (NTHETA entries) of an observer step: the parameters computed from the \
         measurement y as given ({}) and the caller's `theta` (the others, in declaration order).",
        names.join(", ")
    );
    quote! {
        /// Number of parameters the observer's steppers take: the declared
        /// ones that are not computed from the measurement.
        pub const NTHETA_IN: usize = #n_in;

        #[doc = #doc]
        #[inline]
        pub fn theta_of(y: &[f64; NY], theta: &[f64; NTHETA_IN]) -> [f64; NTHETA] {
            let [#(#y_pats),*] = *y;
            let [#(#t_pats),*] = *theta;
            [#(#full),*]
        }
    }
}

/// The θ the steppers take and the schedule they compute from it.
pub(crate) struct Theta {
    /// The type of the steppers' `theta`: `[f64; NTHETA]`, or
    /// `[f64; super::NTHETA_IN]` for a model with measured parameters.
    pub ty: TokenStream,
    /// The argument of `schedule`: `theta`, or `&super::theta_of(y, theta)`.
    pub arg: TokenStream,
}

impl Theta {
    /// The steppers' θ for model `m`.
    pub(crate) fn of(m: &Model) -> Self {
        if any(m) {
            Theta {
                ty: quote!([f64; super::NTHETA_IN]),
                arg: quote!(&super::theta_of(y, theta)),
            }
        } else {
            Theta {
                ty: quote!([f64; NTHETA]),
                arg: quote!(theta),
            }
        }
    }
}
