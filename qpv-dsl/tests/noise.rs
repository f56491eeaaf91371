//! The noise declarations: `noise y1, y2;` (the outputs measured with
//! noise; every output by default) and `disturbance w1, w2;` with `B_w` in
//! matrix form or `+ c*w` terms in the `der` equations, carried into the
//! model and its polytopic form (B_w,l per vertex).

use nalgebra::DMatrix;
use qpv_dsl::{parse, Model, NoiseObjective};

fn one(src: &str) -> Model {
    let mut models = parse(src).unwrap_or_else(|e| panic!("{e}"));
    models.remove(0)
}

const MATRIX_FORM: &str = "model m {
    state x1, x2;
    output y1, y2;
    param th in [0, 2];
    disturbance w1, w2;
    noise y2;
    A = [-1, 1; 0, -2];
    B_w = [1, th; 0, 0.5];
    C = [1, 0; 0, 1];
    region box(1);
    design { alpha = 1; gamma = 0.5; noise = min; }
}";

#[test]
fn matrix_form_declarations_reach_the_polytopic_model() {
    let m = one(MATRIX_FORM);
    assert_eq!(m.disturbances, ["w1", "w2"]);
    assert_eq!(m.noise_outputs, Some(vec![1]));
    assert_eq!(m.designs[0].noise, NoiseObjective::Min);
    let p = m.polytopic();
    // th appears only in B_w: it still generates the two vertices
    assert_eq!(p.nv(), 2);
    assert_eq!(p.noise.outputs, Some(vec![1]));
    assert_eq!(p.noise.disturbances, ["w1", "w2"]);
    assert_eq!(p.noise.b_w.len(), 2);
    assert_eq!(
        p.noise.b_w[0],
        DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 0.5])
    );
    assert_eq!(
        p.noise.b_w[1],
        DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 0.0, 0.5])
    );
}

#[test]
fn equation_form_gives_the_same_b_w() {
    let eq = one("model m {
        state x1, x2;
        output y1, y2;
        param th in [0, 2];
        disturbance w1, w2;
        noise y2;
        der x1 = -x1 + x2 + w1 + th*w2;
        der x2 = -2*x2 + 0.5*w2;
        out y1 = x1;
        out y2 = x2;
        region box(1);
        design { alpha = 1; gamma = 0.5; noise = min; }
    }");
    let mat = one(MATRIX_FORM);
    assert_eq!(eq.polytopic().noise, mat.polytopic().noise);
}

#[test]
fn without_declarations_noise_is_on_every_output() {
    let m = one("model m {
        state x1;
        output y;
        A = [-1];
        C = [1];
        region box(1);
    }");
    assert_eq!(m.noise_outputs, None);
    assert!(m.disturbances.is_empty());
    let p = m.polytopic();
    assert_eq!(p.noise, Default::default());
    assert_eq!(m.designs.len(), 0);
}

#[test]
fn noise_free_is_the_default_objective() {
    let m = one("model m {
        state x1;
        output y;
        A = [-1];
        C = [1];
        region box(1);
        design { alpha = 1; }
        design { alpha = 1; noise = free; }
    }");
    assert_eq!(m.designs[0].noise, NoiseObjective::Free);
    assert_eq!(m.designs[1].noise, NoiseObjective::Free);
}

#[test]
fn noise_rms_keys_are_read_with_one_or_several_values() {
    let src = |design: &str| {
        format!(
            "model m {{ state x1, x2; output y1, y2; A = [-1, 1; 0, -2]; C = [1, 0; 0, 1];
               region box(1); state_bound Q = [1, 0; 0, 1]; design {{ {design} }} }}"
        )
    };
    let m = one(&src("noise = rms; output_std = 0.01; noise_period = 1e-3;"));
    let d = &m.designs[0];
    assert_eq!(d.noise, NoiseObjective::Rms);
    assert_eq!(d.output_std, [0.01]);
    assert_eq!(d.noise_period, Some(1e-3));
    assert!(d.process_std.is_empty());
    let m = one(&src(
        "noise = rms; output_std = 0.01, 0.02; process_std = 1e-3; noise_period = 1e-3;",
    ));
    assert_eq!(m.designs[0].output_std, [0.01, 0.02]);
    assert_eq!(m.designs[0].process_std, [1e-3]);
    assert!(m.designs[0].to_string().contains("output_std = 0.01, 0.02"));
    // Positioned errors: a bad value, a missing key, keys without rms.
    let err = |design: &str| parse(&src(design)).unwrap_err().to_string();
    let e = err("noise = rms; output_std = -1; noise_period = 1e-3;");
    // On line 2, where the design block is.
    assert!(e.contains("2:"), "{e}");
    assert!(e.contains("positive standard deviation"), "{e}");
    let e = err("noise = rms; noise_period = 1e-3;");
    assert!(e.contains("needs the output noise"), "{e}");
    let e = err("noise = rms; output_std = 0.01;");
    assert!(e.contains("noise_period"), "{e}");
    let e = err("output_std = 0.01;");
    assert!(e.contains("add `noise = rms;`"), "{e}");
    let e = err("noise = rms; output_std = 0.01; noise_period = 0;");
    assert!(e.contains("positive period"), "{e}");
    let e = err("noise = rms; output_std = 0.01; noise_period = 1e-3; sample = 1e-3;");
    assert!(e.contains("not implemented yet"), "{e}");
}
