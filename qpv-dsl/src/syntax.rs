//! Text → AST: the pest parser (`grammar.pest`), one `parse_<rule>` function
//! per grammar rule that carries meaning, and the translation of pest's
//! errors into human messages ("expected `;`, found `x2`").

use crate::ast::*;
use crate::diagnostic::{levenshtein, line_col, Diag, Span};
use pest::error::{ErrorVariant, InputLocation};
use pest::iterators::{Pair, Pairs};
use pest::pratt_parser::{Assoc, Op, PrattParser};
use pest::Parser;
use std::sync::LazyLock;

/// The pest parser of `grammar.pest` (its rules are [`Rule`]).
#[derive(pest_derive::Parser)]
#[grammar = "grammar.pest"]
pub struct QpvParser;

/// Deepest bracket nesting accepted; checked before pest runs so that neither
/// pest nor the recursive stages after it can exhaust the stack.
pub(crate) const MAX_NESTING: usize = 64;

/// Largest exponent accepted after `^`.
const MAX_EXPONENT: f64 = 64.0;

static PRATT: LazyLock<PrattParser<Rule>> = LazyLock::new(|| {
    PrattParser::new()
        .op(Op::infix(Rule::add, Assoc::Left) | Op::infix(Rule::sub, Assoc::Left))
        .op(Op::infix(Rule::mul, Assoc::Left) | Op::infix(Rule::div, Assoc::Left))
        .op(Op::prefix(Rule::neg) | Op::prefix(Rule::pos))
});

type Result<T> = std::result::Result<T, Diag>;

fn span_of(pair: &Pair<'_, Rule>) -> Span {
    let s = pair.as_span();
    Span::new(s.start(), s.end())
}

/// Punctuation and keyword pairs: present in the tree only so that errors
/// can name them; the AST builder skips them.
fn is_token(rule: Rule) -> bool {
    matches!(
        rule,
        Rule::semi
            | Rule::comma
            | Rule::assign
            | Rule::lbrack
            | Rule::rbrack
            | Rule::lbrace
            | Rule::rbrace
            | Rule::lparen
            | Rule::rparen
            | Rule::caret
            | Rule::kw_model
            | Rule::kw_state
            | Rule::kw_input
            | Rule::kw_output
            | Rule::kw_param
            | Rule::kw_in
            | Rule::kw_der
            | Rule::kw_out
            | Rule::kw_region
            | Rule::kw_box
            | Rule::kw_vertices
            | Rule::kw_halfspaces
            | Rule::kw_zonotope
            | Rule::kw_state_bound
            | Rule::kw_design
            | Rule::kw_noise
            | Rule::kw_time
            | Rule::kw_disturbance
            | Rule::q_name
            | Rule::kw_auto
            | Rule::kw_let
            | Rule::kw_const
            | Rule::kw_cover
            | Rule::kw_into
            | Rule::kw_rate
            | Rule::EOI
    )
}

/// The meaningful children of a pair (tokens skipped).
fn children<'i>(pair: Pair<'i, Rule>) -> impl Iterator<Item = Pair<'i, Rule>> {
    pair.into_inner().filter(|p| !is_token(p.as_rule()))
}

/// A grammar invariant did not hold: a bug in this crate, reported as an
/// error rather than a panic.
fn internal(span: Span, what: &str) -> Diag {
    Diag::new(
        span,
        format!("internal error in the qpv parser ({what}); please report this input"),
    )
}

fn next<'i>(
    it: &mut impl Iterator<Item = Pair<'i, Rule>>,
    span: Span,
    what: &str,
) -> Result<Pair<'i, Rule>> {
    it.next().ok_or_else(|| internal(span, what))
}

// ===================== Entry point =====================

/// Parses a whole input into its syntax tree.
pub(crate) fn parse_file(src: &str) -> Result<File> {
    check_nesting(src)?;
    let mut pairs: Pairs<'_, Rule> =
        QpvParser::parse(Rule::file, src).map_err(|e| pest_error(src, e))?;
    let whole = Span::new(0, src.len());
    let file = next(&mut pairs, whole, "file")?;
    let models = children(file)
        .filter(|p| p.as_rule() == Rule::model)
        .map(parse_model)
        .collect::<Result<Vec<_>>>()?;
    Ok(File { models })
}

