//! The model builder: the state shared by the pipeline steps (the source,
//! the declared names, the warnings so far) and [`build`], which runs the
//! steps in order.

use super::Model;
use crate::ast::{Expr, Item, ModelAst};
use crate::diagnostic::{line_col, Diag, Span, Warning};
use crate::poly::{eval, Allowed, NameRef, Names, Scope};
use crate::time_unit::TimeUnit;
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
    /// Every output as a constant row c (y = cᵀx) where it is one.
    pub(super) rows: Vec<Option<Vec<f64>>>,
    /// The measured factors a rewrite needs parameters for (second build).
    pub(super) auto: Vec<crate::measured::Wanted>,
    /// Whether some parameter is computed from an output (the state bound
    /// then bounds it, whatever the design uses).
    pub(super) measured_params: bool,
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

/// Builds and validates one model. A model whose terms of degree 3 have
/// measured factors without a parameter is built a second time, with the
/// parameters those factors are scheduled on (`crate::measured`).
pub(crate) fn build(src: &str, ast: &ModelAst) -> R<Model> {
    let (first, wanted) = build_with(src, ast, Vec::new());
    match first {
        Err(_) if !wanted.is_empty() => build_with(src, ast, wanted).0,
        result => result,
    }
}

/// One build, with the parameters `auto` asks for; also what a rewrite
/// still wants.
fn build_with(
    src: &str,
    ast: &ModelAst,
    auto: Vec<crate::measured::Wanted>,
) -> (R<Model>, Vec<crate::measured::Wanted>) {
    let mut b = Builder {
        src,
        ast,
        names: Names::default(),
        decl_spans: HashMap::new(),
        warnings: Vec::new(),
        param_reach: Vec::new(),
        rows: Vec::new(),
        auto,
        measured_params: false,
        nonlinear: Vec::new(),
    };
    let model = b.run();
    let wanted = b.names.wanted.borrow().clone();
    (model, wanted)
}

impl Builder<'_> {
    fn run(&mut self) -> R<Model> {
        let b = self;
        let ast = b.ast;
        b.declare()?;
        b.consts()?;
        b.rows = b.linear_outputs();
        let mut params = b.params()?;
        let input_ranges = b.input_ranges()?;
        b.lets(&params)?;
        let (mut a, mut n, mut bm, mut b_w) = b.dynamics()?;
        let noise_outputs = b.noise_outputs()?;
        let (mut c, mut m) = b.outputs()?;
        b.report_rewrites(&mut params);
        let derived = b.derived(&mut a, &mut n, &mut bm, &mut b_w, &mut c, &mut m)?;
        let lpv = n.iter().chain(&m).all(crate::expr::PolyMatrix::is_zero)
            && b.nonlinear_is_lpv(&params)?;
        let region = b.region(lpv)?;
        let state_bound = b.state_bound(&region, lpv)?;
        b.measured_bound(&params, &state_bound, lpv)?;
        let designs = b.designs(&region)?;
        let time_unit = b.time_unit()?;
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
            time_unit,
            warnings: Vec::new(),
        };
        b.usage(&model)?;
        model.cover = b.cover(&model)?;
        model.warnings = std::mem::take(&mut b.warnings);
        Ok(model)
    }
}

impl<'a> Builder<'a> {
    /// The unit of `time = UNIT;` (seconds when not declared); a second
    /// declaration or an unknown word is an error at its position.
    fn time_unit(&self) -> R<TimeUnit> {
        let mut found: Option<(TimeUnit, Span)> = None;
        for item in &self.ast.items {
            let Item::Time(word, span) = item else {
                continue;
            };
            if let Some((_, prev)) = found {
                return Err(Diag::new(
                    *span,
                    format!(
                        "`time` is declared twice (first at {}): a model has one unit of time",
                        pos(self.src, prev)
                    ),
                ));
            }
            let unit = TimeUnit::from_word(&word.name).ok_or_else(|| {
                let words: Vec<String> = TimeUnit::ALL
                    .iter()
                    .map(|u| format!("`{}`", u.plural()))
                    .collect();
                Diag::new(
                    word.span,
                    format!(
                        "unknown unit of time `{}`: expected {} (or their symbols s, ms, min, \
                         h, d)",
                        word.name,
                        words.join(", ")
                    ),
                )
            })?;
            found = Some((unit, *span));
        }
        Ok(found.map_or(TimeUnit::Seconds, |(u, _)| u))
    }

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
