//! The C99 printer: `<model>.h` and `<model>.c` for one certified design,
//! printing the same bodies ([`crate::build`]) as the `qpv!` Rust emitter.
//!
//! The generated C allocates nothing, has no global or static mutable
//! state (every global is `const`), includes `<math.h>` only when a
//! scheduling function calls a math function or a figure is infinite (and
//! then only those calls need libm), and compiles cleanly with
//! `cc -std=c99 -Wall -Wextra -Werror -pedantic` (and, for `float`,
//! `-Wdouble-promotion -Wfloat-conversion`: every literal carries the `f`
//! suffix and the math functions are the `f` ones). Constants are printed
//! in the shortest form that parses back to the same bits of the chosen
//! type (Rust's round-trip formatting; `f` suffix for `float`).

use crate::build::coeffs::Coeffs;
use crate::build::equations::equations;
use crate::build::observer::{gains_body, plant_bodies, rhs_body};
use crate::build::weights::{mu_body, phi_body};
use crate::design::{vertex_count, CertifiedDesign, Shape};
use crate::ir::{math_name, Body, Expr, Let, Op, Ty};
use qpv_dsl::Model;
use std::fmt::Write as _;

/// The floating-point type of the generated C.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Float {
    /// `double` (the default).
    F64,
    /// `float`: constants rounded to the nearest `float`, `f`-suffixed
    /// literals and math functions.
    F32,
}

impl Float {
    /// The C type.
    pub fn c_type(self) -> &'static str {
        match self {
            Float::F64 => "double",
            Float::F32 => "float",
        }
    }

    /// The name as `--float` spells it.
    pub fn name(self) -> &'static str {
        match self {
            Float::F64 => "f64",
            Float::F32 => "f32",
        }
    }
}

/// The two generated files.
#[derive(Debug, Clone, PartialEq)]
pub struct CFiles {
    /// `<model>.h`: the API, sizes, constants' declarations, the
    /// certificate as a comment.
    pub header: String,
    /// `<model>.c`: the constants and the unrolled observer.
    pub source: String,
}

/// A literal of type `float`: the value rounded to f32, printed so that it
/// parses back to the same bits, with the `f` suffix. f64: the shortest
/// round-trip form. Both always have a `.` or an exponent (a floating
/// constant in C).
pub fn literal(v: f64, float: Float) -> String {
    let text = match float {
        Float::F64 => shortest(format!("{v}"), format!("{v:e}")),
        Float::F32 => {
            let f = v as f32;
            shortest(format!("{f}"), format!("{f:e}"))
        }
    };
    match float {
        Float::F64 => text,
        Float::F32 => format!("{text}f"),
    }
}

/// The shorter of the plain and the exponent form, made a floating constant.
fn shortest(plain: String, exp: String) -> String {
    let plain = if plain.contains('.') || plain.contains("inf") || plain.contains("NaN") {
        plain
    } else {
        format!("{plain}.0")
    };
    if exp.len() + 2 < plain.len() {
        exp
    } else {
        plain
    }
}

/// Prints IR expressions as C.
struct Printer {
    float: Float,
}

impl Printer {
    fn num(&self, v: f64) -> String {
        literal(v, self.float)
    }

    fn expr(&self, e: &Expr) -> String {
        match e {
            Expr::Num(v) => self.num(*v),
            Expr::Int(n) => format!("{n}"),
            Expr::Var(v) => v.clone(),
            Expr::Coef(i) => format!("c->k{i}"),
            Expr::Neg(a) => neg(&self.expr(a)),
            Expr::Paren(a) => format!("({})", self.expr(a)),
            Expr::Product(fs) => fs
                .iter()
                .map(|f| self.expr(f))
                .collect::<Vec<_>>()
                .join(" * "),
            Expr::Bin(op, a, b) => {
                let op = match op {
                    Op::Add => "+",
                    Op::Sub => "-",
                    Op::Mul => "*",
                    Op::Div => "/",
                };
                format!("{} {op} {}", self.expr(a), self.expr(b))
            }
            Expr::Sum(terms) => self.sum(terms),
            Expr::Call(f, a) => {
                let name = math_name(*f);
                let suffix = if self.float == Float::F32 { "f" } else { "" };
                format!("{name}{suffix}({})", self.expr(a))
            }
            Expr::PowI(a, n) => {
                // ((1·b)·b)…, the base evaluated once per factor (pure)
                let b = format!("({})", self.expr(a));
                let mut acc = self.num(1.0);
                for _ in 0..*n {
                    acc = format!("({acc} * {b})");
                }
                acc
            }
            Expr::Clamp(a, lo, hi) => {
                let (a, lo, hi) = (self.expr(a), self.expr(lo), self.expr(hi));
                format!("({a} >= {lo} ? ({a} <= {hi} ? {a} : {hi}) : {lo})")
            }
            Expr::Ge(a, b) => format!("(unsigned)({} >= {})", self.expr(a), self.expr(b)),
            Expr::Select(on, arms) => {
                let last = arms.len().saturating_sub(1);
                let mut out = arms.last().map_or(self.num(0.0), |a| self.expr(a));
                for (i, a) in arms.iter().enumerate().take(last).rev() {
                    out = format!("({on} == {i}u ? {} : {out})", self.expr(a));
                }
                out
            }
        }
    }

    fn sum(&self, terms: &[(f64, Option<Expr>)]) -> String {
        if terms.is_empty() {
            return self.num(0.0);
        }
        let mut out = String::new();
        for (i, (c, f)) in terms.iter().enumerate() {
            let a = c.abs();
            let body = match f {
                None => self.num(a),
                Some(f) if a == 1.0 => self.expr(f),
                Some(f) => format!("{} * {}", self.num(a), self.expr(f)),
            };
            match (i, *c < 0.0) {
                (0, false) => out.push_str(&body),
                (0, true) => out.push_str(&neg(&body)),
                (_, false) => {
                    out.push_str(" + ");
                    out.push_str(&body);
                }
                (_, true) => {
                    out.push_str(" - ");
                    out.push_str(&body);
                }
            }
        }
        out
    }

    /// The lets of a body as `const` declarations.
    fn lets(&self, lets: &[Let], real: &str, indent: &str) -> String {
        let mut out = String::new();
        for l in lets {
            let ty = match l.ty {
                Ty::Real => real,
                Ty::Index => "unsigned",
            };
            let _ = writeln!(
                out,
                "{indent}const {ty} {} = {};",
                l.name,
                self.expr(&l.value)
            );
        }
        out
    }
}

/// `-e`, with a space where `e` starts with a minus (never `--`).
fn neg(e: &str) -> String {
    if e.starts_with('-') {
        format!("- {e}")
    } else {
        format!("-{e}")
    }
}

/// True if the identifier `name` occurs in the C text `code`.
fn uses(code: &str, name: &str) -> bool {
    let is_ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    code.match_indices(name).any(|(i, _)| {
        let before = code[..i].chars().next_back();
        let after = code[i + name.len()..].chars().next();
        !before.is_some_and(|c| is_ident(c) || c == '>' || c == '.') && !after.is_some_and(is_ident)
    })
}

/// `const real x0 = arr[0];` for the names `names` that `code` uses.
fn bind(arr: &str, names: &[String], code: &str, real: &str) -> String {
    let mut out = String::new();
    for (i, n) in names.iter().enumerate() {
        if uses(code, n) {
            let _ = writeln!(out, "    const {real} {n} = {arr}[{i}];");
        }
    }
    out
}

/// `prefix0, prefix1, ...`.
fn names(prefix: &str, n: usize) -> Vec<String> {
    (0..n).map(|i| format!("{prefix}{i}")).collect()
}

