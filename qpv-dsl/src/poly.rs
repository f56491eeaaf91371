//! Expressions → polynomials in the states, inputs and parameters.
//!
//! A term is `c · Π_{i∈S} θ_i · v_1 · v_2` with at most two variables (states
//! or inputs) kept in the order they were written (that order decides where a
//! quadratic term lands in N_k, see the crate docs) and the parameters as a
//! set (a parameter twice in one term is not multi-affine and is rejected as
//! soon as the product forms). Every term remembers the span of the
//! expression it came from, so later stages can point at it.

use crate::ast::{Expr, ExprKind};
use crate::diagnostic::{suggest, Diag, Span};
use crate::expr::{bits, ThetaPoly};
use crate::func::Func;
use crate::sched::{range, RangeInfo, SchedExpr};
use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};

/// Most terms one expression may expand to.
const MAX_TERMS: usize = 4096;

/// A variable factor of a term.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum Var {
    /// The i-th state.
    State(usize),
    /// The j-th input.
    Input(usize),
    /// The j-th process disturbance.
    Disturbance(usize),
}

/// The non-numeric part of a term: parameters (bit mask) and variables in
/// written order.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct Mono {
    pub theta: u64,
    pub vars: Vec<Var>,
}

/// A coefficient and where its term was written.
#[derive(Clone, Debug)]
pub(crate) struct Term {
    pub coef: f64,
    pub span: Span,
}

/// A sum of terms with distinct monomials and nonzero coefficients.
#[derive(Clone, Debug, Default)]
pub(crate) struct Poly {
    pub terms: BTreeMap<Mono, Term>,
}

/// What a declared name denotes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum NameRef {
    State(usize),
    Input(usize),
    Output(usize),
    Param(usize),
    Disturbance(usize),
    /// A `let` scheduling function.
    Let(usize),
    /// A `const` number.
    Const(usize),
}

/// The value of a `let` once defined.
#[derive(Clone, Debug)]
pub(crate) enum LetValue {
    /// A polynomial in the parameters: the name stands for it.
    Inline(Poly),
    /// A scheduling function: one derived variable (its bit in a mask).
    Atom(usize),
}

/// A derived scheduling variable in the making (see `crate::sched`).
#[derive(Clone, Debug)]
pub(crate) struct Atom {
    /// Identifies the function (equal keys: the same φ).
    pub key: String,
    pub expr: SchedExpr,
    pub text: String,
    /// The `let` name, if it has one.
    pub name: Option<String>,
    /// Where it first appears.
    pub span: Span,
    pub lo: f64,
    pub hi: f64,
    pub info: RangeInfo,
}

/// The derived scheduling variables of one model: atom `j` is bit
/// `np + j` of a term mask, after the `np` declared parameters.
#[derive(Clone, Debug, Default)]
pub(crate) struct Atoms {
    pub np: usize,
    /// Bounds of the declared parameters.
    pub boxes: Vec<(f64, f64)>,
    pub list: Vec<Atom>,
}

/// The declared names of one model.
#[derive(Clone, Debug, Default)]
pub(crate) struct Names {
    pub states: Vec<String>,
    pub inputs: Vec<String>,
    pub outputs: Vec<String>,
    pub params: Vec<String>,
    pub disturbances: Vec<String>,
    pub lookup: HashMap<String, NameRef>,
    /// `const` names and values (`None` until evaluated, in source order).
    pub consts: Vec<(String, Option<f64>)>,
    /// `let` names and values (`None` until evaluated, in source order) with
    /// their definitions as scheduling functions.
    pub lets: Vec<(String, Option<(LetValue, SchedExpr)>)>,
    /// The derived scheduling variables created so far.
    pub atoms: RefCell<Atoms>,
    /// The states measured directly by an output (`crate::measured`).
    pub measured_states: Vec<crate::measured::MeasuredState>,
    /// Measured factors of degree-3 terms that have no parameter yet.
    pub wanted: RefCell<Vec<crate::measured::Wanted>>,
    /// The terms rewritten onto measured parameters.
    pub rewrites: RefCell<Vec<crate::measured::Rewrite>>,
    /// What a product of degree 3 or more in the states goes through first
    /// (the model builder's rewrite onto measured parameters), if set.
    pub scheduler: Option<Scheduler>,
}

