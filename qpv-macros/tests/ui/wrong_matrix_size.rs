// C needs 2 columns (two states); its second row has 3.
qpv_macros::qpv! {
    model m {
        state x1, x2;
        output y1, y2;
        A = [-1, 0; 0, -2];
        N1 = 0;
        N2 = 0;
        C = [1, 0; 0, 1, 0];
        M1 = 0;
        M2 = 0;
        region box(1);
        state_bound Q = [0.1, 0; 0, 0.1];
        design { alpha = 1; gamma = 0.5; }
    }
}

fn main() {}
