//! The range of a scheduling function on a parameter box (interval
//! arithmetic refined by bisection): it contains the function's values and
//! is tight to 1e-5, and a function that is undefined or unbounded
//! somewhere on the box (1/θ across 0, ln from 0, tan past π/2) is an
//! error that names a point where it fails.

use qpv_dsl::__internals::range;
use qpv_dsl::{Func, SchedExpr};

fn names() -> Vec<String> {
    vec!["th".into(), "q".into()]
}

#[test]
fn ranges_contain_samples_and_are_tight() {
    let th = || Box::new(SchedExpr::Param(0));
    let cases = [
        (SchedExpr::Pow(th(), 2), (-1.0, 2.0), (0.0, 4.0)),
        (SchedExpr::Call(Func::Sin, th()), (0.0, 3.0), (0.0, 1.0)),
        (
            SchedExpr::Call(Func::Cos, th()),
            (-1.0, 1.0),
            (1f64.cos(), 1.0),
        ),
        (
            SchedExpr::Product(vec![
                (false, SchedExpr::Num(1.0)),
                (true, SchedExpr::Param(0)),
            ]),
            (1.0, 4.0),
            (0.25, 1.0),
        ),
    ];
    for (e, b, (lo, hi)) in cases {
        let (l, h, info) = range(&e, &[b, (0.0, 1.0)], &names()).unwrap();
        assert!(l <= lo && h >= hi, "{e:?}: [{l}, {h}] vs [{lo}, {hi}]");
        assert!(lo - l <= 1e-5 && h - hi <= 1e-5, "{e:?}: {info:?}");
    }
}

#[test]
fn undefined_functions_are_reported() {
    let inv = SchedExpr::Product(vec![
        (false, SchedExpr::Num(1.0)),
        (true, SchedExpr::Param(0)),
    ]);
    let err = range(&inv, &[(-1.0, 1.0), (0.0, 1.0)], &names()).unwrap_err();
    assert!(err.contains("th = 0"), "{err}");
    let ln = SchedExpr::Call(Func::Ln, Box::new(SchedExpr::Param(0)));
    assert!(range(&ln, &[(0.0, 1.0), (0.0, 1.0)], &names()).is_err());
    let tan = SchedExpr::Call(Func::Tan, Box::new(SchedExpr::Param(0)));
    assert!(range(&tan, &[(0.0, 2.0), (0.0, 1.0)], &names()).is_err());
    assert!(range(&tan, &[(0.0, 1.5), (0.0, 1.0)], &names()).is_ok());
}
