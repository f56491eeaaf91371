//! qpv facade.
pub use qpv_dsl as dsl;
pub use qpv_solve as solve;
pub use qpv_macros::qpv;
