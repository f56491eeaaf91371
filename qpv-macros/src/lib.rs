//! qpv macros.
use proc_macro::TokenStream;
/// placeholder
#[proc_macro]
pub fn qpv(_i: TokenStream) -> TokenStream { TokenStream::new() }
