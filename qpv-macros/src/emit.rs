//! Code generation: one module per model with the certified constants, the
//! scheduling weights μ(θ), the gain L(θ), an unrolled `Observer` and the
//! plant equations.
//!
//! The emitter is fed by [`EmitModel`] (the symbolic model plus certified
//! numbers) and knows nothing of the solver. Generated code is fully
//! unrolled and constant-folded: zero coefficients are dropped, factors ±1
//! disappear, θ-dependent coefficients, θ monomials, μ products and state
//! products x̂_i x̂_j are each computed once. It uses `::core` paths only,
//! never allocates, never indexes (arrays are destructured) and cannot panic.

use proc_macro2::{Ident, Literal, Span, TokenStream};
use qpv_dsl::{Model, OutputFilter, PolyMatrix, ThetaPoly};
use quote::{format_ident, quote};
use std::collections::BTreeMap;

/// Everything the emitter needs for one model.
pub struct EmitModel<'a> {
    /// The validated symbolic model (plant equations, names, bounds).
    pub model: &'a Model,
    /// Indices into `model.params` of the parameters that generate vertices,
    /// first most significant (the vertex order of `PolytopicModel`).
    pub scheduling: Vec<usize>,
    /// The designs, in source order; at least one has `certifies` (the
    /// caller checks), and the first such is re-exported at the model level.
    pub designs: Vec<CertifiedDesign>,
}

/// The numbers of one certified design.
#[derive(Debug, Clone, PartialEq)]
pub struct CertifiedDesign {
    /// The request as the user wrote it, in words (`alpha = 10, gamma = 0.18, mode = sound`).
    pub request: String,
    /// `"sound"` or `"paper"`.
    pub mode: String,
    /// True for a certified sound-mode design: an `Observer` is generated.
    /// False for a paper-mode reproduction: only its record is generated
    /// (the printed conditions hold, but they certify nothing), no gain.
    pub certifies: bool,
    /// Certified decay rate α.
    pub alpha: f64,
    /// Certified region scaling γ.
    pub gamma: f64,
    /// The Lyapunov matrix P, nz × nz row-major (nz = nx, or nx + ny for a filter design).
    pub p: Vec<f64>,
    /// The vertex gains L_l, each nz × ny row-major, one per vertex.
    pub l: Vec<Vec<f64>>,
    /// Worst margin per condition family (positive = satisfied).
    pub margins: Vec<(String, f64)>,
    /// The solver's final status.
    pub status: String,
    /// Solver iterations of the accepted solve.
    pub iterations: u32,
    /// The output post-filter of a filter-route design (`output_route =
    /// filter`): then P is (nx+ny)² and each L_l is (nx+ny) × ny, the
    /// design being for the plant augmented by the filter. `None`: the
    /// double-sum route, P is nx × nx, L_l is nx × ny.
    pub filter: Option<OutputFilter>,
}

