//! `poles = ...` in a design block: the three region kinds, lists of them,
//! the request's written form, and positioned errors for every bad value.

use qpv_dsl::{parse, Clash, DesignRequest, Mode, PoleRegion};

const BASE: &str = "model m {
    state x1, x2;
    output y;
    param th in [0, 1];
    A = [-1, th; 0, -2];
    C = [1, 0];
    DESIGN
}
";

fn poles(design: &str) -> Vec<PoleRegion> {
    let src = BASE.replace("DESIGN", design);
    let mut models = parse(&src).unwrap_or_else(|e| panic!("{design}: {e}"));
    models.remove(0).designs.remove(0).poles
}

/// The error of `design`, with the (line, column) it points at and the
/// text at that position.
fn error(design: &str) -> (String, usize, usize, String) {
    let src = BASE.replace("DESIGN", design);
    let e = parse(&src).expect_err(design);
    let at = src[e.span.start..e.span.end].to_string();
    (e.message.clone(), e.line, e.column, at)
}

#[test]
fn each_region_kind_parses() {
    assert_eq!(
        poles("design { poles = disk(centre = -5, radius = 4); }"),
        vec![PoleRegion::Disk {
            centre: -5.0,
            radius: 4.0
        }]
    );
    assert_eq!(
        poles("design { poles = sector(angle = 45); }"),
        vec![PoleRegion::Sector { angle: 45.0 }]
    );
    // Constant expressions, options in any order, a trailing comma.
    assert_eq!(
        poles("design { poles = strip(hi = -1/2, lo = -20,); }"),
        vec![PoleRegion::Strip {
            lo: -20.0,
            hi: -0.5
        }]
    );
    assert!(poles("design { alpha = 1; }").is_empty());
}

#[test]
fn a_list_of_regions_is_their_intersection_in_order() {
    let p = poles("design { alpha = 1; poles = disk(centre = -5, radius = 5), sector(angle = 60), strip(lo = -9, hi = -1); }");
    assert_eq!(p.len(), 3);
    assert_eq!(p[0].name(), "disk");
    assert_eq!(p[1], PoleRegion::Sector { angle: 60.0 });
    assert_eq!(p[2], PoleRegion::Strip { lo: -9.0, hi: -1.0 });
    // Membership, as the tests of the solver use it.
    assert!(p[0].contains(-5.0, 4.9) && !p[0].contains(-5.0, 5.0));
    assert!(p[1].contains(-1.0, 1.7) && !p[1].contains(-1.0, 1.8));
    assert!(p[2].contains(-2.0, 100.0) && !p[2].contains(-0.5, 0.0));
}

#[test]
fn the_request_is_written_with_its_regions() {
    let src = BASE.replace(
        "DESIGN",
        "design { alpha = 2; poles = disk(centre = -3, radius = 2), sector(angle = 30); }",
    );
    let m = parse(&src).unwrap().remove(0);
    let text = m.designs[0].to_string();
    assert!(
        text.ends_with("; poles = disk(centre = -3, radius = 2), sector(angle = 30)"),
        "{text}"
    );
    // The written form parses back to the same request.
    let again = BASE.replace("DESIGN", &format!("design {{ {text}; }}"));
    let m2 = parse(&again).unwrap().remove(0);
    assert_eq!(m2.designs[0].poles, m.designs[0].poles);
}

#[test]
fn bad_regions_are_positioned_errors() {
    // Negative radius: at the value.
    let (msg, line, col, at) = error("design { poles = disk(centre = -1, radius = -2); }");
    assert!(msg.contains("`radius` must be a positive number"), "{msg}");
    assert_eq!((line, at.as_str()), (7, "-2"));
    assert!(col > 40, "{col}");
    // Angle outside (0, 90).
    for bad in ["0", "90", "120", "-10"] {
        let (msg, _, _, at) = error(&format!("design {{ poles = sector(angle = {bad}); }}"));
        assert!(msg.contains("strictly between 0 and 90"), "{bad}: {msg}");
        assert_eq!(at, bad);
    }
    // a ≥ b.
    let (msg, _, _, at) = error("design { poles = strip(lo = -1, hi = -2); }");
    assert!(
        msg.contains("needs a < b") && msg.contains("lo = -1"),
        "{msg}"
    );
    assert_eq!(at, "-2");
    let (msg, _, _, _) = error("design { poles = strip(lo = 3, hi = 3); }");
    assert!(msg.contains("needs a < b"), "{msg}");
    // Unknown kind, with what was expected.
    let (msg, _, _, at) = error("design { poles = circle(centre = 1, radius = 2); }");
    assert!(
        msg.contains("`poles` must be `disk(centre = c, radius = r)`"),
        "{msg}"
    );
    assert_eq!(at, "circle");
    // Unknown option, with a suggestion.
    let (msg, _, _, at) = error("design { poles = disk(center = -1, radius = 2); }");
    assert!(msg.contains("unknown option `center` of `disk`"), "{msg}");
    assert!(msg.contains("did you mean `centre`"), "{msg}");
    assert_eq!(at, "center");
    // A missing option, at the parentheses.
    let (msg, _, _, at) = error("design { poles = disk(radius = 2); }");
    assert!(msg.contains("`disk` needs `centre = ..`"), "{msg}");
    assert_eq!(at, "(radius = 2)");
    // No parentheses at all.
    let (msg, _, _, at) = error("design { poles = sector; }");
    assert!(
        msg.contains("`sector` needs its options in parentheses"),
        "{msg}"
    );
    assert_eq!(at, "sector");
    // An option twice.
    let (msg, _, _, at) = error("design { poles = sector(angle = 10, angle = 20); }");
    assert!(msg.contains("`angle` is set twice"), "{msg}");
    assert_eq!(at, "angle");
    // A parameter is not a constant.
    let (msg, _, _, _) = error("design { poles = disk(centre = th, radius = 1); }");
    assert!(msg.contains("centre"), "{msg}");
    // A list for another key.
    let (msg, _, _, at) = error("design { alpha = 1, 2; }");
    assert!(msg.contains("`alpha` takes one value"), "{msg}");
    assert_eq!(at, "2");
    // `poles` set twice in one block.
    let (msg, _, _, _) =
        error("design { poles = sector(angle = 10); poles = disk(centre = -1, radius = 1); }");
    assert!(msg.contains("`poles` is set twice"), "{msg}");
}

#[test]
fn poles_clash_with_what_has_no_pole_blocks() {
    let base = DesignRequest {
        poles: vec![PoleRegion::Sector { angle: 45.0 }],
        ..DesignRequest::default()
    };
    assert_eq!(base.validate(), Ok(()));
    let paper = DesignRequest {
        mode: Mode::Paper,
        split: qpv_dsl::Split::AsWritten,
        ..base.clone()
    };
    assert_eq!(paper.validate(), Err(Clash::PolesPaper));
    let sampled = DesignRequest {
        sample: Some(1e-3),
        ..base
    };
    assert_eq!(sampled.validate(), Err(Clash::PolesSample));
    // The language refuses at the `poles` key.
    let (msg, _, _, at) = error("design { alpha = 1; noise = min; poles = sector(angle = 45); }");
    assert!(
        msg.contains("`poles` cannot be combined with `noise = min`"),
        "{msg}"
    );
    assert_eq!(at, "poles");
}