/// A rewrite of a term (mask, variables) at `span`: the new mask and
/// variables and the factor its coefficient takes.
pub(crate) type Scheduler =
    fn(&Names, u64, Vec<Var>, Span, &str) -> Result<(u64, Vec<Var>, f64), Diag>;

impl Names {
    fn var(&self, v: Var) -> &str {
        match v {
            Var::State(i) => &self.states[i],
            Var::Input(i) => &self.inputs[i],
            Var::Disturbance(i) => &self.disturbances[i],
        }
    }

    /// `th1^2*x1*x2`-style text of a term given by parameter multiplicities
    /// and variables.
    pub(crate) fn term_text(&self, theta_counts: &[(usize, u32)], vars: &[Var]) -> String {
        let mut parts: Vec<String> = theta_counts
            .iter()
            .map(|&(i, k)| {
                let name = self.var_name(i);
                if k == 1 {
                    name
                } else {
                    format!("{name}^{k}")
                }
            })
            .collect();
        let mut i = 0;
        while i < vars.len() {
            let mut k = 1;
            while i + k < vars.len() && vars[i + k] == vars[i] {
                k += 1;
            }
            let n = self.var(vars[i]).to_string();
            parts.push(if k == 1 { n } else { format!("{n}^{k}") });
            i += k;
        }
        if parts.is_empty() {
            "a constant".into()
        } else {
            parts.join("*")
        }
    }

    /// The name of bit `i` of a mask: a parameter, or a derived variable
    /// shown as its function.
    pub fn var_name(&self, i: usize) -> String {
        match self.params.get(i) {
            Some(p) => p.clone(),
            None => {
                let atoms = self.atoms.borrow();
                match atoms.list.get(i - atoms.np) {
                    Some(a) => a.name.clone().unwrap_or_else(|| format!("({})", a.text)),
                    None => format!("phi{i}"),
                }
            }
        }
    }

    /// The scheduling function of bit `i` of a mask.
    fn var_expr(&self, i: usize) -> SchedExpr {
        let atoms = self.atoms.borrow();
        if i < atoms.np {
            SchedExpr::Param(i)
        } else {
            atoms.list[i - atoms.np].expr.clone()
        }
    }

    /// The bit of the derived variable `expr` (first written at `span`),
    /// created if new: its range is computed here, so a function undefined
    /// somewhere on Θ is an error at its first use.
    pub fn atom(
        &self,
        expr: SchedExpr,
        name: Option<&str>,
        span: Span,
        src: &str,
    ) -> Result<usize, Diag> {
        let key = expr.key(&self.params);
        let mut atoms = self.atoms.borrow_mut();
        if let Some(j) = atoms.list.iter().position(|a| a.key == key) {
            if let (Some(n), None) = (name, &atoms.list[j].name) {
                atoms.list[j].name = Some(n.to_string());
            }
            return Ok(atoms.np + j);
        }
        let text = expr.text(&self.params);
        if atoms.np + atoms.list.len() >= 64 {
            return Err(Diag::new(
                span,
                format!(
                    "{} needs one more derived scheduling variable, but the model already has {} \
                     parameters and {}: at most 64 in all are supported",
                    quote(src, span),
                    atoms.np,
                    atoms.list.len()
                ),
            ));
        }
        let (lo, hi, info) = range(&expr, &atoms.boxes, &self.params).map_err(|e| {
            Diag::new(
                span,
                format!(
                    "`{text}` is not defined on the whole parameter box: {}. Every function of \
                     the parameters must be defined and finite for every θ in the declared ranges \
                     (narrow the range of the parameter, or rewrite the expression)",
                    e.message
                ),
            )
        })?;
        atoms.list.push(Atom {
            key,
            expr,
            text,
            name: name.map(str::to_string),
            span,
            lo,
            hi,
            info,
        });
        Ok(atoms.np + atoms.list.len() - 1)
    }

