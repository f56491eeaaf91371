//! The model builder: the state shared by the pipeline steps (the source,
//! the declared names, the warnings so far) and [`build`], which runs the
//! steps in order.

use super::Model;
use crate::ast::{Expr, ModelAst};
use crate::diagnostic::{line_col, Diag, Span, Warning};
use crate::poly::{eval, Allowed, NameRef, Names, Scope};
use std::collections::HashMap;

pub(super) type R<T> = Result<T, Diag>;

/// What a declared name is, with its article ("a state").
pub(super) fn kind_word(r: NameRef) -> &'static str {
    match r {
        NameRef::State(_) => "a state",
        NameRef::Input(_) => "an input",
        NameRef::Output(_) => "an output",
        NameRef::Param(_) => "a parameter",
        NameRef::Disturbance(_) => "a disturbance",
        NameRef::Let(_) => "a `let` function",
        NameRef::Const(_) => "a `const` number",
    }
}

/// The state of one model's build: its source, its AST, the names declared
/// so far and the warnings collected on the way.
pub(super) struct Builder<'a> {
    pub(super) src: &'a str,
    pub(super) ast: &'a ModelAst,
    pub(super) names: Names,
    pub(super) decl_spans: HashMap<String, Span>,
    pub(super) warnings: Vec<Warning>,
    /// max(|lo|, |hi|) of each declared parameter, once the parameters are read.
    pub(super) param_reach: Vec<f64>,
    /// The nonlinear terms of the `der` equations, as they are read.
    pub(super) nonlinear: Vec<crate::jacobian::NonlinearTerm>,
}

/// `line:column` of a span, for messages that point at an earlier definition.
pub(super) fn pos(src: &str, span: Span) -> String {
    let (l, c) = line_col(src, span.start);
    format!("{l}:{c}")
}

/// The error for a setting with a value outside its domain.
pub(super) fn bad_value(span: Span, key: &str, expected: &str, found: &str) -> Diag {
    Diag::new(span, format!("`{key}` must be {expected}, found `{found}`"))
}

/// Builds and validates one model.
pub(crate) fn build(src: &str, ast: &ModelAst) -> R<Model> {
    let mut b = Builder {
        src,
        ast,
        names: Names::default(),
        decl_spans: HashMap::new(),
        warnings: Vec::new(),
        param_reach: Vec::new(),
        nonlinear: Vec::new(),
    };
    b.declare()?;
    b.consts()?;
    let params = b.params()?;
    let input_ranges = b.input_ranges()?;
    b.lets(&params)?;
    let (mut a, mut n, mut bm, mut b_w) = b.dynamics()?;
    let noise_outputs = b.noise_outputs()?;
    let (mut c, mut m) = b.outputs()?;
    let derived = b.derived(&mut a, &mut n, &mut bm, &mut b_w, &mut c, &mut m)?;
    let lpv =
        n.iter().chain(&m).all(crate::expr::PolyMatrix::is_zero) && b.nonlinear_is_lpv(&params)?;
    let region = b.region(lpv)?;
    let state_bound = b.state_bound(&region, lpv)?;
    let designs = b.designs(&region)?;
    let mut model = Model {
        name: ast.name.name.clone(),
        span: ast.name.span,
        states: b.names.states.clone(),
        inputs: b.names.inputs.clone(),
        input_ranges,
        input_rates: b.input_rates()?,
        outputs: b.names.outputs.clone(),
        params,
        a,
        n,
        b: bm,
        disturbances: b.names.disturbances.clone(),
        b_w,
        noise_outputs,
        c,
        m,
        region,
        state_bound,
        designs,
        derived,
        cover: None,
        nonlinear: std::mem::take(&mut b.nonlinear),
        warnings: Vec::new(),
    };
    b.usage(&model)?;
    model.cover = b.cover(&model)?;
    model.warnings = b.warnings;
    Ok(model)
}

impl<'a> Builder<'a> {
    /// The scope for evaluating an expression that may use `allowed` names.
    pub(super) fn scope(&self, allowed: Allowed, context: &'a str) -> Scope<'_> {
        Scope {
            src: self.src,
            names: &self.names,
            allowed,
            context,
        }
    }

    /// Evaluates a constant expression (numbers only).
    pub(super) fn constant(&self, e: &Expr, context: &str) -> R<f64> {
        let scope = Scope {
            src: self.src,
            names: &self.names,
            allowed: Allowed::Constant,
            context,
        };
        let p = eval(e, &scope)?;
        p.as_constant().ok_or_else(|| {
            Diag::new(
                e.span,
                format!("a constant number is expected in {context}"),
            )
        })
    }
}
