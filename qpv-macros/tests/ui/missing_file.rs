// The include path is relative to the crate's Cargo.toml; this file does not
// exist, and the error is on the string literal.
qpv_macros::qpv!(include "models/does_not_exist.qpv");

fn main() {}
