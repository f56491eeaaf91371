// A missing comma between two state names: the error is on `x2`.
qpv_macros::qpv! {
    model m {
        state x1 x2;
        output y1;
        C = [1, 0];
        region box(1);
        design { alpha = 1; gamma = 0.5; }
    }
}

fn main() {
    // No second error for the module that could not be generated.
    let _ = m::Observer::new();
}
