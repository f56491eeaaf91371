//! The generated `plant` module: the model's own equations
//! x' = A(θ)x + N(θ,x)x + B(θ)u and y = C(θ)x + M(θ,x)x, for simulation and
//! tests.

use super::tokens::{body_array, destructure, uses};
use proc_macro2::TokenStream;
use qpv_codegen::build::coeffs::Coeffs;
use qpv_codegen::build::equations::Equation;
use quote::{format_ident, quote};

/// The rendered bodies of the plant's derivative and output.
pub(super) struct Plant {
    derivative: TokenStream,
    output: TokenStream,
}

impl Plant {
    /// Renders the state and output equations (interning their θ-dependent
    /// coefficients into `coeffs`).
    /// The model's nonlinear terms of unmeasured states are evaluated as
    /// written at the start of the derivative.
    pub(super) fn render(
        m: &qpv_dsl::Model,
        (state_eqs, out_eqs): (&[Equation], &[Equation]),
        coeffs: &mut Coeffs,
        libm: &TokenStream,
    ) -> Self {
        let (mut f, h) = qpv_codegen::build::observer::plant_bodies(state_eqs, out_eqs, coeffs);
        f.lets
            .splice(0..0, qpv_codegen::build::equations::nonlinear_lets(m));
        Plant {
            derivative: body_array(&f, libm),
            output: body_array(&h, libm),
        }
    }

    /// `pub mod plant { derivative, output }` for a model with `nx` states
    /// and `nu` inputs.
    pub(super) fn module(&self, nx: usize, nu: usize) -> TokenStream {
        let (x, u) = (format_ident!("x"), format_ident!("u"));
        let (f_body, h_body) = (&self.derivative, &self.output);
        let f_x = destructure(&x, "x", nx, f_body);
        let f_u = destructure(&u, "u", nu, f_body);
        let h_x = destructure(&x, "x", nx, h_body);
        let f_c = coeffs_binding(f_body);
        let h_c = coeffs_binding(h_body);
        quote! {
            /// The plant equations x' = A(θ)x + N(θ,x)x + B(θ)u, y = C(θ)x + M(θ,x)x,
            /// for simulation and tests (θ used as given, not clamped).
            pub mod plant {
                use super::{NTHETA, NU, NX, NY};

                /// x' = A(θ)x + N(θ,x)x + B(θ)u.
                #[inline]
                pub fn derivative(x: &[f64; NX], u: &[f64; NU], theta: &[f64; NTHETA]) -> [f64; NX] {
                    #f_c
                    #f_x
                    #f_u
                    #f_body
                }

                /// y = C(θ)x + M(θ,x)x.
                #[inline]
                pub fn output(x: &[f64; NX], theta: &[f64; NTHETA]) -> [f64; NY] {
                    #h_c
                    #h_x
                    #h_body
                }
            }
        }
    }
}

/// `let c = super::coeffs(theta);` if the body uses θ-dependent
/// coefficients, else a use of `theta` that silences the unused warning.
fn coeffs_binding(body: &TokenStream) -> TokenStream {
    if uses(body, "c") {
        quote!(let c = super::coeffs(theta);)
    } else {
        quote!(let _ = theta;)
    }
}