/// A float literal; negative values become `-` followed by the magnitude.
/// Callers guarantee finiteness (checked before emission).
fn lit(v: f64) -> TokenStream {
    let a = Literal::f64_unsuffixed(v.abs());
    if v.is_sign_negative() {
        quote!(-#a)
    } else {
        quote!(#a)
    }
}

/// A signed sum of `coefficient × factor` terms, rendered constant-folded:
/// zero terms dropped, `1 ×` and `-1 ×` folded into the sign.
#[derive(Default)]
struct Sum {
    terms: Vec<(f64, Option<TokenStream>)>,
}

impl Sum {
    fn push(&mut self, c: f64, factor: Option<TokenStream>) {
        if c != 0.0 {
            self.terms.push((c, factor));
        }
    }

    fn render(&self) -> TokenStream {
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

/// A monomial of the state and input: the key under which θ-coefficients
/// of one equation are collected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Mono {
    /// x_j
    X(usize),
    /// x_i x_j with i ≤ j
    XX(usize, usize),
    /// u_j
    U(usize),
}

/// The right-hand side of one polynomial equation: monomial → θ-polynomial.
type Equation = BTreeMap<Mono, ThetaPoly>;

fn add_poly(eq: &mut Equation, key: Mono, p: &ThetaPoly) {
    if p.is_zero() {
        return;
    }
    let e = eq.entry(key).or_default();
    for &(mask, c) in &p.terms {
        e.add_term(mask, c);
    }
    if e.is_zero() {
        eq.remove(&key);
    }
}

/// Row k of `lin · x + Σ_ij quad_k[i][j] x_i x_j + inp · u`.
fn equation(
    lin: &PolyMatrix,
    quad: Option<&PolyMatrix>,
    inp: Option<&PolyMatrix>,
    k: usize,
) -> Equation {
    let mut eq = Equation::new();
    for j in 0..lin.cols {
        if let Some(p) = lin.entries.get(k * lin.cols + j) {
            add_poly(&mut eq, Mono::X(j), p);
        }
    }
    if let Some(q) = quad {
        for i in 0..q.rows {
            for j in 0..q.cols {
                if let Some(p) = q.entries.get(i * q.cols + j) {
                    add_poly(&mut eq, Mono::XX(i.min(j), i.max(j)), p);
                }
            }
        }
    }
    if let Some(b) = inp {
        for j in 0..b.cols {
            if let Some(p) = b.entries.get(k * b.cols + j) {
                add_poly(&mut eq, Mono::U(j), p);
            }
        }
    }
    eq
}

/// The plant's state equations (one per state) and output equations (one per output).
fn equations(m: &Model) -> (Vec<Equation>, Vec<Equation>) {
    let nx = m.nx();
    let ny = m.ny();
    let states = (0..nx)
        .map(|k| {
            let b = (m.nu() > 0).then_some(&m.b);
            equation(&m.a, m.n.get(k), b, k)
        })
        .collect();
    let outputs = (0..ny)
        .map(|o| equation(&m.c, m.m.get(o), None, o))
        .collect();
    (states, outputs)
}

/// Names of θ monomials (`t0`, `t0_1`, ...) for a term mask.
fn theta_mono(mask: u64) -> Ident {
    let idx: Vec<String> = (0..64usize)
        .filter(|i| mask >> i & 1 == 1)
        .map(|i| i.to_string())
        .collect();
    format_ident!("t{}", idx.join("_"))
}

/// Interned θ-dependent coefficients: each distinct non-constant polynomial
/// becomes one field `k<i>` of the generated `Coeffs` struct.
#[derive(Default)]
struct Coeffs {
    polys: Vec<ThetaPoly>,
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
}

/// Adds `coef(θ) × factor` to a sum.
fn push_term(sum: &mut Sum, coef: Coef, factor: TokenStream, sign: f64) {
    match coef {
        Coef::Const(c) => sum.push(sign * c, Some(factor)),
        Coef::Field(k) => sum.push(sign, Some(quote!(c.#k * #factor))),
    }
}

/// The factor a monomial stands for in generated code.
fn mono_tokens(m: Mono) -> TokenStream {
    match m {
        Mono::X(j) => {
            let x = format_ident!("x{}", j);
            quote!(#x)
        }
        Mono::XX(i, j) => {
            let p = format_ident!("x{}x{}", i, j);
            quote!(#p)
        }
        Mono::U(j) => {
            let u = format_ident!("u{}", j);
            quote!(#u)
        }
    }
}

/// Renders one equation as a sum over its monomials.
fn render_equation(eq: &Equation, coeffs: &mut Coeffs, sum: &mut Sum, sign: f64) {
    for (&m, p) in eq {
        push_term(sum, coeffs.intern(p), mono_tokens(m), sign);
    }
}

/// `let x0x1 = x0 * x1;` for every product the equations use.
fn product_lets(eqs: &[&Equation]) -> TokenStream {
    let mut seen = std::collections::BTreeSet::new();
    for eq in eqs {
        for m in eq.keys() {
            if let Mono::XX(i, j) = *m {
                seen.insert((i, j));
            }
        }
    }
    seen.into_iter()
        .map(|(i, j)| {
            let p = format_ident!("x{}x{}", i, j);
            let a = format_ident!("x{}", i);
            let b = format_ident!("x{}", j);
            quote!(let #p = #a * #b;)
        })
        .collect()
}

/// True if the identifier `name` occurs anywhere in `ts`.
fn uses(ts: &TokenStream, name: &str) -> bool {
    ts.clone().into_iter().any(|tt| match tt {
        proc_macro2::TokenTree::Ident(i) => i == name,
        proc_macro2::TokenTree::Group(g) => uses(&g.stream(), name),
        _ => false,
    })
}

/// `let [a, _, c] = *arr;` binding only the names `body` uses.
fn destructure(arr: &Ident, prefix: &str, n: usize, body: &TokenStream) -> TokenStream {
    let pats = (0..n).map(|i| {
        let name = format!("{prefix}{i}");
        if uses(body, &name) {
            let id = Ident::new(&name, Span::call_site());
            quote!(#id)
        } else {
            quote!(_)
        }
    });
    quote!(let [#(#pats),*] = *#arr;)
}

/// A `[[f64; C]; R]` constant from a row-major slice.
fn matrix_lit(rows: usize, cols: usize, data: &[f64]) -> TokenStream {
    let rs = (0..rows).map(|i| {
        let es = (0..cols).map(|j| lit(data.get(i * cols + j).copied().unwrap_or(0.0)));
        quote!([#(#es),*])
    });
    quote!([#(#rs),*])
}

fn usize_lit(n: usize) -> Literal {
    Literal::usize_unsuffixed(n)
}

/// Formats a number for documentation text.
fn num(v: f64) -> String {
    format!("{v}")
}

/// Emits the module for one model.
pub fn emit(em: &EmitModel<'_>) -> TokenStream {
    let m = em.model;
    let name = Ident::new(&m.name, Span::call_site());
    let nx = m.nx();
    let ny = m.ny();
    let nu = m.nu();
    let nth = m.ntheta();
    let ns = em.scheduling.len();
    let nv = 1usize << ns;
    let (nx_l, ny_l, nu_l, nth_l, nv_l) = (
        usize_lit(nx),
        usize_lit(ny),
        usize_lit(nu),
        usize_lit(nth),
        usize_lit(nv),
    );
    let lo: Vec<TokenStream> = m.params.iter().map(|p| lit(p.lo)).collect();
    let hi: Vec<TokenStream> = m.params.iter().map(|p| lit(p.hi)).collect();

    let (state_eqs, out_eqs) = equations(m);
    let mut coeffs = Coeffs::default();

    // Plant: f(x, u, θ) and h(x, θ).
    let plant_f: Vec<TokenStream> = state_eqs
        .iter()
        .map(|eq| {
            let mut s = Sum::default();
            render_equation(eq, &mut coeffs, &mut s, 1.0);
            s.render()
        })
        .collect();
    let plant_h: Vec<TokenStream> = out_eqs
        .iter()
        .map(|eq| {
            let mut s = Sum::default();
            render_equation(eq, &mut coeffs, &mut s, 1.0);
            s.render()
        })
        .collect();
    let state_products = product_lets(&state_eqs.iter().collect::<Vec<_>>());
    let output_products = product_lets(&out_eqs.iter().collect::<Vec<_>>());

    let primary_index = em.designs.iter().position(|d| d.certifies).unwrap_or(0) + 1;
    let primary = format_ident!("design{}", primary_index);
    let primary_filter = match em.designs.get(primary_index - 1).and_then(|d| d.filter) {
        Some(_) => quote!(pub use self::#primary::{FILTER_GAIN, FILTER_POLE};),
        None => quote!(),
    };
    // Designs first: they intern the same coefficients as the plant, so the
    // `Coeffs` struct built below covers both.
    let designs: Vec<TokenStream> = em
        .designs
        .iter()
        .enumerate()
        .map(|(i, d)| emit_design(em, d, i + 1, &state_eqs, &out_eqs, &mut coeffs))
        .collect();

    // The Coeffs struct: one field per distinct θ-dependent coefficient.
    let kfields: Vec<Ident> = (0..coeffs.polys.len())
        .map(|i| format_ident!("k{}", i))
        .collect();
    let kvalues: Vec<TokenStream> = coeffs
        .polys
        .iter()
        .map(|p| {
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
        })
        .collect();
    let mono_lets: TokenStream = coeffs
        .products()
        .into_iter()
        .map(|mask| {
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
        })
        .collect();
    let coeffs_body = quote! { #mono_lets Coeffs { #(#kfields: #kvalues),* } };
    let theta_ident = format_ident!("theta");
    let coeffs_destructure = destructure(&theta_ident, "t", nth, &coeffs_body);

    // μ(θ) for a clamped θ: w_i = normalised position, v_i = 1 − w_i,
    // vertex products built as a prefix tree (first parameter most significant).
    let mut mu_lets = TokenStream::new();
    for (i, &pi) in em.scheduling.iter().enumerate() {
        let (plo, phi) = match m.params.get(pi) {
            Some(p) => (p.lo, p.hi),
            None => (0.0, 1.0),
        };
        let t = format_ident!("t{}", pi);
        let w = format_ident!("w{}", i);
        let v = format_ident!("v{}", i);
        let num_expr = if plo == 0.0 {
            quote!(#t)
        } else {
            let l = lit(plo);
            quote!((#t - (#l)))
        };
        let w_expr = if phi - plo == 1.0 {
            num_expr
        } else {
            let inv = lit(1.0 / (phi - plo));
            quote!(#num_expr * #inv)
        };
        mu_lets.extend(quote! { let #w = #w_expr; let #v = 1.0 - #w; });
    }
    let mut level: Vec<(String, TokenStream)> = vec![(String::new(), quote!(1.0))];
    for i in 0..ns {
        let w = format_ident!("w{}", i);
        let v = format_ident!("v{}", i);
        let mut next = Vec::with_capacity(level.len() * 2);
        for (bits, expr) in &level {
            for (bit, f) in [("0", &v), ("1", &w)] {
                let nb = format!("{bits}{bit}");
                let e = if i == 0 {
                    quote!(#f)
                } else {
                    quote!(#expr * #f)
                };
                if i > 0 && i + 1 < ns {
                    let id = format_ident!("p{}", nb);
                    mu_lets.extend(quote!(let #id = #e;));
                    next.push((nb, quote!(#id)));
                } else {
                    next.push((nb, e));
                }
            }
        }
        level = next;
    }
    let mu_exprs: Vec<TokenStream> = level.into_iter().map(|(_, e)| e).collect();
    let mu_body = quote! { #mu_lets [#(#mu_exprs),*] };
    let mu_destructure = destructure(&theta_ident, "t", nth, &mu_body);

    // clamp_theta: each component into [lo, hi]; NaN → lo.
    let clamp_items: Vec<TokenStream> = (0..nth)
        .map(|i| {
            let th = format_ident!("th{}", i);
            let (l, h) = (&lo[i], &hi[i]);
            quote! {
                if #th >= #l {
                    if #th <= #h { #th } else { clamped = true; #h }
                } else {
                    clamped = true;
                    #l
                }
            }
        })
        .collect();
    let th_names: Vec<Ident> = (0..nth).map(|i| format_ident!("th{}", i)).collect();
    let clamp_mut = if nth > 0 {
        quote!(let mut clamped = false;)
    } else {
        quote!(let clamped = false;)
    };

    // Plant functions.
    let x_ident = format_ident!("x");
    let u_ident = format_ident!("u");
    let plant_f_body = quote! { #state_products [#(#plant_f),*] };
    let plant_h_body = quote! { #output_products [#(#plant_h),*] };
    let pf_x = destructure(&x_ident, "x", nx, &plant_f_body);
    let pf_u = destructure(&u_ident, "u", nu, &plant_f_body);
    let ph_x = destructure(&x_ident, "x", nx, &plant_h_body);
    let pf_c = if uses(&plant_f_body, "c") {
        quote!(let c = super::coeffs(theta);)
    } else {
        quote!(let _ = theta;)
    };
    let ph_c = if uses(&plant_h_body, "c") {
        quote!(let c = super::coeffs(theta);)
    } else {
        quote!(let _ = theta;)
    };

    let state_list = m.states.join(", ");
    let output_list = m.outputs.join(", ");
    let input_list = if m.inputs.is_empty() {
        "none".to_string()
    } else {
        m.inputs.join(", ")
    };
    let param_list: Vec<String> = m
        .params
        .iter()
        .map(|p| format!("{} ∈ [{}, {}]", p.name, num(p.lo), num(p.hi)))
        .collect();
    let param_list = if param_list.is_empty() {
        "none".to_string()
    } else {
        param_list.join(", ")
    };
    let sched_list: Vec<&str> = em
        .scheduling
        .iter()
        .filter_map(|&i| m.params.get(i).map(|p| p.name.as_str()))
        .collect();
    let mod_doc: String = format!(
        " Generated by `qpv!` for model `{}`: states {state_list}; outputs {output_list}; \
         inputs {input_list}; parameters {param_list}.\n\n \
         The θ vector has one entry per declared parameter, in declaration order. \
         The gain is scheduled over {nv} vertices (the corners of the box of {}), first \
         parameter most significant, lo before hi.\n\n \
         Designs: {} (`design{primary_index}`, the first certified one, is re-exported here; \
         a paper-mode design only records that the paper's printed conditions hold — they \
         certify nothing, so it gets no gain and no observer).\n\n \
         θ outside its bounds: the observer, `mu` and `gain` clamp θ into Θ (a NaN \
         component is replaced by its lower bound) and `Observer` counts the steps \
         where that happened ([`Observer::clamped`]); the design is only certified inside Θ. \
         The `plant` functions evaluate the equations at θ as given. NaN in x, y or u \
         propagates into the result (never a panic).",
        m.name,
        if sched_list.is_empty() {
            "no parameter".to_string()
        } else {
            sched_list.join(", ")
        },
        em.designs
            .iter()
            .enumerate()
            .map(|(i, d)| format!("`design{}` ({}: {})", i + 1, d.mode, d.request))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut mod_doc = mod_doc;
    for w in &m.warnings {
        mod_doc.push_str("\n\n Note from the model compiler: ");
        mod_doc.push_str(&w.message);
    }

    quote! {
        #[doc = #mod_doc]
        #[allow(
            non_snake_case,
            clippy::approx_constant,
            clippy::excessive_precision,
            clippy::unreadable_literal,
            clippy::too_many_arguments,
            clippy::let_and_return,
            clippy::just_underscores_and_digits,
            clippy::neg_multiply,
            clippy::double_neg
        )]
        pub mod #name {
            /// Number of states.
            pub const NX: usize = #nx_l;
            /// Number of measured outputs.
            pub const NY: usize = #ny_l;
            /// Number of known inputs (0 for a model without inputs).
            pub const NU: usize = #nu_l;
            /// Number of declared parameters (length of θ).
            pub const NTHETA: usize = #nth_l;
            /// Number of vertices of the parameter box (gain-scheduling weights).
            pub const NV: usize = #nv_l;
            /// Lower bounds of θ, in declaration order.
            pub const THETA_MIN: [f64; NTHETA] = [#(#lo),*];
            /// Upper bounds of θ, in declaration order.
            pub const THETA_MAX: [f64; NTHETA] = [#(#hi),*];

            /// The worst margin of one family of design conditions (positive = satisfied).
            #[derive(Clone, Copy, Debug, PartialEq)]
            pub struct Margin {
                /// The condition family: `S1`, `S2`, `S3`, `S5` (sound) or `S1`, `13`, `14`, `26` (paper).
                pub family: &'static str,
                /// Its worst margin, recomputed independently of the solver.
                pub margin: f64,
            }

            /// The proof that travels with the code: what was requested, what was
            /// certified, and by how much every condition family holds.
            #[derive(Clone, Copy, Debug, PartialEq)]
            pub struct Certificate {
                /// The model's name.
                pub model: &'static str,
                /// The design request as written.
                pub request: &'static str,
                /// The condition set: `sound`, or `paper` (reproduction only).
                pub mode: &'static str,
                /// The output route: `double_sum` or `filter` (output post-filter).
                pub route: &'static str,
                /// True if the conditions prove V' ≤ −αV on the certified set
                /// (sound mode); false for a paper-mode reproduction.
                pub certifies: bool,
                /// Certified decay rate α of V = eᵀPe.
                pub alpha: f64,
                /// Certified region scaling γ.
                pub gamma: f64,
                /// Worst margin per condition family, all positive (recomputed by
                /// the macro from the baked P and L_l).
                pub margins: &'static [Margin],
                /// The solver's final status for the accepted solve.
                pub solver_status: &'static str,
                /// Interior-point iterations of the accepted solve.
                pub iterations: u32,
            }

            impl ::core::fmt::Display for Certificate {
                fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                    ::core::writeln!(
                        f,
                        "model {}: {} ({} mode) alpha = {}, gamma = {}",
                        self.model,
                        if self.certifies { "certified" } else { "reproduction, certifies nothing" },
                        self.mode,
                        self.alpha,
                        self.gamma
                    )?;
                    ::core::writeln!(f, "  request: {}", self.request)?;
                    ::core::writeln!(f, "  output route: {}", self.route)?;
                    for m in self.margins {
                        ::core::writeln!(f, "  {:<24} margin {:.3e}", m.family, m.margin)?;
                    }
                    ::core::write!(
                        f,
                        "  solver: {} after {} iterations",
                        self.solver_status, self.iterations
                    )
                }
            }

            /// θ clamped into Θ = [THETA_MIN, THETA_MAX] (a NaN component becomes its
            /// lower bound), and whether any component had to be changed.
            #[inline]
            pub fn clamp_theta(theta: &[f64; NTHETA]) -> ([f64; NTHETA], bool) {
                let [#(#th_names),*] = *theta;
                #clamp_mut
                let t = [#(#clamp_items),*];
                (t, clamped)
            }

            /// The scheduling weights μ_l(θ), l = 1..NV: non-negative, summing to 1
            /// (θ is clamped into Θ first).
            #[inline]
            pub fn mu(theta: &[f64; NTHETA]) -> [f64; NV] {
                mu_clamped(&clamp_theta(theta).0)
            }

            #[inline(always)]
            fn mu_clamped(theta: &[f64; NTHETA]) -> [f64; NV] {
                #mu_destructure
                #mu_body
            }

            /// θ-dependent coefficients of the equations, each computed once.
            #[derive(Clone, Copy)]
            struct Coeffs {
                #(#kfields: f64,)*
            }

            #[inline(always)]
            fn coeffs(theta: &[f64; NTHETA]) -> Coeffs {
                #coeffs_destructure
                #coeffs_body
            }

            pub use self::#primary::{gain, Observer, ALPHA, CERTIFICATE, CERTIFIES, GAMMA, L, NS, NZ, P, ROUTE};
            #primary_filter

            #(#designs)*

            /// The plant equations x' = A(θ)x + N(θ,x)x + B(θ)u, y = C(θ)x + M(θ,x)x,
            /// for simulation and tests (θ used as given, not clamped).
            pub mod plant {
                use super::{NTHETA, NU, NX, NY};

                /// x' = A(θ)x + N(θ,x)x + B(θ)u.
                #[inline]
                pub fn derivative(x: &[f64; NX], u: &[f64; NU], theta: &[f64; NTHETA]) -> [f64; NX] {
                    #pf_c
                    #pf_x
                    #pf_u
                    #plant_f_body
                }

                /// y = C(θ)x + M(θ,x)x.
                #[inline]
                pub fn output(x: &[f64; NX], theta: &[f64; NTHETA]) -> [f64; NY] {
                    #ph_c
                    #ph_x
                    #plant_h_body
                }
            }
        }
    }
}

/// Binds the names of `names` that `body` uses, `_` for the others:
/// `let [x0, _, zh0] = *arr;`.
fn destructure_names(arr: &Ident, names: &[String], body: &TokenStream) -> TokenStream {
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

/// Emits `pub mod design<i>` with the certified constants, `gain` and `Observer`.
fn emit_design(
    em: &EmitModel<'_>,
    d: &CertifiedDesign,
    index: usize,
    state_eqs: &[Equation],
    out_eqs: &[Equation],
    coeffs: &mut Coeffs,
) -> TokenStream {
    let m = em.model;
    let nx = m.nx();
    let ny = m.ny();
    let nu = m.nu();
    let nv = 1usize << em.scheduling.len();
    let modname = format_ident!("design{}", index);
    // The design's state: the plant's (double sum), or the plant's and one
    // filter state per output (filter route). The observer's state adds the
    // filtered measurement x_y for the filter route.
    let filter = d.filter;
    let nz = if filter.is_some() { nx + ny } else { nx };
    let ns = if filter.is_some() { nx + 2 * ny } else { nx };

    let alpha = lit(d.alpha);
    let gamma = lit(d.gamma);
    let p = matrix_lit(nz, nz, &d.p);
    let l_vertices: Vec<TokenStream> = (0..nv)
        .map(|l| match d.l.get(l) {
            Some(lv) => matrix_lit(nz, ny, lv),
            None => matrix_lit(nz, ny, &[]),
        })
        .collect();
    let fam: Vec<TokenStream> = d
        .margins
        .iter()
        .map(|(f, v)| {
            let v = lit(*v);
            quote!(super::Margin { family: #f, margin: #v })
        })
        .collect();
    let (model_name, request, mode, status) = (&m.name, &d.request, &d.mode, &d.status);
    let route = if filter.is_some() {
        "filter"
    } else {
        "double_sum"
    };
    let iterations = Literal::u32_unsuffixed(d.iterations);
    let certifies = d.certifies;
    let certificate = quote! {
        /// The independent certificate of this design.
        pub const CERTIFICATE: Certificate = Certificate {
            model: #model_name,
            request: #request,
            mode: #mode,
            route: #route,
            certifies: #certifies,
            alpha: ALPHA,
            gamma: GAMMA,
            margins: &[#(#fam),*],
            solver_status: #status,
            iterations: #iterations,
        };
    };
    if !d.certifies {
        let doc = format!(
            " Design {index} of model `{model_name}` ({request}): a reproduction of the \
             paper's printed conditions, which hold at alpha = {}, gamma = {} but certify \
             nothing (spec §6). No gain and no observer are generated for it.",
            num(d.alpha),
            num(d.gamma)
        );
        return quote! {
            #[doc = #doc]
            pub mod #modname {
                use super::Certificate;
                /// False: this design proves nothing about convergence.
                pub const CERTIFIES: bool = false;
                /// The output route of the request (`"double_sum"` or `"filter"`).
                pub const ROUTE: &str = #route;
                /// α at which the printed conditions hold.
                pub const ALPHA: f64 = #alpha;
                /// γ at which the printed conditions hold.
                pub const GAMMA: f64 = #gamma;
                #certificate
            }
        };
    }

    // gain entries g_ko(μ) = Σ_l μ_l L_l[k][o], k over the design's nz states
    let lval = |l: usize, k: usize, o: usize| -> f64 {
        d.l.get(l)
            .and_then(|lv| lv.get(k * ny + o))
            .copied()
            .unwrap_or(0.0)
    };
    let mu_ident = format_ident!("mu");
    let g_exprs: Vec<Vec<TokenStream>> = (0..nz)
        .map(|k| {
            (0..ny)
                .map(|o| {
                    let mut s = Sum::default();
                    if nv == 1 {
                        s.push(lval(0, k, o), None);
                    } else {
                        for l in 0..nv {
                            let ml = format_ident!("m{}", l);
                            s.push(lval(l, k, o), Some(quote!(#ml)));
                        }
                    }
                    s.render()
                })
                .collect()
        })
        .collect();
    let g_rows: Vec<TokenStream> = g_exprs.iter().map(|r| quote!([#(#r),*])).collect();
    let gains_body = quote!([#(#g_rows),*]);
    let gains_mu = destructure(&mu_ident, "m", nv, &gains_body);

    // The observer state's names: x̂ (x<i>), then for the filter route the
    // filter estimate x̂_y (zh<k>) and the filtered measurement x_y (zm<k>).
    let mut state_names: Vec<String> = (0..nx).map(|i| format!("x{i}")).collect();
    if filter.is_some() {
        state_names.extend((0..ny).map(|k| format!("zh{k}")));
        state_names.extend((0..ny).map(|k| format!("zm{k}")));
    }

    // The residual the gain multiplies: y − C(θ)x̂ − M(θ,x̂)x̂ (double sum),
    // x_y − x̂_y (filter).
    let resid: Vec<TokenStream> = (0..ny)
        .map(|o| {
            let r = format_ident!("r{}", o);
            let mut s = Sum::default();
            match (filter, out_eqs.get(o)) {
                (Some(_), _) => {
                    let (zm, zh) = (format_ident!("zm{}", o), format_ident!("zh{}", o));
                    s.push(1.0, Some(quote!(#zm)));
                    s.push(-1.0, Some(quote!(#zh)));
                }
                (None, eq) => {
                    let y = format_ident!("y{}", o);
                    s.push(1.0, Some(quote!(#y)));
                    if let Some(eq) = eq {
                        render_equation(eq, coeffs, &mut s, -1.0);
                    }
                }
            }
            let e = s.render();
            quote!(let #r = #e;)
        })
        .collect();
    // Σ_o g_ko r_o added to row k of the design state.
    let inject = |s: &mut Sum, k: usize| {
        for o in 0..ny {
            let r = format_ident!("r{}", o);
            if (0..nv).all(|l| lval(l, k, o) == 0.0) {
                continue;
            }
            if nv == 1 {
                s.push(lval(0, k, o), Some(quote!(#r)));
            } else {
                let g = format_ident!("g{}_{}", k, o);
                s.push(1.0, Some(quote!(#g * #r)));
            }
        }
    };
    let mut rows: Vec<TokenStream> = state_eqs
        .iter()
        .enumerate()
        .map(|(k, eq)| {
            let mut s = Sum::default();
            render_equation(eq, coeffs, &mut s, 1.0);
            inject(&mut s, k);
            s.render()
        })
        .collect();
    if let Some(f) = filter {
        // x̂_y' = −a x̂_y + b (C(θ)x̂ + M(θ,x̂)x̂) + L_y(θ)(x_y − x̂_y)
        for (k, eq) in out_eqs.iter().enumerate() {
            let zh = format_ident!("zh{}", k);
            let mut s = Sum::default();
            s.push(-f.pole, Some(quote!(#zh)));
            render_equation(eq, coeffs, &mut s, f.gain);
            inject(&mut s, nx + k);
            rows.push(s.render());
        }
        // x_y' = −a x_y + b y: the observer filters the measurement itself.
        for k in 0..ny {
            let (zm, y) = (format_ident!("zm{}", k), format_ident!("y{}", k));
            let mut s = Sum::default();
            s.push(-f.pole, Some(quote!(#zm)));
            s.push(f.gain, Some(quote!(#y)));
            rows.push(s.render());
        }
    }
    let all: Vec<&Equation> = state_eqs.iter().chain(out_eqs.iter()).collect();
    let products = product_lets(&all);
    let rhs_body = quote! { #products #(#resid)* [#(#rows),*] };
    let s_ident = format_ident!("s");
    let y_ident = format_ident!("y");
    let u_ident = format_ident!("u");
    let g_ident = format_ident!("g");
    let rhs_s = destructure_names(&s_ident, &state_names, &rhs_body);
    let rhs_y = destructure(&y_ident, "y", ny, &rhs_body);
    let rhs_u = destructure(&u_ident, "u", nu, &rhs_body);
    let g_pats: Vec<TokenStream> = (0..nz)
        .map(|k| {
            let ps = (0..ny).map(|o| {
                let name = format!("g{k}_{o}");
                if nv > 1 && uses(&rhs_body, &name) {
                    let id = Ident::new(&name, Span::call_site());
                    quote!(#id)
                } else {
                    quote!(_)
                }
            });
            quote!([#(#ps),*])
        })
        .collect();
    let rhs_g = quote!(let [#(#g_pats),*] = *#g_ident;);
    let rhs_c = if uses(&rhs_body, "c") {
        quote!()
    } else {
        quote!(let _ = c;)
    };

    // RK4 and Euler combinations over the whole observer state, unrolled.
    let idx: Vec<usize> = (0..ns).collect();
    let xs: Vec<Ident> = idx.iter().map(|i| format_ident!("s{}", i)).collect();
    let k1: Vec<Ident> = idx.iter().map(|i| format_ident!("a{}", i)).collect();
    let k2: Vec<Ident> = idx.iter().map(|i| format_ident!("b{}", i)).collect();
    let k3: Vec<Ident> = idx.iter().map(|i| format_ident!("c{}", i)).collect();
    let k4: Vec<Ident> = idx.iter().map(|i| format_ident!("d{}", i)).collect();
    // estimate(): the first NX entries; with_state(x0): x0 then zeros.
    let est: Vec<&Ident> = xs.iter().take(nx).collect();
    let est_pat = if ns > nx {
        quote!(let [#(#est,)* ..] = self.state;)
    } else {
        quote!(let [#(#est),*] = self.state;)
    };
    let init_zeros: Vec<TokenStream> = (nx..ns).map(|_| quote!(0.0)).collect();
    let ns_l = usize_lit(ns);
    let nz_l = usize_lit(nz);

    let route_doc = match filter {
        None => " Output route of this design: `\"double_sum\"` (the output map enters the \
                  rate conditions directly; L(θ) = Σ_l μ_l(θ) L_l multiplies y − C(θ)x̂ − \
                  M(θ,x̂)x̂)."
            .to_string(),
        Some(f) => format!(
            " Output route of this design: `\"filter\"`, the output post-filter \
             x_y' = −{a} x_y + {b} y (per output; [`FILTER_POLE`] = {a}, [`FILTER_GAIN`] = {b}). \
             The design is for the augmented plant z = (x, x_y), [`NZ`] = NX + NY states, \
             measured output x_y: P is NZ × NZ, each L_l is NZ × NY (plant rows first).",
            a = num(f.pole),
            b = num(f.gain)
        ),
    };
    let doc = format!(
        " Design {index} of model `{model_name}`: {request}. Certified alpha = {}, gamma = {}.\n\n{route_doc}",
        num(d.alpha),
        num(d.gamma)
    );
    let obs_doc = match filter {
        None => " The certified observer of model `MODEL` (design INDEX): \
                 x̂' = A(θ)x̂ + N(θ,x̂)x̂ + B(θ)u + L(θ)[y − C(θ)x̂ − M(θ,x̂)x̂], fully unrolled. \
                 Its state is x̂ ([`NS`] = NX entries).\n\n"
            .to_string(),
        Some(f) => format!(
            " The certified observer of model `MODEL` (design INDEX), output route `filter` \
             (pole a = {a}, gain b = {b}), fully unrolled:\n\n \
             ```text\n \
             x̂'   = A(θ)x̂ + N(θ,x̂)x̂ + B(θ)u + L_x(θ)(x_y − x̂_y)\n \
             x̂_y' = −a x̂_y + b (C(θ)x̂ + M(θ,x̂)x̂) + L_y(θ)(x_y − x̂_y)\n \
             x_y'  = −a x_y + b y\n \
             ```\n\n \
             with L_x, L_y the first NX and last NY rows of L(θ). The observer runs the output \
             filter on the measurement itself: its state ([`NS`] = NX + 2·NY entries, \
             [`Observer::state`]) is (x̂, x̂_y, x_y), in that order, and starts with \
             x̂_y = x_y = 0 (the certificate assumes the filter-state error starts at 0; \
             `new` and `with_state` do that). [`Observer::estimate`] returns x̂ only.\n\n",
            a = num(f.pole),
            b = num(f.gain)
        ),
    }
    .replace("MODEL", model_name)
    .replace("INDEX", &index.to_string())
        + " θ is clamped into Θ (NaN → lower bound) before use; `step_euler`/`step_rk4` count \
           the steps where that happened ([`Observer::clamped`]). NaN in y or u propagates \
           into the estimate; nothing here can panic or allocate.";
    let filter_consts = match filter {
        Some(f) => {
            let (a, b) = (lit(f.pole), lit(f.gain));
            quote! {
                /// The output filter's pole a: x_y' = −a x_y + b y.
                pub const FILTER_POLE: f64 = #a;
                /// The output filter's input gain b: x_y' = −a x_y + b y.
                pub const FILTER_GAIN: f64 = #b;
            }
        }
        None => quote!(),
    };
    let nz_doc = if filter.is_some() {
        " Size of the design's state z = (x, x_y): NX + NY (P is NZ × NZ, L_l is NZ × NY)."
    } else {
        " Size of the design's state: NX (P is NZ × NZ, L_l is NZ × NY)."
    };
    let ns_doc = if filter.is_some() {
        " Size of the observer's state (x̂, x̂_y, x_y): NX + 2·NY."
    } else {
        " Size of the observer's state x̂: NX."
    };
    let from_state_doc = if filter.is_some() {
        " An observer with the whole state (x̂, x̂_y, x_y) given. The certificate \
         assumes x̂_y(0) = x_y(0); `with_state` is the usual start."
    } else {
        " An observer with the whole state given (the same as `with_state` for this route)."
    };

    quote! {
        #[doc = #doc]
        pub mod #modname {
            use super::{Certificate, Coeffs, NTHETA, NU, NV, NX, NY};

            /// The output route of this design: `"double_sum"` or `"filter"`.
            pub const ROUTE: &str = #route;
            #[doc = #nz_doc]
            pub const NZ: usize = #nz_l;
            #[doc = #ns_doc]
            pub const NS: usize = #ns_l;
            #filter_consts
            /// Certified decay rate: V = eᵀPe satisfies V' ≤ −α V.
            pub const ALPHA: f64 = #alpha;
            /// Certified region scaling γ.
            pub const GAMMA: f64 = #gamma;
            /// The Lyapunov matrix P (symmetric positive definite), NZ × NZ.
            pub const P: [[f64; NZ]; NZ] = #p;
            /// The vertex gains L_l, NZ × NY each; L(θ) = Σ_l μ_l(θ) L_l.
            pub const L: [[[f64; NY]; NZ]; NV] = [#(#l_vertices),*];
            /// True: the conditions prove V' ≤ −αV on the certified set.
            pub const CERTIFIES: bool = true;
            #certificate

            /// The scheduled gain L(θ) = Σ_l μ_l(θ) L_l (θ clamped into Θ).
            #[inline]
            pub fn gain(theta: &[f64; NTHETA]) -> [[f64; NY]; NZ] {
                gains(&super::mu_clamped(&super::clamp_theta(theta).0))
            }

            #[inline(always)]
            fn gains(mu: &[f64; NV]) -> [[f64; NY]; NZ] {
                #gains_mu
                #gains_body
            }

            #[inline(always)]
            fn rhs(
                c: &Coeffs,
                g: &[[f64; NY]; NZ],
                s: &[f64; NS],
                y: &[f64; NY],
                u: &[f64; NU],
            ) -> [f64; NS] {
                #rhs_c
                #rhs_g
                #rhs_s
                #rhs_y
                #rhs_u
                #rhs_body
            }

            /// The θ-dependent data of one evaluation, and whether θ was clamped.
            #[inline(always)]
            fn schedule(theta: &[f64; NTHETA]) -> (Coeffs, [[f64; NY]; NZ], bool) {
                let (t, clamped) = super::clamp_theta(theta);
                (super::coeffs(&t), gains(&super::mu_clamped(&t)), clamped)
            }

            #[doc = #obs_doc]
            #[derive(Clone, Copy, Debug, PartialEq)]
            pub struct Observer {
                state: [f64; NS],
                clamped: u64,
            }

            impl ::core::default::Default for Observer {
                fn default() -> Self {
                    Self::new()
                }
            }

            impl Observer {
                #[doc = #ns_doc]
                pub const NS: usize = NS;

                /// An observer with x̂(0) = 0 (and, for the filter route, x̂_y = x_y = 0).
                pub const fn new() -> Self {
                    Observer { state: [0.0; NS], clamped: 0 }
                }

                /// An observer with x̂(0) = `x0` (and, for the filter route, x̂_y = x_y = 0).
                pub fn with_state(x0: &[f64; NX]) -> Self {
                    let [#(#est),*] = *x0;
                    Observer { state: [#(#est,)* #(#init_zeros),*], clamped: 0 }
                }

                #[doc = #from_state_doc]
                pub fn from_state(state: &[f64; NS]) -> Self {
                    Observer { state: *state, clamped: 0 }
                }

                /// The current estimate x̂ of the plant's state.
                #[inline]
                pub fn estimate(&self) -> [f64; NX] {
                    #est_pat
                    [#(#est),*]
                }

                /// The whole observer state ([`NS`] entries; see [`Observer`]).
                #[inline]
                pub fn state(&self) -> [f64; NS] {
                    self.state
                }

                /// How many steps had θ outside Θ (or NaN) and clamped it.
                #[inline]
                pub fn clamped(&self) -> u64 {
                    self.clamped
                }

                /// The derivative of the whole observer state ([`NS`] entries) at
                /// the current state, θ clamped into Θ.
                #[inline]
                pub fn derivative(&self, y: &[f64; NY], u: &[f64; NU], theta: &[f64; NTHETA]) -> [f64; NS] {
                    let (c, g, _) = schedule(theta);
                    rhs(&c, &g, &self.state, y, u)
                }

                /// One explicit Euler step of length `dt` with y, u, θ held.
                #[inline]
                pub fn step_euler(&mut self, dt: f64, y: &[f64; NY], u: &[f64; NU], theta: &[f64; NTHETA]) {
                    let (c, g, clamped) = schedule(theta);
                    self.clamped = self.clamped.saturating_add(clamped as u64);
                    let [#(#k1),*] = rhs(&c, &g, &self.state, y, u);
                    let [#(#xs),*] = self.state;
                    self.state = [#(#xs + dt * #k1),*];
                }

                /// One classical Runge–Kutta 4 step of length `dt` with y, u, θ held
                /// over the step.
                #[inline]
                pub fn step_rk4(&mut self, dt: f64, y: &[f64; NY], u: &[f64; NU], theta: &[f64; NTHETA]) {
                    let (c, g, clamped) = schedule(theta);
                    self.clamped = self.clamped.saturating_add(clamped as u64);
                    let h2 = 0.5 * dt;
                    let h6 = dt / 6.0;
                    let [#(#xs),*] = self.state;
                    let [#(#k1),*] = rhs(&c, &g, &self.state, y, u);
                    let [#(#k2),*] = rhs(&c, &g, &[#(#xs + h2 * #k1),*], y, u);
                    let [#(#k3),*] = rhs(&c, &g, &[#(#xs + h2 * #k2),*], y, u);
                    let [#(#k4),*] = rhs(&c, &g, &[#(#xs + dt * #k3),*], y, u);
                    self.state = [#(#xs + h6 * (#k1 + 2.0 * #k2 + 2.0 * #k3 + #k4)),*];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = "model t {
        state x1, x2; input u1; output y1;
        param a in [-1, 3]; param b in [0, 1];
        A = [-1 - a, 0; 1, -2*a*b];
        N1 = [0, 1; 0, 0]; N2 = 0;
        B = [0; 1];
        C = [1, 0]; M1 = 0;
        region box(1);
        state_bound Q = [0.1, 0; 0, 0.1];
        design { alpha = 1; gamma = 0.5; }
    }";

    fn generated() -> String {
        generated_with(None)
    }

    fn generated_with(filter: Option<OutputFilter>) -> String {
        let nz = if filter.is_some() { 3 } else { 2 };
        let models = qpv_dsl::parse(MODEL).expect("test model parses");
        let model = &models[0];
        let design = CertifiedDesign {
            request: "alpha = 1; gamma = 0.5; mode = sound".into(),
            mode: "sound".into(),
            certifies: true,
            alpha: 1.0,
            gamma: 0.5,
            p: (0..nz * nz)
                .map(|i| if i % (nz + 1) == 0 { 1.0 } else { 0.0 })
                .collect(),
            l: (0..4)
                .map(|l| {
                    let mut v = vec![0.0; nz];
                    v[0] = f64::from(l);
                    v
                })
                .collect(),
            margins: vec![("S1".into(), 0.5)],
            status: "Solved".into(),
            iterations: 7,
            filter,
        };
        emit(&EmitModel {
            model,
            scheduling: vec![0, 1],
            designs: vec![design],
        })
        .to_string()
    }

    #[test]
    fn output_is_a_valid_rust_file() {
        let code = generated();
        assert!(syn::parse_str::<syn::File>(&code).is_ok(), "{code}");
    }

    #[test]
    fn filter_route_output_is_valid_and_documents_the_filter() {
        let code = generated_with(Some(OutputFilter {
            pole: 40.0,
            gain: 20.0,
        }));
        assert!(syn::parse_str::<syn::File>(&code).is_ok(), "{code}");
        assert!(
            code.contains("pub const ROUTE : & str = \"filter\""),
            "{code}"
        );
        assert!(code.contains("pub const FILTER_POLE : f64 = 40.0"));
        assert!(code.contains("pub const FILTER_GAIN : f64 = 20.0"));
        assert!(code.contains("pub const NZ : usize = 3"));
        assert!(code.contains("pub const NS : usize = 4"));
        // the filter rows: x̂_y' = −a x̂_y + b·h(x̂) + …, x_y' = −a x_y + b y
        assert!(code.contains("- 40.0 * zh0 + 20.0 * x0"), "{code}");
        assert!(code.contains("- 40.0 * zm0 + 20.0 * y0"), "{code}");
        // the residual is the filter-state error
        assert!(code.contains("let r0 = zm0 - zh0"), "{code}");
        let code: TokenStream = code.parse().expect("tokens");
        assert!(!indexes(code), "arrays are destructured, never indexed");
    }

    /// Every identifier of a token stream (string literals and docs skipped).
    fn idents(ts: TokenStream, out: &mut Vec<String>) {
        for tt in ts {
            match tt {
                proc_macro2::TokenTree::Ident(i) => out.push(i.to_string()),
                proc_macro2::TokenTree::Group(g) => idents(g.stream(), out),
                _ => {}
            }
        }
    }

    #[test]
    fn no_loops_no_heap_no_std_no_panics() {
        let code: TokenStream = generated().parse().expect("tokens");
        let mut ids = Vec::new();
        idents(code, &mut ids);
        for word in [
            "while",
            "loop",
            "unwrap",
            "expect",
            "panic",
            "unreachable",
            "Vec",
            "Box",
            "std",
            "alloc",
            "unsafe",
        ] {
            assert!(
                !ids.iter().any(|i| i == word),
                "generated code uses `{word}`"
            );
        }
        // the only `for … in` loop prints the certificate's margins (Display)
        assert_eq!(ids.iter().filter(|i| *i == "in").count(), 1);
        assert!(
            !indexes(generated().parse().expect("tokens")),
            "arrays are destructured, never indexed"
        );
    }

    /// True if some `[...]` follows a name or a call, i.e. an index expression.
    fn indexes(ts: TokenStream) -> bool {
        let tts: Vec<proc_macro2::TokenTree> = ts.into_iter().collect();
        tts.iter().enumerate().any(|(i, tt)| match tt {
            proc_macro2::TokenTree::Group(g) => {
                let indexed = g.delimiter() == proc_macro2::Delimiter::Bracket
                    && match i.checked_sub(1).and_then(|j| tts.get(j)) {
                        Some(proc_macro2::TokenTree::Ident(id)) => {
                            // `let [..]`, `mut`, and the lifetime in `&'static [..]`
                            id != "let" && id != "mut" && id != "static"
                        }
                        Some(proc_macro2::TokenTree::Group(p)) => {
                            p.delimiter() == proc_macro2::Delimiter::Parenthesis
                        }
                        _ => false,
                    };
                indexed || indexes(g.stream())
            }
            _ => false,
        })
    }

    #[test]
    fn constants_are_folded() {
        let code = generated();
        assert!(!code.contains("0.0 * "), "zero terms are dropped");
        assert!(!code.contains("1.0 * "), "unit factors are dropped");
        // the θ product a·b is computed once and reused
        assert_eq!(code.matches("let t0_1 = t0 * t1").count(), 1);
        // L_l[1][0] = 0 at every vertex: no gain term in the second equation
        assert!(code.contains("g0_0 * r0"));
        assert!(!code.contains("g1_0 * r0"));
        // the state product is computed once
        assert_eq!(
            code.matches("let x0x1 = x0 * x1").count(),
            2,
            "observer + plant"
        );
    }

    #[test]
    fn float_literals_round_trip() {
        for v in [0.1, -2.5e-300, 1.0 / 3.0, 123456.789, -0.0] {
            let t = lit(v).to_string().replace(' ', "");
            assert_eq!(t.parse::<f64>().ok(), Some(v), "{t}");
        }
    }

    #[test]
    fn sums_fold_signs_and_units() {
        let mut s = Sum::default();
        s.push(-1.0, Some(quote!(x)));
        s.push(0.0, Some(quote!(y)));
        s.push(1.0, Some(quote!(z)));
        s.push(-2.5, None);
        assert_eq!(s.render().to_string(), "- x + z - 2.5");
        assert_eq!(Sum::default().render().to_string(), "0.0");
    }
}
