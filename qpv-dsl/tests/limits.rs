//! Input size bounds: an over-long text, an expression that would expand
//! past the term limit, a region with too many rows and coefficients that
//! overflow are refused with positioned errors, and a text just under the
//! size limit still parses.

use qpv_dsl::{diagnostic::line_col, parse, MAX_SOURCE_BYTES};

fn model(body: &str) -> String {
    format!("model m {{\n    state x1, x2;\n    output y;\n    C = [1, 0];\n{body}\n}}\n")
}

#[test]
fn text_over_the_size_limit_is_refused_at_its_start() {
    let long = model(&format!(
        "    der x1 = -x1{};\n    der x2 = -x2;\n    region box(1);",
        " + 0*x2".repeat(MAX_SOURCE_BYTES / 7)
    ));
    assert!(long.len() > MAX_SOURCE_BYTES);
    let e = parse(&long).unwrap_err();
    assert_eq!((e.line, e.column), (1, 1));
    assert_eq!(line_col(&long, e.span.start), (1, 1));
    assert!(
        e.message
            .contains(&format!("at most {MAX_SOURCE_BYTES} bytes (1 MiB)")),
        "{}",
        e.message
    );
    assert!(e.excerpt.len() <= 80, "the excerpt stays short");
}

#[test]
fn text_just_under_the_size_limit_parses() {
    // one long expression: x1 + x1 + ... (each `+ x1` is 5 bytes)
    let terms = (MAX_SOURCE_BYTES - 200) / 5;
    let src = model(&format!(
        "    der x1 = -x1{};\n    der x2 = -x2;\n    region box(1);",
        " + x1".repeat(terms)
    ));
    assert!(src.len() <= MAX_SOURCE_BYTES);
    let m = parse(&src)
        .unwrap_or_else(|e| panic!("{}", e.message))
        .remove(0);
    assert_eq!(m.eval_a(&[])[(0, 0)], terms as f64 - 1.0);
}

#[test]
fn a_product_that_would_explode_stops_at_the_term_limit() {
    // two factors of 4096 terms each: the product would have 2^24 terms
    let params: Vec<String> = (1..=24).map(|i| format!("th{i}")).collect();
    let group = |r: std::ops::Range<usize>| {
        r.map(|i| format!("(1 + {})", params[i]))
            .collect::<Vec<_>>()
            .join("*")
    };
    let src = model(&format!(
        "    param {} in [0, 1];\n    A = [-1, ({})*({}); 0, -2];\n    region box(1);",
        params.join(", "),
        group(0..12),
        group(12..24)
    ));
    let e = parse(&src).unwrap_err();
    assert!(
        e.message.contains("expands to more than 4096 terms"),
        "{}",
        e.message
    );
    assert_eq!(e.line, 6);
}

#[test]
fn a_region_with_too_many_rows_is_refused_at_the_first_extra_row() {
    let rows: Vec<String> = (0..5000)
        .map(|i| {
            let t = i as f64 * 2.0 * std::f64::consts::PI / 5000.0;
            format!("{:.6}, {:.6}", t.cos(), t.sin())
        })
        .collect();
    let src = model(&format!(
        "    A = [-1, 0; 0, -2];\n    region vertices [\n{}\n    ];",
        rows.join(";\n")
    ));
    let e = parse(&src).unwrap_err();
    assert!(
        e.message
            .contains("the region lists 5000 rows: at most 4096 vertex rows"),
        "{}",
        e.message
    );
    // row 4097 is on line 6 + 4097 of the text
    assert_eq!(e.line, 6 + 4097);
}

#[test]
fn too_many_models_are_refused_at_the_first_extra_one() {
    let one = |i: usize| {
        format!("model m{i} {{ state x; output y; A = [-1]; C = [1]; region box(1); }}\n")
    };
    let src: String = (0..70).map(one).collect();
    let e = parse(&src).unwrap_err();
    assert!(
        e.message
            .contains("the text defines 70 models: at most 64 are supported"),
        "{}",
        e.message
    );
    assert_eq!((e.line, e.column), (65, 7));
    let fine: String = (0..64).map(one).collect();
    assert_eq!(parse(&fine).map(|m| m.len()), Ok(64));
}
