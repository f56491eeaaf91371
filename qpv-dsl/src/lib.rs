#![doc = include_str!("../README.md")]

pub mod ast;
pub mod cover;
pub mod diagnostic;
mod equations;
pub mod expr;
pub mod func;
pub mod jacobian;
mod measured;
pub mod model;
mod poly;
pub mod region;
pub mod sched;
mod syntax;
pub mod time_unit;
pub mod vertices;

pub use cover::{Cover, CoverAxis, Piece};
pub use diagnostic::{fmt_sig, Error, Span, Warning};
pub use expr::{PolyMatrix, ThetaPoly};
pub use func::Func;
pub use jacobian::{Jacobian, JacobianBound, JacobianEntry, NonlinearTerm};
pub use measured::{Measured, MeasuredOrigin};
pub use model::{
    AlphaSpec, Clash, Conditions, DesignRequest, Float, GammaSpec, Mode, Model, NoiseObjective,
    OutputFilter, OutputRoute, Param, PoleRegion, Split, StateBound, MAX_COEFFICIENT,
};
pub use region::{Region, RegionError};
pub use sched::{Derived, RangeInfo, SchedExpr};
pub use time_unit::TimeUnit;
pub use vertices::{NoiseDecl, PolytopicModel, Vertex};

/// Not part of the API (it may change at any time): the internals that the
/// tests of this crate check directly, exposed for the root package's test
/// target `dsl` (`qpv-dsl/tests/`), which is built outside this crate.
#[doc(hidden)]
pub mod __internals {
    use crate::ast::{Expr, File};
    use crate::{Error, RangeInfo, SchedExpr};

    pub use crate::syntax::{is_matrix_name_shape, QpvParser, Rule};
    /// The trait of [`QpvParser::parse`].
    pub use pest::Parser;

    /// The syntax tree of a whole text, before any model is built.
    pub fn parse_file(src: &str) -> Result<File, Error> {
        crate::syntax::parse_file(src).map_err(|d| d.into_error(src))
    }

    /// The syntax tree of one pair of rule [`Rule::expr`].
    pub fn parse_expr(pair: pest::iterators::Pair<'_, Rule>) -> Result<Expr, Error> {
        let src = pair.get_input();
        crate::syntax::parse_expr(pair).map_err(|d| d.into_error(src))
    }

    /// The range of `e` on the parameter box `theta` (see
    /// `crate::sched::range`); the error is its message.
    pub fn range(
        e: &SchedExpr,
        theta: &[(f64, f64)],
        names: &[String],
    ) -> Result<(f64, f64, RangeInfo), String> {
        crate::sched::range(e, theta, names).map_err(|e| e.message)
    }
}

/// Parses and validates a model text: one or more `model NAME { ... }`
/// blocks. Every check of the language happens here, so
/// [`Model::polytopic`] cannot fail afterwards.
///
/// On failure the [`Error`] carries the byte span of the offending text in
/// `src`, its line and column, and a message that says what was expected.
/// Non-fatal remarks are in each model's [`Model::warnings`].
pub fn parse(src: &str) -> Result<Vec<Model>, Error> {
    if src.len() > MAX_SOURCE_BYTES {
        return Err(too_long(src));
    }
    if let Some((at, c)) = src
        .char_indices()
        .find(|&(_, c)| c.is_control() && !matches!(c, '\t' | '\n' | '\r'))
    {
        let name = if c == '\0' { " (NUL)" } else { "" };
        return Err(Error::new(
            src,
            Span::new(at, at + c.len_utf8()),
            format!(
                "a control character U+{:04X}{name} in the text: a model file is plain text \
                 (is this a binary file, or UTF-16 rather than UTF-8?)",
                c as u32
            ),
        ));
    }
    parse_diag(src).map_err(|d| d.into_error(src))
}

/// Largest model text [`parse`] accepts, in bytes (1 MiB). Real models are a
/// few kilobytes; the bound keeps the memory a hostile or mistaken input can
/// claim to a few hundred megabytes at most. Tools that read files can check
/// a file's size against it before reading the file.
pub const MAX_SOURCE_BYTES: usize = 1 << 20;

/// Most `model` blocks one text may hold. Each model may carry a region of
/// up to 4096 vertices, so this bounds the memory of a text of many small
/// models (tens of megabytes at most).
pub const MAX_MODELS: usize = 64;

/// The error for a text longer than [`MAX_SOURCE_BYTES`], at the start of
/// the text (with a short excerpt: the first line may be the whole text).
fn too_long(src: &str) -> Error {
    let first: String = diagnostic::source_lines(src)
        .next()
        .unwrap_or("")
        .chars()
        .take(80)
        .collect();
    Error {
        message: format!(
            "the model text is {} bytes long: at most {MAX_SOURCE_BYTES} bytes (1 MiB) are \
             supported",
            src.len()
        ),
        span: Span::new(0, 0),
        line: 1,
        column: 1,
        excerpt: first,
    }
}

fn parse_diag(src: &str) -> Result<Vec<Model>, diagnostic::Diag> {
    let file = syntax::parse_file(src)?;
    if let Some(extra) = file.models.get(MAX_MODELS) {
        return Err(diagnostic::Diag::new(
            extra.name.span,
            format!(
                "the text defines {} models: at most {MAX_MODELS} are supported in one text",
                file.models.len()
            ),
        ));
    }
    let mut models: Vec<Model> = Vec::with_capacity(file.models.len());
    for m in &file.models {
        if let Some(prev) = models.iter().find(|p| p.name == m.name.name) {
            let (l, c) = diagnostic::line_col(src, prev.span.start);
            return Err(diagnostic::Diag::new(
                m.name.span,
                format!(
                    "a model named `{}` is already defined at {l}:{c}",
                    m.name.name
                ),
            ));
        }
        models.push(model::build(src, m)?);
    }
    Ok(models)
}