    /// `a ∪ b` as a multi-affine mask: a variable in both becomes the
    /// derived variable of its square (θ·θ = φ with φ = θ²), repeatedly.
    pub(crate) fn combine(&self, a: u64, b: u64, span: Span, src: &str) -> Result<u64, Diag> {
        let mut m = a;
        for i in bits(b) {
            m = self.insert(m, i, span, src)?;
        }
        Ok(m)
    }

    fn insert(&self, m: u64, i: usize, span: Span, src: &str) -> Result<u64, Diag> {
        if m & (1 << i) == 0 {
            return Ok(m | (1 << i));
        }
        let sq = match self.var_expr(i) {
            SchedExpr::Pow(e, k) => SchedExpr::Pow(e, 2 * k),
            e => SchedExpr::Pow(Box::new(e), 2),
        };
        let j = self.atom(sq, None, span, src)?;
        self.insert(m & !(1 << i), j, span, src)
    }

    /// The text of a monomial, e.g. `th1*x1*x2`.
    pub fn mono_text(&self, m: &Mono) -> String {
        self.term_text(&bits(m.theta).map(|i| (i, 1)).collect::<Vec<_>>(), &m.vars)
    }
}

/// Which names an expression may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Allowed {
    /// Numbers only (bounds, region, Q, design values).
    Constant,
    /// Numbers and parameters (matrix entries).
    Coefficient,
    /// Numbers, parameters, states and inputs (`der`, `out`).
    Equation,
}

/// Everything `eval` needs besides the expression.
pub(crate) struct Scope<'a> {
    pub src: &'a str,
    pub names: &'a Names,
    pub allowed: Allowed,
    /// What is being written, for messages ("the state bound Q").
    pub context: &'a str,
}

impl Poly {
    fn constant(c: f64, span: Span) -> Poly {
        let mut p = Poly::default();
        if c != 0.0 {
            p.terms.insert(
                Mono {
                    theta: 0,
                    vars: vec![],
                },
                Term { coef: c, span },
            );
        }
        p
    }

    fn single(mono: Mono, span: Span) -> Poly {
        let mut p = Poly::default();
        p.terms.insert(mono, Term { coef: 1.0, span });
        p
    }

    /// The value if the polynomial is a plain number.
    pub fn as_constant(&self) -> Option<f64> {
        let mut v = 0.0;
        for (m, t) in &self.terms {
            if m.theta != 0 || !m.vars.is_empty() {
                return None;
            }
            v += t.coef;
        }
        Some(v)
    }

    fn add_term(&mut self, mono: Mono, coef: f64, span: Span) {
        use std::collections::btree_map::Entry;
        match self.terms.entry(mono) {
            Entry::Occupied(mut e) => {
                e.get_mut().coef += coef;
                if e.get().coef == 0.0 {
                    e.remove();
                }
            }
            Entry::Vacant(e) => {
                if coef != 0.0 {
                    e.insert(Term { coef, span });
                }
            }
        }
    }

    fn add(mut self, other: Poly, negate: bool) -> Poly {
        for (m, t) in other.terms {
            self.add_term(m, if negate { -t.coef } else { t.coef }, t.span);
        }
        self
    }

    fn scale(mut self, c: f64) -> Poly {
        for t in self.terms.values_mut() {
            t.coef *= c;
        }
        self.terms.retain(|_, t| t.coef != 0.0);
        self
    }

    /// The θ-polynomial of a polynomial without variables (variables are
    /// rejected before this is called).
    pub fn to_theta(&self) -> ThetaPoly {
        let mut p = ThetaPoly::zero();
        for (m, t) in &self.terms {
            if m.vars.is_empty() {
                p.add_term(m.theta, t.coef);
            }
        }
        p
    }
}

/// Text of a span for a message, shortened if long.
pub(crate) fn quote(src: &str, span: Span) -> String {
    let t: String = span
        .text(src)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    if t.chars().count() > 60 {
        let head: String = t.chars().take(57).collect();
        format!("`{head}...`")
    } else {
        format!("`{t}`")
    }
}

