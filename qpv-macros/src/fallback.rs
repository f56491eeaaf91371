//! What the macro emits when expansion fails: exactly one `compile_error!`
//! on the offending token, plus a harmless stub so that the user sees that
//! one error and not a cascade of "cannot find `Observer`" after it.
//!
//! When the model itself is valid (the design failed), the stub is the real
//! module API with zero data ([`crate::emit`] on a zero design): every name
//! and type the user's code refers to exists, and the build still fails
//! because of the `compile_error!`, so the zeros can never run.

use proc_macro2::Ident;
use proc_macro2::{Span, TokenStream};
use quote::quote;

/// One user-facing error: a message and the first/last token it covers.
#[derive(Debug, Clone)]
pub struct Failure {
    /// First token of the offending text.
    pub first: Span,
    /// Last token of the offending text (same as `first` for one token).
    pub last: Span,
    /// What is wrong and what is expected instead.
    pub message: String,
}

impl Failure {
    /// A failure on a single token.
    pub fn at(span: Span, message: impl Into<String>) -> Self {
        Failure {
            first: span,
            last: span,
            message: message.into(),
        }
    }

    /// `::core::compile_error!{"..."}` spanning `first..last`, so rustc
    /// underlines exactly the offending tokens (syn's start/end-span trick).
    pub fn to_compile_error(&self) -> TokenStream {
        let a = Ident::new("first", self.first);
        let b = Ident::new("last", self.last);
        syn::Error::new_spanned(quote!(#a #b), &self.message).to_compile_error()
    }
}

/// The compile error followed by the stub (which may be empty).
pub fn emit(failure: &Failure, stub: TokenStream) -> TokenStream {
    let mut out = failure.to_compile_error();
    out.extend(stub);
    out
}