/// `(void)p;` for each parameter `code` does not use.
fn unused(params: &[&str], code: &str) -> String {
    params
        .iter()
        .filter(|p| !uses(code, p))
        .map(|p| format!("    (void){p};\n"))
        .collect()
}

/// Everything the C emitter needs for one model and one design.
pub struct CModel<'a> {
    /// The validated model.
    pub model: &'a Model,
    /// Indices into `model.params` of the parameters that generate vertices.
    pub scheduling: &'a [usize],
    /// The certified design to bake (`certifies` must be true).
    pub design: &'a CertifiedDesign,
    /// `double` or `float`.
    pub float: Float,
    /// Lines of text for the certificate comment block beyond the design's
    /// own record (where the numbers came from, the f32 check, ...).
    pub notes: Vec<String>,
}

/// Prints `<model>.h` and `<model>.c`, section by section.
pub fn emit(cm: &CModel<'_>) -> CFiles {
    let cx = Ctx::new(cm);
    let b = Bodies::of(cm, cx.shape);
    let cert_text = certificate_text(cm, cx.shape);
    let header = [
        cx.header_preamble(&cert_text),
        cx.header_sizes(),
        crate::measured::c_header(cx.m, &cx.up),
        cx.header_constants(),
        cx.header_observer(),
        crate::measured::c_api_docs(cx.m, &cx.header_api()),
    ]
    .concat();
    let source = [
        cx.source_preamble(b.uses_math()),
        cx.source_scalars(),
        cx.source_matrices(&cert_text),
        cx.coeffs_struct(&b.coeffs),
        cx.clamp_theta_fn(),
        cx.phi_fn(&b.phi),
        cx.mu_clamped_fn(&b.mu),
        cx.coeffs_at_fn(&b.coeffs),
        cx.gains_fn(&b.gains),
        cx.rhs_fn(&b.rhs),
        cx.schedule_fns(),
        crate::measured::c_theta_of(cx.m, cx.name, &cx.real),
        cx.init_fns(),
        crate::measured::c_steps(cx.m, cx.name, &cx.real, &cx.derivative_and_euler_fns()),
        crate::measured::c_steps(cx.m, cx.name, &cx.real, &cx.rk4_fn()),
        cx.schedule_api_fns(),
        cx.plant_fns(&b.plant_f, &b.plant_h),
    ]
    .concat();
    CFiles { header, source }
}

/// The arithmetic the C functions print, built once per model and design.
struct Bodies {
    plant_f: Body,
    plant_h: Body,
    rhs: Body,
    gains: Body,
    mu: Body,
    coeffs: Body,
    phi: Body,
}

impl Bodies {
    /// Every body; the θ-coefficients are the ones the plant and observer
    /// rows collect while they are built.
    fn of(cm: &CModel<'_>, shape: Shape) -> Bodies {
        let m = cm.model;
        let (state_eqs, out_eqs) = equations(m);
        let mut coeffs = Coeffs::default();
        let (mut plant_f, plant_h) = plant_bodies(&state_eqs, &out_eqs, &mut coeffs);
        let mut rhs = rhs_body(cm.design, shape, &state_eqs, &out_eqs, &mut coeffs);
        let nl = crate::build::equations::nonlinear_lets(m);
        plant_f.lets.splice(0..0, nl.clone());
        rhs.lets.splice(0..0, nl);
        let gains = gains_body(cm.design, shape);
        let mu = mu_body(m, cm.scheduling);
        Bodies {
            plant_f,
            plant_h,
            rhs,
            gains,
            mu,
            coeffs: coeffs.body(),
            phi: phi_body(m),
        }
    }

    /// True if a scheduling body or a nonlinear term of the plant calls a
    /// math function (then the source includes `<math.h>`).
    fn uses_math(&self) -> bool {
        [&self.mu, &self.phi, &self.coeffs, &self.rhs, &self.plant_f]
            .iter()
            .any(|b| b.lets.iter().any(|l| has_call(&l.value)) || b.out.iter().any(has_call))
    }
}

/// The counting of a clamped θ in the step functions.
const COUNT_CLAMPED: &str =
    "    if (clamped && o->clamped != ULONG_MAX) {\n        o->clamped += 1;\n    }\n";

/// The names and sizes every section of the two C files is printed with.
struct Ctx<'a> {
    cm: &'a CModel<'a>,
    m: &'a Model,
    d: &'a CertifiedDesign,
    p: Printer,
    shape: Shape,
    /// The model's name, the prefix of every C identifier.
    name: &'a str,
    /// The name in capitals, the prefix of every macro.
    up: String,
    /// `<name>_real`, the number type.
    real: String,
    nv: usize,
    nx: usize,
    ny: usize,
    nu: usize,
    nth: usize,
    nphi: usize,
    nz: usize,
    ns: usize,
}

