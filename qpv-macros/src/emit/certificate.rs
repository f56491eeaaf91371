//! The certificate that travels with the generated code: the `Margin` and
//! `Certificate` types (and `Sampled`) of the model module (with `Display`) and each
//! design's `CERTIFICATE` constant.

use super::tokens::lit;
use super::CertifiedDesign;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// The model-level types `Margin` and `Certificate` and the latter's
/// `Display` (the same for every model).
pub(super) fn types() -> TokenStream {
    quote! {
        /// The worst margin of one family of design conditions (positive = satisfied).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Margin {
            /// The condition family: `S1`, `S2`, `S3`, `S5` (sound; `S5d` in place of `S5` for a sampled design) or `S1`, `13`, `14`, `26` (paper).
            pub family: &'static str,
            /// Its worst margin, recomputed independently of the solver.
            pub margin: f64,
        }

        /// The sample period a design is certified at (`sample = h`): the
        /// observer stepped by one explicit Euler step of exactly `period`
        /// (`Observer::step`), V(e_{k+1}) ≤ `decrease` · V(e_k).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Sampled {
            /// The sample period h, in the model's unit of time.
            pub period: f64,
            /// 1 − hα, the certified decrease of V per step.
            pub decrease: f64,
            /// The period and its rate in words, e.g. `h = 1e-3 s (1 kHz)`.
            pub text: &'static str,
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
            /// The sample period of a design certified at it (family S5d in
            /// place of S5); `None` for a continuous-time design.
            pub sample: ::core::option::Option<Sampled>,
            /// Worst margin per condition family, all positive (recomputed by
            /// the macro from the baked P and L_l).
            pub margins: &'static [Margin],
            /// The solver's final status for the accepted solve.
            pub solver_status: &'static str,
            /// Interior-point iterations of the accepted solve.
            pub iterations: u32,
            /// The float type of the design's observer: `"f64"` or `"f32"`.
            pub float: &'static str,
            /// f32 designs: the certified error floor, lim sup ‖e(t)‖ caused by
            /// the f32 rounding of the right-hand side alone (`None` for f64
            /// designs, or if no floor could be certified).
            pub f32_error_floor: ::core::option::Option<f64>,
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
                if let ::core::option::Option::Some(s) = self.sample {
                    ::core::writeln!(
                        f,
                        "  certified at {}: V(e_k+1) <= {} V(e_k) per explicit Euler step",
                        s.text, s.decrease
                    )?;
                }
                ::core::writeln!(f, "  request: {}", self.request)?;
                ::core::writeln!(f, "  output route: {}", self.route)?;
                for m in self.margins {
                    ::core::writeln!(f, "  {:<24} margin {:.3e}", m.family, m.margin)?;
                }
                ::core::writeln!(f, "  float: {}", self.float)?;
                if let ::core::option::Option::Some(v) = self.f32_error_floor {
                    ::core::writeln!(f, "  f32 error floor: lim sup |e| <= {:.3e}", v)?;
                }
                ::core::write!(
                    f,
                    "  solver: {} after {} iterations",
                    self.solver_status, self.iterations
                )
            }
        }
    }
}

/// The `CERTIFICATE` constant of one design of model `model_name` with the
/// output route `route` (its `ALPHA` and `GAMMA` are the design module's).
pub(super) fn constant(model_name: &str, route: &str, d: &CertifiedDesign) -> TokenStream {
    let (alpha, gamma) = if d.float == qpv_dsl::Float::F32 {
        // the design module's ALPHA and GAMMA are f32: the record keeps the f64 values
        (lit(d.alpha), lit(d.gamma))
    } else {
        (quote!(ALPHA), quote!(GAMMA))
    };
    let float = d.float.name();
    let floor = match d.figures.f32_floor {
        Some(v) => {
            let v = lit(v);
            quote!(::core::option::Option::Some(#v))
        }
        None => quote!(::core::option::Option::None),
    };
    let fam: Vec<TokenStream> = d
        .margins
        .iter()
        .map(|(f, v)| {
            let v = lit(*v);
            quote!(super::Margin { family: #f, margin: #v })
        })
        .collect();
    let (request, mode, status) = (&d.request, &d.mode, &d.status);
    let iterations = Literal::u32_unsuffixed(d.iterations);
    let certifies = d.certifies;
    let sample = match d.sample {
        Some(h) => {
            let (period, decrease) = (lit(h), lit(1.0 - h * d.alpha));
            let text = d.sample_text().unwrap_or_default();
            quote!(::core::option::Option::Some(super::Sampled {
                period: #period,
                decrease: #decrease,
                text: #text,
            }))
        }
        None => quote!(::core::option::Option::None),
    };
    quote! {
        /// The independent certificate of this design.
        pub const CERTIFICATE: Certificate = Certificate {
            model: #model_name,
            request: #request,
            mode: #mode,
            route: #route,
            certifies: #certifies,
            alpha: #alpha,
            gamma: #gamma,
            sample: #sample,
            margins: &[#(#fam),*],
            solver_status: #status,
            iterations: #iterations,
            float: #float,
            f32_error_floor: #floor,
        };
    }
}