fn check_finite(p: &Poly, span: Span, scope: &Scope<'_>) -> Result<(), Diag> {
    if p.terms.values().any(|t| !t.coef.is_finite()) {
        return Err(Diag::new(
            span,
            format!(
                "the value of {} overflows a 64-bit float",
                quote(scope.src, span)
            ),
        ));
    }
    if p.terms.len() > MAX_TERMS {
        return Err(too_many_terms(scope.src, span));
    }
    Ok(())
}

fn too_many_terms(src: &str, span: Span) -> Diag {
    Diag::new(
        span,
        format!(
            "{} expands to more than {MAX_TERMS} terms",
            quote(src, span)
        ),
    )
}

/// Product of two polynomials; `span` is the product expression.
fn mul(a: &Poly, b: &Poly, span: Span, scope: &Scope<'_>) -> Result<Poly, Diag> {
    let names = scope.names;
    let mut out = Poly::default();
    for (ma, ta) in &a.terms {
        for (mb, tb) in &b.terms {
            let mut vars = ma.vars.clone();
            vars.extend_from_slice(&mb.vars);
            let theta = names.combine(ma.theta, mb.theta, span, scope.src)?;
            let (theta, vars, k) = match names.scheduler {
                Some(f) if vars.len() > 2 => f(names, theta, vars, span, scope.src)?,
                _ => (theta, vars, 1.0),
            };
            let disturbance = vars.iter().find(|v| matches!(v, Var::Disturbance(_)));
            if let (Some(&w), true) = (disturbance, vars.len() > 1) {
                let other = vars.iter().find(|v| **v != w).copied().unwrap_or(w);
                let what = match other {
                    _ if other == w => {
                        format!("disturbance `{}` multiplied by itself", names.var(w))
                    }
                    Var::State(_) => format!(
                        "disturbance `{}` multiplied by state `{}`",
                        names.var(w),
                        names.var(other)
                    ),
                    _ => format!(
                        "disturbance `{}` multiplied by `{}`",
                        names.var(w),
                        names.var(other)
                    ),
                };
                return Err(Diag::new(
                    span,
                    format!(
                        "{} has {what}: disturbances may only enter linearly, as B_w(θ)w",
                        quote(scope.src, span)
                    ),
                ));
            }
            let input = vars.iter().find(|v| matches!(v, Var::Input(_)));
            if let (Some(&u), true) = (input, vars.len() > 1) {
                let other = vars.iter().find(|v| **v != u).copied().unwrap_or(u);
                let what = match other {
                    Var::Input(_) if other == u => {
                        format!("input `{}` multiplied by itself", names.var(u))
                    }
                    Var::Input(_) => format!(
                        "inputs `{}` and `{}` multiplied together",
                        names.var(u),
                        names.var(other)
                    ),
                    Var::State(_) | Var::Disturbance(_) => format!(
                        "input `{}` multiplied by state `{}`",
                        names.var(u),
                        names.var(other)
                    ),
                };
                return Err(Diag::new(
                    span,
                    format!(
                        "{} has {what}: inputs may only enter linearly, as B(θ)u",
                        quote(scope.src, span)
                    ),
                ));
            }
            if vars.len() > 2 {
                let counts: Vec<(usize, u32)> = bits(theta).map(|i| (i, 1)).collect();
                return Err(Diag::new(
                    span,
                    format!(
                        "{} contains the term {} of degree {} in the states: the system class \
                         allows at most quadratic terms (x' = A(θ)x + N(θ,x)x + B(θ)u){}",
                        quote(scope.src, span),
                        names.term_text(&counts, &vars),
                        vars.len(),
                        schedule_hint(names, &counts, &vars)
                    ),
                ));
            }
            out.add_term(Mono { theta, vars }, ta.coef * tb.coef * k, span);
            if out.terms.len() > MAX_TERMS {
                // stop before the product grows to |a|·|b| terms
                return Err(too_many_terms(scope.src, span));
            }
        }
    }
    check_finite(&out, span, scope)?;
    Ok(out)
}

