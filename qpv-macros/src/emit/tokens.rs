//! Small token builders shared by every part of the emitter: float and
//! size literals, constant-folded sums, matrix constants, and array
//! destructuring that binds only the names a body uses.

use proc_macro2::{Ident, Literal, Span, TokenStream};
use qpv_codegen::ir::{Body, Expr, Let, Op, Ty};
use quote::{format_ident, quote};

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

/// An expression of the shared IR ([`qpv_codegen::ir`]) as Rust tokens;
/// `libm` is the path of the math functions of scheduling functions.
pub(super) fn expr(e: &Expr, libm: &TokenStream) -> TokenStream {
    match e {
        Expr::Num(v) => lit(*v),
        Expr::Int(n) => {
            let n = usize_lit(*n);
            quote!(#n)
        }
        Expr::Var(name) => {
            let id = Ident::new(name, Span::call_site());
            quote!(#id)
        }
        Expr::Coef(i) => {
            let k = format_ident!("k{}", i);
            quote!(c.#k)
        }
        Expr::Neg(a) => {
            let a = expr(a, libm);
            quote!(-#a)
        }
        Expr::Paren(a) => {
            let a = expr(a, libm);
            quote!((#a))
        }
        Expr::Product(fs) => {
            let mut out = TokenStream::new();
            for (i, f) in fs.iter().enumerate() {
                if i > 0 {
                    out.extend(quote!(*));
                }
                out.extend(expr(f, libm));
            }
            out
        }
        Expr::Bin(op, a, b) => {
            let (a, b) = (expr(a, libm), expr(b, libm));
            match op {
                Op::Add => quote!(#a + #b),
                Op::Sub => quote!(#a - #b),
                Op::Mul => quote!(#a * #b),
                Op::Div => quote!(#a / #b),
            }
        }
        Expr::Sum(terms) => sum(terms, libm),
        Expr::Call(f, a) => {
            let a = expr(a, libm);
            let name = format_ident!("{}", qpv_codegen::ir::math_name(*f));
            quote!(#libm::#name(#a))
        }
        Expr::PowI(a, n) => {
            let a = expr(a, libm);
            let mut acc = quote!(1.0);
            for _ in 0..*n {
                acc = quote!((#acc * b));
            }
            quote!({ let b: f64 = #a; #acc })
        }
        Expr::Clamp(a, lo, hi) => {
            let (a, lo, hi) = (expr(a, libm), expr(lo, libm), expr(hi, libm));
            quote!(if #a >= #lo { if #a <= #hi { #a } else { #hi } } else { #lo })
        }
        Expr::Ge(a, b) => {
            let (a, b) = (expr(a, libm), expr(b, libm));
            quote!(usize::from(#a >= #b))
        }
        Expr::Select(on, arms) => {
            let on = Ident::new(on, Span::call_site());
            let last = arms.len().saturating_sub(1);
            if last == 0 {
                return arms.first().map_or(quote!(0.0), |a| expr(a, libm));
            }
            let arms = arms.iter().enumerate().map(|(i, a)| {
                let a = expr(a, libm);
                if i == last {
                    quote!(_ => #a,)
                } else {
                    let i = usize_lit(i);
                    quote!(#i => #a,)
                }
            });
            quote!(match #on { #(#arms)* })
        }
    }
}

/// A folded sum: zero terms are never stored, `1 ×` and `-1 ×` fold into
/// the sign; `0.0` when empty.
fn sum(terms: &[(f64, Option<Expr>)], libm: &TokenStream) -> TokenStream {
    if terms.is_empty() {
        return quote!(0.0);
    }
    let mut out = TokenStream::new();
    for (i, (c, f)) in terms.iter().enumerate() {
        let neg = *c < 0.0;
        let a = c.abs();
        let al = Literal::f64_unsuffixed(a);
        let body = match f {
            None => quote!(#al),
            Some(f) if a == 1.0 => expr(f, libm),
            Some(f) => {
                let f = expr(f, libm);
                quote!(#al * #f)
            }
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

/// The lets of a body: `let name = value;` (`let name: usize = ...;` for an index).
pub(super) fn lets(lets: &[Let], libm: &TokenStream) -> TokenStream {
    lets.iter()
        .map(|l| {
            let name = Ident::new(&l.name, Span::call_site());
            let v = expr(&l.value, libm);
            match l.ty {
                Ty::Real => quote!(let #name = #v;),
                Ty::Index => quote!(let #name: usize = #v;),
            }
        })
        .collect()
}

/// A body as a block's statements and an array of its outputs:
/// `let ...; [a, b, ...]`.
pub(super) fn body_array(b: &Body, libm: &TokenStream) -> TokenStream {
    let l = lets(&b.lets, libm);
    let out = b.out.iter().map(|e| expr(e, libm));
    quote!(#l [#(#out),*])
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

/// The model-level helpers an f32 design module defines itself: a
/// `super::` before them is dropped by [`to_f32`].
const LOCAL: [&str; 5] = [
    "clamp_theta",
    "mu_clamped",
    "coeffs",
    "theta_of",
    "NTHETA_IN",
];
/// The libm functions of scheduling functions; `libm::sin(..)` becomes `libm::sinf(..)`.
const MATH: [&str; 9] = [
    "sqrt", "exp", "log", "sin", "cos", "tan", "tanh", "atan", "fabs",
];

/// The same code in single precision: the type `f64` becomes `f32`, every
/// float literal is rounded to the nearest f32 (printed in the shortest
/// form that parses back to it), a libm call gets its f32 name (`sinf`),
/// and `super::clamp_theta`/`mu_clamped`/`coeffs`/`theta_of`/`NTHETA_IN`
/// refer to the f32 copies in the same module. Integer and string literals are untouched.
pub(super) fn to_f32(ts: TokenStream, local: bool) -> TokenStream {
    use proc_macro2::{Group, TokenTree as T};
    let tts: Vec<T> = ts.into_iter().collect();
    let mut out: Vec<T> = Vec::with_capacity(tts.len());
    let is_colon = |t: Option<&T>| matches!(t, Some(T::Punct(p)) if p.as_char() == ':');
    let mut i = 0;
    while i < tts.len() {
        match &tts[i] {
            T::Ident(id) if id == "f64" => out.push(T::Ident(Ident::new("f32", id.span()))),
            T::Ident(id)
                if local
                    && id == "super"
                    && is_colon(tts.get(i + 1))
                    && is_colon(tts.get(i + 2))
                    && matches!(tts.get(i + 3), Some(T::Ident(n)) if LOCAL.iter().any(|l| n == l)) =>
            {
                i += 3;
                continue;
            }
            T::Ident(id)
                if MATH.iter().any(|m| id == m)
                    && i > 0
                    && is_colon(tts.get(i - 1))
                    && matches!(tts.get(i + 1), Some(T::Group(g)) if g.delimiter() == proc_macro2::Delimiter::Parenthesis) =>
            {
                out.push(T::Ident(Ident::new(&format!("{id}f"), id.span())));
            }
            T::Literal(l) => {
                let s = l.to_string();
                let float = s.starts_with(|c: char| c.is_ascii_digit())
                    && !s.starts_with("0x")
                    && (s.contains('.') || s.contains('e') || s.contains('E'));
                match s.parse::<f64>() {
                    Ok(v) if float && (v as f32).is_finite() => {
                        out.push(T::Literal(Literal::f32_unsuffixed(v as f32)))
                    }
                    Ok(_) if float => {
                        out.extend(quote!(::core::f32::MAX));
                    }
                    _ => out.push(T::Literal(l.clone())),
                }
            }
            T::Group(g) => {
                let mut ng = Group::new(g.delimiter(), to_f32(g.stream(), local));
                ng.set_span(g.span());
                out.push(T::Group(ng));
            }
            other => out.push(other.clone()),
        }
        i += 1;
    }
    out.into_iter().collect()
}