/// Rejects bracket nesting deeper than [`MAX_NESTING`] before pest runs.
fn check_nesting(src: &str) -> Result<()> {
    let b = src.as_bytes();
    let mut depth = 0usize;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'/' if b.get(i + 1) == Some(&b'*') => match src[i + 2..].find("*/") {
                Some(k) => i += 2 + k + 1,
                None => return Ok(()), // unterminated comment: pest reports it
            },
            b'(' | b'[' | b'{' => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(Diag::new(
                        Span::new(i, i + 1),
                        format!(
                            "brackets nested too deeply: at most {MAX_NESTING} levels are accepted"
                        ),
                    ));
                }
            }
            b')' | b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
        i += 1;
    }
    Ok(())
}

// ===================== Models and statements =====================

fn parse_model(pair: Pair<'_, Rule>) -> Result<ModelAst> {
    let span = span_of(&pair);
    let close = pair
        .clone()
        .into_inner()
        .filter(|p| p.as_rule() == Rule::rbrace)
        .last()
        .map(|p| span_of(&p))
        .unwrap_or(Span::new(span.end, span.end));
    let mut it = children(pair);
    let name = parse_ident(next(&mut it, span, "model name")?);
    let items = it.map(parse_statement).collect::<Result<Vec<_>>>()?;
    Ok(ModelAst {
        name,
        span,
        items,
        close,
    })
}

