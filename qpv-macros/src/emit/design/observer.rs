//! The certified observer of a design: its right-hand side `rhs` (the plant
//! equations plus the gain times the output residual, and for the filter
//! route the filter rows), the per-evaluation `schedule`, and the
//! `Observer` type with its constructors and Euler / RK4 steppers.

use super::{docs, Shape};
use crate::emit::measured::Theta;
use crate::emit::tokens::{body_array, destructure, destructure_names, uses};
use crate::emit::CertifiedDesign;
use proc_macro2::{Ident, Span, TokenStream};
use qpv_codegen::build::coeffs::Coeffs;
use qpv_codegen::build::equations::Equation;
use quote::{format_ident, quote};

/// `rhs`, `schedule`, `Observer` and its methods for design `index` of
/// model `em.model` (its nonlinear terms of unmeasured states evaluated at
/// x̂ as written, with `em.libm`'s math functions).
pub(super) fn items(
    em: &crate::emit::EmitModel<'_>,
    index: usize,
    d: &CertifiedDesign,
    shape: Shape,
    (state_eqs, out_eqs): (&[Equation], &[Equation]),
    coeffs: &mut Coeffs,
    th: &Theta,
) -> TokenStream {
    let model_name = em.model.name.as_str();
    let mut body = qpv_codegen::build::observer::rhs_body(d, shape, state_eqs, out_eqs, coeffs);
    let nl = qpv_codegen::build::equations::nonlinear_lets(em.model);
    let libm = if nl.is_empty() {
        TokenStream::new()
    } else {
        em.libm.clone()
    };
    body.lets.splice(0..0, nl);
    let body = body_array(&body, &libm);
    let rhs = rhs_fn(shape, &body);
    let observer = observer_type(model_name, index, shape, d.sample.is_some(), th);
    quote! {
        #rhs

        /// The θ-dependent data of one evaluation, and whether θ was clamped.
        #[inline(always)]
        fn schedule(theta: &[f64; NTHETA]) -> (Coeffs, [[f64; NY]; NZ], bool) {
            let (t, clamped) = super::clamp_theta(theta);
            (super::coeffs(&t), gains(&super::mu_clamped(&t)), clamped)
        }

        #observer
    }
}

