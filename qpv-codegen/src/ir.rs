//! The expression language of generated observer code: what the Rust and
//! the C printers print. Every value is a real number (f64 in Rust, the
//! model's `real` in C) except the [`Ty::Index`] lets of a cover's piece
//! location. Names are plain identifiers (`x0`, `t0_1`, `g2_0`, ...) bound
//! by the printer (function arguments) or by a [`Let`] of the same body.

use qpv_dsl::Func;

/// A binary operator, printed without parentheses (wrap operands in
/// [`Expr::Paren`] where precedence needs it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `a + b`
    Add,
    /// `a - b`
    Sub,
    /// `a * b`
    Mul,
    /// `a / b`
    Div,
}

/// An expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A real constant (finite; negative values print as `-` and the magnitude).
    Num(f64),
    /// An index constant (piece arithmetic of a cover).
    Int(usize),
    /// A local name or argument.
    Var(String),
    /// The interned θ-coefficient number `i` (`c.k<i>`).
    Coef(usize),
    /// `-e`.
    Neg(Box<Expr>),
    /// `(e)`.
    Paren(Box<Expr>),
    /// `a * b * ...`, left to right.
    Product(Vec<Expr>),
    /// `a op b`.
    Bin(Op, Box<Expr>, Box<Expr>),
    /// A constant-folded signed sum Σ c_i·f_i (a term without factor is the
    /// number c_i): zero terms are never stored, `1·f` prints as `f`,
    /// negative coefficients fold into the sign; empty is `0.0`.
    Sum(Vec<(f64, Option<Expr>)>),
    /// A scheduling function's math call, `f(e)`.
    Call(Func, Box<Expr>),
    /// `e^n` by repeated multiplication, `((1·e)·e)…` (the evaluation order
    /// of the model compiler's `SchedExpr::eval`).
    PowI(Box<Expr>, u32),
    /// `e` clamped into `[lo, hi]`: `e >= lo ? (e <= hi ? e : hi) : lo`
    /// (NaN → lo).
    Clamp(Box<Expr>, Box<Expr>, Box<Expr>),
    /// The index 1 if `a >= b`, else 0.
    Ge(Box<Expr>, Box<Expr>),
    /// Arm `i` when the index variable equals `i`; the last arm for every
    /// other value.
    Select(String, Vec<Expr>),
}

impl Expr {
    /// A name.
    pub fn var(name: impl Into<String>) -> Expr {
        Expr::Var(name.into())
    }

    /// `a op b`.
    pub fn bin(op: Op, a: Expr, b: Expr) -> Expr {
        Expr::Bin(op, Box::new(a), Box::new(b))
    }

    /// `(e)`.
    pub fn paren(e: Expr) -> Expr {
        Expr::Paren(Box::new(e))
    }

    /// True if the name `name` occurs in the expression.
    pub fn uses(&self, name: &str) -> bool {
        match self {
            Expr::Num(_) | Expr::Int(_) => false,
            Expr::Coef(_) => name == "c",
            Expr::Var(v) => v == name,
            Expr::Neg(e) | Expr::Paren(e) | Expr::Call(_, e) | Expr::PowI(e, _) => e.uses(name),
            Expr::Product(es) => es.iter().any(|e| e.uses(name)),
            Expr::Bin(_, a, b) | Expr::Ge(a, b) => a.uses(name) || b.uses(name),
            Expr::Sum(ts) => ts
                .iter()
                .any(|(_, f)| f.as_ref().is_some_and(|f| f.uses(name))),
            Expr::Clamp(e, lo, hi) => e.uses(name) || lo.uses(name) || hi.uses(name),
            Expr::Select(on, arms) => on == name || arms.iter().any(|a| a.uses(name)),
        }
    }

    /// Every real constant of the expression, in order (for the f32 checks).
    pub fn numbers(&self, out: &mut Vec<f64>) {
        match self {
            Expr::Num(v) => out.push(*v),
            Expr::Int(_) | Expr::Var(_) | Expr::Coef(_) => {}
            Expr::Neg(e) | Expr::Paren(e) | Expr::Call(_, e) | Expr::PowI(e, _) => e.numbers(out),
            Expr::Product(es) => es.iter().for_each(|e| e.numbers(out)),
            Expr::Bin(_, a, b) | Expr::Ge(a, b) => {
                a.numbers(out);
                b.numbers(out);
            }
            Expr::Sum(ts) => {
                for (c, f) in ts {
                    out.push(*c);
                    if let Some(f) = f {
                        f.numbers(out);
                    }
                }
            }
            Expr::Clamp(e, lo, hi) => {
                e.numbers(out);
                lo.numbers(out);
                hi.numbers(out);
            }
            Expr::Select(_, arms) => arms.iter().for_each(|e| e.numbers(out)),
        }
    }
}

/// A builder of [`Expr::Sum`]: zero terms are dropped on the way in.
#[derive(Debug, Clone, Default)]
pub struct Sum {
    terms: Vec<(f64, Option<Expr>)>,
}

impl Sum {
    /// Adds `c × factor` (`c` alone without a factor); zero terms are dropped.
    pub fn push(&mut self, c: f64, factor: Option<Expr>) {
        if c != 0.0 {
            self.terms.push((c, factor));
        }
    }

    /// The sum as an expression.
    pub fn expr(self) -> Expr {
        Expr::Sum(self.terms)
    }
}

/// The type of a [`Let`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ty {
    /// A real number.
    Real,
    /// A non-negative index (piece arithmetic).
    Index,
}

/// `let name: ty = value;`.
#[derive(Debug, Clone, PartialEq)]
pub struct Let {
    /// The bound name (unique in its body).
    pub name: String,
    /// Real or index.
    pub ty: Ty,
    /// Its value, over the arguments and the earlier lets.
    pub value: Expr,
}

impl Let {
    /// A real-valued let.
    pub fn real(name: impl Into<String>, value: Expr) -> Let {
        Let {
            name: name.into(),
            ty: Ty::Real,
            value,
        }
    }
}

/// A function body: lets in order, then the output values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Body {
    /// The intermediate values.
    pub lets: Vec<Let>,
    /// The results, in order.
    pub out: Vec<Expr>,
}

impl Body {
    /// True if the body reads the name `name` (an argument or a let).
    pub fn uses(&self, name: &str) -> bool {
        self.lets.iter().any(|l| l.value.uses(name)) || self.out.iter().any(|e| e.uses(name))
    }

    /// Every real constant of the body.
    pub fn numbers(&self) -> Vec<f64> {
        let mut v = Vec::new();
        for l in &self.lets {
            l.value.numbers(&mut v);
        }
        for e in &self.out {
            e.numbers(&mut v);
        }
        v
    }
}

/// The C99 `<math.h>` (and Rust `libm`) name of a scheduling function's
/// math function for f64; the f32 one appends `f` (`sinf`).
pub fn math_name(f: Func) -> &'static str {
    match f {
        Func::Sqrt => "sqrt",
        Func::Exp => "exp",
        Func::Ln => "log",
        Func::Sin => "sin",
        Func::Cos => "cos",
        Func::Tan => "tan",
        Func::Tanh => "tanh",
        Func::Atan => "atan",
        Func::Abs => "fabs",
    }
}