/// The rewrite a term of degree 3 or more in the states admits when one
/// factor is measured: that factor as a scheduling parameter fed with the
/// measurement, the rest a quadratic term (the factor written most often,
/// else the first). Worded as a condition: whether the state is measured
/// is the user's to say.
fn schedule_hint(names: &Names, counts: &[(usize, u32)], vars: &[Var]) -> String {
    let Some(&factor) = vars.iter().max_by_key(|v| {
        (
            vars.iter().filter(|w| w == v).count(),
            std::cmp::Reverse(**v),
        )
    }) else {
        return String::new();
    };
    let mut rest = vars.to_vec();
    if let Some(i) = rest.iter().position(|v| *v == factor) {
        rest.remove(i);
    }
    let x = names.var(factor);
    if rest.len() > 2 {
        return ". If some factors are measured, schedule on them: one `param` per measured factor, fed with its measurement, until two states remain".to_string();
    }
    format!(
        ". If `{x}` is measured, say so (`output y; out y = {x};`): a factor that is a measured output is scheduled on it automatically, or write it yourself as `param p = y in [lo, hi];` and `p*{}`",
        names.term_text(counts, &rest)
    )
}

/// Evaluates an expression into a polynomial, enforcing `scope.allowed`.
pub(crate) fn eval(e: &Expr, scope: &Scope<'_>) -> Result<Poly, Diag> {
    let p = match &e.kind {
        ExprKind::Number(v) => Poly::constant(*v, e.span),
        ExprKind::Name(n) => return name(n, e.span, scope),
        ExprKind::Neg(inner) => eval(inner, scope)?.scale(-1.0),
        ExprKind::Sum(terms) => {
            let mut acc = Poly::default();
            for (negate, t) in terms {
                acc = acc.add(eval(t, scope)?, *negate);
            }
            acc
        }
        ExprKind::Product(factors) => {
            let mut acc: Option<Poly> = None;
            for (divide, f) in factors {
                let v = eval(f, scope)?;
                let span = Span::new(e.span.start, f.span.end);
                acc = Some(match acc {
                    None if !*divide => v,
                    prev => {
                        let prev = prev.unwrap_or_else(|| Poly::constant(1.0, span));
                        if *divide {
                            match divisor(&v, f, scope)? {
                                Divisor::Number(c) => prev.scale(1.0 / c),
                                Divisor::Atom(bit) => {
                                    let inv = Poly::single(
                                        Mono {
                                            theta: 1 << bit,
                                            vars: vec![],
                                        },
                                        f.span,
                                    );
                                    mul(&prev, &inv, span, scope)?
                                }
                            }
                        } else {
                            mul(&prev, &v, span, scope)?
                        }
                    }
                });
                if let Some(a) = &acc {
                    check_finite(a, span, scope)?;
                }
            }
            acc.unwrap_or_default()
        }
        ExprKind::Call(func, fspan, arg) => call(*func, *fspan, arg, e, scope)?,
        ExprKind::Pow(base, n) => {
            let b = eval(base, scope)?;
            let mut acc = Poly::constant(1.0, e.span);
            for _ in 0..*n {
                acc = mul(&acc, &b, e.span, scope)?;
            }
            acc
        }
    };
    check_finite(&p, e.span, scope)?;
    Ok(p)
}

/// What a product divides by: a number, or a derived variable 1/d(θ).
enum Divisor {
    Number(f64),
    Atom(usize),
}

/// The first state, input or disturbance of a polynomial, if any.
fn first_var(p: &Poly) -> Option<Var> {
    p.terms.keys().find_map(|m| m.vars.first().copied())
}

/// Why a construct with a state (input, disturbance) inside is outside the
/// system class: the error for `what` (a denominator, a function) at `span`.
fn outside_class(v: Var, what: &str, span: Span, scope: &Scope<'_>, hint: &str) -> Diag {
    let (kind, name) = match v {
        Var::State(i) => ("state", &scope.names.states[i]),
        Var::Input(i) => ("input", &scope.names.inputs[i]),
        Var::Disturbance(i) => ("disturbance", &scope.names.disturbances[i]),
    };
    Diag::new(
        span,
        format!(
            "{} has the {kind} `{name}` {what}: the QPV class allows states only polynomially \
             (x' = A(θ)x + N(θ,x)x + B(θ)u, at most quadratic in the states, inputs and \
             disturbances linear), so this model is outside it{hint}",
            quote(scope.src, span)
        ),
    )
}