/// `fn rhs(c, g, s, y, u)` around `body`, binding only the state, output,
/// input and gain entries the body uses.
fn rhs_fn(shape: Shape, body: &TokenStream) -> TokenStream {
    let Shape { ny, nu, nv, nz, .. } = shape;
    let (s, y, u, g) = (
        format_ident!("s"),
        format_ident!("y"),
        format_ident!("u"),
        format_ident!("g"),
    );
    let bind_s = destructure_names(&s, &shape.state_names(), body);
    let bind_y = destructure(&y, "y", ny, body);
    let bind_u = destructure(&u, "u", nu, body);
    let g_pats: Vec<TokenStream> = (0..nz)
        .map(|k| {
            let ps = (0..ny).map(|o| {
                let name = format!("g{k}_{o}");
                if nv > 1 && uses(body, &name) {
                    let id = Ident::new(&name, Span::call_site());
                    quote!(#id)
                } else {
                    quote!(_)
                }
            });
            quote!([#(#ps),*])
        })
        .collect();
    let bind_g = quote!(let [#(#g_pats),*] = *#g;);
    let bind_c = if uses(body, "c") {
        quote!()
    } else {
        quote!(let _ = c;)
    };
    quote! {
        #[inline(always)]
        fn rhs(
            c: &Coeffs,
            g: &[[f64; NY]; NZ],
            s: &[f64; NS],
            y: &[f64; NY],
            u: &[f64; NU],
        ) -> [f64; NS] {
            #bind_c
            #bind_g
            #bind_s
            #bind_y
            #bind_u
            #body
        }
    }
}

/// The `Observer` struct, its `Default`, constructors, accessors,
/// `derivative` and the steppers.
fn observer_type(
    model_name: &str,
    index: usize,
    shape: Shape,
    sampled: bool,
    th: &Theta,
) -> TokenStream {
    let (th_ty, th_arg) = (&th.ty, &th.arg);
    let Shape { nx, ns, .. } = shape;
    let xs: Vec<Ident> = (0..ns).map(|i| format_ident!("s{}", i)).collect();
    // estimate(): the first NX entries; with_state(x0): x0 then zeros.
    let est: Vec<&Ident> = xs.iter().take(nx).collect();
    let est_pat = if ns > nx {
        quote!(let [#(#est,)* ..] = self.state;)
    } else {
        quote!(let [#(#est),*] = self.state;)
    };
    let init_zeros: Vec<TokenStream> = (nx..ns).map(|_| quote!(0.0)).collect();
    let obs_doc = docs::observer(model_name, index, shape.filter);
    let ns_doc = docs::ns(shape.filter);
    let from_state_doc = docs::from_state(shape.filter);
    let steppers = steppers(&xs, th);
    let step = if sampled {
        fixed_step(&xs, th)
    } else {
        quote!()
    };
    quote! {
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
            pub fn derivative(&self, y: &[f64; NY], u: &[f64; NU], theta: &#th_ty) -> [f64; NS] {
                let (c, g, _) = schedule(#th_arg);
                rhs(&c, &g, &self.state, y, u)
            }

            #step

            #steppers
        }
    }
}

/// `step`, the certified fixed step of a sampled design: one explicit Euler
/// step of exactly `SAMPLE_PERIOD` (no step argument, no debug check: the
/// step is the one certified).
fn fixed_step(xs: &[Ident], th: &Theta) -> TokenStream {
    let (th_ty, th_arg) = (&th.ty, &th.arg);
    let k1: Vec<Ident> = (0..xs.len()).map(|i| format_ident!("a{}", i)).collect();
    quote! {
        /// The certified step: one explicit Euler step of exactly
        /// [`SAMPLE_PERIOD`] with the samples y_k, u_k, θ_k,
        /// x̂_{k+1} = x̂_k + SAMPLE_PERIOD · f̂(x̂_k, y_k, u_k, θ_k).
        ///
        /// Against the plant stepped by the same Euler step, with θ_k in Θ,
        /// the plant in the state bound F and e_0 in the certified set, the
        /// design proves V(e_{k+1}) ≤ (1 − SAMPLE_PERIOD·ALPHA) V(e_k)
        /// (see [`CERTIFICATE`]). Call it once per sample period.
        #[inline]
        pub fn step(&mut self, y: &[f64; NY], u: &[f64; NU], theta: &#th_ty) {
            let (c, g, clamped) = schedule(#th_arg);
            self.clamped = self.clamped.saturating_add(clamped as u64);
            let [#(#k1),*] = rhs(&c, &g, &self.state, y, u);
            let [#(#xs),*] = self.state;
            self.state = [#(#xs + SAMPLE_PERIOD * #k1),*];
        }
    }
}

/// `step_euler` and `step_rk4` over the whole observer state (named `xs`),
/// unrolled.
fn steppers(xs: &[Ident], th: &Theta) -> TokenStream {
    let (th_ty, th_arg) = (&th.ty, &th.arg);
    let stage = |prefix: &str| -> Vec<Ident> {
        (0..xs.len())
            .map(|i| format_ident!("{}{}", prefix, i))
            .collect()
    };
    let (k1, k2, k3, k4) = (stage("a"), stage("b"), stage("c"), stage("d"));
    // h/6 as a product (the C prints the same constant): no division per step
    let sixth = crate::emit::tokens::lit(1.0 / 6.0);
    quote! {
        /// One explicit Euler step of length `dt` with y, u, θ held.
        ///
        /// For `dt ≤ MAX_STEP_EULER` the design proves that V = eᵀPe
        /// contracts by at least (1 − dt·EULER_BETA) per step on the
        /// certified set, assuming the plant is discretised by the same
        /// Euler step (a continuous plant is covered by simulation only).
        /// Above `MAX_STEP_EULER` nothing is proven (`STEP_ESTIMATE_RK4`
        /// is the RK4 counterpart, an estimate only).
        ///
        /// In debug builds a `dt` above `MAX_STEP_EULER` panics through
        /// `debug_assert!` (not when `MAX_STEP_EULER` is 0, i.e. no step
        /// could be proven); release builds do not check.
        #[inline]
        pub fn step_euler(&mut self, dt: f64, y: &[f64; NY], u: &[f64; NU], theta: &#th_ty) {
            debug_assert!(
                !(MAX_STEP_EULER > 0.0 && dt > MAX_STEP_EULER),
                "step_euler: dt = {} exceeds MAX_STEP_EULER = {}, the certified Euler step",
                dt,
                MAX_STEP_EULER
            );
            let (c, g, clamped) = schedule(#th_arg);
            self.clamped = self.clamped.saturating_add(clamped as u64);
            let [#(#k1),*] = rhs(&c, &g, &self.state, y, u);
            let [#(#xs),*] = self.state;
            self.state = [#(#xs + dt * #k1),*];
        }

        /// One classical Runge–Kutta 4 step of length `dt` with y, u, θ held
        /// over the step.
        ///
        /// `STEP_ESTIMATE_RK4` estimates the largest stable step (every
        /// frozen vertex error dynamics stable under RK4); it is an
        /// estimate, not a certificate: prefer `step_euler` below
        /// `MAX_STEP_EULER` where a proof is needed. No step size is
        /// checked here, in debug or release builds.
        #[inline]
        pub fn step_rk4(&mut self, dt: f64, y: &[f64; NY], u: &[f64; NU], theta: &#th_ty) {
            let (c, g, clamped) = schedule(#th_arg);
            self.clamped = self.clamped.saturating_add(clamped as u64);
            let h2 = 0.5 * dt;
            let h6 = dt * #sixth;
            let [#(#xs),*] = self.state;
            let [#(#k1),*] = rhs(&c, &g, &self.state, y, u);
            let [#(#k2),*] = rhs(&c, &g, &[#(#xs + h2 * #k1),*], y, u);
            let [#(#k3),*] = rhs(&c, &g, &[#(#xs + h2 * #k2),*], y, u);
            let [#(#k4),*] = rhs(&c, &g, &[#(#xs + dt * #k3),*], y, u);
            self.state = [#(#xs + h6 * (#k1 + 2.0 * #k2 + 2.0 * #k3 + #k4)),*];
        }
    }
}
