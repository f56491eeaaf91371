// `th2` is used in A but only `th1` is declared.
qpv_macros::qpv! {
    model m {
        state x1, x2;
        output y1;
        param th1 in [0, 1];
        A = [-1 - th1, 1; 0, -2 + th2];
        N1 = 0;
        N2 = 0;
        C = [1, 0];
        M1 = 0;
        region box(1);
        state_bound Q = [0.1, 0; 0, 0.1];
        design { alpha = 1; gamma = 0.5; }
    }
}

fn main() {}