fn divisor(v: &Poly, f: &Expr, scope: &Scope<'_>) -> Result<Divisor, Diag> {
    let span = f.span;
    if let Some(c) = v.as_constant() {
        if c == 0.0 {
            return Err(Diag::new(
                span,
                format!("division by zero: {} is 0", quote(scope.src, span)),
            ));
        }
        return Ok(Divisor::Number(c));
    }
    if let Some(var) = first_var(v) {
        return Err(outside_class(
            var,
            "in a denominator",
            span,
            scope,
            " (a rational function of the state, such as Monod kinetics s/(K + s), cannot be \
             written with A, N and B; only functions of the parameters may divide)",
        ));
    }
    let d = sched_expr(f, scope)?;
    let inv = SchedExpr::Product(vec![(false, SchedExpr::Num(1.0)), (true, d)]);
    Ok(Divisor::Atom(scope.names.atom(inv, None, span, scope.src)?))
}

/// `f(arg)`: a number for a constant argument, else one derived variable.
fn call(f: Func, fspan: Span, arg: &Expr, whole: &Expr, scope: &Scope<'_>) -> Result<Poly, Diag> {
    let a = eval(arg, scope)?;
    if let Some(var) = first_var(&a) {
        let hint = match var {
            Var::State(i) => {
                let x = &scope.names.states[i];
                format!(
                    ". If `{x}` is measured, schedule on the measurement instead: declare it as a \
                     parameter (`param {x}_m in [lo, hi];`) and write `{}({x}_m)`",
                    f.name()
                )
            }
            _ => String::new(),
        };
        return Err(outside_class(
            var,
            &format!("inside the function `{}`", f.name()),
            whole.span,
            scope,
            &hint,
        ));
    }
    if let Some(c) = a.as_constant() {
        let v = f.apply(c);
        if !v.is_finite() {
            return Err(Diag::new(
                fspan,
                format!(
                    "{} is not defined: its value is {v}",
                    quote(scope.src, whole.span)
                ),
            ));
        }
        return Ok(Poly::constant(v, whole.span));
    }
    if scope.allowed == Allowed::Constant {
        return Err(Diag::new(
            whole.span,
            format!("a constant number is expected in {}", scope.context),
        ));
    }
    let e = SchedExpr::Call(f, Box::new(sched_expr(arg, scope)?));
    let bit = scope.names.atom(e, None, whole.span, scope.src)?;
    Ok(Poly::single(
        Mono {
            theta: 1 << bit,
            vars: vec![],
        },
        whole.span,
    ))
}

/// The scheduling function an expression of the parameters denotes (its
/// states, inputs and outputs are refused before this is called).
pub(crate) fn sched_expr(e: &Expr, scope: &Scope<'_>) -> Result<SchedExpr, Diag> {
    let list = |items: &[(bool, Expr)]| -> Result<Vec<(bool, SchedExpr)>, Diag> {
        items
            .iter()
            .map(|(flag, x)| Ok((*flag, sched_expr(x, scope)?)))
            .collect()
    };
    Ok(match &e.kind {
        ExprKind::Number(v) => SchedExpr::Num(*v),
        ExprKind::Name(n) => match scope.names.lookup.get(n).copied() {
            Some(NameRef::Param(i)) => SchedExpr::Param(i),
            Some(NameRef::Const(k)) => SchedExpr::Num(scope.names.consts[k].1.unwrap_or(f64::NAN)),
            Some(NameRef::Let(k)) => match &scope.names.lets[k].1 {
                Some((_, def)) => SchedExpr::Named(n.clone(), Box::new(def.clone())),
                None => return Err(used_before(n, e.span)),
            },
            _ => {
                return Err(Diag::new(
                    e.span,
                    format!("`{n}` cannot appear in a function of the parameters"),
                ))
            }
        },
        ExprKind::Neg(x) => SchedExpr::Neg(Box::new(sched_expr(x, scope)?)),
        ExprKind::Sum(t) => SchedExpr::Sum(list(t)?),
        ExprKind::Product(f) => SchedExpr::Product(list(f)?),
        ExprKind::Pow(x, n) => SchedExpr::Pow(Box::new(sched_expr(x, scope)?), *n),
        ExprKind::Call(f, _, x) => SchedExpr::Call(*f, Box::new(sched_expr(x, scope)?)),
    })
}