impl<'a> Ctx<'a> {
    /// The names and sizes of `cm`.
    fn new(cm: &'a CModel<'a>) -> Ctx<'a> {
        let m = cm.model;
        let nv = vertex_count(m, cm.scheduling);
        let shape = Shape::of(m, nv, cm.design);
        let name = m.name.as_str();
        Ctx {
            cm,
            m,
            d: cm.design,
            p: Printer { float: cm.float },
            shape,
            name,
            up: name.to_uppercase(),
            real: format!("{name}_real"),
            nv,
            nx: m.nx(),
            ny: m.ny(),
            nu: m.nu(),
            nth: m.ntheta(),
            nphi: m.derived.len(),
            nz: shape.nz,
            ns: shape.ns,
        }
    }

    /// A figure as a constant, `none` where it is absent or not finite.
    fn fig(&self, v: Option<f64>, none: &str) -> String {
        match v {
            Some(x) if x.is_finite() => self.p.num(x),
            _ => none.to_string(),
        }
    }

    /// A row-major `rows × cols` matrix as a C initialiser (missing entries 0).
    fn matrix(&self, rows: usize, cols: usize, data: &[f64]) -> String {
        let rs: Vec<String> = (0..rows)
            .map(|i| {
                let es: Vec<String> = (0..cols)
                    .map(|j| self.p.num(data.get(i * cols + j).copied().unwrap_or(0.0)))
                    .collect();
                format!("{{{}}}", es.join(", "))
            })
            .collect();
        format!("{{{}}}", rs.join(",\n    "))
    }

    // ------------------------------------------------------------ header

    /// The header's opening comment (with the certificate), include guard
    /// and number type.
    fn header_preamble(&self, cert_text: &str) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let float = self.cm.float;
        let mut h = String::new();
        let _ = writeln!(
            h,
            "/* {name}.h: certified QPV state observer for model `{name}`,\n * generated by `qpv codegen --lang c --float {}` (qpv {}). Do not edit: regenerate.\n *",
            float.name(),
            env!("CARGO_PKG_VERSION")
        );
        for line in cert_text.lines() {
            let _ = writeln!(h, " * {}", c_comment(line));
        }
        h.push_str(" */\n");
        let _ = write!(
            h,
            "#ifndef {up}_H\n#define {up}_H\n\n#ifdef __cplusplus\nextern \"C\" {{\n#endif\n\n"
        );
        let _ = writeln!(
            h,
            "/** The number type of this observer ({}). */\ntypedef {} {r};\n",
            float.name(),
            float.c_type()
        );
        h
    }

    /// The size macros (`<NAME>_NX`, ...) and `<NAME>_CERTIFIES`.
    fn header_sizes(&self) -> String {
        let (up, nphi) = (&self.up, self.nphi);
        let mut h = String::new();
        for (k, v, doc) in [
            ("NX", self.nx, "plant states"),
            ("NY", self.ny, "measured outputs"),
            ("NU", self.nu, "known inputs (u may be NULL when 0)"),
            (
                "NTHETA",
                self.nth,
                "parameters θ (theta may be NULL when 0)",
            ),
            ("NV", self.nv, "vertices of the gain schedule"),
            ("NZ", self.nz, "rows of P and of each L_l"),
            (
                "NS",
                self.ns,
                "observer states (NX, plus 2·NY filter states for a filter design)",
            ),
        ] {
            let _ = writeln!(h, "#define {up}_{k} {v} /* {doc} */");
        }
        if nphi > 0 {
            let _ = writeln!(
                h,
                "#define {up}_NPHI {nphi} /* derived scheduling variables φ(θ) */"
            );
        }
        let _ = writeln!(
            h,
            "#define {up}_FLOAT_BITS {} /* the width of {name}_real: 32 (float) or 64 (double) */",
            match self.cm.float {
                Float::F32 => 32,
                Float::F64 => 64,
            },
            name = self.name
        );
        let _ = writeln!(
            h,
            "#define {up}_CERTIFIES 1 /* only certified designs are exported */\n"
        );
        h
    }

    /// The declarations of the design's constants: the scalars, P, the
    /// gains, Θ and the certificate text.
    fn header_constants(&self) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let mut h = String::from("/* The certified design (see the comment above). */\n");
        let scalars = [
            (
                "ALPHA",
                "certified decay rate: V = e'Pe satisfies V' <= -ALPHA V",
            ),
            ("GAMMA", "certified region scaling"),
            (
                "MAX_STEP_EULER",
                "largest certified explicit Euler step (0: none proven)",
            ),
            ("EULER_BETA", "contraction rate behind MAX_STEP_EULER"),
            (
                "STEP_ESTIMATE_RK4",
                "estimated largest stable RK4 step (an estimate, not a proof; 0: none)",
            ),
            (
                "NOISE_SIGMA",
                "certified noise gain sigma (infinite: no bound certified)",
            ),
            (
                "ERROR_BOUND_PER_NOISE",
                "certified ultimate error bound per unit noise amplitude",
            ),
            (
                "MAX_NOISE_AMPLITUDE",
                "noise amplitude up to which the bounds apply (0: none; infinite: every amplitude, global observer)",
            ),
        ];
        for (k, doc) in scalars {
            let _ = writeln!(h, "extern const {r} {name}_{k}; /* {doc} */");
        }
        if let Some((_, per)) = &self.d.figures.rms {
            let _ = writeln!(
                h,
                "extern const {r} {name}_RMS_BOUND; /* noise = rms: certified bound on the time-averaged RMS error under the design's white noise (while x in F, e in the region/gamma) */\nextern const {r} {name}_RMS_BOUND_PER_STATE[{}]; /* the same bound per state */",
                per.len()
            );
        }
        if self.cm.float == Float::F32 {
            let _ = writeln!(
                h,
                "extern const {r} {name}_F32_ERROR_FLOOR; /* certified f32 error floor: lim sup |e| \
                 from the float rounding of the right-hand side alone, even without noise \
                 (INFINITY: none certified) */\n\
                 extern const {r} {name}_F32_EULER_FLOOR, {name}_F32_EULER_UPDATE_ROUNDING, \
                 {name}_F32_EULER_MIN_STEP; /* with step_euler at F32_EULER_MIN_STEP < h <= \
                 MAX_STEP_EULER, the state update's rounding included: lim sup |e| <= \
                 F32_EULER_FLOOR + F32_EULER_UPDATE_ROUNDING / h (INFINITY: none certified) */\n\
                 extern const {r} {name}_F32_ROUNDING_D0, {name}_F32_ROUNDING_D1; /* the f32 \
                 rounding of one right-hand side evaluation, d0 + d1*rho per state (rho = \
                 sqrt(e'Pe)), in the P-norm: D0 and D1 (INFINITY: no floor certified) */\n\
                 extern const {r} {name}_F32_RATE; /* the rate the floor is certified with, \
                 ALPHA - 2*D1 (0: no floor certified) */"
            );
            if self.d.sample.is_some() {
                let _ = writeln!(
                    h,
                    "extern const {r} {name}_F32_STEP_FLOOR; /* {name}_step at SAMPLE_PERIOD, \
                     against the plant stepped by the same Euler step, no noise: lim sup |e_k| \
                     <= this, the state update's rounding included (INFINITY: none certified) */"
                );
            }
        }
        if self.d.alpha_sup.is_some() {
            let _ = writeln!(
                h,
                "extern const {r} {name}_ALPHA_SUP; /* alpha = max: the search's estimate of the \
                 certified supremum of alpha; an estimate, not a rate this design certifies \
                 (that is ALPHA) */"
            );
        }
        if let Some(t) = self.d.sample_text() {
            let _ = writeln!(
                h,
                "extern const {r} {name}_SAMPLE_PERIOD; /* the sample period the design is certified at, {}: {t} */",
                self.d.time_unit.plural()
            );
        }
        let _ = writeln!(
            h,
            "extern const {r} {name}_P[{up}_NZ][{up}_NZ]; /* the Lyapunov matrix P, as certified */"
        );
        let _ = writeln!(
            h,
            "extern const {r} {name}_L[{up}_NV][{up}_NZ][{up}_NY]; /* the vertex gains L_l, as certified */"
        );
        if self.nth > 0 {
            let _ = writeln!(
                h,
                "extern const {r} {name}_THETA_MIN[{up}_NTHETA], {name}_THETA_MAX[{up}_NTHETA]; /* Θ */"
            );
        }
        let _ = writeln!(
            h,
            "#ifndef {up}_NO_CERTIFICATE\n\
             extern const char {name}_CERTIFICATE[]; /* the certificate, as text (about 2 KB of \
             .rodata; define {up}_NO_CERTIFICATE to leave it out) */\n#endif\n"
        );
        h
    }

    /// The observer struct: x̂, the filter states of a filter design, and
    /// the count of clamped steps.
    fn header_observer(&self) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let filter_field = if self.shape.filter.is_some() {
            format!(
                "    {r} filter[2 * {up}_NY]; /* the output filter: x̂_y, then the filtered measurement x_y */\n"
            )
        } else {
            String::new()
        };
        format!(
            "/** The observer: x̂ and the number of steps whose θ was outside Θ (clamped). */\n\
             typedef struct {{\n    {r} xhat[{up}_NX];\n{filter_field}    unsigned long clamped;\n}} {name}_observer;\n\n"
        )
    }

    /// The public functions' prototypes with their documentation, and the
    /// end of the header.
    fn header_api(&self) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let mut api = vec![
            (
                format!("void {name}_init({name}_observer *o)"),
                "x̂ = 0 (and filter states 0), clamped = 0.",
            ),
            (
                format!("void {name}_init_at({name}_observer *o, const {r} *x0)"),
                "x̂ = x0 (NX entries; filter states 0), clamped = 0: the certified bounds hold from an x0 whose error x(0) - x0 is in the certified set.",
            ),
            (
                format!("void {name}_step_euler({name}_observer *o, {r} h, const {r} *y, const {r} *u, const {r} *theta)"),
                "One explicit Euler step of length h, y (NY), u (NU) and θ (NTHETA) held. Certified contraction for h <= MAX_STEP_EULER.",
            ),
            (
                format!("void {name}_step_rk4({name}_observer *o, {r} h, const {r} *y, const {r} *u, const {r} *theta)"),
                "One classical Runge-Kutta 4 step of length h, y, u and θ held.",
            ),
            (
                format!("const {r} *{name}_estimate(const {name}_observer *o)"),
                "The estimate x̂ (NX entries).",
            ),
            (
                format!("void {name}_derivative(const {name}_observer *o, const {r} *y, const {r} *u, const {r} *theta, {r} *ds)"),
                "The derivative of the whole observer state (NS entries: x̂, then the filter states) at θ clamped into Θ.",
            ),
            (
                format!("void {name}_mu(const {r} *theta, {r} *mu)"),
                "The scheduling weights μ_l(θ) (NV entries), θ clamped into Θ.",
            ),
            (
                format!("void {name}_gain(const {r} *theta, {r} *g)"),
                "The scheduled gain L(θ), NZ × NY row-major, θ clamped into Θ.",
            ),
            (
                format!("void {name}_plant_derivative(const {r} *x, const {r} *u, const {r} *theta, {r} *dx)"),
                "The plant x' = A(θ)x + N(θ,x)x + B(θ)u (θ as given).",
            ),
            (
                format!("void {name}_plant_output(const {r} *x, const {r} *theta, {r} *y)"),
                "The plant's output y = C(θ)x + M(θ,x)x (θ as given).",
            ),
        ];
        if self.d.sample.is_some() {
            api.insert(
                1,
                (
                    format!("void {name}_step({name}_observer *o, const {r} *y, const {r} *u, const {r} *theta)"),
                    "The certified step: one explicit Euler step of exactly SAMPLE_PERIOD with the samples y_k (NY), u_k (NU), θ_k (NTHETA); V(e_k+1) <= (1 - SAMPLE_PERIOD*ALPHA) V(e_k) against the plant stepped by the same Euler step (see the certificate above). Call it once per sample period.",
                ),
            );
        }
        let mut h = String::new();
        for (sig, doc) in &api {
            let _ = writeln!(h, "/** {doc} */\n{sig};\n");
        }
        let _ = write!(h, "#ifdef __cplusplus\n}}\n#endif\n\n#endif /* {up}_H */\n");
        h
    }

    // ------------------------------------------------------------ source

    /// The source's opening comment and includes (`<math.h>` only when
    /// `math` or a figure is infinite).
    fn source_preamble(&self, math: bool) -> String {
        let name = self.name;
        let f = &self.d.figures;
        let finite = |v: Option<f64>| matches!(v, Some(x) if x.is_finite());
        let infinite = !finite(f.sigma)
            || !finite(f.error_bound)
            || f.max_amplitude == Some(f64::INFINITY)
            || (self.cm.float == Float::F32
                && !(finite(f.f32_floor)
                    && f.f32_euler.is_some()
                    && f.f32_rounding.is_some()
                    && (self.d.sample.is_none() || finite(f.f32_step_floor))));
        let mut s = String::new();
        let _ = writeln!(
            s,
            "/* {name}.c: generated by `qpv codegen --lang c --float {}`; see {name}.h. Do not edit. */\n",
            self.cm.float.name()
        );
        let _ = writeln!(s, "#include \"{name}.h\"\n#include <limits.h>");
        if math || infinite {
            s.push_str("#include <math.h>\n");
        }
        s.push('\n');
        s
    }

    /// The scalar constants: α, γ, the figures, the f32 floor and the
    /// sample period.
    fn source_scalars(&self) -> String {
        let (name, r, d) = (self.name, self.real.as_str(), self.d);
        let (f, p) = (&d.figures, &self.p);
        let inf = "INFINITY";
        let zero = p.num(0.0);
        let values = [
            ("ALPHA", p.num(d.alpha)),
            ("GAMMA", p.num(d.gamma)),
            ("MAX_STEP_EULER", self.fig(f.euler.map(|e| e.0), &zero)),
            ("EULER_BETA", self.fig(f.euler.map(|e| e.1), &zero)),
            ("STEP_ESTIMATE_RK4", self.fig(f.rk4, &zero)),
            ("NOISE_SIGMA", self.fig(f.sigma, inf)),
            ("ERROR_BOUND_PER_NOISE", self.fig(f.error_bound, inf)),
            (
                "MAX_NOISE_AMPLITUDE",
                match f.max_amplitude {
                    // Unlimited: the global observer's claim holds for every e.
                    Some(x) if x == f64::INFINITY => inf.to_string(),
                    other => self.fig(other, &zero),
                },
            ),
        ];
        let mut s = String::new();
        for (k, v) in values {
            let _ = writeln!(s, "const {r} {name}_{k} = {v};");
        }
        if let Some((total, per)) = &self.d.figures.rms {
            let per: Vec<String> = per.iter().map(|v| self.p.num(*v)).collect();
            let _ = writeln!(
                s,
                "const {r} {name}_RMS_BOUND = {};\nconst {r} {name}_RMS_BOUND_PER_STATE[{}] = {{{}}};",
                self.p.num(*total),
                per.len(),
                per.join(", ")
            );
        }
        if self.cm.float == Float::F32 {
            let v = f.f32_floor.filter(|x| x.is_finite()).map(round_up_to_f32);
            let _ = writeln!(
                s,
                "const {r} {name}_F32_ERROR_FLOOR = {};",
                self.fig(v, inf)
            );
            let e = f.f32_euler;
            let euler = [
                ("F32_EULER_FLOOR", e.map(|e| e.base)),
                ("F32_EULER_UPDATE_ROUNDING", e.map(|e| e.per_step)),
                ("F32_EULER_MIN_STEP", e.map(|e| e.min_step)),
            ];
            for (k, v) in euler {
                let v = v.filter(|x| x.is_finite()).map(round_up_to_f32);
                let _ = writeln!(s, "const {r} {name}_{k} = {};", self.fig(v, inf));
            }
            let split = f.f32_rounding;
            for (k, v) in [
                ("F32_ROUNDING_D0", split.map(|x| x.d0)),
                ("F32_ROUNDING_D1", split.map(|x| x.d1)),
            ] {
                let v = v.filter(|x| x.is_finite()).map(round_up_to_f32);
                let _ = writeln!(s, "const {r} {name}_{k} = {};", self.fig(v, inf));
            }
            let rate = split.map(|x| x.rate).filter(|x| x.is_finite() && *x > 0.0);
            let _ = writeln!(
                s,
                "const {r} {name}_F32_RATE = {};",
                self.fig(rate.map(round_down_to_f32), &zero)
            );
            if d.sample.is_some() {
                let v = f
                    .f32_step_floor
                    .filter(|x| x.is_finite())
                    .map(round_up_to_f32);
                let _ = writeln!(s, "const {r} {name}_F32_STEP_FLOOR = {};", self.fig(v, inf));
            }
        }
        if let Some(a) = d.alpha_sup {
            let _ = writeln!(s, "const {r} {name}_ALPHA_SUP = {};", p.num(a));
        }
        if let Some(period) = d.sample {
            let _ = writeln!(s, "const {r} {name}_SAMPLE_PERIOD = {};", p.num(period));
        }
        s
    }

    /// The array constants: P, the vertex gains, Θ and the certificate.
    fn source_matrices(&self, cert_text: &str) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let (m, d, nz, ny) = (self.m, self.d, self.nz, self.ny);
        let mut s = String::new();
        let _ = writeln!(
            s,
            "const {r} {name}_P[{up}_NZ][{up}_NZ] = {};",
            self.matrix(nz, nz, &d.p)
        );
        let ls: Vec<String> = (0..self.nv)
            .map(|l| self.matrix(nz, ny, d.l.get(l).map_or(&[][..], |v| v.as_slice())))
            .collect();
        let _ = writeln!(
            s,
            "const {r} {name}_L[{up}_NV][{up}_NZ][{up}_NY] = {{\n    {}}};",
            ls.join(",\n    ")
        );
        if self.nth > 0 {
            let lo: Vec<String> = m.params.iter().map(|q| self.p.num(q.lo)).collect();
            let hi: Vec<String> = m.params.iter().map(|q| self.p.num(q.hi)).collect();
            let _ = writeln!(
                s,
                "const {r} {name}_THETA_MIN[{up}_NTHETA] = {{{}}};\nconst {r} {name}_THETA_MAX[{up}_NTHETA] = {{{}}};",
                lo.join(", "),
                hi.join(", ")
            );
        }
        let _ = writeln!(
            s,
            "#ifndef {up}_NO_CERTIFICATE\nconst char {name}_CERTIFICATE[] =\n{};\n#endif\n",
            cert_text
                .lines()
                .map(|l| format!("    \"{}\\n\"", c_escape(l)))
                .collect::<Vec<_>>()
                .join("\n")
        );
        s
    }

    /// The struct of the θ-dependent coefficients, one member per coefficient.
    fn coeffs_struct(&self, coeffs: &Body) -> String {
        let (name, r) = (self.name, self.real.as_str());
        let nk = coeffs.out.len();
        let mut s = String::from(
            "/* The θ-dependent coefficients of the equations, each computed once. */\ntypedef struct {\n",
        );
        if nk == 0 {
            let _ = writeln!(
                s,
                "    {r} none; /* the equations have constant coefficients */"
            );
        }
        for i in 0..nk {
            let _ = writeln!(s, "    {r} k{i};");
        }
        let _ = writeln!(s, "}} {name}_coeffs;\n");
        s
    }

    /// `<name>_clamp_theta`: θ clamped into Θ, NaN to the lower bound.
    fn clamp_theta_fn(&self) -> String {
        let (name, r) = (self.name, self.real.as_str());
        let mut s = String::new();
        let _ = writeln!(
            s,
            "/* θ clamped into Θ (NaN -> lower bound); returns 1 if any component changed. */\nstatic int {name}_clamp_theta(const {r} *theta, {r} *t) {{"
        );
        if self.nth == 0 {
            s.push_str("    (void)theta;\n    (void)t;\n    return 0;\n}\n\n");
        } else {
            s.push_str("    int clamped = 0;\n");
            for (i, q) in self.m.params.iter().enumerate() {
                let (lo, hi) = (self.p.num(q.lo), self.p.num(q.hi));
                let _ = writeln!(
                    s,
                    "    if (theta[{i}] >= {lo}) {{\n        if (theta[{i}] <= {hi}) {{ t[{i}] = theta[{i}]; }} else {{ clamped = 1; t[{i}] = {hi}; }}\n    }} else {{\n        clamped = 1;\n        t[{i}] = {lo};\n    }}"
                );
            }
            s.push_str("    return clamped;\n}\n\n");
        }
        s
    }

    /// `<name>_phi`: the derived scheduling variables φ(θ) (nothing when
    /// the model has none).
    fn phi_fn(&self, phi: &Body) -> String {
        if self.nphi == 0 {
            return String::new();
        }
        let (name, r) = (self.name, self.real.as_str());
        let code = body_assign(&self.p, phi, "f", r);
        let binds = bind("theta", &names("t", self.nth), &code, r);
        format!(
            "/* The derived scheduling variables φ(θ) (θ as given). */\nstatic void {name}_phi(const {r} *theta, {r} *f) {{\n{}{binds}{code}}}\n\n",
            unused(&["theta"], &format!("{binds}{code}")),
        )
    }

    /// The call of `<name>_phi` and the bindings of `phis` (the names the
    /// body gives φ) when `code` uses any of them; else nothing.
    fn phi_prelude(&self, phis: &[String], code: &str) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let mut pre = String::new();
        if phis.iter().any(|n| uses(code, n)) {
            let _ = writeln!(
                pre,
                "    {r} phi_values[{up}_NPHI];\n    {name}_phi(theta, phi_values);"
            );
            pre.push_str(&bind("phi_values", phis, code, r));
        }
        pre
    }

    /// `<name>_mu_clamped`: the scheduling weights μ_l at a clamped θ.
    fn mu_clamped_fn(&self, mu: &Body) -> String {
        let (name, r) = (self.name, self.real.as_str());
        let code = body_assign(&self.p, mu, "mu", r);
        let pre = self.phi_prelude(&names("f", self.nphi), &code);
        let theta_bind = bind("theta", &names("t", self.nth), &format!("{pre}{code}"), r);
        let all = format!("{theta_bind}{pre}{code}");
        format!(
            "/* The scheduling weights μ_l at a clamped θ. */\nstatic void {name}_mu_clamped(const {r} *theta, {r} *mu) {{\n{}{theta_bind}{pre}{code}}}\n\n",
            unused(&["theta"], &all)
        )
    }

    /// `<name>_coeffs_at`: the θ-dependent coefficients at θ.
    fn coeffs_at_fn(&self, coeffs: &Body) -> String {
        let (name, r) = (self.name, self.real.as_str());
        let mut code = self.p.lets(&coeffs.lets, r, "    ");
        for (i, e) in coeffs.out.iter().enumerate() {
            let _ = writeln!(code, "    c->k{i} = {};", self.p.expr(e));
        }
        if coeffs.out.is_empty() {
            let _ = writeln!(code, "    c->none = {};", self.p.num(0.0));
        }
        let phis: Vec<String> = (self.nth..self.nth + self.nphi)
            .map(|i| format!("t{i}"))
            .collect();
        let pre = self.phi_prelude(&phis, &code);
        let binds = bind("theta", &names("t", self.nth), &code, r);
        let all = format!("{binds}{pre}{code}");
        format!(
            "/* The θ-dependent coefficients at θ. */\nstatic void {name}_coeffs_at(const {r} *theta, {name}_coeffs *c) {{\n{}{binds}{pre}{code}}}\n\n",
            unused(&["theta"], &all),
        )
    }

    /// `<name>_gains`: the scheduled gain Σ_l μ_l L_l.
    fn gains_fn(&self, gains: &Body) -> String {
        let (name, r) = (self.name, self.real.as_str());
        let code = body_assign(&self.p, gains, "g", r);
        let binds = bind("mu", &names("m", self.nv), &code, r);
        format!(
            "/* The scheduled gain Σ_l μ_l L_l, NZ × NY row-major. */\nstatic void {name}_gains(const {r} *mu, {r} *g) {{\n{}{binds}{code}}}\n\n",
            unused(&["mu"], &format!("{binds}{code}")),
        )
    }

    /// `<name>_rhs`: the observer's right-hand side.
    fn rhs_fn(&self, rhs: &Body) -> String {
        let (name, r) = (self.name, self.real.as_str());
        let code = body_assign(&self.p, rhs, "ds", r);
        let ny = self.ny;
        let gnames: Vec<String> = (0..self.nz)
            .flat_map(|k| (0..ny).map(move |o| format!("g{k}_{o}")))
            .collect();
        let binds = [
            bind("s", &self.shape.state_names(), &code, r),
            bind("y", &names("y", ny), &code, r),
            bind("u", &names("u", self.nu), &code, r),
            bind("g", &gnames, &code, r),
        ]
        .concat();
        format!(
            "/* The observer's right-hand side: the plant rows plus the gain times the residual. */\nstatic void {name}_rhs(const {name}_coeffs *c, const {r} *g, const {r} *s, const {r} *y, const {r} *u, {r} *ds) {{\n{}{binds}{code}}}\n\n",
            unused(&["c", "g", "s", "y", "u"], &format!("{binds}{code}"))
        )
    }

    /// `<name>_schedule` (the θ-dependent data of one step), and
    /// `<name>_load`/`<name>_store` between the observer and its state array.
    fn schedule_fns(&self) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let (nx, ns) = (self.nx, self.ns);
        let mut s = format!(
            "/* The θ-dependent data of one step; returns 1 if θ was clamped. */\n\
             static int {name}_schedule(const {r} *theta, {name}_coeffs *c, {r} *g) {{\n\
             \x20   {r} t[{tn}];\n\
             \x20   {r} mu[{up}_NV];\n\
             \x20   const int clamped = {name}_clamp_theta(theta, t);\n\
             \x20   {name}_coeffs_at(t, c);\n\
             \x20   {name}_mu_clamped(t, mu);\n\
             \x20   {name}_gains(mu, g);\n\
             \x20   return clamped;\n}}\n\n",
            tn = self.nth.max(1)
        );
        let mut load = String::new();
        let mut store = String::new();
        for i in 0..nx {
            let _ = writeln!(load, "    s[{i}] = o->xhat[{i}];");
            let _ = writeln!(store, "    o->xhat[{i}] = s[{i}];");
        }
        for k in nx..ns {
            let _ = writeln!(load, "    s[{k}] = o->filter[{}];", k - nx);
            let _ = writeln!(store, "    o->filter[{}] = s[{k}];", k - nx);
        }
        let _ = write!(
            s,
            "static void {name}_load(const {name}_observer *o, {r} *s) {{\n{load}}}\n\n\
             static void {name}_store({name}_observer *o, const {r} *s) {{\n{store}}}\n\n"
        );
        s
    }

    /// `<name>_init` and `<name>_estimate`.
    fn init_fns(&self) -> String {
        let (name, r) = (self.name, self.real.as_str());
        let zero = self.p.num(0.0);
        let mut init = String::new();
        for i in 0..self.nx {
            let _ = writeln!(init, "    o->xhat[{i}] = {zero};");
        }
        for k in 0..self.ns - self.nx {
            let _ = writeln!(init, "    o->filter[{k}] = {zero};");
        }
        let mut at = String::new();
        for i in 0..self.nx {
            let _ = writeln!(at, "    o->xhat[{i}] = x0[{i}];");
        }
        for k in 0..self.ns - self.nx {
            let _ = writeln!(at, "    o->filter[{k}] = {zero};");
        }
        format!(
            "void {name}_init({name}_observer *o) {{\n{init}    o->clamped = 0;\n}}\n\n\
             void {name}_init_at({name}_observer *o, const {r} *x0) {{\n{at}    o->clamped = 0;\n}}\n\n\
             const {r} *{name}_estimate(const {name}_observer *o) {{\n    return o->xhat;\n}}\n\n"
        )
    }

    /// One stage of a step: `dst[i] = s[i] + coef * k[i];` for every
    /// observer state.
    fn stage(&self, dst: &str, coef: &str, k: &str) -> String {
        (0..self.ns)
            .map(|i| format!("    {dst}[{i}] = s[{i}] + {coef} * {k}[{i}];\n"))
            .collect()
    }

    /// `<name>_derivative`, `<name>_step_euler` and, for a sampled design,
    /// the certified `<name>_step`.
    fn derivative_and_euler_fns(&self) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let mut s = format!(
            "void {name}_derivative(const {name}_observer *o, const {r} *y, const {r} *u, const {r} *theta, {r} *ds) {{\n\
             \x20   {name}_coeffs c;\n    {r} g[{up}_NZ * {up}_NY];\n    {r} s[{up}_NS];\n\
             \x20   (void){name}_schedule(theta, &c, g);\n    {name}_load(o, s);\n\
             \x20   {name}_rhs(&c, g, s, y, u, ds);\n}}\n\n"
        );
        let _ = write!(
            s,
            "void {name}_step_euler({name}_observer *o, {r} h, const {r} *y, const {r} *u, const {r} *theta) {{\n\
             \x20   {name}_coeffs c;\n    {r} g[{up}_NZ * {up}_NY];\n    {r} s[{up}_NS];\n    {r} a[{up}_NS];\n\
             \x20   const int clamped = {name}_schedule(theta, &c, g);\n{COUNT_CLAMPED}\
             \x20   {name}_load(o, s);\n    {name}_rhs(&c, g, s, y, u, a);\n{}\
             \x20   {name}_store(o, s);\n}}\n\n",
            self.stage("s", "h", "a")
        );
        if self.d.sample.is_some() {
            // The certified step is step_euler at exactly SAMPLE_PERIOD.
            let _ = write!(
                s,
                "void {name}_step({name}_observer *o, const {r} *y, const {r} *u, const {r} *theta) {{\n\
                 \x20   {name}_step_euler(o, {name}_SAMPLE_PERIOD, y, u, theta);\n}}\n\n"
            );
        }
        s
    }

    /// `<name>_step_rk4`: one classical Runge-Kutta 4 step.
    fn rk4_fn(&self) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        let two = self.p.num(2.0);
        let fin: String = (0..self.ns)
            .map(|i| {
                format!(
                    "    s[{i}] = s[{i}] + h6 * (a[{i}] + {two} * b[{i}] + {two} * c3[{i}] + d[{i}]);\n"
                )
            })
            .collect();
        format!(
            "void {name}_step_rk4({name}_observer *o, {r} h, const {r} *y, const {r} *u, const {r} *theta) {{\n\
             \x20   {name}_coeffs c;\n    {r} g[{up}_NZ * {up}_NY];\n    {r} s[{up}_NS], tmp[{up}_NS];\n\
             \x20   {r} a[{up}_NS], b[{up}_NS], c3[{up}_NS], d[{up}_NS];\n\
             \x20   const {r} h2 = {half} * h;\n    const {r} h6 = h * {sixth};\n\
             \x20   const int clamped = {name}_schedule(theta, &c, g);\n{COUNT_CLAMPED}\
             \x20   {name}_load(o, s);\n    {name}_rhs(&c, g, s, y, u, a);\n{}\
             \x20   {name}_rhs(&c, g, tmp, y, u, b);\n{}\
             \x20   {name}_rhs(&c, g, tmp, y, u, c3);\n{}\
             \x20   {name}_rhs(&c, g, tmp, y, u, d);\n{fin}\
             \x20   {name}_store(o, s);\n}}\n\n",
            self.stage("tmp", "h2", "a"),
            self.stage("tmp", "h2", "b"),
            self.stage("tmp", "h", "c3"),
            half = self.p.num(0.5),
            sixth = self.p.num(1.0 / 6.0),
        )
    }

    /// The public `<name>_mu` and `<name>_gain` (θ clamped first).
    fn schedule_api_fns(&self) -> String {
        let (name, up, r) = (self.name, &self.up, self.real.as_str());
        format!(
            "void {name}_mu(const {r} *theta, {r} *mu) {{\n    {r} t[{tn}];\n    (void){name}_clamp_theta(theta, t);\n    {name}_mu_clamped(t, mu);\n}}\n\n\
             void {name}_gain(const {r} *theta, {r} *g) {{\n    {r} t[{tn}];\n    {r} mu[{up}_NV];\n    (void){name}_clamp_theta(theta, t);\n    {name}_mu_clamped(t, mu);\n    {name}_gains(mu, g);\n}}\n\n",
            tn = self.nth.max(1)
        )
    }

    /// `<name>_plant_derivative` and `<name>_plant_output` (θ as given).
    fn plant_fns(&self, plant_f: &Body, plant_h: &Body) -> String {
        let (name, r) = (self.name, self.real.as_str());
        let mut s = String::new();
        for (fname, body, args, out, xs) in [
            (
                "plant_derivative",
                plant_f,
                format!("const {r} *x, const {r} *u, const {r} *theta, {r} *dx"),
                "dx",
                true,
            ),
            (
                "plant_output",
                plant_h,
                format!("const {r} *x, const {r} *theta, {r} *y"),
                "y",
                false,
            ),
        ] {
            let code = body_assign(&self.p, body, out, r);
            let mut pre = String::new();
            if uses(&code, "c") {
                let _ = writeln!(pre, "    {name}_coeffs cs;\n    const {name}_coeffs *c = &cs;\n    {name}_coeffs_at(theta, &cs);");
            }
            let mut binds = bind("x", &names("x", self.nx), &code, r);
            if xs {
                binds.push_str(&bind("u", &names("u", self.nu), &code, r));
            }
            let params: &[&str] = if xs {
                &["x", "u", "theta"]
            } else {
                &["x", "theta"]
            };
            let all = format!("{pre}{binds}{code}");
            let _ = write!(
                s,
                "void {name}_{fname}({args}) {{\n{}{pre}{binds}{code}}}\n\n",
                unused(params, &all)
            );
        }
        s
    }
}

