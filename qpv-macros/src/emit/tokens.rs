//! Small token builders shared by every part of the emitter: float and
//! size literals, constant-folded sums, matrix constants, and array
//! destructuring that binds only the names a body uses.

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

/// A float literal; negative values become `-` followed by the magnitude.
/// Callers guarantee finiteness (checked before emission).
pub(super) fn lit(v: f64) -> TokenStream {
    let a = Literal::f64_unsuffixed(v.abs());
    if v.is_sign_negative() {
        quote!(-#a)
    } else {
        quote!(#a)
    }
}

/// A `usize` literal without suffix.
pub(super) fn usize_lit(n: usize) -> Literal {
    Literal::usize_unsuffixed(n)
}

/// Formats a number for documentation text.
pub(super) fn num(v: f64) -> String {
    format!("{v}")
}

/// A signed sum of `coefficient × factor` terms, rendered constant-folded:
/// zero terms dropped, `1 ×` and `-1 ×` folded into the sign.
#[derive(Default)]
pub(super) struct Sum {
    terms: Vec<(f64, Option<TokenStream>)>,
}

impl Sum {
    /// Adds `c × factor` (`c` alone without a factor); zero terms are dropped.
    pub(super) fn push(&mut self, c: f64, factor: Option<TokenStream>) {
        if c != 0.0 {
            self.terms.push((c, factor));
        }
    }

    /// The sum as an expression (`0.0` when empty).
    pub(super) fn render(&self) -> TokenStream {
        if self.terms.is_empty() {
            return quote!(0.0);
        }
        let mut out = TokenStream::new();
        for (i, (c, f)) in self.terms.iter().enumerate() {
            let neg = *c < 0.0;
            let a = c.abs();
            let al = Literal::f64_unsuffixed(a);
            let body = match f {
                None => quote!(#al),
                Some(f) if a == 1.0 => f.clone(),
                Some(f) => quote!(#al * #f),
            };
            out.extend(match (i, neg) {
                (0, false) => body,
                (0, true) => quote!(-#body),
                (_, false) => quote!(+ #body),
                (_, true) => quote!(- #body),
            });
        }
        out
    }
}

/// A `[[f64; C]; R]` constant from a row-major slice.
pub(super) fn matrix_lit(rows: usize, cols: usize, data: &[f64]) -> TokenStream {
    let rs = (0..rows).map(|i| {
        let es = (0..cols).map(|j| lit(data.get(i * cols + j).copied().unwrap_or(0.0)));
        quote!([#(#es),*])
    });
    quote!([#(#rs),*])
}

/// True if the identifier `name` occurs anywhere in `ts`.
pub(super) fn uses(ts: &TokenStream, name: &str) -> bool {
    ts.clone().into_iter().any(|tt| match tt {
        proc_macro2::TokenTree::Ident(i) => i == name,
        proc_macro2::TokenTree::Group(g) => uses(&g.stream(), name),
        _ => false,
    })
}

/// `let [a, _, c] = *arr;` binding only the names `body` uses.
pub(super) fn destructure(arr: &Ident, prefix: &str, n: usize, body: &TokenStream) -> TokenStream {
    let names: Vec<String> = (0..n).map(|i| format!("{prefix}{i}")).collect();
    destructure_names(arr, &names, body)
}

/// Binds the names of `names` that `body` uses, `_` for the others:
/// `let [x0, _, zh0] = *arr;`.
pub(super) fn destructure_names(arr: &Ident, names: &[String], body: &TokenStream) -> TokenStream {
    let pats = names.iter().map(|name| {
        if uses(body, name) {
            let id = Ident::new(name, Span::call_site());
            quote!(#id)
        } else {
            quote!(_)
        }
    });
    quote!(let [#(#pats),*] = *#arr;)
}
