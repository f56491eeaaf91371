// `include` takes one string literal.
qpv::qpv!(include models / paper);

fn main() {}