/// `x` rounded down to a `float`, so that a rate printed from it never
/// overstates `x`.
fn round_down_to_f32(x: f64) -> f64 {
    -round_up_to_f32(-x)
}

/// `x` rounded up to the nearest `float`, so that a constant printed from
/// it never understates `x`.
fn round_up_to_f32(x: f64) -> f64 {
    let r = x as f32;
    let r = if f64::from(r) < x {
        f32::from_bits(r.to_bits() + 1)
    } else {
        r
    };
    f64::from(r)
}

/// A body's lets, then `out[i] = value;` per output.
fn body_assign(p: &Printer, b: &Body, out: &str, real: &str) -> String {
    let mut code = p.lets(&b.lets, real, "    ");
    for (i, e) in b.out.iter().enumerate() {
        let _ = writeln!(code, "    {out}[{i}] = {};", p.expr(e));
    }
    code
}

/// True if the expression calls a math function.
fn has_call(e: &Expr) -> bool {
    match e {
        Expr::Call(..) => true,
        Expr::Num(_) | Expr::Int(_) | Expr::Var(_) | Expr::Coef(_) => false,
        Expr::Neg(a) | Expr::Paren(a) | Expr::PowI(a, _) => has_call(a),
        Expr::Product(es) | Expr::Select(_, es) => es.iter().any(has_call),
        Expr::Bin(_, a, b) | Expr::Ge(a, b) => has_call(a) || has_call(b),
        Expr::Sum(ts) => ts.iter().any(|(_, f)| f.as_ref().is_some_and(has_call)),
        Expr::Clamp(a, b, c) => has_call(a) || has_call(b) || has_call(c),
    }
}

