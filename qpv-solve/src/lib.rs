//! LMI synthesis with Clarabel, independent certification and simulation of
//! QPV observers: `PolytopicModel` + design request → certified `Design`.

#[cfg(feature = "pure-lapack")]
pub mod lapack;

pub mod certificate;
pub mod conditions;
pub mod falsify;
pub mod report;
pub mod sdp;
pub mod search;
pub mod simulate;
