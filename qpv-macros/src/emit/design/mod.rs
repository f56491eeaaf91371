//! One `pub mod design<i>` per design request: its certified constants
//! (`ALPHA`, `GAMMA`, `P`, `L`, `CERTIFICATE`), the gain schedule and the
//! observer; or, for a paper-mode reproduction, only its record.

mod docs;
mod gain;
mod observer;

use super::certificate;
use super::tokens::{lit, matrix_lit, num, usize_lit};
use super::{CertifiedDesign, EmitModel};
use proc_macro2::TokenStream;
use qpv_codegen::build::coeffs::Coeffs;
use qpv_codegen::build::equations::Equation;
use quote::{format_ident, quote};

pub(super) use qpv_codegen::Shape;

/// Emits `pub mod design<index>`: the certified constants, `gain` and
/// `Observer`; for a design that certifies nothing (paper mode) only its
/// record. θ-dependent coefficients are interned into `coeffs`.
pub(super) fn emit_design(
    em: &EmitModel<'_>,
    d: &CertifiedDesign,
    index: usize,
    state_eqs: &[Equation],
    out_eqs: &[Equation],
    coeffs: &mut Coeffs,
) -> TokenStream {
    let shape = Shape::of(em.model, em.nv(), d);
    let certificate = certificate::constant(&em.model.name, shape.route(), d);
    if !d.certifies {
        return paper_record(&em.model.name, d, index, shape, &certificate);
    }
    let modname = format_ident!("design{}", index);
    let doc = docs::design(&em.model.name, d, index, shape.filter);
    if d.float == qpv_dsl::Float::F32 {
        return f32_design(em, d, index, (state_eqs, out_eqs), &certificate);
    }
    let constants = certified_constants(d, shape, &certificate);
    let gain = gain::items(d, shape);
    let th = crate::emit::measured::Theta::of(em.model);
    let observer = observer::items(em, index, d, shape, (state_eqs, out_eqs), coeffs, &th);
    quote! {
        #[doc = #doc]
        pub mod #modname {
            use super::{Certificate, Coeffs, NTHETA, NU, NV, NX, NY};

            #constants
            #gain
            #observer
        }
    }
}

