//! The qpv model language: text → AST → [`Model`] → [`PolytopicModel`].

pub mod diagnostic;
pub mod expr;
pub mod model;
pub mod region;
pub mod vertices;

pub use diagnostic::{Error, Span, Warning};
pub use expr::{PolyMatrix, ThetaPoly};
pub use model::{AlphaSpec, DesignRequest, GammaSpec, Mode, Model, Param, StateBound};
pub use region::Region;
pub use vertices::{PolytopicModel, Vertex};
