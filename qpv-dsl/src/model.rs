//! The typed model: names, dimensions, symbolic θ-polynomial matrices, the
//! convergence region, the state bound and the design requests of one
//! `model NAME { ... }` block, after validation.

use crate::diagnostic::{Span, Warning};
use crate::expr::PolyMatrix;
use crate::region::Region;
use serde::Serialize;

/// A bounded scheduling parameter `param NAME in [lo, hi];`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Param {
    /// The parameter's name as declared.
    pub name: String,
    /// Lower bound of θ_i.
    pub lo: f64,
    /// Upper bound of θ_i (strictly greater than `lo`).
    pub hi: f64,
    /// Where it was declared.
    pub span: Span,
}

/// Which set of LMI conditions a design uses (spec §5 / §6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// The sound conditions (S1)-(S5): the default, and the only mode that certifies.
    #[default]
    Sound,
    /// The paper's printed conditions (13), (14), (26): reproduction only.
    Paper,
}

/// The convergence rate requested by a design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AlphaSpec {
    /// A fixed decay rate α > 0.
    Fixed(f64),
    /// The largest certifiable α (bisection).
    Max,
}

/// The region scaling γ requested by a design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GammaSpec {
    /// A fixed γ in (0, 1).
    Fixed(f64),
    /// Search γ over (0, min(1, γ_max)] maximising α.
    Search,
}

/// How N_k (and M_k) are represented in the design LMIs (spec §1).
///
/// Only the symmetric part of N_k moves the plant, but the matrix
/// rows(N_k, e) in the conditions depends on the representation, so the
/// choice changes what can be certified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Split {
    /// N_k and M_k exactly as written (the paper's representation; the
    /// default in paper mode, which reproduces the printed conditions).
    AsWritten,
    /// N_k → (N_k + N_kᵀ)/2 and M_k → (M_k + M_kᵀ)/2: the same plant; the
    /// default in sound mode (measured better on the paper example).
    #[default]
    Symmetric,
    /// The symmetric split plus a skew-symmetric slack K_{k,l} = −K_{k,l}ᵀ
    /// per θ-vertex, searched by alternating solves after the symmetric
    /// design (N_k + K_k is still the same plant). Sound mode only; the
    /// report carries K so the design can be re-checked.
    SkewSlack,
}

impl Split {
    /// The name used in the language, reports and the CLI.
    pub fn name(self) -> &'static str {
        match self {
            Split::AsWritten => "as_written",
            Split::Symmetric => "symmetric",
            Split::SkewSlack => "skew_slack",
        }
    }
}

impl Split {
    /// The default split of a condition set: [`Split::Symmetric`] in sound
    /// mode, [`Split::AsWritten`] in paper mode.
    pub fn default_for(mode: Mode) -> Split {
        match mode {
            Mode::Sound => Split::Symmetric,
            Mode::Paper => Split::AsWritten,
        }
    }
}

/// Which family of vertex conditions (S5) is imposed (issue 6 §3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Conditions {
    /// All p² vertex pairs (i, j) per θ-vertex.
    #[default]
    Full,
    /// One slack Z_l per θ-vertex (per rate combination for the double sum):
    /// 2p blocks per θ-vertex (sufficient for
    /// the full family, which certification still re-checks).
    Decoupled,
}

/// How the output map enters the design (issue 6 §4; spec §3, Remark 3).
///
/// With a constant C and M_k both routes are available and `double_sum` is
/// exactly the paper's single sum over θ-vertices. With a θ-dependent
/// C(θ), M_k(θ) the choice matters: the double sum keeps the observer's
/// structure and adds vertex-pair blocks; the filter adds ny states.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum OutputRoute {
    /// C(θ), M_k(θ) enter the rate conditions directly, with the gain
    /// L(θ) = Σ_l μ_l L_l: Σ_l Σ_m μ_l μ_m Ξ_{lm} ≺ 0 is imposed by the
    /// relaxation Ξ_ll ≺ 0, (2/(r−1)) Ξ_ll + Ξ_lm + Ξ_ml ≺ 0 (l ≠ m) of
    /// Tuan et al. (2001). The default.
    #[default]
    DoubleSum,
    /// Output post-filter x_y' = −a x_y + b y (per output), and the observer
    /// of the augmented plant (x, x_y) measures ỹ = x_y: the output matrix
    /// is constant and the θ-dependence moves into the state equation.
    Filter(OutputFilter),
}

/// The output post-filter x_{y,k}' = −pole·x_{y,k} + gain·y_k of
/// [`OutputRoute::Filter`] (A_y = −pole·I Hurwitz, B_y = gain·I diagonal).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OutputFilter {
    /// a > 0: the filter's pole is −a (rad/s).
    pub pole: f64,
    /// b ≠ 0: the filter's input gain (b = a gives unit DC gain).
    pub gain: f64,
}

impl OutputFilter {
    /// The pole used by `output_route = filter;` without options.
    pub const DEFAULT_POLE: f64 = 50.0;
}

impl Default for OutputFilter {
    fn default() -> Self {
        OutputFilter {
            pole: Self::DEFAULT_POLE,
            gain: Self::DEFAULT_POLE,
        }
    }
}

/// One `design { ... }` request of a model.
///
/// Build one with `..Default::default()` so that new settings do not break
/// construction sites: the default is `alpha = max; gamma = search;
/// mode = sound; split = symmetric; conditions = full; output_route = double_sum;`.
/// In paper mode set
/// `split: Split::AsWritten` as well (see [`Split::default_for`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignRequest {
    /// Requested decay rate.
    pub alpha: AlphaSpec,
    /// Requested region scaling.
    pub gamma: GammaSpec,
    /// Condition set.
    pub mode: Mode,
    /// Representation of N_k, M_k in the LMIs.
    pub split: Split,
    /// Full or decoupled vertex conditions.
    pub conditions: Conditions,
    /// How the output map enters the design (matters when C or M_k depend on θ).
    pub output_route: OutputRoute,
    /// The `design` block in the source, for errors about this request.
    pub span: Span,
}

impl Default for DesignRequest {
    fn default() -> Self {
        DesignRequest {
            alpha: AlphaSpec::Max,
            gamma: GammaSpec::Search,
            mode: Mode::Sound,
            split: Split::default_for(Mode::Sound),
            conditions: Conditions::Full,
            output_route: OutputRoute::DoubleSum,
            span: Span::default(),
        }
    }
}

