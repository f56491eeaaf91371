//! The `qpv!` macro: a QPV model written inline (or `include "file.qpv"`)
//! is parsed, solved and independently certified at build time, and expands
//! to a module of specialised, unrolled, `no_std` observer code.
//!
//! Pipeline: `input` (tokens → text + span table) → `qpv_dsl::parse` →
//! polytopic model → `qpv_solve::design`, or a `cache` hit (the design's
//! JSON report) → `qpv_solve::export::Baked` (the numbers to bake,
//! certified on exactly those values, with their figures; a hit re-checked
//! by `Design::recheck`) → `emit`. A design that is not certified is
//! explained by `qpv_solve::export::explain`. Any error becomes one
//! `compile_error!` on the offending token (`fallback`). (These are the
//! crate's private modules.)
//!
//! See the `qpv` crate's documentation of `qpv!` for the generated API.

mod cache;
mod emit;
mod expand;
mod fallback;
mod input;
mod slow_solve;

use proc_macro::TokenStream;

/// Builds a certified observer at compile time from a QPV model: the
/// `qpv::qpv!` macro, whose documentation (the generated API, output
/// routes, errors, build time) is in the `qpv` crate.
///
/// Use it directly only in a crate that cannot depend on the `qpv` facade
/// (a `#![no_std]` firmware crate): the code generated for a model with
/// scheduling functions then calls `::libm`, so such a crate depends on
/// `libm` too. Through `qpv::qpv!` the facade supplies its own copy.
#[proc_macro]
pub fn qpv(input: TokenStream) -> TokenStream {
    expand::expand(input.into(), quote::quote!(::libm)).into()
}

/// `qpv!` with the path of the `libm` crate in parentheses first, as the
/// `qpv` facade's `qpv!` calls it: `qpv_with_libm!((path::to::libm) model
/// ...)`. Not for direct use.
#[doc(hidden)]
#[proc_macro]
pub fn qpv_with_libm(input: TokenStream) -> TokenStream {
    let input: proc_macro2::TokenStream = input.into();
    let mut trees = input.into_iter();
    match trees.next() {
        Some(proc_macro2::TokenTree::Group(g))
            if g.delimiter() == proc_macro2::Delimiter::Parenthesis =>
        {
            expand::expand(trees.collect(), g.stream()).into()
        }
        _ => fallback::emit(
            &fallback::Failure::at(
                proc_macro2::Span::call_site(),
                "qpv_with_libm! expects the path of `libm` in parentheses first; \
                 use `qpv::qpv!` instead",
            ),
            proc_macro2::TokenStream::new(),
        )
        .into(),
    }
}