/// A string for a C string literal: `\\`, `"` and every `?` escaped (a
/// `??=`, `??/`, ... would be a trigraph under `-std=c99`, which
/// `-Wtrigraphs` turns into an error with `-Werror`; `\\?` is always `?`),
/// control characters as octal escapes.
fn c_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '\\' => out.push_str("\\\\"),
            '"' => out.push_str("\\\""),
            '?' => out.push_str("\\?"),
            c if (c as u32) < 0x20 || c as u32 == 0x7f => {
                let _ = write!(out, "\\{:03o}", c as u32);
            }
            c => out.push(c),
        }
    }
    out
}

/// A line for the inside of a C block comment: no `*/` (which would end
/// it), no `/*` (`-Wcomment`), no `??` (a trigraph: `??/` ends in a line
/// splice, which `-Wtrigraphs` reports), no control characters.
fn c_comment(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut prev = '\0';
    for ch in s.chars() {
        let c = if ch.is_control() { ' ' } else { ch };
        let split = matches!((prev, c), ('*', '/') | ('/', '*') | ('?', '?'));
        if split {
            out.push(' ');
        }
        out.push(c);
        prev = c;
    }
    out
}

/// The standard headers of C89 to C23 (without `.h`): a model of one of
/// these names would write `<name>.h`, which shadows the system header
/// under `-I OUT` (the generated source itself includes `<limits.h>` and
/// may include `<math.h>`).
pub const STANDARD_HEADERS: [&str; 31] = [
    "assert",
    "complex",
    "ctype",
    "errno",
    "fenv",
    "float",
    "inttypes",
    "iso646",
    "limits",
    "locale",
    "math",
    "setjmp",
    "signal",
    "stdalign",
    "stdarg",
    "stdatomic",
    "stdbit",
    "stdbool",
    "stdckdint",
    "stddef",
    "stdint",
    "stdio",
    "stdlib",
    "stdnoreturn",
    "string",
    "tgmath",
    "threads",
    "time",
    "uchar",
    "wchar",
    "wctype",
];