/// The set F = {x : xᵀ Q⁻¹ x ≤ 1} known to contain the state trajectory.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum StateBound {
    /// No `state_bound` given.
    None,
    /// `state_bound Q = [...]`: a symmetric positive definite Q (nx × nx).
    Given(nalgebra::DMatrix<f64>),
    /// `state_bound auto;` or `state_bound auto(h = ...);`: Q is computed by
    /// the solver (an invariant ellipsoid containing the region, inside the
    /// box |x_i| ≤ h, maximising γ_max). With `h` given the box size is
    /// fixed; otherwise it is searched.
    Auto {
        /// The half-width of the enclosing box, if fixed by the model.
        h: Option<f64>,
    },
}

/// One validated `model` block with symbolic θ-dependent matrices.
///
/// Matrices are over the declared parameters (bit i of a term mask = i-th
/// entry of `params`). `n` has one nx × nx matrix per state and `m` one per
/// output; row k of N(θ,x)x is xᵀ N_k(θ) x, with N_k as written (no
/// symmetrisation).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Model {
    /// The model's name.
    pub name: String,
    /// Where the model block starts (its name).
    pub span: Span,
    /// State names x_1..x_nx.
    pub states: Vec<String>,
    /// Input names u_1..u_nu (may be empty).
    pub inputs: Vec<String>,
    /// Output names y_1..y_ny.
    pub outputs: Vec<String>,
    /// Declared parameters in declaration order.
    pub params: Vec<Param>,
    /// A(θ), nx × nx.
    pub a: PolyMatrix,
    /// N_k(θ), nx matrices of nx × nx.
    pub n: Vec<PolyMatrix>,
    /// B(θ), nx × nu.
    pub b: PolyMatrix,
    /// C(θ), ny × nx.
    pub c: PolyMatrix,
    /// M_k(θ), ny matrices of nx × nx.
    pub m: Vec<PolyMatrix>,
    /// The convergence region P, in both representations.
    pub region: Region,
    /// The state bound F.
    pub state_bound: StateBound,
    /// Design requests in source order.
    pub designs: Vec<DesignRequest>,
    /// Non-fatal remarks found while building the model.
    pub warnings: Vec<Warning>,
}

impl Model {
    /// Number of states.
    pub fn nx(&self) -> usize {
        self.states.len()
    }
    /// Number of inputs.
    pub fn nu(&self) -> usize {
        self.inputs.len()
    }
    /// Number of outputs.
    pub fn ny(&self) -> usize {
        self.outputs.len()
    }
    /// Number of declared parameters.
    pub fn ntheta(&self) -> usize {
        self.params.len()
    }
}

// ===================== Building: AST → validated Model =====================

use crate::ast::{self, Expr, ExprKind, Item, MatrixLit, MatrixValue, ModelAst};
use crate::diagnostic::{line_col, suggest, Diag};
use crate::equations::{self, Split as TermSplit};
use crate::poly::{bits, eval, fmt_num, quote, Allowed, NameRef, Names, Poly, Scope};
use crate::region::{hull_from_halfspaces, hull_from_vertices, RegionError, MAX_REGION_VERTICES};
use nalgebra::{DMatrix, DVector};
use std::collections::HashMap;

/// Most states, inputs or outputs of a model.
pub const MAX_DIM: usize = 64;
/// Most declared parameters of a model (θ masks are 64-bit).
pub const MAX_PARAMS: usize = 63;
/// Most parameters that may generate vertices (2^16 vertices).
pub const MAX_SCHEDULING: usize = 16;

type R<T> = Result<T, Diag>;

fn kind_word(r: NameRef) -> &'static str {
    match r {
        NameRef::State(_) => "a state",
        NameRef::Input(_) => "an input",
        NameRef::Output(_) => "an output",
        NameRef::Param(_) => "a parameter",
    }
}

/// What a matrix name denotes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum MatName {
    A,
    B,
    C,
    N(usize),
    M(usize),
}

impl MatName {
    fn label(self) -> String {
        match self {
            MatName::A => "A".into(),
            MatName::B => "B".into(),
            MatName::C => "C".into(),
            MatName::N(k) => format!("N{}", k + 1),
            MatName::M(k) => format!("M{}", k + 1),
        }
    }
}

struct Builder<'a> {
    src: &'a str,
    ast: &'a ModelAst,
    names: Names,
    decl_spans: HashMap<String, Span>,
    warnings: Vec<Warning>,
}

fn pos(src: &str, span: Span) -> String {
    let (l, c) = line_col(src, span.start);
    format!("{l}:{c}")
}

/// Builds and validates one model.
pub(crate) fn build(src: &str, ast: &ModelAst) -> R<Model> {
    let mut b = Builder {
        src,
        ast,
        names: Names::default(),
        decl_spans: HashMap::new(),
        warnings: Vec::new(),
    };
    b.declare()?;
    let params = b.params()?;
    let (a, n, bm) = b.dynamics()?;
    let (c, m) = b.outputs()?;
    let region = b.region()?;
    let state_bound = b.state_bound(&region)?;
    let designs = b.designs()?;
    let mut model = Model {
        name: ast.name.name.clone(),
        span: ast.name.span,
        states: b.names.states.clone(),
        inputs: b.names.inputs.clone(),
        outputs: b.names.outputs.clone(),
        params,
        a,
        n,
        b: bm,
        c,
        m,
        region,
        state_bound,
        designs,
        warnings: Vec::new(),
    };
    b.usage(&model)?;
    model.warnings = b.warnings;
    Ok(model)
}

