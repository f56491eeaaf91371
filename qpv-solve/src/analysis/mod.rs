//! Analysis of a finished design: simulation of plant and observer, and
//! sampling-based falsification of the claimed decay, both on the one
//! reference right-hand side ([`simulate::Frozen`]).

pub mod euler;
pub mod falsify;
pub mod noise;
pub(crate) mod rng;
pub mod sampled;
pub mod simulate;
