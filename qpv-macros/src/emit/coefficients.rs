//! θ-dependent coefficients: every distinct non-constant θ-polynomial of
//! the equations becomes one field of the generated `Coeffs` struct, and
//! the generated `coeffs(θ)` computes each of them (and each product of
//! parameters they use) once per evaluation.

use super::tokens::{destructure, uses, Sum};
use proc_macro2::{Ident, TokenStream};
use qpv_dsl::ThetaPoly;
use quote::{format_ident, quote};

/// Interned θ-dependent coefficients: each distinct non-constant polynomial
/// becomes one field `k<i>` of the generated `Coeffs` struct.
#[derive(Default)]
pub(super) struct Coeffs {
    pub(super) polys: Vec<ThetaPoly>,
}

/// How a θ-polynomial coefficient appears in an expression.
enum Coef {
    /// A number.
    Const(f64),
    /// The field `k<i>` of `Coeffs`.
    Field(Ident),
}

impl Coeffs {
    fn intern(&mut self, p: &ThetaPoly) -> Coef {
        if let Some(c) = p.as_constant() {
            return Coef::Const(c);
        }
        let i = match self.polys.iter().position(|q| q == p) {
            Some(i) => i,
            None => {
                self.polys.push(p.clone());
                self.polys.len() - 1
            }
        };
        Coef::Field(format_ident!("k{}", i))
    }

    /// Adds `sign × p(θ) × factor` to a sum: a number for a constant `p`,
    /// else the field `c.k<i>` of the interned polynomial.
    pub(super) fn push_term(
        &mut self,
        sum: &mut Sum,
        p: &ThetaPoly,
        factor: TokenStream,
        sign: f64,
    ) {
        match self.intern(p) {
            Coef::Const(c) => sum.push(sign * c, Some(factor)),
            Coef::Field(k) => sum.push(sign, Some(quote!(c.#k * #factor))),
        }
    }

    /// The masks (≥ 2 parameters) of θ monomials the coefficients use.
    fn products(&self) -> Vec<u64> {
        let mut v: Vec<u64> = self
            .polys
            .iter()
            .flat_map(|p| p.terms.iter().map(|t| t.0))
            .filter(|m| m.count_ones() >= 2)
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// The generated `struct Coeffs` (one `f64` field per interned
    /// polynomial) and `fn coeffs(θ) -> Coeffs`, for a model with `nth`
    /// parameters.
    pub(super) fn items(&self, nth: usize, nphi: usize) -> TokenStream {
        let kfields: Vec<Ident> = (0..self.polys.len())
            .map(|i| format_ident!("k{}", i))
            .collect();
        let kvalues: Vec<TokenStream> = self.polys.iter().map(poly_expr).collect();
        let mono_lets: TokenStream = self.products().into_iter().map(product_let).collect();
        let body = quote! { #mono_lets Coeffs { #(#kfields: #kvalues),* } };
        let theta = format_ident!("theta");
        let mut bind = destructure(&theta, "t", nth, &body);
        // the derived scheduling variables φ_j are the variables t<nth + j>
        let phis: Vec<String> = (nth..nth + nphi).map(|i| format!("t{i}")).collect();
        if phis.iter().any(|n| uses(&body, n)) {
            let values = format_ident!("phi_values");
            let phi_bind = super::tokens::destructure_names(&values, &phis, &body);
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
}

/// Names of θ monomials (`t0`, `t0_1`, ...) for a term mask.
fn theta_mono(mask: u64) -> Ident {
    let idx: Vec<String> = (0..64usize)
        .filter(|i| mask >> i & 1 == 1)
        .map(|i| i.to_string())
        .collect();
    format_ident!("t{}", idx.join("_"))
}

/// A θ-polynomial as a sum of its monomials.
fn poly_expr(p: &ThetaPoly) -> TokenStream {
    let mut s = Sum::default();
    for &(mask, c) in &p.terms {
        if mask == 0 {
            s.push(c, None);
        } else {
            let t = theta_mono(mask);
            s.push(c, Some(quote!(#t)));
        }
    }
    s.render()
}

/// `let t0_1 = t0 * t1;` for a product of parameters.
fn product_let(mask: u64) -> TokenStream {
    let name = theta_mono(mask);
    let factors: Vec<Ident> = (0..64usize)
        .filter(|i| mask >> i & 1 == 1)
        .map(|i| format_ident!("t{}", i))
        .collect();
    let mut product = TokenStream::new();
    for (i, f) in factors.iter().enumerate() {
        if i > 0 {
            product.extend(quote!(*));
        }
        product.extend(quote!(#f));
    }
    quote!(let #name = #product;)
}
