// The paper's example in sound mode at the paper's gamma = 0.4: (S4) fails
// for the paper's Q (gamma_max = 0.18898), so no gain may be baked. The error
// is on the design block. The failure is structural (the data alone decide
// it), so the message names the limit and runs no search: its numbers
// depend on Q and gamma only.
qpv_macros::qpv! {
    model paper {
        state  x1, x2, x3;
        output y1, y2;
        param  th1 in [0, 1];
        param  th2 in [0, 1];
        A  = [ -4 - th1, 10, 2 + 2*th2 ; -1, -1 - th2, 1.5 + 2*th1 ; 1, 1, -4 - 3*th1 ];
        N1 = [ 0.5, 1 + th1, 0 ;  0, 0, -th2 ;  0, 1 + th2, 0 ];
        N2 = [ -0.4, 0, 1 - th1 ;  1.5, 0, 1 + th2 ;  2 + th2, 0, 0 ];
        N3 = [ 1.5, -0.5 - th1, 0 ;  3 + th1, 0, 0 ;  0, 2 - th2, 0 ];
        C  = [ 1, 0, 0 ; 0, 1, 0 ];
        M1 = [ 0, 0, 0 ; 0, 0, 1 ; 0, 0, 0 ];
        M2 = [ 0, 0, 1 ; 0, 0, 0 ; 0, 0, 0 ];
        region box(0.02);
        state_bound Q = [ 0.0112, 0.0017, 0.0006 ; 0.0017, 0.0025, -0.0022 ; 0.0006, -0.0022, 0.0061 ];
        design { alpha = 10; gamma = 0.4; mode = sound; }
    }
}

fn main() {
    // Uses of the module do not add errors: the macro leaves a stub.
    let _ = paper::Observer::new().estimate();
}
