//! The dynamics and output matrices, from matrix literals (`A = [...]`) or
//! from equations (`der x = ...;`, `out y = ...;`): which matrix a name
//! denotes, its size, and the all-or-none rule for N_k and M_k.

use super::build::{kind_word, pos, Builder, R};
use crate::ast::{self, Item, MatrixLit, MatrixValue};
use crate::diagnostic::{suggest, Diag, Span};
use crate::equations::{self, Split as TermSplit};
use crate::expr::PolyMatrix;
use crate::poly::{eval, Allowed, NameRef, Poly, Scope};

/// What a matrix name denotes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum MatName {
    A,
    B,
    /// B_w: the process disturbances' matrix.
    Bw,
    C,
    N(usize),
    M(usize),
}

impl MatName {
    fn label(self) -> String {
        match self {
            MatName::A => "A".into(),
            MatName::B => "B".into(),
            MatName::Bw => "B_w".into(),
            MatName::C => "C".into(),
            MatName::N(k) => format!("N{}", k + 1),
            MatName::M(k) => format!("M{}", k + 1),
        }
    }
}

impl<'a> Builder<'a> {
    fn mat_name(&self, id: &ast::Ident) -> R<MatName> {
        let nx = self.names.states.len();
        let ny = self.names.outputs.len();
        let w = id.name.as_str();
        let unknown = || {
            let mut list = String::from("A, B, B_w, C");
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
            "B_w" => return Ok(MatName::Bw),
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
            MatName::Bw => (
                nx,
                self.names.disturbances.len(),
                "one per state",
                "one per disturbance",
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
    pub(super) fn check_shape(
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
                        let entry = eval(e, &scope)?.to_theta();
                        self.check_magnitude(entry.terms.iter().copied(), e.span)?;
                        *pm.get_mut(i, j) = entry;
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

    /// A, N_k, B and B_w, from the matrix form or the `der` equations.
    pub(super) fn dynamics(&mut self) -> R<(PolyMatrix, Vec<PolyMatrix>, PolyMatrix, PolyMatrix)> {
        let defs = self.matrix_defs()?;
        let ders = self.equations(true)?;
        let nx = self.names.states.len();
        let nu = self.names.inputs.len();
        let dyn_defs: Vec<&(MatName, &ast::MatrixDef)> = defs
            .iter()
            .filter(|(m, _)| matches!(m, MatName::A | MatName::B | MatName::Bw | MatName::N(_)))
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
            let mut nonlinear = Vec::new();
            for (i, eq) in &ders {
                let (poly, terms) = super::nonlinear::split(*i, &eq.rhs, &scope)?;
                polys[*i] = poly;
                nonlinear.extend(terms);
                self.check_equation_magnitude(&polys[*i])?;
            }
            self.nonlinear = nonlinear;
            let d = equations::dynamics(self.src, &self.names, &polys, TermSplit::AsWritten)?;
            for (j, w) in self.names.disturbances.iter().enumerate() {
                if (0..nx).all(|i| d.b_w.get(i, j).is_zero()) {
                    return Err(Diag::new(
                        self.decl_spans[w],
                        format!(
                            "disturbance `{w}` enters no equation: add a term such as `+ {w}` \
                             or `+ 0.5*{w}` to a `der` equation, or remove it"
                        ),
                    ));
                }
            }
            return Ok((d.a, d.n, d.b, d.b_w));
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
        let nw = self.names.disturbances.len();
        let b_w = match (get(MatName::Bw), nw) {
            (Some(def), 0) => {
                return Err(Diag::new(
                    def.name.span,
                    "B_w is given but the model declares no disturbances: add \
                     `disturbance w1, ...;` or remove B_w",
                ))
            }
            (Some(def), _) => self.matrix_value(def, MatName::Bw)?.0,
            (None, 0) => PolyMatrix::zeros(nx, 0),
            (None, _) => {
                let first = &self.names.disturbances[0];
                return Err(Diag::new(
                    self.decl_spans[first],
                    format!(
                        "model `{}` declares disturbances ({}) but gives no `B_w = [...];` \
                         ({nx}×{nw}, one column per disturbance)",
                        self.ast.name.name,
                        self.names.disturbances.join(", ")
                    ),
                ));
            }
        };
        let n = self.all_or_none(&defs, true)?;
        Ok((a, n, b, b_w))
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

    pub(super) fn outputs(&mut self) -> R<(PolyMatrix, Vec<PolyMatrix>)> {
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
                self.check_equation_magnitude(&polys[*i])?;
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
}
