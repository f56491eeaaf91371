//! The syntax tree: plain data built from the pest pairs by `syntax.rs`, one
//! node per grammar rule that carries meaning, every node with its byte span.

use crate::diagnostic::Span;

/// A name as written, with its span.
#[derive(Debug, Clone, PartialEq)]
pub struct Ident {
    /// The name.
    pub name: String,
    /// Where it is written.
    pub span: Span,
}

/// A whole input: one or more models.
#[derive(Debug, Clone, PartialEq)]
pub struct File {
    /// The `model` blocks in source order.
    pub models: Vec<ModelAst>,
}

/// One `model NAME { ... }` block.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelAst {
    /// The model's name.
    pub name: Ident,
    /// The whole block.
    pub span: Span,
    /// The statements in source order.
    pub items: Vec<Item>,
    /// The closing `}`.
    pub close: Span,
}

/// One statement inside a model.
#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    /// `state x1, x2;`
    States(Vec<Ident>),
    /// `input u1;`, `input u1, u2 in [lo, hi];` with the range (lower and
    /// upper bound, and the interval's span) every listed input stays in,
    /// and `rate r` (the bound on |u'| and the clause's span).
    Inputs(Vec<Ident>, Option<(Expr, Expr, Span)>, Option<(Expr, Span)>),
    /// `output y1;`
    Outputs(Vec<Ident>),
    /// `param th1, th2 in [lo, hi];`
    Params(ParamDecl),
    /// `A = [...];` or `N2 = 0;`
    Matrix(MatrixDef),
    /// `der x1 = expr;`
    Der(Equation),
    /// `out y1 = expr;`
    Out(Equation),
    /// `region box(...);`, `region vertices [...];`, `region halfspaces [...];`
    Region(RegionDecl),
    /// `state_bound Q = [...];` or `state_bound auto;` / `state_bound auto(h = 0.08);`
    StateBound(BoundDecl, Span),
    /// `design { key = value; ... }`
    Design(DesignBlock),
    /// `noise y1, y2;`: the outputs measured with noise, and the statement's span.
    Noise(Vec<Ident>, Span),
    /// `disturbance w1, w2;`
    Disturbances(Vec<Ident>),
    /// `time = hours;`: the word naming the model's unit of time, and the
    /// statement's span.
    Time(Ident, Span),
    /// `let NAME = EXPR;`: a named scheduling function of the parameters.
    Let(Ident, Expr, Span),
    /// `const NAME = EXPR;`: a named number.
    Const(Ident, Expr, Span),
    /// `cover q2 into 4, m into 2;`: the parameter box cut into equal
    /// pieces along each named parameter, and the statement's span.
    Cover(Vec<CoverAxisAst>, Span),
}

/// One `NAME into COUNT` of a `cover` statement.
#[derive(Debug, Clone, PartialEq)]
pub struct CoverAxisAst {
    /// The parameter cut.
    pub param: Ident,
    /// The number of equal pieces (a constant expression).
    pub pieces: Expr,
    /// The whole `NAME into COUNT`.
    pub span: Span,
}

/// The right-hand side of a `state_bound` statement.
#[derive(Debug, Clone, PartialEq)]
pub enum BoundDecl {
    /// `Q = [...]`: the matrix Q of F = {x : xᵀQ⁻¹x ≤ 1}.
    Given(MatrixLit),
    /// `auto` or `auto(key = value, ...)`: computed by the solver; the
    /// options in source order (only `h` is accepted).
    Auto(Vec<DesignEntry>),
}

/// `param NAMES in [lo, hi];`, or `param NAME = OUTPUT in [lo, hi];` (the
/// interval optional) for a parameter computed from a measured output.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamDecl {
    /// The declared names (they share the bounds).
    pub names: Vec<Ident>,
    /// `= OUTPUT`: the output the parameter is computed from.
    pub measured: Option<Ident>,
    /// The bounds `[lo, hi]` and the interval's span (`None` only for a
    /// measured parameter, whose interval is then derived).
    pub range: Option<(Expr, Expr, Span)>,
    /// `rate EXPR`: the bound on |θ'| and the clause's span.
    pub rate: Option<(Expr, Span)>,
}

