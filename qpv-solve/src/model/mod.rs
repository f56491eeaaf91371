//! The polytopic model made ready for the observer: validation, the state
//! bound (given or computed), the output route, the split of N_k and M_k
//! and the skew slack, each a transformation of the [`PolytopicModel`].

pub mod diagnosis;
pub mod jacobian;
pub mod noise;
pub(crate) mod observer;
pub mod output_filter;
pub(crate) mod plant;
pub(crate) mod scaling;
pub mod size;
pub(crate) mod skew;
pub mod state_bound;

pub use observer::{ClaimedBound, ObserverModel, ObserverOptions, StateBoundClaim};
pub use plant::{
    gamma_max, gamma_max_for, global_model, is_double_sum, region_radius, validate, with_split,
    ObserverKind,
};
pub use scaling::StateScaling;