/// If the model name `name` makes a header that shadows a C standard
/// header (compared without case: on a case-insensitive file system
/// `Math.h` is `math.h`), the reason, in words.
pub fn shadowed_header(name: &str) -> Option<String> {
    let lower = name.to_ascii_lowercase();
    STANDARD_HEADERS.iter().find(|h| **h == lower).map(|h| {
        format!(
            "model name `{name}`: the C export would write {name}.h, which shadows the C \
             standard header <{h}.h> wherever OUT is on the include path (-I); rename the model \
             (e.g. `{name}_model`)"
        )
    })
}

/// The certificate as text: the request, α, γ, the margins per family, the
/// solver's status, the figures, and the caller's notes.
fn certificate_text(cm: &CModel<'_>, shape: Shape) -> String {
    let d = cm.design;
    let m = cm.model;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "Certificate of model `{}`, design: {}",
        m.name, d.request
    );
    let _ = writeln!(
        t,
        "states {}; outputs {}; inputs {}; parameters {}",
        m.states.join(", "),
        m.outputs.join(", "),
        if m.inputs.is_empty() {
            "none".to_string()
        } else {
            m.inputs.join(", ")
        },
        if m.params.is_empty() {
            "none".to_string()
        } else {
            m.params
                .iter()
                .map(|p| format!("{} in [{}, {}]", p.name, p.lo, p.hi))
                .collect::<Vec<_>>()
                .join(", ")
        }
    );
    let _ = writeln!(
        t,
        "route {}; alpha = {}; gamma = {}; {} vertices",
        shape.route(),
        d.alpha,
        d.gamma,
        shape.nv
    );
    if let Some(a) = d.alpha_sup {
        let _ = writeln!(
            t,
            "alpha = max: the search's certified supremum estimate is ALPHA_SUP = {a} (an \
             estimate of the supremum, not a rate of this design)"
        );
    }
    if let (Some(text), Some(period)) = (d.sample_text(), d.sample) {
        let _ = writeln!(
            t,
            "certified at {text}: {name}_step (one explicit Euler step of exactly SAMPLE_PERIOD)\n\
             gives V(e_k+1) <= {} V(e_k) (1 - h*alpha) against the plant stepped by the same Euler step;\n\
             family S5d in place of S5 (docs/method.md section 16)",
            1.0 - period * d.alpha,
            name = m.name
        );
    }
    let _ = writeln!(
        t,
        "independent certificate (sound mode), worst margin per condition family (positive = holds):"
    );
    for (fam, margin) in &d.margins {
        let _ = writeln!(t, "  {fam:<6} {margin:.6e}");
    }
    let _ = writeln!(t, "solver: {} ({} iterations)", d.status, d.iterations);
    let f = &d.figures;
    let opt = |v: Option<f64>| v.map_or("none certified".to_string(), |x| format!("{x:.6e}"));
    if d.sample.is_some() {
        let _ = writeln!(
            t,
            "noise bound and Euler step figures: not computed for a sampled design (the continuous\n\
             noise bound and step figures say nothing about it; docs/method.md section 16)"
        );
    } else {
        continuous_figures(&mut t, f, d.noise_missing.as_deref(), opt);
    }
    if cm.float == Float::F32 {
        f32_figures(&mut t, cm);
    }
    let _ = writeln!(
        t,
        "theta outside its bounds is clamped into them (NaN -> lower bound) and counted in `clamped`;\n{}",
        if m.is_lpv() {
            "the certificate covers theta in its bounds and every plant state and initial error \
             (the global observer of an LPV plant assumes no state bound)."
        } else {
            "the certificate covers theta in its bounds, the plant state in the model's state \
             bound F and initial errors in the region."
        }
    );
    for n in &cm.notes {
        let _ = writeln!(t, "{n}");
    }
    t
}