/// `NAME = value;`
#[derive(Debug, Clone, PartialEq)]
pub struct MatrixDef {
    /// The matrix name (`A`, `B`, `C`, `N<k>`, `M<k>`).
    pub name: Ident,
    /// The right-hand side.
    pub value: MatrixValue,
    /// The whole statement.
    pub span: Span,
}

/// The right-hand side of a matrix definition.
#[derive(Debug, Clone, PartialEq)]
pub enum MatrixValue {
    /// A bracketed matrix literal.
    Literal(MatrixLit),
    /// A scalar expression (only `0`, the zero matrix, is accepted).
    Scalar(Expr),
}

/// `[a, b; c, d]`
#[derive(Debug, Clone, PartialEq)]
pub struct MatrixLit {
    /// The rows.
    pub rows: Vec<Row>,
    /// The whole literal including brackets.
    pub span: Span,
}

/// One row of a matrix literal.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The entries.
    pub entries: Vec<Expr>,
    /// The row's text.
    pub span: Span,
}

/// `der x = rhs;` or `out y = rhs;`
#[derive(Debug, Clone, PartialEq)]
pub struct Equation {
    /// The state (for `der`) or output (for `out`).
    pub target: Ident,
    /// The right-hand side.
    pub rhs: Expr,
    /// The whole statement.
    pub span: Span,
}

/// `region ...;`
#[derive(Debug, Clone, PartialEq)]
pub struct RegionDecl {
    /// The shape.
    pub shape: RegionShape,
    /// The whole statement.
    pub span: Span,
}

/// The ways to give the region.
#[derive(Debug, Clone, PartialEq)]
pub enum RegionShape {
    /// `box(r)`: |x_i| ≤ r for all i.
    BoxScalar(Expr),
    /// `box([r1, .., rn])`: |x_i| ≤ r_i.
    BoxVector(Vec<Expr>, Span),
    /// `vertices [...]`: one vertex per row.
    Vertices(MatrixLit),
    /// `halfspaces [...]`: one row a_k per facet a_kᵀ x ≤ 1.
    Halfspaces(MatrixLit),
    /// `zonotope [...]`: one generator g_k per row, the region
    /// {Σ_k t_k g_k : |t_k| ≤ 1}.
    Zonotope(MatrixLit),
}

/// `design { ... }`
#[derive(Debug, Clone, PartialEq)]
pub struct DesignBlock {
    /// The entries in source order.
    pub entries: Vec<DesignEntry>,
    /// The whole block.
    pub span: Span,
}

/// The options in parentheses after a design value, with the span of the
/// parenthesised list.
pub type ValueOptions = (Vec<DesignEntry>, crate::diagnostic::Span);

/// `key = value;` inside a design block (or `key = value` inside
/// `state_bound auto(...)`).
#[derive(Debug, Clone, PartialEq)]
pub struct DesignEntry {
    /// The key.
    pub key: Ident,
    /// The value: an expression or a word such as `max`.
    pub value: Expr,
    /// Options in parentheses after the value, `filter(pole = 40)`, with the
    /// span of the parenthesised list (`None` when there are none).
    pub options: Option<ValueOptions>,
    /// Further values after commas, each with its options (`poles =
    /// disk(..), sector(..)`: the only key that takes a list); empty for
    /// a single value and for options.
    pub more: Vec<(Expr, Option<ValueOptions>)>,
    /// The whole entry.
    pub span: Span,
}

/// An expression with its span.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    /// What it is.
    pub kind: ExprKind,
    /// Where it is written (parentheses included).
    pub span: Span,
}

/// The expression forms. Sums and products are flattened (n-ary) so that
/// long chains do not nest.
#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    /// A number literal.
    Number(f64),
    /// A state, input or parameter name (or a design word such as `max`).
    Name(String),
    /// Unary minus.
    Neg(Box<Expr>),
    /// `t1 ± t2 ± ...`: each term with `true` if it is subtracted.
    Sum(Vec<(bool, Expr)>),
    /// `f1 * f2 / f3 ...`: each factor with `true` if it divides.
    Product(Vec<(bool, Expr)>),
    /// `base ^ n` with a whole-number exponent.
    Pow(Box<Expr>, u32),
    /// `f(arg)`: a function of the parameters, with the span of its name.
    Call(crate::func::Func, Span, Box<Expr>),
}