fn parse_statement(pair: Pair<'_, Rule>) -> Result<Item> {
    let span = span_of(&pair);
    match pair.as_rule() {
        Rule::state_decl => Ok(Item::States(parse_decl(pair)?)),
        Rule::input_decl => {
            let mut it = children(pair);
            let names = parse_name_list(next(&mut it, span, "input names")?);
            let (mut range, mut rate) = (None, None);
            for p in it {
                match p.as_rule() {
                    Rule::rate_clause => rate = Some(parse_rate(p)?),
                    _ => range = Some(parse_interval(p)?),
                }
            }
            Ok(Item::Inputs(names, range, rate))
        }
        Rule::output_decl => Ok(Item::Outputs(parse_decl(pair)?)),
        Rule::param_decl => Ok(Item::Params(parse_param_decl(pair)?)),
        Rule::matrix_def => Ok(Item::Matrix(parse_matrix_def(pair)?)),
        Rule::der_eq => Ok(Item::Der(parse_equation(pair)?)),
        Rule::out_eq => Ok(Item::Out(parse_equation(pair)?)),
        Rule::region_decl => Ok(Item::Region(parse_region_decl(pair)?)),
        Rule::bound_decl => {
            let mut it = children(pair);
            let inner = next(&mut it, span, "state bound")?;
            let bound = match inner.as_rule() {
                Rule::bound_given => {
                    let ispan = span_of(&inner);
                    let mut it = children(inner);
                    BoundDecl::Given(parse_matrix(next(&mut it, ispan, "state bound matrix")?)?)
                }
                _ => {
                    let options = children(inner)
                        .map(parse_design_entry)
                        .collect::<Result<Vec<_>>>()?;
                    BoundDecl::Auto(options)
                }
            };
            Ok(Item::StateBound(bound, span))
        }
        Rule::design_block => Ok(Item::Design(parse_design_block(pair)?)),
        Rule::noise_decl => Ok(Item::Noise(parse_decl(pair)?, span)),
        Rule::disturbance_decl => Ok(Item::Disturbances(parse_decl(pair)?)),
        Rule::time_decl => {
            let mut it = children(pair).filter(|p| p.as_rule() == Rule::ident);
            let unit = next(&mut it, span, "time unit")?;
            Ok(Item::Time(parse_ident(unit), span))
        }
        Rule::let_decl | Rule::const_decl => {
            let is_let = pair.as_rule() == Rule::let_decl;
            let mut it = children(pair);
            let name = parse_ident(next(&mut it, span, "definition name")?);
            let value = parse_expr(next(&mut it, span, "definition value")?)?;
            Ok(if is_let {
                Item::Let(name, value, span)
            } else {
                Item::Const(name, value, span)
            })
        }
        Rule::cover_decl => {
            let axes = children(pair)
                .map(|axis| {
                    let aspan = span_of(&axis);
                    let mut it = children(axis);
                    let param = parse_ident(next(&mut it, aspan, "covered parameter")?);
                    let pieces = parse_expr(next(&mut it, aspan, "number of pieces")?)?;
                    Ok(CoverAxisAst {
                        param,
                        pieces,
                        span: aspan,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(Item::Cover(axes, span))
        }
        _ => Err(internal(span, "unexpected statement")),
    }
}

/// `state ...;`, `input ...;`, `output ...;`
fn parse_decl(pair: Pair<'_, Rule>) -> Result<Vec<Ident>> {
    let span = span_of(&pair);
    let mut it = children(pair);
    Ok(parse_name_list(next(&mut it, span, "name list")?))
}

fn parse_name_list(pair: Pair<'_, Rule>) -> Vec<Ident> {
    children(pair).map(parse_ident).collect()
}

fn parse_ident(pair: Pair<'_, Rule>) -> Ident {
    Ident {
        name: pair.as_str().to_string(),
        span: span_of(&pair),
    }
}

fn parse_param_decl(pair: Pair<'_, Rule>) -> Result<ParamDecl> {
    let span = span_of(&pair);
    let mut it = children(pair);
    let names = parse_name_list(next(&mut it, span, "parameter names")?);
    let (mut measured, mut range, mut rate) = (None, None, None);
    for p in it {
        match p.as_rule() {
            Rule::measured => {
                let mspan = span_of(&p);
                let mut inner = children(p);
                measured = Some(parse_ident(next(&mut inner, mspan, "output name")?));
            }
            Rule::rate_clause => rate = Some(parse_rate(p)?),
            _ => range = Some(parse_interval(p)?),
        }
    }
    Ok(ParamDecl {
        names,
        measured,
        range,
        rate,
    })
}

/// `rate EXPR`: the bound's expression and the clause's span.
fn parse_rate(pair: Pair<'_, Rule>) -> Result<(Expr, Span)> {
    let span = span_of(&pair);
    let mut it = children(pair);
    let e = parse_expr(next(&mut it, span, "rate bound")?)?;
    Ok((e, span))
}

fn parse_interval(pair: Pair<'_, Rule>) -> Result<(Expr, Expr, Span)> {
    let span = span_of(&pair);
    let mut it = children(pair);
    let lo = parse_expr(next(&mut it, span, "lower bound")?)?;
    let hi = parse_expr(next(&mut it, span, "upper bound")?)?;
    Ok((lo, hi, span))
}

fn parse_matrix_def(pair: Pair<'_, Rule>) -> Result<MatrixDef> {
    let span = span_of(&pair);
    let mut it = children(pair);
    let name = parse_ident(next(&mut it, span, "matrix name")?);
    let value = next(&mut it, span, "matrix value")?;
    let value = match value.as_rule() {
        Rule::matrix => MatrixValue::Literal(parse_matrix(value)?),
        _ => MatrixValue::Scalar(parse_expr(value)?),
    };
    Ok(MatrixDef { name, value, span })
}

fn parse_matrix(pair: Pair<'_, Rule>) -> Result<MatrixLit> {
    let span = span_of(&pair);
    let rows = children(pair).map(parse_row).collect::<Result<Vec<_>>>()?;
    Ok(MatrixLit { rows, span })
}

fn parse_row(pair: Pair<'_, Rule>) -> Result<Row> {
    let span = span_of(&pair);
    let entries = children(pair).map(parse_expr).collect::<Result<Vec<_>>>()?;
    Ok(Row { entries, span })
}

fn parse_vector(pair: Pair<'_, Rule>) -> Result<(Vec<Expr>, Span)> {
    let span = span_of(&pair);
    let entries = children(pair).map(parse_expr).collect::<Result<Vec<_>>>()?;
    Ok((entries, span))
}

fn parse_equation(pair: Pair<'_, Rule>) -> Result<Equation> {
    let span = span_of(&pair);
    let mut it = children(pair);
    let target = parse_ident(next(&mut it, span, "equation target")?);
    let rhs = parse_expr(next(&mut it, span, "equation right-hand side")?)?;
    Ok(Equation { target, rhs, span })
}

fn parse_region_decl(pair: Pair<'_, Rule>) -> Result<RegionDecl> {
    let span = span_of(&pair);
    let mut it = children(pair);
    let shape = next(&mut it, span, "region shape")?;
    let shape = match shape.as_rule() {
        Rule::region_box => parse_region_box(shape)?,
        Rule::region_vertices => {
            let s = span_of(&shape);
            RegionShape::Vertices(parse_matrix(next(&mut children(shape), s, "vertex list")?)?)
        }
        Rule::region_halfspaces => {
            let s = span_of(&shape);
            RegionShape::Halfspaces(parse_matrix(next(&mut children(shape), s, "facet list")?)?)
        }
        Rule::region_zonotope => {
            let s = span_of(&shape);
            RegionShape::Zonotope(parse_matrix(next(
                &mut children(shape),
                s,
                "generator list",
            )?)?)
        }
        _ => return Err(internal(span, "unexpected region shape")),
    };
    Ok(RegionDecl { shape, span })
}

fn parse_region_box(pair: Pair<'_, Rule>) -> Result<RegionShape> {
    let span = span_of(&pair);
    let arg = next(&mut children(pair), span, "box radius")?;
    match arg.as_rule() {
        Rule::vector => {
            let (v, s) = parse_vector(arg)?;
            Ok(RegionShape::BoxVector(v, s))
        }
        _ => Ok(RegionShape::BoxScalar(parse_expr(arg)?)),
    }
}

fn parse_design_block(pair: Pair<'_, Rule>) -> Result<DesignBlock> {
    let span = span_of(&pair);
    let entries = children(pair)
        .map(parse_design_entry)
        .collect::<Result<Vec<_>>>()?;
    Ok(DesignBlock { entries, span })
}

fn parse_design_entry(pair: Pair<'_, Rule>) -> Result<DesignEntry> {
    let span = span_of(&pair);
    let mut it = children(pair);
    let key = parse_ident(next(&mut it, span, "design key")?);
    let value = parse_expr(next(&mut it, span, "design value")?)?;
    // The values in order, each followed by its options, if any.
    let mut values: Vec<(Expr, Option<ValueOptions>)> = vec![(value, None)];
    for child in it {
        if child.as_rule() == Rule::value_options {
            let ospan = span_of(&child);
            let list = children(child)
                .map(parse_design_entry)
                .collect::<Result<Vec<_>>>()?;
            match values.last_mut() {
                Some(last) if last.1.is_none() => last.1 = Some((list, ospan)),
                _ => return Err(internal(ospan, "options without a value")),
            }
        } else {
            values.push((parse_expr(child)?, None));
        }
    }
    let mut values = values.into_iter();
    let (value, options) = values
        .next()
        .ok_or_else(|| internal(span, "design entry without a value"))?;
    Ok(DesignEntry {
        key,
        value,
        options,
        more: values.collect(),
        span,
    })
}

// ===================== Expressions =====================

/// The syntax tree of an `expr` pair: sums and products flattened in
/// left-to-right order.
pub(crate) fn parse_expr(pair: Pair<'_, Rule>) -> Result<Expr> {
    PRATT
        .map_primary(parse_power)
        .map_prefix(|op, rhs| {
            let rhs = rhs?;
            let span = span_of(&op).to(rhs.span);
            Ok(match op.as_rule() {
                Rule::neg => Expr {
                    kind: ExprKind::Neg(Box::new(rhs)),
                    span,
                },
                _ => Expr {
                    kind: rhs.kind,
                    span,
                },
            })
        })
        .map_infix(|lhs, op, rhs| {
            let (lhs, rhs) = (lhs?, rhs?);
            let span = lhs.span.to(rhs.span);
            let (is_sum, flag) = match op.as_rule() {
                Rule::add => (true, false),
                Rule::sub => (true, true),
                Rule::mul => (false, false),
                _ => (false, true),
            };
            let kind = match (is_sum, lhs.kind) {
                (true, ExprKind::Sum(mut terms)) => {
                    terms.push((flag, rhs));
                    ExprKind::Sum(terms)
                }
                (false, ExprKind::Product(mut factors)) => {
                    factors.push((flag, rhs));
                    ExprKind::Product(factors)
                }
                (is_sum, kind) => {
                    let lhs = Expr {
                        kind,
                        span: lhs.span,
                    };
                    if is_sum {
                        ExprKind::Sum(vec![(false, lhs), (flag, rhs)])
                    } else {
                        ExprKind::Product(vec![(false, lhs), (flag, rhs)])
                    }
                }
            };
            Ok(Expr { kind, span })
        })
        .parse(pair.into_inner())
}

fn parse_power(pair: Pair<'_, Rule>) -> Result<Expr> {
    let span = span_of(&pair);
    let mut it = children(pair);
    let base = parse_primary(next(&mut it, span, "operand")?)?;
    match it.next() {
        None => Ok(base),
        Some(exp) => {
            let n = parse_exponent(&exp)?;
            Ok(Expr {
                kind: ExprKind::Pow(Box::new(base), n),
                span,
            })
        }
    }
}

fn parse_exponent(pair: &Pair<'_, Rule>) -> Result<u32> {
    let text = pair.as_str();
    match text.parse::<f64>() {
        Ok(v) if v.fract() == 0.0 && (0.0..=MAX_EXPONENT).contains(&v) => Ok(v as u32),
        _ => Err(Diag::new(
            span_of(pair),
            format!("the exponent of `^` must be a whole number from 0 to {MAX_EXPONENT}, found `{text}`"),
        )),
    }
}

fn parse_primary(pair: Pair<'_, Rule>) -> Result<Expr> {
    let span = span_of(&pair);
    match pair.as_rule() {
        Rule::number => Ok(Expr {
            kind: ExprKind::Number(parse_number(&pair)?),
            span,
        }),
        Rule::ident => Ok(Expr {
            kind: ExprKind::Name(pair.as_str().to_string()),
            span,
        }),
        Rule::call => {
            let mut it = children(pair);
            let fname = next(&mut it, span, "function name")?;
            let fspan = span_of(&fname);
            let arg = parse_expr(next(&mut it, span, "function argument")?)?;
            let Some(f) = crate::func::Func::from_name(fname.as_str()) else {
                return Err(internal(fspan, "unknown function"));
            };
            Ok(Expr {
                kind: ExprKind::Call(f, fspan, Box::new(arg)),
                span,
            })
        }
        Rule::paren => {
            let inner = parse_expr(next(&mut children(pair), span, "parenthesised expression")?)?;
            Ok(Expr {
                kind: inner.kind,
                span,
            })
        }
        _ => Err(internal(span, "unexpected operand")),
    }
}

fn parse_number(pair: &Pair<'_, Rule>) -> Result<f64> {
    match pair.as_str().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(Diag::new(
            span_of(pair),
            format!(
                "the number `{}` is too large (it exceeds the range of a 64-bit float)",
                pair.as_str()
            ),
        )),
    }
}

// ===================== Errors =====================

/// What the parser wanted at the failing position, in words.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Want {
    Model,
    Statement,
    DesignKey,
    BoundOption,
    ValueOption,
    Name,
    Expression,
    Exponent,
    Operator,
    Token(&'static str),
    RegionShape,
    Matrix,
    Interval,
    EndOfInput,
}

fn want(rule: Rule) -> Option<Want> {
    use Want::*;
    Some(match rule {
        Rule::kw_model | Rule::model => Model,
        Rule::kw_state
        | Rule::kw_input
        | Rule::kw_output
        | Rule::kw_param
        | Rule::kw_der
        | Rule::kw_out
        | Rule::kw_region
        | Rule::kw_state_bound
        | Rule::kw_design
        | Rule::kw_noise
        | Rule::kw_disturbance
        | Rule::kw_let
        | Rule::kw_const
        | Rule::kw_cover
        | Rule::cover_decl
        | Rule::let_decl
        | Rule::const_decl
        | Rule::noise_decl
        | Rule::time_decl
        | Rule::kw_time
        | Rule::disturbance_decl
        | Rule::matrix_name
        | Rule::state_decl
        | Rule::input_decl
        | Rule::output_decl
        | Rule::param_decl
        | Rule::der_eq
        | Rule::out_eq
        | Rule::region_decl
        | Rule::bound_decl
        | Rule::design_block
        | Rule::matrix_def => Statement,
        Rule::design_key | Rule::design_entry => DesignKey,
        Rule::bound_key | Rule::bound_option => BoundOption,
        Rule::option_key | Rule::value_option => ValueOption,
        Rule::ident | Rule::name_list => Name,
        Rule::number
        | Rule::call
        | Rule::func_name
        | Rule::paren
        | Rule::expr
        | Rule::power
        | Rule::neg
        | Rule::pos
        | Rule::row => Expression,
        Rule::exponent => Exponent,
        Rule::add | Rule::sub | Rule::mul | Rule::div | Rule::caret => Operator,
        Rule::semi => Token("`;`"),
        Rule::comma => Token("`,`"),
        Rule::assign => Token("`=`"),
        Rule::lbrack | Rule::vector => Token("`[`"),
        Rule::rbrack => Token("`]`"),
        Rule::lbrace => Token("`{`"),
        Rule::rbrace => Token("`}`"),
        Rule::lparen => Token("`(`"),
        Rule::rparen => Token("`)`"),
        Rule::kw_in => Token("`in`"),
        Rule::measured => Token("`=`"),
        Rule::kw_into => Token("`into`"),
        Rule::kw_rate | Rule::rate_clause => Token("`rate`"),
        Rule::cover_axis => Name,
        Rule::q_name | Rule::bound_given => Token("`Q` (write `state_bound Q = [...]`)"),
        Rule::kw_auto | Rule::bound_auto => Token("`auto`"),
        Rule::kw_box
        | Rule::kw_vertices
        | Rule::kw_halfspaces
        | Rule::kw_zonotope
        | Rule::region_box
        | Rule::region_vertices
        | Rule::region_halfspaces
        | Rule::region_zonotope => RegionShape,
        Rule::matrix => Matrix,
        Rule::interval => Interval,
        Rule::EOI => EndOfInput,
        _ => return None,
    })
}

fn want_text(w: Want) -> &'static str {
    match w {
        Want::Model => "a model `model NAME { ... }`",
        Want::Statement => {
            "a statement (`state`, `input`, `output`, `param`, `let`, `const`, `der`, `out`, \
             `region`, `state_bound`, `design`, `noise`, `disturbance`, `cover`, `time` or a \
             matrix such as `A = [...]`)"
        }
        Want::DesignKey => {
            "a design setting (`alpha`, `gamma`, `mode`, `split`, `conditions`, `output_route` \
             or `noise`)"
        }
        Want::BoundOption => "a state bound option (`h = ...`)",
        Want::ValueOption => "an option `name = value` (e.g. `pole = 40`)",
        Want::Name => "a name",
        Want::Expression => "an expression (a number, a name or `(`)",
        Want::Exponent => "a whole-number exponent",
        Want::Operator => "an operator (`+ - * / ^`)",
        Want::Token(t) => t,
        Want::RegionShape => "`box(...)`, `vertices [...]`, `halfspaces [...]` or `zonotope [...]`",
        Want::Matrix => "a matrix `[...]`",
        Want::Interval => "an interval `[lo, hi]`",
        Want::EndOfInput => "the end of the input",
    }
}

/// "a, b or c"
fn join_or(items: &[&str]) -> String {
    match items {
        [] => String::new(),
        [one] => one.to_string(),
        [init @ .., last] => format!("{} or {}", init.join(", "), last),
    }
}

const KEYWORDS: &[&str] = &[
    "model",
    "state_bound",
    "state",
    "input",
    "output",
    "param",
    "der",
    "out",
    "region",
    "design",
    "in",
];

const STATEMENT_KEYWORDS: &[&str] = &[
    "state",
    "input",
    "output",
    "param",
    "der",
    "out",
    "region",
    "state_bound",
    "design",
    "noise",
    "disturbance",
    "let",
    "const",
    "cover",
    "time",
];

fn is_ident_start(c: char) -> bool {
    c.is_ascii_alphabetic() || c == '_'
}

fn is_ident_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The token at byte `pos` of `src`: its span and a description.
fn found_token(src: &str, pos: usize) -> (Span, String) {
    let pos = pos.min(src.len());
    let rest = &src[pos..];
    let Some(c) = rest.chars().next() else {
        return (Span::new(pos, pos), "the end of the input".into());
    };
    let len = if is_ident_start(c) {
        rest.find(|ch: char| !is_ident_char(ch))
            .unwrap_or(rest.len())
    } else if c.is_ascii_digit()
        || (c == '.' && rest[1..].starts_with(|d: char| d.is_ascii_digit()))
    {
        rest.find(|ch: char| !(ch.is_ascii_alphanumeric() || ch == '.'))
            .unwrap_or(rest.len())
    } else if rest.starts_with("/*") {
        2
    } else {
        c.len_utf8()
    };
    let text = &rest[..len];
    let span = Span::new(pos, pos + len);
    let desc = if KEYWORDS.contains(&text) {
        format!("the keyword `{text}`")
    } else {
        format!("`{}`", text.escape_debug())
    };
    (span, desc)
}

/// The word ending just before `pos` (skipping whitespace), if any.
fn word_before(src: &str, pos: usize) -> Option<(Span, &str)> {
    let head = src.get(..pos)?;
    let trimmed = head.trim_end();
    let start = trimmed
        .char_indices()
        .rev()
        .find(|(_, c)| !is_ident_char(*c))
        .map(|(i, c)| i + c.len_utf8())
        .unwrap_or(0);
    let w = &trimmed[start..];
    if w.is_empty() || !w.starts_with(is_ident_start) {
        return None;
    }
    Some((Span::new(start, trimmed.len()), w))
}

/// The innermost bracket still open at the end of `src` (comments skipped).
fn unclosed_bracket(src: &str) -> Option<(usize, char)> {
    let b = src.as_bytes();
    let mut stack = Vec::new();
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'/' if b.get(i + 1) == Some(&b'*') => match src[i + 2..].find("*/") {
                Some(k) => i += 2 + k + 1,
                None => break,
            },
            c @ (b'(' | b'[' | b'{') => stack.push((i, c as char)),
            b')' | b']' | b'}' => {
                stack.pop();
            }
            _ => {}
        }
        i += 1;
    }
    stack.pop()
}