impl<'a> Builder<'a> {
    fn scope(&self, allowed: Allowed, context: &'a str) -> Scope<'_> {
        Scope {
            src: self.src,
            names: &self.names,
            allowed,
            context,
        }
    }

    fn constant(&self, e: &Expr, context: &str) -> R<f64> {
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

    // ----- declarations -----

    fn declare(&mut self) -> R<()> {
        for item in &self.ast.items {
            let (list, kind): (&[ast::Ident], u8) = match item {
                Item::States(l) => (l, 0),
                Item::Inputs(l) => (l, 1),
                Item::Outputs(l) => (l, 2),
                Item::Params(p) => (&p.names, 3),
                _ => continue,
            };
            for id in list {
                if let Some(prev) = self.names.lookup.get(&id.name) {
                    let at = self.decl_spans[&id.name];
                    return Err(Diag::new(
                        id.span,
                        format!(
                            "`{}` is already declared as {} at {}: every name in a model must be unique",
                            id.name,
                            kind_word(*prev),
                            pos(self.src, at)
                        ),
                    ));
                }
                let (vec, limit, what) = match kind {
                    0 => (&mut self.names.states, MAX_DIM, "states"),
                    1 => (&mut self.names.inputs, MAX_DIM, "inputs"),
                    2 => (&mut self.names.outputs, MAX_DIM, "outputs"),
                    _ => (&mut self.names.params, MAX_PARAMS, "parameters"),
                };
                if vec.len() >= limit {
                    return Err(Diag::new(
                        id.span,
                        format!("too many {what}: at most {limit} are supported"),
                    ));
                }
                let r = match kind {
                    0 => NameRef::State(vec.len()),
                    1 => NameRef::Input(vec.len()),
                    2 => NameRef::Output(vec.len()),
                    _ => NameRef::Param(vec.len()),
                };
                vec.push(id.name.clone());
                self.names.lookup.insert(id.name.clone(), r);
                self.decl_spans.insert(id.name.clone(), id.span);
            }
        }
        let name = &self.ast.name;
        if self.names.states.is_empty() {
            return Err(Diag::new(
                name.span,
                format!(
                    "model `{}` declares no states: add `state x1, x2, ...;`",
                    name.name
                ),
            ));
        }
        if self.names.outputs.is_empty() {
            return Err(Diag::new(
                name.span,
                format!(
                    "model `{}` declares no outputs: an observer needs measurements, add `output y1, ...;`",
                    name.name
                ),
            ));
        }
        Ok(())
    }

    fn params(&self) -> R<Vec<Param>> {
        let mut out = Vec::new();
        for item in &self.ast.items {
            let Item::Params(p) = item else { continue };
            let lo = self.constant(&p.lo, "a parameter bound")?;
            let hi = self.constant(&p.hi, "a parameter bound")?;
            if lo == hi {
                return Err(Diag::new(
                    p.interval,
                    format!(
                        "empty parameter range [{}, {}]: the upper bound must be greater than the lower \
                         bound (a parameter with a fixed value is a constant: write the number instead)",
                        fmt_num(lo),
                        fmt_num(hi)
                    ),
                ));
            }
            if lo > hi {
                return Err(Diag::new(
                    p.interval,
                    format!(
                        "reversed parameter range [{}, {}]: the lower bound comes first, write [{}, {}]",
                        fmt_num(lo),
                        fmt_num(hi),
                        fmt_num(hi),
                        fmt_num(lo)
                    ),
                ));
            }
            for id in &p.names {
                out.push(Param {
                    name: id.name.clone(),
                    lo,
                    hi,
                    span: id.span,
                });
            }
        }
        Ok(out)
    }

    // ----- matrices -----

    fn mat_name(&self, id: &ast::Ident) -> R<MatName> {
        let nx = self.names.states.len();
        let ny = self.names.outputs.len();
        let w = id.name.as_str();
        let unknown = || {
            let mut list = String::from("A, B, C");
            list.push_str(&if nx == 1 {
                ", N1".to_string()
            } else {
                format!(", N1..N{nx}")
            });
            list.push_str(&if ny == 1 {
                " or M1".to_string()
            } else {
                format!(" or M1..M{ny}")
            });
            let extra = if w == "Q" {
                " (the state bound is written `state_bound Q = [...];`)"
            } else if w == "D" {
                " (direct feedthrough D u is not supported)"
            } else {
                ""
            };
            Diag::new(
                id.span,
                format!("unknown matrix `{w}`: expected {list}{extra}"),
            )
        };
        match w {
            "A" => return Ok(MatName::A),
            "B" => return Ok(MatName::B),
            "C" => return Ok(MatName::C),
            _ => {}
        }
        if !crate::syntax::is_matrix_name_shape(w) {
            return Err(unknown());
        }
        let digits = w[1..].trim_start_matches('_');
        let k: usize = digits.parse().unwrap_or(usize::MAX);
        let (count, what, letter) = if w.starts_with('N') {
            (nx, "states", 'N')
        } else {
            (ny, "outputs", 'M')
        };
        if k == 0 || k > count {
            return Err(Diag::new(
                id.span,
                format!(
                    "`{w}` does not exist: the model has {count} {what}, so {} (numbered from 1)",
                    if count == 1 {
                        format!("{letter}1 is the only one")
                    } else {
                        format!("{letter}1..{letter}{count}")
                    }
                ),
            ));
        }
        Ok(if letter == 'N' {
            MatName::N(k - 1)
        } else {
            MatName::M(k - 1)
        })
    }

    /// Size and meaning of rows/columns of each matrix.
    fn shape(&self, m: MatName) -> (usize, usize, &'static str, &'static str) {
        let nx = self.names.states.len();
        match m {
            MatName::A => (nx, nx, "one per state", "one per state"),
            MatName::B => (
                nx,
                self.names.inputs.len(),
                "one per state",
                "one per input",
            ),
            MatName::C => (
                self.names.outputs.len(),
                nx,
                "one per output",
                "one per state",
            ),
            MatName::N(_) | MatName::M(_) => (nx, nx, "one per state", "one per state"),
        }
    }

    /// Checks the shape of a literal: each row's length, then the row count.
    fn check_shape(
        &self,
        lit: &MatrixLit,
        label: &str,
        rows: usize,
        cols: usize,
        rmean: &str,
        cmean: &str,
    ) -> R<()> {
        for (r, row) in lit.rows.iter().enumerate() {
            if row.entries.len() != cols {
                return Err(Diag::new(
                    row.span,
                    format!(
                        "row {} of {label} has {} {}, expected {cols} ({cmean})",
                        r + 1,
                        row.entries.len(),
                        if row.entries.len() == 1 {
                            "entry"
                        } else {
                            "entries"
                        }
                    ),
                ));
            }
        }
        if lit.rows.len() != rows {
            return Err(Diag::new(
                lit.span,
                format!(
                    "{label} must have {rows} rows ({rmean}), found {}",
                    lit.rows.len()
                ),
            ));
        }
        Ok(())
    }

    fn matrix_value(&self, def: &ast::MatrixDef, m: MatName) -> R<(PolyMatrix, Vec<Span>)> {
        let (rows, cols, rmean, cmean) = self.shape(m);
        let label = m.label();
        match &def.value {
            MatrixValue::Scalar(e) => {
                let scope = self.scope(Allowed::Coefficient, "a matrix entry");
                let p = eval(e, &scope)?;
                if p.as_constant() == Some(0.0) {
                    Ok((PolyMatrix::zeros(rows, cols), vec![e.span; rows * cols]))
                } else {
                    Err(Diag::new(
                        e.span,
                        format!(
                            "{label} must be a matrix `[...]` of size {rows}×{cols}; only `0` may stand \
                             for a whole (zero) matrix"
                        ),
                    ))
                }
            }
            MatrixValue::Literal(lit) => {
                self.check_shape(lit, &label, rows, cols, rmean, cmean)?;
                let context = format!("an entry of {label}");
                let scope = Scope {
                    src: self.src,
                    names: &self.names,
                    allowed: Allowed::Coefficient,
                    context: &context,
                };
                let mut pm = PolyMatrix::zeros(rows, cols);
                let mut spans = Vec::with_capacity(rows * cols);
                for (i, row) in lit.rows.iter().enumerate() {
                    for (j, e) in row.entries.iter().enumerate() {
                        *pm.get_mut(i, j) = eval(e, &scope)?.to_theta();
                        spans.push(e.span);
                    }
                }
                Ok((pm, spans))
            }
        }
    }

    /// The matrix definitions by name (duplicates rejected).
    fn matrix_defs(&self) -> R<Vec<(MatName, &'a ast::MatrixDef)>> {
        let mut out: Vec<(MatName, &ast::MatrixDef)> = Vec::new();
        for item in &self.ast.items {
            let Item::Matrix(def) = item else { continue };
            let m = self.mat_name(&def.name)?;
            if let Some((_, prev)) = out.iter().find(|(n, _)| *n == m) {
                return Err(Diag::new(
                    def.name.span,
                    format!(
                        "{} is defined twice (first at {})",
                        m.label(),
                        pos(self.src, prev.name.span)
                    ),
                ));
            }
            out.push((m, def));
        }
        Ok(out)
    }

    /// Equations `der`/`out` by target index; duplicates and unknown targets rejected.
    fn equations(&self, der: bool) -> R<Vec<(usize, &'a ast::Equation)>> {
        let mut out: Vec<(usize, &ast::Equation)> = Vec::new();
        let (kw, want) = if der {
            ("der", "state")
        } else {
            ("out", "output")
        };
        for item in &self.ast.items {
            let eq = match (item, der) {
                (Item::Der(e), true) | (Item::Out(e), false) => e,
                _ => continue,
            };
            let t = &eq.target;
            let idx = match (self.names.lookup.get(&t.name), der) {
                (Some(NameRef::State(i)), true) | (Some(NameRef::Output(i)), false) => *i,
                (Some(r), _) => {
                    let hint = match r {
                        NameRef::Output(_) => {
                            format!(" (write `out {} = ...;` for an output)", t.name)
                        }
                        NameRef::State(_) => {
                            format!(" (write `der {} = ...;` for a state)", t.name)
                        }
                        _ => String::new(),
                    };
                    return Err(Diag::new(
                        t.span,
                        format!(
                            "`{kw} {}`: `{}` is {}, not {} {want}{hint}",
                            t.name,
                            t.name,
                            kind_word(*r),
                            if der { "a" } else { "an" }
                        ),
                    ));
                }
                (None, _) => {
                    let list = if der {
                        &self.names.states
                    } else {
                        &self.names.outputs
                    };
                    let hint = suggest(&t.name, list.iter().map(|s| s.as_str()))
                        .map(|s| format!(" (did you mean `{s}`?)"))
                        .unwrap_or_default();
                    return Err(Diag::new(
                        t.span,
                        format!(
                            "`{kw} {}`: `{}` is not a declared {want}{hint}",
                            t.name, t.name
                        ),
                    ));
                }
            };
            if let Some((_, prev)) = out.iter().find(|(i, _)| *i == idx) {
                return Err(Diag::new(
                    t.span,
                    format!(
                        "`{kw} {}` is given twice (first at {})",
                        t.name,
                        pos(self.src, prev.span)
                    ),
                ));
            }
            out.push((idx, eq));
        }
        Ok(out)
    }

    fn missing_equation(&self, der: bool, have: &[(usize, &ast::Equation)]) -> R<()> {
        let (kw, list, what) = if der {
            ("der", &self.names.states, "state")
        } else {
            ("out", &self.names.outputs, "output")
        };
        if let Some(i) = (0..list.len()).find(|i| !have.iter().any(|(j, _)| j == i)) {
            return Err(Diag::new(
                self.ast.name.span,
                format!(
                    "model `{}` has no equation for the {what} `{}`: add `{kw} {} = ...;` (once \
                     equations are used, every {what} needs one)",
                    self.ast.name.name, list[i], list[i]
                ),
            ));
        }
        Ok(())
    }

    fn dynamics(&mut self) -> R<(PolyMatrix, Vec<PolyMatrix>, PolyMatrix)> {
        let defs = self.matrix_defs()?;
        let ders = self.equations(true)?;
        let nx = self.names.states.len();
        let nu = self.names.inputs.len();
        let dyn_defs: Vec<&(MatName, &ast::MatrixDef)> = defs
            .iter()
            .filter(|(m, _)| matches!(m, MatName::A | MatName::B | MatName::N(_)))
            .collect();
        if !ders.is_empty() {
            if let Some((m, def)) = dyn_defs.first() {
                return Err(Diag::new(
                    def.name.span,
                    format!(
                        "{} is given as a matrix, but the dynamics are also written as equations \
                         (`der {}` at {}): use one form",
                        m.label(),
                        ders[0].1.target.name,
                        pos(self.src, ders[0].1.span)
                    ),
                ));
            }
            self.missing_equation(true, &ders)?;
            let scope = self.scope(Allowed::Equation, "an equation");
            let mut polys = vec![Poly::default(); nx];
            for (i, eq) in &ders {
                polys[*i] = eval(&eq.rhs, &scope)?;
            }
            let d = equations::dynamics(self.src, &self.names, &polys, TermSplit::AsWritten)?;
            return Ok((d.a, d.n, d.b));
        }
        // matrix form
        let get = |m: MatName| defs.iter().find(|(n, _)| *n == m).map(|(_, d)| *d);
        let Some(adef) = get(MatName::A) else {
            return Err(Diag::new(
                self.ast.name.span,
                format!(
                    "model `{}` has no dynamics: give `A = [...];` (and N1..N{nx} for quadratic terms) \
                     or one `der x = ...;` per state",
                    self.ast.name.name
                ),
            ));
        };
        let (a, _) = self.matrix_value(adef, MatName::A)?;
        let b =
            match (get(MatName::B), nu) {
                (Some(def), 0) => return Err(Diag::new(
                    def.name.span,
                    "B is given but the model declares no inputs: add `input u1, ...;` or remove B",
                )),
                (Some(def), _) => self.matrix_value(def, MatName::B)?.0,
                (None, 0) => PolyMatrix::zeros(nx, 0),
                (None, _) => {
                    return Err(Diag::new(
                        self.ast.name.span,
                        format!(
                            "model `{}` declares inputs ({}) but gives no `B = [...];` ({nx}×{nu})",
                            self.ast.name.name,
                            self.names.inputs.join(", ")
                        ),
                    ))
                }
            };
        let n = self.all_or_none(&defs, true)?;
        Ok((a, n, b))
    }

    /// N_1..N_nx (or M_1..M_ny): all given, or none (then zero).
    fn all_or_none(&self, defs: &[(MatName, &ast::MatrixDef)], n: bool) -> R<Vec<PolyMatrix>> {
        let nx = self.names.states.len();
        let count = if n { nx } else { self.names.outputs.len() };
        let mk = |k| if n { MatName::N(k) } else { MatName::M(k) };
        let given: Vec<Option<&ast::MatrixDef>> = (0..count)
            .map(|k| defs.iter().find(|(m, _)| *m == mk(k)).map(|(_, d)| *d))
            .collect();
        let first = given.iter().flatten().next();
        let Some(first) = first else {
            return Ok(vec![PolyMatrix::zeros(nx, nx); count]);
        };
        if let Some(missing) = given.iter().position(|g| g.is_none()) {
            let letter = if n { 'N' } else { 'M' };
            let have: Vec<String> = (0..count)
                .filter(|k| given[*k].is_some())
                .map(|k| format!("{letter}{}", k + 1))
                .collect();
            return Err(Diag::new(
                first.name.span,
                format!(
                    "{letter}{} is missing ({} given): give all of {letter}1..{letter}{count} \
                     (`{letter}{} = 0;` for a zero matrix), or none for a model without quadratic terms",
                    missing + 1,
                    have.join(", "),
                    missing + 1
                ),
            ));
        }
        let mut out = Vec::with_capacity(count);
        for (k, def) in given.iter().enumerate() {
            let def = def.ok_or_else(|| Diag::new(first.name.span, "internal error: N/M"))?;
            out.push(self.matrix_value(def, mk(k))?.0);
        }
        Ok(out)
    }

    fn outputs(&mut self) -> R<(PolyMatrix, Vec<PolyMatrix>)> {
        let defs = self.matrix_defs()?;
        let outs = self.equations(false)?;
        let nx = self.names.states.len();
        let ny = self.names.outputs.len();
        if !outs.is_empty() {
            if let Some((m, def)) = defs
                .iter()
                .find(|(m, _)| matches!(m, MatName::C | MatName::M(_)))
            {
                return Err(Diag::new(
                    def.name.span,
                    format!(
                        "{} is given as a matrix, but the outputs are also written as equations \
                         (`out {}` at {}): use one form",
                        m.label(),
                        outs[0].1.target.name,
                        pos(self.src, outs[0].1.span)
                    ),
                ));
            }
            self.missing_equation(false, &outs)?;
            let scope = self.scope(Allowed::Equation, "an equation");
            let mut polys = vec![Poly::default(); ny];
            for (i, eq) in &outs {
                polys[*i] = eval(&eq.rhs, &scope)?;
            }
            let o = equations::outputs(self.src, &self.names, &polys, TermSplit::AsWritten)?;
            return Ok((o.c, o.m));
        }
        let Some((_, cdef)) = defs.iter().find(|(m, _)| *m == MatName::C) else {
            return Err(Diag::new(
                self.ast.name.span,
                format!(
                    "model `{}` has no output equation: give `C = [...];` ({ny}×{nx}, and M1..M{ny} for \
                     quadratic terms) or one `out y = ...;` per output",
                    self.ast.name.name
                ),
            ));
        };
        let (c, _) = self.matrix_value(cdef, MatName::C)?;
        let m = self.all_or_none(&defs, false)?;
        Ok((c, m))
    }

    // ----- region, state bound, designs -----

    fn constant_rows(&self, lit: &MatrixLit, what: &str, context: &str) -> R<Vec<DVector<f64>>> {
        let nx = self.names.states.len();
        for (r, row) in lit.rows.iter().enumerate() {
            if row.entries.len() != nx {
                return Err(Diag::new(
                    row.span,
                    format!(
                        "{what} {} has {} {}, expected {nx} (one per state)",
                        r + 1,
                        row.entries.len(),
                        if row.entries.len() == 1 {
                            "coordinate"
                        } else {
                            "coordinates"
                        }
                    ),
                ));
            }
        }
        lit.rows
            .iter()
            .map(|row| {
                let v = row
                    .entries
                    .iter()
                    .map(|e| self.constant(e, context))
                    .collect::<R<Vec<f64>>>()?;
                Ok(DVector::from_vec(v))
            })
            .collect()
    }

    fn region(&mut self) -> R<Region> {
        let nx = self.names.states.len();
        let mut decl: Option<&ast::RegionDecl> = None;
        for item in &self.ast.items {
            if let Item::Region(r) = item {
                if let Some(prev) = decl {
                    return Err(Diag::new(
                        r.span,
                        format!(
                            "the region is given twice (first at {})",
                            pos(self.src, prev.span)
                        ),
                    ));
                }
                decl = Some(r);
            }
        }
        let Some(decl) = decl else {
            return Err(Diag::new(
                self.ast.name.span,
                format!(
                    "model `{}` has no region: add `region box(r);`, `region vertices [...];` or \
                     `region halfspaces [...];`",
                    self.ast.name.name
                ),
            ));
        };
        let ctx = "the region";
        let radius = |e: &Expr| -> R<f64> {
            let r = self.constant(e, ctx)?;
            if r > 0.0 {
                Ok(r)
            } else {
                Err(Diag::new(
                    e.span,
                    format!("a box radius must be positive, found {}", fmt_num(r)),
                ))
            }
        };
        let too_big = |span: Span| {
            Diag::new(
                span,
                format!(
                    "a box in {nx} dimensions has 2^{nx} vertices; at most {MAX_REGION_VERTICES} are \
                     supported (give the region by `vertices` or `halfspaces` instead)"
                ),
            )
        };
        let (result, lit, what) = match &decl.shape {
            ast::RegionShape::BoxScalar(e) => {
                let r = radius(e)?;
                return Region::from_box(&vec![r; nx]).map_err(|_| too_big(decl.span));
            }
            ast::RegionShape::BoxVector(v, span) => {
                if v.len() != nx {
                    return Err(Diag::new(
                        *span,
                        format!(
                            "box radii: expected {nx} values (one per state), found {}",
                            v.len()
                        ),
                    ));
                }
                let r = v.iter().map(radius).collect::<R<Vec<f64>>>()?;
                return Region::from_box(&r).map_err(|_| too_big(decl.span));
            }
            ast::RegionShape::Vertices(lit) => {
                let pts = self.constant_rows(lit, "vertex", ctx)?;
                (hull_from_vertices(&pts), lit, "vertex")
            }
            ast::RegionShape::Halfspaces(lit) => {
                let rows = self.constant_rows(lit, "halfspace", ctx)?;
                (hull_from_halfspaces(&rows), lit, "halfspace")
            }
        };
        match result {
            Ok((region, dropped)) => {
                for i in dropped {
                    let msg = if what == "vertex" {
                        format!(
                            "vertex {} is not a vertex of the region (it lies inside, on a face, or repeats \
                             another); it is ignored",
                            i + 1
                        )
                    } else {
                        format!(
                            "halfspace {} is redundant (implied by the others, or repeated); it is ignored",
                            i + 1
                        )
                    };
                    self.warnings.push(Warning {
                        message: msg,
                        span: lit.rows[i].span,
                    });
                }
                Ok(region)
            }
            Err(e) => {
                let extra = match e {
                    RegionError::OriginNotInterior { .. } | RegionError::Unbounded { .. } => "",
                    _ => "",
                };
                Err(Diag::new(lit.span, format!("{e}{extra}")))
            }
        }
    }

    fn state_bound(&mut self, region: &Region) -> R<StateBound> {
        let mut decl: Option<(&ast::BoundDecl, Span)> = None;
        for item in &self.ast.items {
            if let Item::StateBound(bound, span) = item {
                if let Some((_, prev)) = decl {
                    return Err(Diag::new(
                        *span,
                        format!(
                            "the state bound is given twice (first at {})",
                            pos(self.src, prev)
                        ),
                    ));
                }
                decl = Some((bound, *span));
            }
        }
        let Some((bound, span)) = decl else {
            return Ok(StateBound::None);
        };
        let lit = match bound {
            ast::BoundDecl::Given(lit) => lit,
            ast::BoundDecl::Auto(options) => return self.auto_bound(options, region),
        };
        let nx = self.names.states.len();
        self.check_shape(lit, "Q", nx, nx, "one per state", "one per state")?;
        let mut q = DMatrix::zeros(nx, nx);
        for (i, row) in lit.rows.iter().enumerate() {
            for (j, e) in row.entries.iter().enumerate() {
                q[(i, j)] = self.constant(e, "the state bound Q")?;
            }
        }
        let scale = q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for i in 0..nx {
            for j in 0..i {
                if (q[(i, j)] - q[(j, i)]).abs() > 1e-9 * scale {
                    return Err(Diag::new(
                        lit.rows[i].entries[j].span,
                        format!(
                            "Q must be symmetric: entry ({}, {}) is {} but entry ({}, {}) is {}",
                            i + 1,
                            j + 1,
                            fmt_num(q[(i, j)]),
                            j + 1,
                            i + 1,
                            fmt_num(q[(j, i)])
                        ),
                    ));
                }
            }
        }
        let q = (&q + q.transpose()) * 0.5;
        let min_eig = q
            .clone()
            .symmetric_eigenvalues()
            .iter()
            .fold(f64::INFINITY, |m, x| m.min(*x));
        let chol = if min_eig > 1e-12 * scale {
            q.clone().cholesky()
        } else {
            None
        };
        let Some(chol) = chol else {
            return Err(Diag::new(
                lit.span,
                format!(
                    "Q must be positive definite (F = {{x : xᵀQ⁻¹x ≤ 1}} is then a bounded ellipsoid), \
                     but its smallest eigenvalue is {}",
                    fmt_num(min_eig)
                ),
            ));
        };
        let qinv = chol.inverse();
        if let Some((worst, i)) = region.max_quadratic(&qinv) {
            if worst > 1.0 + 1e-9 {
                let v = &region.vertices[i];
                let coords: Vec<String> = v.iter().map(|x| fmt_num(*x)).collect();
                self.warnings.push(Warning {
                    message: format!(
                        "the region is not inside the state bound F = {{x : xᵀQ⁻¹x ≤ 1}} (Assumption 2, \
                         P ⊂ F): the vertex ({}) has xᵀQ⁻¹x = {:.4} > 1; the region would have to shrink \
                         by the factor {:.4} to fit",
                        coords.join(", "),
                        worst,
                        1.0 / worst.sqrt()
                    ),
                    span,
                });
            }
        }
        Ok(StateBound::Given(q))
    }

    /// `state_bound auto(h = ...);`: validates the options.
    fn auto_bound(&self, options: &[ast::DesignEntry], region: &Region) -> R<StateBound> {
        let mut h = None;
        let mut seen: Option<Span> = None;
        for entry in options {
            let key = entry.key.name.as_str();
            if key != "h" {
                let hint = suggest(key, ["h"])
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                return Err(Diag::new(
                    entry.key.span,
                    format!(
                        "unknown state bound option `{key}`: expected `h` (the half-width of the \
                         box |x_i| ≤ h that encloses F){hint}"
                    ),
                ));
            }
            if let Some(prev) = seen {
                return Err(Diag::new(
                    entry.key.span,
                    format!("`h` is set twice (first at {})", pos(self.src, prev)),
                ));
            }
            seen = Some(entry.key.span);
            let v = &entry.value;
            let value = self.constant(v, "the state bound option h")?;
            if !(value > 0.0 && value.is_finite()) {
                return Err(bad_value(v.span, "h", "a positive number", &fmt_num(value)));
            }
            let reach = region
                .vertices
                .iter()
                .flat_map(|x| x.iter())
                .fold(0.0f64, |m, x| m.max(x.abs()));
            if value <= reach {
                return Err(Diag::new(
                    v.span,
                    format!(
                        "`h` = {} is too small: F must contain the region and lie inside the box \
                         |x_i| ≤ h, but the region reaches |x_i| = {}; choose h > {}",
                        fmt_num(value),
                        fmt_num(reach),
                        fmt_num(reach)
                    ),
                ));
            }
            h = Some(value);
        }
        Ok(StateBound::Auto { h })
    }

    fn designs(&self) -> R<Vec<DesignRequest>> {
        let mut out = Vec::new();
        for item in &self.ast.items {
            let Item::Design(block) = item else { continue };
            let mut req = DesignRequest {
                span: block.span,
                ..Default::default()
            };
            let mut split: Option<Split> = None;
            let mut seen: Vec<(&str, Span)> = Vec::new();
            for entry in &block.entries {
                let key = entry.key.name.as_str();
                if let Some((_, prev)) = seen.iter().find(|(k, _)| *k == key) {
                    return Err(Diag::new(
                        entry.key.span,
                        format!(
                            "`{key}` is set twice in this design block (first at {})",
                            pos(self.src, *prev)
                        ),
                    ));
                }
                let word = match &entry.value.kind {
                    ExprKind::Name(n) => Some(n.as_str()),
                    _ => None,
                };
                let v = &entry.value;
                if let (Some((_, ospan)), false) = (&entry.options, key == "output_route") {
                    return Err(Diag::new(
                        *ospan,
                        format!(
                            "`{key}` takes no options in parentheses (only `output_route = \
                             filter(...)` does)"
                        ),
                    ));
                }
                match key {
                    "alpha" => {
                        req.alpha = match word {
                            Some("max") => AlphaSpec::Max,
                            Some(w) => {
                                return Err(bad_value(
                                    v.span,
                                    "alpha",
                                    "a positive number or `max`",
                                    w,
                                ))
                            }
                            None => {
                                let a = self.constant(v, "the design value of alpha")?;
                                if a <= 0.0 {
                                    return Err(bad_value(
                                        v.span,
                                        "alpha",
                                        "a positive number or `max`",
                                        &fmt_num(a),
                                    ));
                                }
                                AlphaSpec::Fixed(a)
                            }
                        }
                    }
                    "gamma" => {
                        req.gamma = match word {
                            Some("search") => GammaSpec::Search,
                            Some(w) => {
                                return Err(bad_value(
                                    v.span,
                                    "gamma",
                                    "a number strictly between 0 and 1 or `search`",
                                    w,
                                ))
                            }
                            None => {
                                let g = self.constant(v, "the design value of gamma")?;
                                if !(g > 0.0 && g < 1.0) {
                                    return Err(bad_value(
                                        v.span,
                                        "gamma",
                                        "a number strictly between 0 and 1 or `search`",
                                        &fmt_num(g),
                                    ));
                                }
                                GammaSpec::Fixed(g)
                            }
                        }
                    }
                    "mode" => {
                        req.mode = match word {
                            Some("sound") => Mode::Sound,
                            Some("paper") => Mode::Paper,
                            _ => {
                                return Err(bad_value(
                                    v.span,
                                    "mode",
                                    "`sound` or `paper`",
                                    &quote(self.src, v.span).replace('`', ""),
                                ))
                            }
                        }
                    }
                    "split" => {
                        split = Some(match word {
                            Some("as_written") => Split::AsWritten,
                            Some("symmetric") => Split::Symmetric,
                            Some("skew_slack") => Split::SkewSlack,
                            _ => {
                                return Err(bad_value(
                                    v.span,
                                    "split",
                                    "`as_written`, `symmetric` or `skew_slack`",
                                    &quote(self.src, v.span).replace('`', ""),
                                ))
                            }
                        })
                    }
                    "conditions" => {
                        req.conditions = match word {
                            Some("full") => Conditions::Full,
                            Some("decoupled") => Conditions::Decoupled,
                            _ => {
                                return Err(bad_value(
                                    v.span,
                                    "conditions",
                                    "`full` or `decoupled`",
                                    &quote(self.src, v.span).replace('`', ""),
                                ))
                            }
                        }
                    }
                    "output_route" => req.output_route = match word {
                        Some("double_sum") => {
                            if let Some((_, ospan)) = &entry.options {
                                return Err(Diag::new(
                                    *ospan,
                                    "`double_sum` takes no options (only `filter(pole = .., \
                                         gain = ..)` does)",
                                ));
                            }
                            OutputRoute::DoubleSum
                        }
                        Some("filter") => OutputRoute::Filter(
                            self.filter_options(
                                entry
                                    .options
                                    .as_ref()
                                    .map(|(o, _)| o.as_slice())
                                    .unwrap_or(&[]),
                            )?,
                        ),
                        _ => return Err(bad_value(
                            v.span,
                            "output_route",
                            "`double_sum` or `filter` (optionally `filter(pole = .., gain = ..)`)",
                            &quote(self.src, v.span).replace('`', ""),
                        )),
                    },
                    _ => {
                        let hint = suggest(key, DESIGN_KEYS)
                            .map(|s| format!(" (did you mean `{s}`?)"))
                            .unwrap_or_default();
                        return Err(Diag::new(
                            entry.key.span,
                            format!(
                                "unknown design setting `{key}`: expected `alpha`, `gamma`, `mode`, \
                                 `split`, `conditions` or `output_route`{hint}"
                            ),
                        ));
                    }
                }
                seen.push((key, entry.key.span));
            }
            req.split = split.unwrap_or(Split::default_for(req.mode));
            if req.split == Split::SkewSlack && req.mode == Mode::Paper {
                let (_, at) = seen
                    .iter()
                    .find(|(k, _)| *k == "split")
                    .copied()
                    .unwrap_or(("", block.span));
                return Err(Diag::new(
                    at,
                    "`split = skew_slack` needs `mode = sound`: the paper's printed conditions \
                     are reproduced as written, with no slack",
                ));
            }
            out.push(req);
        }
        Ok(out)
    }

    /// `filter(pole = .., gain = ..)`: both optional; gain defaults to pole
    /// (unit DC gain), pole to [`OutputFilter::DEFAULT_POLE`].
    fn filter_options(&self, options: &[ast::DesignEntry]) -> R<OutputFilter> {
        let mut pole = None;
        let mut gain = None;
        for entry in options {
            let key = entry.key.name.as_str();
            let slot = match key {
                "pole" => &mut pole,
                "gain" => &mut gain,
                _ => {
                    let hint = suggest(key, ["pole", "gain"])
                        .map(|s| format!(" (did you mean `{s}`?)"))
                        .unwrap_or_default();
                    return Err(Diag::new(
                        entry.key.span,
                        format!(
                            "unknown filter option `{key}`: expected `pole` (a > 0, the filter is \
                             x_y' = -a x_y + b y) or `gain` (b ≠ 0){hint}"
                        ),
                    ));
                }
            };
            if let Some((_, prev)) = slot {
                return Err(Diag::new(
                    entry.key.span,
                    format!("`{key}` is set twice (first at {})", pos(self.src, *prev)),
                ));
            }
            let v = &entry.value;
            let value = self.constant(v, &format!("the filter option {key}"))?;
            let ok = value.is_finite()
                && if key == "pole" {
                    value > 0.0
                } else {
                    value != 0.0
                };
            if !ok {
                let want = if key == "pole" {
                    "a positive number (the filter pole is -pole)"
                } else {
                    "a nonzero number"
                };
                return Err(bad_value(v.span, key, want, &fmt_num(value)));
            }
            *slot = Some((value, entry.key.span));
        }
        let pole = pole.map(|p| p.0).unwrap_or(OutputFilter::DEFAULT_POLE);
        Ok(OutputFilter {
            pole,
            gain: gain.map(|g| g.0).unwrap_or(pole),
        })
    }

    // ----- usage warnings and limits -----

    fn usage(&mut self, model: &Model) -> R<()> {
        let used = model.param_mask();
        for (i, p) in model.params.iter().enumerate() {
            if used & (1 << i) == 0 {
                self.warnings.push(Warning {
                    message: format!(
                        "parameter `{}` appears in no matrix: it adds no vertices (remove it, or check \
                         the equations)",
                        p.name
                    ),
                    span: p.span,
                });
            }
        }
        let sched: Vec<usize> = bits(used).collect();
        if sched.len() > MAX_SCHEDULING {
            let p = &model.params[sched[MAX_SCHEDULING]];
            return Err(Diag::new(
                p.span,
                format!(
                    "too many scheduling parameters ({}): the polytopic model would have 2^{} vertices; \
                     at most {MAX_SCHEDULING} parameters may appear in the matrices",
                    sched.len(),
                    sched.len()
                ),
            ));
        }
        for (j, u) in model.inputs.iter().enumerate() {
            if (0..model.nx()).all(|i| model.b.get(i, j).is_zero()) {
                self.warnings.push(Warning {
                    message: format!("input `{u}` has no effect: its column of B is zero"),
                    span: self.decl_spans.get(u).copied().unwrap_or(model.span),
                });
            }
        }
        Ok(())
    }
}

/// The keys of a `design { ... }` block.
const DESIGN_KEYS: [&str; 6] = [
    "alpha",
    "gamma",
    "mode",
    "split",
    "conditions",
    "output_route",
];

fn bad_value(span: Span, key: &str, expected: &str, found: &str) -> Diag {
    Diag::new(span, format!("`{key}` must be {expected}, found `{found}`"))
}

impl Model {
    /// A(θ) at a full parameter vector (one entry per declared parameter).
    pub fn eval_a(&self, theta: &[f64]) -> DMatrix<f64> {
        self.a.eval(theta)
    }
    /// N_k(θ), k = 1..nx.
    pub fn eval_n(&self, theta: &[f64]) -> Vec<DMatrix<f64>> {
        self.n.iter().map(|m| m.eval(theta)).collect()
    }
    /// B(θ).
    pub fn eval_b(&self, theta: &[f64]) -> DMatrix<f64> {
        self.b.eval(theta)
    }
    /// C(θ).
    pub fn eval_c(&self, theta: &[f64]) -> DMatrix<f64> {
        self.c.eval(theta)
    }
    /// M_k(θ), k = 1..ny.
    pub fn eval_m(&self, theta: &[f64]) -> Vec<DMatrix<f64>> {
        self.m.iter().map(|m| m.eval(theta)).collect()
    }
    /// The right-hand side f(x, u, θ) = A(θ)x + N(θ,x)x + B(θ)u.
    pub fn rhs(&self, x: &DVector<f64>, u: &DVector<f64>, theta: &[f64]) -> DVector<f64> {
        let mut f = self.eval_a(theta) * x;
        if self.nu() > 0 {
            f += self.eval_b(theta) * u;
        }
        for (k, nk) in self.eval_n(theta).iter().enumerate() {
            f[k] += (x.transpose() * nk * x)[(0, 0)];
        }
        f
    }
    /// The output h(x, θ) = C(θ) x + M(θ, x)x.
    pub fn output(&self, x: &DVector<f64>, theta: &[f64]) -> DVector<f64> {
        let mut y = self.eval_c(theta) * x;
        for (k, mk) in self.eval_m(theta).iter().enumerate() {
            y[k] += (x.transpose() * mk * x)[(0, 0)];
        }
        y
    }
    /// Indices of the parameters that appear in A, N_k, B, C or M_k (those
    /// that generate vertices), in declaration order.
    pub fn scheduling(&self) -> Vec<usize> {
        bits(self.param_mask()).collect()
    }

    /// Bit mask of the parameters that appear in some matrix.
    fn param_mask(&self) -> u64 {
        self.a.param_mask()
            | self.b.param_mask()
            | self.c.param_mask()
            | self
                .n
                .iter()
                .chain(&self.m)
                .fold(0, |m, p| m | p.param_mask())
    }

    /// Whether C or some M_k depends on θ (issue 6 §4: such a model is
    /// designed by the double-sum relaxation or an output post-filter).
    pub fn output_varies(&self) -> bool {
        self.c.param_mask() != 0 || self.m.iter().any(|p| p.param_mask() != 0)
    }
}