/// An f32 design: the same items as an f64 one, plus its own copies of the
/// model-level `THETA_MIN`, `THETA_MAX`, `clamp_theta`, `phi`, `piece`,
/// `mu`, the coefficients and the `plant` module, all in `f32`
/// ([`tokens::to_f32`]), and `F32_ERROR_FLOOR`. The figures are rounded
/// to f32 on their safe side (rates and steps down, bounds up); the
/// `CERTIFICATE` record keeps the f64 values.
fn f32_design(
    em: &EmitModel<'_>,
    d: &CertifiedDesign,
    index: usize,
    (state_eqs, out_eqs): (&[Equation], &[Equation]),
    certificate: &TokenStream,
) -> TokenStream {
    let m = em.model;
    let shape = Shape::of(m, em.nv(), d);
    let modname = format_ident!("design{}", index);
    let doc = docs::design(&m.name, d, index, shape.filter)
        + "\n\n Float: f32. Every value, literal and operation of this module is `f32`; \
           P and the L_l are the f32 values the certificate checked. [`F32_ERROR_FLOOR`] \
           bounds the error that f32 arithmetic alone leaves, even without noise.";
    let d32 = safe_side(d);
    let mut local = Coeffs::default();
    let plant = super::plant::Plant::render(m, (state_eqs, out_eqs), &mut local, &em.libm);
    let constants = certified_constants(&d32, shape, &TokenStream::new());
    let gain = gain::items(&d32, shape);
    let th = crate::emit::measured::Theta::of(m);
    let observer = observer::items(
        em,
        index,
        &d32,
        shape,
        (state_eqs, out_eqs),
        &mut local,
        &th,
    );
    let weights = super::weights::items(m, &em.scheduling, &em.libm);
    let coefficients = super::coefficients::items(&local, m.ntheta(), m.derived.len(), &em.libm);
    let lo: Vec<TokenStream> = m.params.iter().map(|p| lit(p.lo)).collect();
    let hi: Vec<TokenStream> = m.params.iter().map(|p| lit(p.hi)).collect();
    let inf = || quote!(::core::f64::INFINITY);
    let floor = figure(d32.figures.f32_floor, inf());
    let e = d32.figures.f32_euler;
    let euler_floor = figure(e.map(|e| e.base), inf());
    let update = figure(e.map(|e| e.per_step), inf());
    let min_step = figure(e.map(|e| e.min_step), inf());
    let split = d32.figures.f32_rounding;
    let d0 = figure(split.map(|r| r.d0), inf());
    let d1 = figure(split.map(|r| r.d1), inf());
    let rate = figure(split.map(|r| r.rate).filter(|r| *r > 0.0), quote!(0.0));
    let step_floor = match d.sample {
        Some(_) => {
            let v = figure(d32.figures.f32_step_floor, inf());
            quote! {
                /// `Observer::step` at `SAMPLE_PERIOD`, against the plant
                /// stepped by the same Euler step, no noise: lim sup ‖e_k‖ ≤
                /// this, the rounding of the state update included
                /// (docs/embedded.md). Infinite if none is certified.
                pub const F32_STEP_FLOOR: f64 = #v;
            }
        }
        None => quote!(),
    };
    let body = super::tokens::to_f32(
        quote! {
            /// Lower bounds of θ (f32), in declaration order.
            pub const THETA_MIN: [f64; NTHETA] = [#(#lo),*];
            /// Upper bounds of θ (f32), in declaration order.
            pub const THETA_MAX: [f64; NTHETA] = [#(#hi),*];
            /// The certified f32 error floor: with x(t) in F, θ in Θ, the inputs
            /// in their declared ranges and no noise, lim sup ‖e(t)‖ ≤ this,
            /// caused by the f32 rounding of one evaluation of the right-hand
            /// side (a bounded disturbance through the noise bound). The
            /// rounding of the state update x̂ + h·k comes on top. Infinite if
            /// no floor could be certified.
            pub const F32_ERROR_FLOOR: f64 = #floor;
            /// With `step_euler` at `F32_EULER_MIN_STEP < dt <= MAX_STEP_EULER`,
            /// the state update's rounding included:
            /// lim sup ‖e‖ ≤ `F32_EULER_FLOOR + F32_EULER_UPDATE_ROUNDING / dt`
            /// (no noise). Infinite if none is certified.
            pub const F32_EULER_FLOOR: f64 = #euler_floor;
            /// The state update's rounding in the Euler floor (divided by dt).
            pub const F32_EULER_UPDATE_ROUNDING: f64 = #update;
            /// The smallest step (exclusive) of the Euler floor: below it the
            /// update's rounding is too large to certify anything.
            pub const F32_EULER_MIN_STEP: f64 = #min_step;
            /// D₀: the part of the f32 rounding of one right-hand side
            /// evaluation that does not shrink with the error, in the P-norm
            /// (the rounding is d₀ + d₁ρ per state, ρ = √(eᵀPe)). Infinite if
            /// no floor is certified.
            pub const F32_ROUNDING_D0: f64 = #d0;
            /// D₁: the part per unit ρ, in the P-norm; it lowers the rate
            /// the floor is certified with to `F32_RATE` = α − 2D₁.
            pub const F32_ROUNDING_D1: f64 = #d1;
            /// α − 2D₁: the rate the f32 floor is certified with (0: none).
            pub const F32_RATE: f64 = #rate;
            #step_floor
            #constants
            #gain
            #observer
            #weights
            #coefficients
        },
        true,
    );
    let plant = super::tokens::to_f32(plant.module(m.nx(), m.nu()), false);
    quote! {
        #[doc = #doc]
        pub mod #modname {
            use super::{Certificate, NTHETA, NU, NV, NX, NY};

            #body
            #plant
            #certificate
        }
    }
}

/// The figures rounded to f32 on their safe side: α and the steps and
/// amplitudes down, σ and the bounds up (P and L_l are f32 values already).
fn safe_side(d: &CertifiedDesign) -> CertifiedDesign {
    let down = |v: f64| {
        let r = v as f32;
        if f64::from(r) > v {
            f64::from(r.next_down_compat())
        } else {
            f64::from(r)
        }
    };
    let up = |v: f64| -down(-v);
    let mut out = d.clone();
    out.alpha = down(d.alpha);
    let f = &mut out.figures;
    f.sigma = f.sigma.map(up);
    f.error_bound = f.error_bound.map(up);
    f.max_amplitude = f.max_amplitude.map(down);
    f.euler = f.euler.map(|(h, b)| (down(h), down(b)));
    f.rk4 = f.rk4.map(down);
    f.f32_floor = f.f32_floor.map(up);
    f.f32_step_floor = f.f32_step_floor.map(up);
    f.f32_rounding = f.f32_rounding.map(|r| qpv_codegen::design::F32Rounding {
        d0: up(r.d0),
        d1: up(r.d1),
        rate: down(r.rate),
    });
    f.f32_euler = f.f32_euler.map(|e| qpv_codegen::design::EulerFloor {
        base: up(e.base),
        per_step: up(e.per_step),
        min_step: up(e.min_step),
    });
    out
}

/// `f32::next_down` (stable only from Rust 1.86).
trait NextDown {
    fn next_down_compat(self) -> f32;
}

impl NextDown for f32 {
    fn next_down_compat(self) -> f32 {
        if self.is_nan() || self == f32::NEG_INFINITY {
            return self;
        }
        if self == 0.0 {
            return -f32::from_bits(1);
        }
        let b = self.to_bits();
        f32::from_bits(if self > 0.0 { b - 1 } else { b + 1 })
    }
}

/// The record of a paper-mode design: `CERTIFIES = false`, the route, α and
/// γ at which the printed conditions hold, and the certificate; no gain.
fn paper_record(
    model_name: &str,
    d: &CertifiedDesign,
    index: usize,
    shape: Shape,
    certificate: &TokenStream,
) -> TokenStream {
    let modname = format_ident!("design{}", index);
    let (alpha, gamma, route) = (lit(d.alpha), lit(d.gamma), shape.route());
    let doc = format!(
        " Design {index} of model `{model_name}` ({}): a reproduction of the \
         paper's printed conditions, which hold at alpha = {}, gamma = {} but certify \
         nothing (docs/method.md §6). No gain and no observer are generated for it.",
        d.request,
        num(d.alpha),
        num(d.gamma)
    );
    quote! {
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
    }
}

/// The constants of a certified design: route, sizes, filter, α, γ, P,
/// the vertex gains L_l, `CERTIFIES` and the certificate.
fn certified_constants(
    d: &CertifiedDesign,
    shape: Shape,
    certificate: &TokenStream,
) -> TokenStream {
    let Shape { ny, nv, nz, ns, .. } = shape;
    let route = shape.route();
    let (alpha, gamma) = (lit(d.alpha), lit(d.gamma));
    let p = matrix_lit(nz, nz, &d.p);
    let l_vertices: Vec<TokenStream> = (0..nv)
        .map(|l| match d.l.get(l) {
            Some(lv) => matrix_lit(nz, ny, lv),
            None => matrix_lit(nz, ny, &[]),
        })
        .collect();
    let (nz_l, ns_l) = (usize_lit(nz), usize_lit(ns));
    let bits: u32 = match d.float {
        qpv_dsl::Float::F32 => 32,
        qpv_dsl::Float::F64 => 64,
    };
    let noise_consts = noise_constants(d);
    let nz_doc = docs::nz(shape.filter);
    let ns_doc = docs::ns(shape.filter);
    let alpha_doc = match d.sample {
        Some(_) => format!(
            " Certified decay rate per {}: each `Observer::step` (one Euler step of \
             SAMPLE_PERIOD) gives V(e_{{k+1}}) ≤ (1 − SAMPLE_PERIOD·ALPHA) V(e_k), V = eᵀPe.",
            d.time_unit.singular()
        ),
        None => " Certified decay rate: V = eᵀPe satisfies V' ≤ −α V.".to_string(),
    };
    let sample_const = match d.sample {
        Some(h) => {
            let doc = format!(
                " The sample period this design is certified at, {} ({}): \
                 `Observer::step` is one explicit Euler step of exactly this length.",
                d.time_unit.plural(),
                d.sample_text().unwrap_or_default()
            );
            let h = lit(h);
            quote! {
                #[doc = #doc]
                pub const SAMPLE_PERIOD: f64 = #h;
            }
        }
        None => quote!(),
    };
    let alpha_sup = match d.alpha_sup {
        Some(a) => {
            let a = lit(a);
            quote! {
                /// `alpha = max`: the search's estimate of the certified
                /// supremum of α (the fastest α it certified, at another γ
                /// or at a higher gain). An estimate of the supremum, not a
                /// rate this design certifies: that is `ALPHA`.
                pub const ALPHA_SUP: f64 = #a;
            }
        }
        None => quote!(),
    };
    let filter_consts = match shape.filter {
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
    quote! {
        /// The output route of this design: `"double_sum"` or `"filter"`.
        pub const ROUTE: &str = #route;
        #[doc = #nz_doc]
        pub const NZ: usize = #nz_l;
        #[doc = #ns_doc]
        pub const NS: usize = #ns_l;
        #filter_consts
        #[doc = #alpha_doc]
        pub const ALPHA: f64 = #alpha;
        #alpha_sup
        #sample_const
        /// The width of this design's numbers: 32 (`f32`) or 64 (`f64`).
        pub const FLOAT_BITS: u32 = #bits;
        /// Certified region scaling γ.
        pub const GAMMA: f64 = #gamma;
        /// The Lyapunov matrix P (symmetric positive definite), NZ × NZ.
        pub const P: [[f64; NZ]; NZ] = #p;
        /// The vertex gains L_l, NZ × NY each; L(θ) = Σ_l μ_l(θ) L_l.
        pub const L: [[[f64; NY]; NZ]; NV] = [#(#l_vertices),*];
        /// True: the conditions prove V' ≤ −αV on the certified set.
        pub const CERTIFIES: bool = true;
        #noise_consts
        #certificate
    }
}

/// A figure as a literal, or `none` (e.g. `f64::INFINITY` for "no bound").
fn figure(v: Option<f64>, none: TokenStream) -> TokenStream {
    match v {
        Some(x) if x.is_finite() => lit(x),
        _ => none,
    }
}

/// The noise and sampling constants of a certified design, with what each
/// guarantees and under which assumption.
fn noise_constants(d: &CertifiedDesign) -> TokenStream {
    let f = &d.figures;
    let inf = quote!(::core::f64::INFINITY);
    let sigma = figure(f.sigma, inf.clone());
    let bound = figure(f.error_bound, inf.clone());
    // Unlimited (the global observer's claim holds for every e) is ∞.
    let amp = match f.max_amplitude {
        Some(x) if x == f64::INFINITY => inf.clone(),
        other => figure(other, quote!(0.0)),
    };
    let euler = figure(f.euler.map(|e| e.0), quote!(0.0));
    let beta = figure(f.euler.map(|e| e.1), quote!(0.0));
    let rk4 = figure(f.rk4, quote!(0.0));
    let rms = match &f.rms {
        Some((total, per)) => {
            let total = lit(*total);
            let n = per.len();
            let per = per.iter().map(|v| lit(*v));
            quote! {
                /// `noise = rms`: the certified bound on the time-averaged RMS
                /// estimation error √(mean E|e|²) under the design's white noise
                /// (its report's `rms` key), while x stays in F and e in the
                /// region scaled by 1/γ (docs/method.md, "RMS-optimal gains").
                pub const RMS_BOUND: f64 = #total;
                /// The certified RMS bound of each state's error.
                pub const RMS_BOUND_PER_STATE: [f64; #n] = [#(#per),*];
            }
        }
        None => quote!(),
    };
    quote! {
        #rms
        /// Certified noise gain σ: V' + αV ≤ σ(|v|² + |w|²) for the model's
        /// measurement noise v (y_meas = y + v on the declared noisy outputs)
        /// and process disturbances w, on the certified set. Infinite if no
        /// bound could be certified.
        pub const NOISE_SIGMA: f64 = #sigma;
        /// Certified ultimate error bound per unit noise amplitude:
        /// with |v|, |w| ≤ ν (ν ≤ MAX_NOISE_AMPLITUDE), lim sup ‖e(t)‖ ≤
        /// ERROR_BOUND_PER_NOISE · ν, i.e. √(σ/(α λ_min(P))). Infinite if no
        /// bound could be certified.
        pub const ERROR_BOUND_PER_NOISE: f64 = #bound;
        /// ν_max = √(α/σ): up to this noise amplitude the certified set
        /// {eᵀPe ≤ 1} stays invariant, so the bounds above apply. Zero if
        /// no bound could be certified; infinite for the global observer of
        /// an LPV plant, whose bounds hold for every e.
        pub const MAX_NOISE_AMPLITUDE: f64 = #amp;
        /// The certified largest explicit Euler step h: for every step
        /// dt ≤ h, V = eᵀPe contracts by at least (1 − dt·EULER_BETA) per
        /// step at every vertex of the certified family, when the plant and
        /// the observer are discretised by the same Euler step (the
        /// continuous plant sampled by `step_euler` is covered by
        /// simulation, not by this proof). Zero if no step could be proven.
        pub const MAX_STEP_EULER: f64 = #euler;
        /// β of the Euler contraction behind MAX_STEP_EULER (α/2).
        pub const EULER_BETA: f64 = #beta;
        /// An estimate, not a proof: the largest RK4 step for which every
        /// frozen vertex error dynamics stays stable (the RK4 stability
        /// polynomial on its eigenvalues). Zero if none could be estimated.
        pub const STEP_ESTIMATE_RK4: f64 = #rk4;
    }
}