/// The f32 figures of the certificate text: the error floor (or why none),
/// the Euler step's floor, the rounding's D0 and D1, a sampled step's floor.
fn f32_figures(t: &mut String, cm: &CModel<'_>) {
    let (d, m) = (cm.design, cm.model);
    let f = &d.figures;
    let opt = |v: Option<f64>| v.map_or("none certified".to_string(), |x| format!("{x:.6e}"));
    let _ = match f.f32_floor {
        Some(x) => writeln!(
            t,
            "f32 error floor: lim sup |e| <= {x:.6e} from the float rounding of one evaluation \
             of the right-hand side (u = 2^-24, over F x Theta and the input ranges), even \
             without noise; the rounding of the state update comes on top"
        ),
        None => writeln!(
            t,
            "f32 error floor: none certified (the rounding bound needs the states' range: \
             a state bound F and input ranges{})",
            if m.is_lpv() {
                "; the global observer of an LPV plant has no region or F to bound it over"
            } else {
                ""
            }
        ),
    };
    let _ = match f.f32_euler {
        Some(e) => writeln!(
            t,
            "f32 floor of step_euler, the state update's rounding included: lim sup |e| <= \
             {:.6e} + {:.6e} / h for {:.6e} < h <= MAX_STEP_EULER",
            e.base, e.per_step, e.min_step
        ),
        None => writeln!(t, "f32 floor of step_euler: none certified"),
    };
    if let Some(r) = f.f32_rounding {
        let _ = writeln!(
            t,
            "f32 rounding of one right-hand side evaluation in the P-norm: D0 = {:.6e}, \
             D1 = {:.6e}; the floor is certified at the rate alpha - 2*D1 = {:.6e}",
            r.d0, r.d1, r.rate
        );
    }
    if d.sample.is_some() {
        let _ = writeln!(
            t,
            "f32 floor of {}_step at SAMPLE_PERIOD, the state update's rounding included: \
             lim sup |e_k| <= {}",
            m.name,
            opt(f.f32_step_floor)
        );
    }
}

