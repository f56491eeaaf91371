//! Analysis of a finished design: simulation of plant and observer (RK4,
//! Euler, sampled) and their verdicts, and sampling-based falsification of
//! the claimed decay, all on the one reference right-hand side
//! ([`rhs::Frozen`]).

mod checks;
pub mod continuous;
mod envelope;
pub mod euler;
pub mod falsify;
mod integrate;
pub mod noise;
pub(crate) mod rhs;
pub(crate) mod rng;
pub mod sampled;
mod scenario;
pub mod simulate;
mod trajectory;
