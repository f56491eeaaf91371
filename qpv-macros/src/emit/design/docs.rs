//! The documentation text of a design module and of its observer: what
//! was certified, the output route, and the meaning of the state.

use crate::emit::tokens::num;
use crate::emit::CertifiedDesign;
use qpv_dsl::OutputFilter;

/// The doc of `design<index>`: the request, the certified (α, γ), the route.
pub(super) fn design(
    model_name: &str,
    d: &CertifiedDesign,
    index: usize,
    filter: Option<OutputFilter>,
) -> String {
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
    let sample_doc = match d.sample_text() {
        Some(t) => format!(
            " Certified at {t}: the observer stepped by one explicit Euler step of exactly \
             [`SAMPLE_PERIOD`] ([`Observer::step`]) against the plant stepped by the same \
             Euler step gives V(e_{{k+1}}) ≤ {} V(e_k) (1 − hα; family S5d of the certificate \
             in place of S5, docs/method.md §16). A continuous plant between samples is not \
             covered by this proof.\n\n",
            num(1.0 - d.sample.unwrap_or(0.0) * d.alpha)
        ),
        None => String::new(),
    };
    format!(
        " Design {index} of model `{model_name}`: {}. Certified alpha = {}, gamma = {}.\n\n{sample_doc}{route_doc}",
        d.request,
        num(d.alpha),
        num(d.gamma)
    )
}

/// The doc of `Observer`: its equations, its state and how θ is handled.
pub(super) fn observer(model_name: &str, index: usize, filter: Option<OutputFilter>) -> String {
    let equations = match filter {
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
    };
    equations
        .replace("MODEL", model_name)
        .replace("INDEX", &index.to_string())
        + " θ is clamped into Θ (NaN → lower bound) before use; `step_euler`/`step_rk4` count \
           the steps where that happened ([`Observer::clamped`]). NaN in y or u propagates \
           into the estimate; nothing here can panic or allocate."
}

/// The doc of `NZ`.
pub(super) fn nz(filter: Option<OutputFilter>) -> &'static str {
    if filter.is_some() {
        " Size of the design's state z = (x, x_y): NX + NY (P is NZ × NZ, L_l is NZ × NY)."
    } else {
        " Size of the design's state: NX (P is NZ × NZ, L_l is NZ × NY)."
    }
}

/// The doc of `NS` (the constant and `Observer::NS`).
pub(super) fn ns(filter: Option<OutputFilter>) -> &'static str {
    if filter.is_some() {
        " Size of the observer's state (x̂, x̂_y, x_y): NX + 2·NY."
    } else {
        " Size of the observer's state x̂: NX."
    }
}

/// The doc of `Observer::from_state`.
pub(super) fn from_state(filter: Option<OutputFilter>) -> &'static str {
    if filter.is_some() {
        " An observer with the whole state (x̂, x̂_y, x_y) given. The certificate \
         assumes x̂_y(0) = x_y(0); `with_state` is the usual start."
    } else {
        " An observer with the whole state given (the same as `with_state` for this route)."
    }
}
