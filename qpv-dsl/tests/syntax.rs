//! The parser below `parse`: the lexer rules consume whole numbers, names,
//! expressions and matrices and refuse keywords as names; a chain of sums
//! and products becomes flat term and factor lists in left-to-right order;
//! and which names have the shape of a matrix name (A, B, C, N_k, M_k).

use qpv_dsl::__internals::{is_matrix_name_shape, parse_expr, Parser, QpvParser, Rule};
use qpv_dsl::ast::ExprKind;

fn lex(rule: Rule, s: &str) -> bool {
    QpvParser::parse(rule, s)
        .map(|mut p| p.next().map(|p| p.as_str().len()) == Some(s.len()))
        .unwrap_or(false)
}

#[test]
fn lexer_rules_consume_whole_input() {
    for n in ["2", "0.5", ".5", "1e-3", "2.5E+4", "3."] {
        assert!(lex(Rule::number, n), "{n}");
    }
    for i in ["x1", "_a", "th_2", "states", "inx"] {
        assert!(lex(Rule::ident, i), "{i}");
    }
    for k in ["state", "in", "model"] {
        assert!(!lex(Rule::ident, k), "{k}");
    }
    assert!(lex(Rule::expr, "-(4 + th1)*x1 + 0.5*x1^2 - x2/2"));
    assert!(lex(Rule::matrix, "[1, 2; 3, 4;]"));
}

#[test]
fn flattening_keeps_left_to_right_order() {
    let mut p = QpvParser::parse(Rule::expr, "a - b + c * d / e").unwrap();
    let e = parse_expr(p.next().unwrap()).unwrap();
    match e.kind {
        ExprKind::Sum(t) => {
            assert_eq!(t.len(), 3);
            assert!(t[1].0 && !t[2].0);
            assert!(matches!(&t[2].1.kind, ExprKind::Product(f) if f.len() == 3 && f[2].0));
        }
        k => panic!("{k:?}"),
    }
}

#[test]
fn matrix_names() {
    for w in ["A", "B", "C", "N1", "N_2", "M12"] {
        assert!(is_matrix_name_shape(w), "{w}");
    }
    for w in ["N", "Q", "N_", "Na", "stat"] {
        assert!(!is_matrix_name_shape(w), "{w}");
    }
}
