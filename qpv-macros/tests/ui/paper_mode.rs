// Paper mode reproduces the published conditions, which certify nothing:
// a model with only a paper-mode design gets no observer (the error is on
// the design block and suggests a sound design). Without a state bound no
// sound design can be attempted, so the message names that reason instead
// of running a search for the best sound design (which the macro's unit
// tests check on the paper's model with its Q).
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
        design { alpha = 10; gamma = 0.4; mode = paper; }
    }
}

fn main() {}
