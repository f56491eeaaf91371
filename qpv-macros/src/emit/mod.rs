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

//!
//! One submodule per part of the generated code: [`tokens`] (literals,
//! folded sums, destructuring), [`equations`] (the plant's rows as
//! monomial → θ-polynomial maps), [`coefficients`] (the interned
//! θ-dependent coefficients), [`weights`] (`clamp_theta`, `mu`),
//! [`certificate`] (the proof's types and constants), [`plant`] (the
//! `plant` module) and [`design`] (one module per design: constants, gain
//! schedule, observer derivative and steppers).

mod certificate;
mod coefficients;
mod design;
mod measured;
mod plant;
mod tokens;
mod weights;

use plant::Plant;
use proc_macro2::{Ident, Span, TokenStream};
use qpv_codegen::build::coeffs::Coeffs;
use qpv_codegen::build::equations::equations;
pub use qpv_codegen::{CertifiedDesign, Figures};
use qpv_dsl::Model;
#[cfg(test)]
use qpv_dsl::OutputFilter;
use quote::{format_ident, quote};
use tokens::{lit, num, usize_lit};

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
    /// The path of the `libm` crate in the calling crate (`::libm`, or the
    /// `qpv` facade's re-export), for the scheduling functions' math.
    pub libm: TokenStream,
}

impl EmitModel<'_> {
    /// Number of vertices: 2^s corners (s scheduling parameters and derived
    /// variables) per piece of the model's cover.
    pub fn nv(&self) -> usize {
        qpv_codegen::design::vertex_count(self.model, &self.scheduling)
    }
}

/// Emits the module for one model.
pub fn emit(em: &EmitModel<'_>) -> TokenStream {
    let m = em.model;
    let name = Ident::new(&m.name, Span::call_site());
    let (state_eqs, out_eqs) = equations(m);
    let mut coeffs = Coeffs::default();
    // The plant, then the designs, intern the θ-dependent coefficients; the
    // `Coeffs` struct built after them covers all of them.
    let plant = Plant::render(m, (&state_eqs, &out_eqs), &mut coeffs, &em.libm);
    let primary_index = em.designs.iter().position(|d| d.certifies).unwrap_or(0) + 1;
    let primary = format_ident!("design{}", primary_index);
    let primary_filter = match em.designs.get(primary_index - 1).and_then(|d| d.filter) {
        Some(_) => quote!(pub use self::#primary::{FILTER_GAIN, FILTER_POLE};),
        None => quote!(),
    };
    let primary_sample = match em.designs.get(primary_index - 1).and_then(|d| d.sample) {
        Some(_) => quote!(pub use self::#primary::SAMPLE_PERIOD;),
        None => quote!(),
    };
    let primary_rms = match em
        .designs
        .get(primary_index - 1)
        .map(|d| d.figures.rms.is_some())
    {
        Some(true) => quote!(pub use self::#primary::{RMS_BOUND, RMS_BOUND_PER_STATE};),
        _ => quote!(),
    };
    let primary_sup = match em.designs.get(primary_index - 1).and_then(|d| d.alpha_sup) {
        Some(_) => quote!(pub use self::#primary::ALPHA_SUP;),
        None => quote!(),
    };
    let designs: Vec<TokenStream> = em
        .designs
        .iter()
        .enumerate()
        .map(|(i, d)| design::emit_design(em, d, i + 1, &state_eqs, &out_eqs, &mut coeffs))
        .collect();

    let constants = model_constants(m, em.nv());
    let certificate_types = certificate::types();
    let weights = weights::items(m, &em.scheduling, &em.libm);
    let coefficients = coefficients::items(&coeffs, m.ntheta(), m.derived.len(), &em.libm);
    let plant = plant.module(m.nx(), m.nu());
    let mod_doc = module_doc(em, primary_index);
    quote! {
        #[doc = #mod_doc]
        #[allow(
            non_snake_case,
            clippy::approx_constant,
            clippy::excessive_precision,
            clippy::unreadable_literal,
            clippy::let_and_return,
            clippy::just_underscores_and_digits,
            clippy::neg_multiply,
            clippy::double_neg
        )]
        pub mod #name {
            #constants

            #certificate_types

            #weights

            #coefficients

            pub use self::#primary::{
                gain, Observer, ALPHA, CERTIFICATE, CERTIFIES, ERROR_BOUND_PER_NOISE, EULER_BETA, GAMMA, L,
                MAX_NOISE_AMPLITUDE, MAX_STEP_EULER, NOISE_SIGMA, NS, NZ, P, ROUTE,
                STEP_ESTIMATE_RK4,
            };
            #primary_filter
            #primary_sample
            #primary_rms
            #primary_sup

            #(#designs)*

            #plant
        }
    }
}