/// Rewrites a pest error as a positioned human message.
fn pest_error(src: &str, e: pest::error::Error<Rule>) -> Diag {
    let pos = match e.location {
        InputLocation::Pos(p) => p,
        InputLocation::Span((s, _)) => s,
    };
    let (span, found) = found_token(src, pos);
    let positives = match &e.variant {
        ErrorVariant::ParsingError { positives, .. } => positives.clone(),
        ErrorVariant::CustomError { message } => {
            return Diag::new(span, format!("the input could not be parsed: {message}"));
        }
    };
    let found_text = span.text(src);

    if found_text == "/*" {
        return Diag::new(span, "unterminated comment: `/*` has no closing `*/`");
    }

    let mut wants: Vec<Want> = positives.iter().filter_map(|r| want(*r)).collect();
    wants.sort();
    wants.dedup();

    // A mistyped statement keyword parses as a matrix name, so the parser then
    // wants `=`: say what is really wrong.
    if wants == [Want::Token("`=`")] {
        if let Some((wspan, w)) = word_before(src, pos) {
            let before = src[..wspan.start].trim_end();
            let at_statement_start =
                before.ends_with(';') || before.ends_with('{') || before.ends_with('}');
            if at_statement_start && !is_matrix_name_shape(w) {
                let suggestion = STATEMENT_KEYWORDS
                    .iter()
                    .map(|k| (levenshtein(w, k), *k))
                    .filter(|(d, _)| *d <= 2)
                    .min();
                let msg = match suggestion {
                    Some((_, k)) => format!("unknown statement `{w}`: did you mean `{k}`?"),
                    None => format!(
                        "unknown statement `{w}`: a statement starts with `state`, `input`, `output`, \
                         `param`, `let`, `const`, `der`, `out`, `region`, `state_bound`, `design`, \
                         `noise`, `disturbance`, `cover` or `time`, or is a matrix definition \
                         such as `A = [...];`"
                    ),
                };
                return Diag::new(wspan, msg);
            }
        }
    }

    let expected: Vec<&str> = wants.iter().map(|w| want_text(*w)).collect();
    let mut msg = if expected.is_empty() {
        format!("unexpected {found}")
    } else {
        format!("expected {}, found {found}", join_or(&expected))
    };

    let prev = src[..pos].chars().last();
    if let (true, "(", Some((wspan, w))) = (
        wants.contains(&Want::Operator),
        found_text,
        word_before(src, pos),
    ) {
        if wspan.end == pos || src[wspan.end..pos].trim().is_empty() {
            return unknown_function(wspan, w);
        }
    }
    if wants.contains(&Want::Operator)
        && found_text.starts_with(is_ident_start)
        && prev.is_some_and(|c| c.is_ascii_digit() || c == '.')
    {
        msg.push_str(" (write multiplication explicitly, e.g. `2*x1`)");
    } else if wants.contains(&Want::Expression) && found_text == "[" {
        msg.push_str(" (matrix rows are separated by `;`, e.g. `[1, 2; 3, 4]`)");
    } else if found_text.chars().next().is_some_and(|c| !c.is_ascii()) {
        msg.push_str(" (names use ASCII letters, digits and `_`, e.g. `th1`)");
    } else if pos >= src.len() {
        if let Some((at, c)) = unclosed_bracket(src) {
            let (l, col) = line_col(src, at);
            msg.push_str(&format!(" (the `{c}` at {l}:{col} is never closed)"));
        }
    }
    Diag::new(span, msg)
}

/// `name(` where no function of that name exists.
fn unknown_function(span: Span, w: &str) -> Diag {
    let names: Vec<&str> = crate::func::Func::ALL.iter().map(|f| f.name()).collect();
    let hint = crate::diagnostic::suggest(w, names.iter().copied())
        .map(|s| format!(" (did you mean `{s}`?)"))
        .unwrap_or_default();
    let list: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    let list: Vec<&str> = list.iter().map(|s| s.as_str()).collect();
    Diag::new(
        span,
        format!(
            "unknown function `{w}`{hint}: the functions are {}; to multiply, write `{w}*(...)`",
            join_or(&list)
        ),
    )
}

/// True for names that can denote a matrix: A, B, C, `N<k>`, `M<k>` (with or
/// without `_` before k).
pub fn is_matrix_name_shape(w: &str) -> bool {
    matches!(w, "A" | "B" | "B_w" | "C")
        || ((w.starts_with('N') || w.starts_with('M'))
            && w.len() > 1
            && w[1..]
                .trim_start_matches('_')
                .chars()
                .all(|c| c.is_ascii_digit())
            && !w[1..].trim_start_matches('_').is_empty())
}