fn used_before(n: &str, span: Span) -> Diag {
    Diag::new(
        span,
        format!("`{n}` is used before its definition: define it earlier in the model"),
    )
}

fn name(n: &str, span: Span, scope: &Scope<'_>) -> Result<Poly, Diag> {
    let names = scope.names;
    let ctx = scope.context;
    match names.lookup.get(n).copied() {
        None => {
            let expected = match scope.allowed {
                Allowed::Constant => "a number is expected here".to_string(),
                Allowed::Coefficient => "expected a declared parameter or a number".to_string(),
                Allowed::Equation => {
                    "expected a declared state, input, disturbance or parameter".to_string()
                }
            };
            let candidates = names.lookup.iter().filter(|(_, r)| match (scope.allowed, r) {
                (Allowed::Constant, _) | (_, NameRef::Output(_)) => false,
                (Allowed::Coefficient, r) => {
                    matches!(r, NameRef::Param(_) | NameRef::Let(_) | NameRef::Const(_))
                }
                (Allowed::Equation, _) => true,
            });
            let hint = suggest(n, candidates.map(|(k, _)| k.as_str()))
                .map(|s| format!(" (did you mean `{s}`?)"))
                .unwrap_or_default();
            Err(Diag::new(span, format!("unknown name `{n}` in {ctx}: {expected}{hint}")))
        }
        Some(NameRef::Const(k)) => match names.consts[k].1 {
            Some(v) => Ok(Poly::constant(v, span)),
            None => Err(used_before(n, span)),
        },
        Some(NameRef::Let(k)) => {
            if scope.allowed == Allowed::Constant {
                return Err(Diag::new(
                    span,
                    format!("`{n}` is a function of the parameters and cannot appear in {ctx}: a constant number is expected"),
                ));
            }
            match &names.lets[k].1 {
                Some((LetValue::Inline(p), _)) => {
                    let mut p = p.clone();
                    p.terms.values_mut().for_each(|t| t.span = span);
                    Ok(p)
                }
                Some((LetValue::Atom(bit), _)) => Ok(Poly::single(
                    Mono {
                        theta: 1 << bit,
                        vars: vec![],
                    },
                    span,
                )),
                None => Err(used_before(n, span)),
            }
        }
        Some(NameRef::Output(_)) => Err(Diag::new(
            span,
            format!("`{n}` is an output: outputs cannot appear in expressions (define them with `out {n} = ...;`)"),
        )),
        Some(NameRef::Param(i)) => {
            if scope.allowed == Allowed::Constant {
                return Err(Diag::new(
                    span,
                    format!("parameter `{n}` cannot appear in {ctx}: a constant number is expected"),
                ));
            }
            Ok(Poly::single(
                Mono {
                    theta: 1 << i,
                    vars: vec![],
                },
                span,
            ))
        }
        Some(r @ (NameRef::State(_) | NameRef::Input(_) | NameRef::Disturbance(_))) => {
            let (kind, var) = match r {
                NameRef::State(i) => ("state", Var::State(i)),
                NameRef::Disturbance(i) => ("disturbance", Var::Disturbance(i)),
                NameRef::Input(i)
                | NameRef::Output(i)
                | NameRef::Param(i)
                | NameRef::Let(i)
                | NameRef::Const(i) => ("input", Var::Input(i)),
            };
            match scope.allowed {
                Allowed::Equation => Ok(Poly::single(
                    Mono {
                        theta: 0,
                        vars: vec![var],
                    },
                    span,
                )),
                Allowed::Coefficient => Err(Diag::new(
                    span,
                    format!(
                        "{kind} `{n}` cannot appear in {ctx}: matrix entries may depend on parameters \
                         only (to write the dynamics with states, use `der x = ...;`)"
                    ),
                )),
                Allowed::Constant => Err(Diag::new(
                    span,
                    format!("{kind} `{n}` cannot appear in {ctx}: a constant number is expected"),
                )),
            }
        }
    }
}