/// The model's sizes and parameter bounds: `NX`, `NY`, `NU`, `NTHETA`,
/// `NV` (`nv` vertices), `THETA_MIN`, `THETA_MAX`.
fn model_constants(m: &Model, nv: usize) -> TokenStream {
    let (nx_l, ny_l, nu_l, nth_l, nv_l) = (
        usize_lit(m.nx()),
        usize_lit(m.ny()),
        usize_lit(m.nu()),
        usize_lit(m.ntheta()),
        usize_lit(nv),
    );
    let lo: Vec<TokenStream> = m.params.iter().map(|p| lit(p.lo)).collect();
    let hi: Vec<TokenStream> = m.params.iter().map(|p| lit(p.hi)).collect();
    quote! {
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
    }
}

/// The module's documentation: names, parameters, vertices, the designs
/// (which one is re-exported), θ clamping and NaN handling, and the model
/// compiler's warnings.
fn module_doc(em: &EmitModel<'_>, primary_index: usize) -> String {
    let m = em.model;
    let nv = em.nv();
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
    let sched_list: Vec<String> = sched_list
        .iter()
        .map(|s| s.to_string())
        .chain(m.derived.iter().map(|d| format!("{} = {}", d.name, d.text)))
        .collect();
    let mut mod_doc: String = format!(
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
    if let Some(c) = &m.cover {
        let pieces: Vec<String> = (0..c.len())
            .map(|k| format!("{} ({})", k + 1, c.label(k)))
            .collect();
        mod_doc.push_str(&format!(
            "\n\n Cover: Θ is cut into {} pieces, each with its own box of (θ, φ) (the φ \
             ranges recomputed on the piece); the vertices are the corners of every piece's \
             box, piece after piece: {}. `mu` locates the piece of θ ([`piece`]; a breakpoint \
             belongs to the piece above it) and is zero on every other piece, so the gain \
             L(θ) may jump at a breakpoint (the certificate holds at every θ).",
            c.len(),
            pieces.join(", ")
        ));
    }
    for w in &m.warnings {
        mod_doc.push_str("\n\n Note from the model compiler: ");
        mod_doc.push_str(&w.message);
    }
    mod_doc
}

#[cfg(test)]
mod tests {
    use super::*;
    use qpv_codegen::ir::Sum;

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
        generated_float(filter, qpv_dsl::Float::F64)
    }

    fn generated_float(filter: Option<OutputFilter>, float: qpv_dsl::Float) -> String {
        generated_edited(filter, float, |_| {})
    }

    /// The test model's code with its design edited by `edit` first.
    fn generated_edited(
        filter: Option<OutputFilter>,
        float: qpv_dsl::Float,
        edit: impl FnOnce(&mut CertifiedDesign),
    ) -> String {
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
            figures: Figures::default(),
            noise_missing: None,
            filter,
            float,
            sample: None,
            time_unit: Default::default(),
            alpha_sup: Some(1.5),
        };
        let mut design = design;
        edit(&mut design);
        emit(&EmitModel {
            model,
            libm: quote!(::libm),
            scheduling: vec![0, 1],
            designs: vec![design],
        })
        .to_string()
    }

    /// A sampled f32 design carries the floor of its `step`, and every f32
    /// design the rounding split of its floor, rounded to the safe side.
    #[test]
    fn a_sampled_f32_design_has_the_floor_of_its_step() {
        let code = generated_edited(None, qpv_dsl::Float::F32, |d| {
            d.sample = Some(1e-3);
            d.figures.f32_floor = Some(1e-6);
            d.figures.f32_step_floor = Some(2.5e-6);
            d.figures.f32_rounding = Some(qpv_codegen::design::F32Rounding {
                d0: 3e-5,
                d1: 0.125,
                rate: 0.75,
            });
        });
        assert!(syn::parse_str::<syn::File>(&code).is_ok(), "{code}");
        for item in [
            "pub const F32_STEP_FLOOR : f32 = 0.0000025",
            "pub const F32_ROUNDING_D1 : f32 = 0.125",
            "pub const F32_RATE : f32 = 0.75",
            "pub const SAMPLE_PERIOD : f32",
            "pub fn step (& mut self",
        ] {
            assert!(code.contains(item), "missing `{item}`");
        }
        // without a sample period, no step floor
        let code = generated_float(None, qpv_dsl::Float::F32);
        assert!(!code.contains("F32_STEP_FLOOR"));
        assert!(
            code.contains("pub const F32_RATE : f32 = 0.0"),
            "none certified: 0"
        );
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

    /// The tokens of `pub mod design1 { ... }` in the generated module.
    fn design_module(ts: TokenStream) -> Option<TokenStream> {
        let tts: Vec<proc_macro2::TokenTree> = ts.into_iter().collect();
        for (i, tt) in tts.iter().enumerate() {
            if let proc_macro2::TokenTree::Group(g) = tt {
                let named = matches!(
                    i.checked_sub(1).and_then(|j| tts.get(j)),
                    Some(proc_macro2::TokenTree::Ident(id)) if id == "design1"
                );
                if named {
                    return Some(g.stream());
                }
                if let Some(found) = design_module(g.stream()) {
                    return Some(found);
                }
            }
        }
        None
    }

    /// Every `f64` identifier and every float literal that is not an f32
    /// value, outside the `CERTIFICATE` record (which keeps the f64 α, γ
    /// and margins in the model-level `Certificate` type).
    fn f64_traces(ts: TokenStream, out: &mut Vec<String>) {
        let mut skip = false;
        for tt in ts {
            match tt {
                proc_macro2::TokenTree::Ident(i) if i == "CERTIFICATE" => skip = true,
                proc_macro2::TokenTree::Punct(p) if p.as_char() == ';' => skip = false,
                _ if skip => {}
                proc_macro2::TokenTree::Ident(i) if i == "f64" => out.push("f64".into()),
                proc_macro2::TokenTree::Literal(l) => {
                    let s = l.to_string();
                    if s.starts_with(|c: char| c.is_ascii_digit())
                        && (s.contains('.') || s.contains('e'))
                    {
                        // an f32 value: exact in f64, or printed as `to_f32`
                        // prints the f32 it parses to (the shortest form)
                        let v: f64 = s.parse().unwrap_or(f64::NAN);
                        let v32: f32 = s.parse().unwrap_or(f32::NAN);
                        let shortest = proc_macro2::Literal::f32_unsuffixed(v32).to_string();
                        if f64::from(v as f32) != v && shortest != s {
                            out.push(s);
                        }
                    }
                }
                proc_macro2::TokenTree::Group(g) => f64_traces(g.stream(), out),
                _ => {}
            }
        }
    }

    #[test]
    fn an_f32_design_module_has_no_f64_value_or_literal() {
        let code = generated_float(None, qpv_dsl::Float::F32);
        assert!(syn::parse_str::<syn::File>(&code).is_ok(), "{code}");
        let module = design_module(code.parse().expect("tokens")).expect("design1");
        let text = module.to_string();
        for item in [
            "pub fn step_euler (& mut self , dt : f32 , y : & [f32 ; NY]",
            "pub const P : [[f32 ; NZ] ; NZ]",
            "pub fn mu (theta : & [f32 ; NTHETA]) -> [f32 ; NV]",
            "pub fn derivative (x : & [f32 ; NX] , u : & [f32 ; NU] , theta : & [f32 ; NTHETA]) -> [f32 ; NX]",
            "pub const F32_ERROR_FLOOR : f32",
            "pub const F32_ROUNDING_D0 : f32",
            "pub const F32_ROUNDING_D1 : f32",
            "pub const F32_RATE : f32",
            "pub const FLOAT_BITS : u32 = 32u32",
            "let h6 = dt * 0.16666667",
            "pub fn with_state (x0 : & [f32 ; NX]) -> Self",
        ] {
            assert!(text.contains(item), "missing `{item}`");
        }
        let mut traces = Vec::new();
        f64_traces(module, &mut traces);
        assert!(traces.is_empty(), "f64 in the f32 design: {traces:?}");
        assert!(generated().contains("pub const FLOAT_BITS : u32 = 64u32"));
        // and the f64 design of the same model does use f64 (the scan sees it)
        let f64_module = design_module(generated().parse().expect("tokens")).expect("design1");
        let mut traces = Vec::new();
        f64_traces(f64_module, &mut traces);
        assert!(traces.iter().any(|t| t == "f64"));
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
        use qpv_codegen::ir::Expr;
        let mut s = Sum::default();
        s.push(-1.0, Some(Expr::var("x")));
        s.push(0.0, Some(Expr::var("y")));
        s.push(1.0, Some(Expr::var("z")));
        s.push(-2.5, None);
        let none = TokenStream::new();
        assert_eq!(tokens::expr(&s.expr(), &none).to_string(), "- x + z - 2.5");
        assert_eq!(
            tokens::expr(&Sum::default().expr(), &none).to_string(),
            "0.0"
        );
        // equal vertex gains: one product over the weights' sum, as in C
        let mut w = Sum::default();
        w.push(1.0, Some(Expr::var("m0")));
        w.push(1.0, Some(Expr::var("m1")));
        let mut g = Sum::default();
        g.push(12.777_471, Some(Expr::paren(w.expr())));
        g.push(-3.5, Some(Expr::var("m2")));
        assert_eq!(
            tokens::expr(&g.expr(), &none).to_string(),
            "12.777471 * (m0 + m1) - 3.5 * m2"
        );
    }
}
