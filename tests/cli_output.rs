//! What the command line prints adds up: one meaning per count, no region
//! vertices for the global observer, numbers in one readable form, the
//! flags' overrides said, charts whose axes and legends hide no data.

use crate::common::{qpv, text};

#[test]
fn numbers_print_in_one_readable_form() {
    use qpv::dsl::fmt_sig;
    assert_eq!(fmt_sig(0.0, 5), "0");
    assert_eq!(fmt_sig(2.44140625e296, 4), "2.441e296");
    assert_eq!(fmt_sig(1e-300, 3), "1.00e-300");
    assert_eq!(fmt_sig(0.18898, 6), "0.188980");
    assert_eq!(fmt_sig(12.3949, 3), "12.4");
    let info = qpv::solve::GammaSearchInfo {
        gamma_lo: 0.0,
        gamma_hi: 0.18898,
        grid_points: 3,
        points: 4,
        solves: 9,
        local_maxima: Vec::new(),
        continued: 0,
    };
    let s = info.statement();
    assert!(s.contains("γ ∈ [0, 0.188980]"), "{s}");
    // a sample period far off the scale: its rate in exponent form
    for h in ["1e-300", "1e300"] {
        let out = qpv(&[
            "design",
            "examples/paper.qpv",
            "--alpha",
            "5",
            "--gamma",
            "0.18",
            "--sample",
            h,
        ]);
        let all = text(&out);
        let longest = all
            .split(|c: char| !c.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(longest < 20, "a {longest}-digit number:\n{all}");
        assert!(!all.contains("(0 Hz)"), "{all}");
    }
}