/// The noise and step figures of a continuous design, for the certificate text.
fn continuous_figures(
    t: &mut String,
    f: &crate::design::Figures,
    noise_missing: Option<&str>,
    opt: impl Fn(Option<f64>) -> String,
) {
    let _ = match (f.sigma, noise_missing) {
        (None, Some(why)) => writeln!(t, "noise: none certified: {why}"),
        _ => writeln!(
            t,
            "noise: sigma {}, error bound per unit noise {}, up to amplitude {}",
            opt(f.sigma),
            opt(f.error_bound),
            opt(f.max_amplitude)
        ),
    };
    let _ = writeln!(
        t,
        "steps: max certified Euler step {}, RK4 step estimate {} (not a proof)",
        opt(f.euler.map(|e| e.0)),
        opt(f.rk4)
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_parse_back_to_the_same_bits() {
        for v in [
            0.1,
            -2.5e-300,
            1.0 / 3.0,
            123456.789,
            1e22,
            5e-324,
            10.0,
            -0.0,
        ] {
            let t = literal(v, Float::F64);
            assert!(
                t.contains('.') || t.contains('e'),
                "{t} is a floating constant"
            );
            assert_eq!(t.parse::<f64>().map(f64::to_bits), Ok(v.to_bits()), "{t}");
            let t = literal(v, Float::F32);
            let body = t.strip_suffix('f').expect("f suffix");
            assert!(body.contains('.') || body.contains('e'), "{t}");
            assert_eq!(
                body.parse::<f32>().map(f32::to_bits),
                Ok((v as f32).to_bits()),
                "{t}"
            );
        }
    }

    #[test]
    fn baked_text_has_no_trigraph_and_ends_no_comment() {
        let path = "d/a??=b??/c??(\"q\\\t.qpv";
        let lit = c_escape(path);
        assert!(!lit.contains("??"), "{lit}");
        assert_eq!(lit, r#"d/a\?\?=b\?\?/c\?\?(\"q\\\011.qpv"#);
        let com = c_comment("a??/ */ /* b");
        assert!(
            !com.contains("??") && !com.contains("*/") && !com.contains("/*"),
            "{com}"
        );
        assert!(shadowed_header("math").is_some() && shadowed_header("Limits").is_some());
        assert!(shadowed_header("paper_example").is_none() && shadowed_header("mathx").is_none());
    }

    /// Equal vertex gains print as one product over the sum of their
    /// weights (the tree the Rust printer prints too).
    #[test]
    fn equal_vertex_gains_print_as_one_product() {
        use crate::ir::Sum;
        let mut w = Sum::default();
        w.push(1.0, Some(Expr::var("m0")));
        w.push(1.0, Some(Expr::var("m1")));
        let mut s = Sum::default();
        s.push(12.777_471, Some(Expr::paren(w.expr())));
        s.push(-3.5, Some(Expr::var("m2")));
        let p = Printer { float: Float::F32 };
        assert_eq!(p.expr(&s.expr()), "12.777471f * (m0 + m1) - 3.5f * m2");
    }

    #[test]
    fn selections_clamps_and_signs_print_as_c() {
        let p = Printer { float: Float::F32 };
        let sel = Expr::Select(
            "k".into(),
            vec![Expr::Num(1.0), Expr::Num(2.0), Expr::Num(3.0)],
        );
        assert_eq!(p.expr(&sel), "(k == 0u ? 1.0f : (k == 1u ? 2.0f : 3.0f))");
        let clamp = Expr::Clamp(
            Box::new(Expr::var("f0")),
            Box::new(Expr::Num(-1.0)),
            Box::new(Expr::Num(2.0)),
        );
        assert_eq!(
            p.expr(&clamp),
            "(f0 >= -1.0f ? (f0 <= 2.0f ? f0 : 2.0f) : -1.0f)"
        );
        // never `--` (a decrement)
        let nn = Expr::Neg(Box::new(Expr::Num(-1.0)));
        assert_eq!(p.expr(&nn), "- -1.0f");
        let call = Expr::Call(qpv_dsl::Func::Sin, Box::new(Expr::var("t0")));
        assert_eq!(p.expr(&call), "sinf(t0)");
        assert_eq!(Printer { float: Float::F64 }.expr(&call), "sin(t0)");
    }
}
