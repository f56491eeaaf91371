//! A `#![no_std]` crate that uses `qpv!`: it compiles only if the generated
//! observer needs nothing but `core` (no `std`, no `alloc`, no heap).

#![no_std]
#![deny(missing_docs, unsafe_code)]

qpv_macros::qpv!(include "paper_sound.qpv");

/// One RK4 step of the generated observer, as firmware would call it.
pub fn observer_step(
    obs: &mut paper_sound::Observer,
    dt: f64,
    y: &[f64; paper_sound::NY],
    theta: &[f64; paper_sound::NTHETA],
) -> [f64; paper_sound::NX] {
    obs.step_rk4(dt, y, &[], theta);
    obs.estimate()
}

/// The plant's output, evaluated without `std`.
pub fn plant_output(
    x: &[f64; paper_sound::NX],
    theta: &[f64; paper_sound::NTHETA],
) -> [f64; paper_sound::NY] {
    paper_sound::plant::output(x, theta)
}

/// The certified decay rate, usable in `const` context.
pub const ALPHA: f64 = paper_sound::ALPHA;

qpv_macros::qpv!(include "theta_filter.qpv");

/// One RK4 step of a filter-route observer (state x̂, x̂_y, x_y), without `std`.
pub fn filter_observer_step(
    obs: &mut theta_filter::Observer,
    dt: f64,
    y: &[f64; theta_filter::NY],
    theta: &[f64; theta_filter::NTHETA],
) -> [f64; theta_filter::NS] {
    obs.step_rk4(dt, y, &[], theta);
    obs.state()
}

qpv_macros::qpv!(include "scheduling_functions.qpv");

/// The derived scheduling variables and the gain of a model with scheduling
/// functions (sin, cos, a quotient), computed without `std`.
pub fn scheduled_gain(
    theta: &[f64; scheduling_functions::NTHETA],
) -> (
    [f64; scheduling_functions::NPHI],
    [[f64; scheduling_functions::NY]; scheduling_functions::NX],
) {
    (
        scheduling_functions::phi(theta),
        scheduling_functions::gain(theta),
    )
}
