// `include` takes one string literal.
qpv_macros::qpv!(include models / paper);

fn main() {}
