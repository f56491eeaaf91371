#![doc = include_str!("../README.md")]

pub mod ast;
pub mod diagnostic;
mod equations;
pub mod expr;
pub mod model;
mod poly;
pub mod region;
mod syntax;
pub mod vertices;

pub use diagnostic::{Error, Span, Warning};
pub use expr::{PolyMatrix, ThetaPoly};
pub use model::{
    AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, Model, OutputFilter, OutputRoute, Param,
    Split, StateBound,
};
pub use region::{Region, RegionError};
pub use vertices::{PolytopicModel, Vertex};

/// Parses and validates a model text: one or more `model NAME { ... }`
/// blocks. Every check of the language happens here, so
/// [`Model::polytopic`] cannot fail afterwards.
///
/// On failure the [`Error`] carries the byte span of the offending text in
/// `src`, its line and column, and a message that says what was expected.
/// Non-fatal remarks are in each model's [`Model::warnings`].
pub fn parse(src: &str) -> Result<Vec<Model>, Error> {
    parse_diag(src).map_err(|d| d.into_error(src))
}

fn parse_diag(src: &str) -> Result<Vec<Model>, diagnostic::Diag> {
    let file = syntax::parse_file(src)?;
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
