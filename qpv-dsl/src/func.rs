//! The functions a scheduling expression may call (`sqrt`, `sin`, ...):
//! their names as written in a model and their values. Vocabulary shared by
//! the syntax tree, the parser and the scheduling functions.

/// A function that may appear in a scheduling expression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Func {
    /// √x, defined for x ≥ 0.
    Sqrt,
    /// eˣ.
    Exp,
    /// Natural logarithm, defined for x > 0.
    Ln,
    /// sin x (radians).
    Sin,
    /// cos x (radians).
    Cos,
    /// tan x, undefined at π/2 + kπ.
    Tan,
    /// tanh x.
    Tanh,
    /// atan x.
    Atan,
    /// |x|.
    Abs,
}

impl Func {
    /// Every function, in the order the documentation lists them.
    pub const ALL: [Func; 9] = [
        Func::Sqrt,
        Func::Exp,
        Func::Ln,
        Func::Sin,
        Func::Cos,
        Func::Tan,
        Func::Tanh,
        Func::Atan,
        Func::Abs,
    ];

    /// The name as written in a model.
    pub fn name(self) -> &'static str {
        match self {
            Func::Sqrt => "sqrt",
            Func::Exp => "exp",
            Func::Ln => "ln",
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Tanh => "tanh",
            Func::Atan => "atan",
            Func::Abs => "abs",
        }
    }

    /// The function of a name, if it is one.
    pub fn from_name(s: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == s)
    }

    /// The value at `x` (NaN or infinite where undefined).
    pub fn apply(self, x: f64) -> f64 {
        match self {
            Func::Sqrt => x.sqrt(),
            Func::Exp => x.exp(),
            Func::Ln => x.ln(),
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Tan => x.tan(),
            Func::Tanh => x.tanh(),
            Func::Atan => x.atan(),
            Func::Abs => x.abs(),
        }
    }
}
