//! Scheduling functions: the non-multi-affine functions of the parameters a
//! model uses (`sin(q2)`, `1/(4 - m)`, `th^2`, `k0*exp(-E/(R*T))`), their
//! exact evaluation, and a range that provably contains their values on the
//! parameter box Θ.
//!
//! Every maximal sub-expression that is not multi-affine in the parameters
//! becomes a *derived scheduling variable* φ_j(θ). Each matrix entry is then
//! multi-affine in (θ, φ), so the polytopic model over the box of (θ, φ) is
//! exact for every θ ∈ Θ (the point (θ, φ(θ)) lies in that box). The range
//! [φ_lo, φ_hi] comes from interval arithmetic with outward rounding, refined
//! by bisecting Θ until it is within [`RANGE_TOLERANCE`] (relative to the
//! width of the sampled range) of the values sampled on the way.

pub use crate::func::Func;

mod gradient;
pub use gradient::{enclose_gradient, gradient_bound, gradient_hull, GradientEnclosure};
use serde::Serialize;
use std::fmt::Write as _;

/// Relative tolerance of a computed range: the enclosure exceeds the range
/// of the values sampled on Θ by at most this fraction of its width on each
/// side (unless the bisection budget runs out first; the report says so).
pub const RANGE_TOLERANCE: f64 = 1e-6;

/// Most boxes the bisection of Θ may evaluate for one range.
const MAX_BOXES: usize = 3000;

/// A scheduling function of the declared parameters, as a tree. Evaluation
/// ([`SchedExpr::eval`]) and the generated code follow the same tree, so
/// the two agree to rounding.
#[derive(Debug, Clone, PartialEq)]
pub enum SchedExpr {
    /// A number.
    Num(f64),
    /// The i-th declared parameter.
    Param(usize),
    /// A `let` name and its definition.
    Named(String, Box<SchedExpr>),
    /// −e.
    Neg(Box<SchedExpr>),
    /// A sum: each term with `true` if it is subtracted.
    Sum(Vec<(bool, SchedExpr)>),
    /// A product: each factor with `true` if it divides.
    Product(Vec<(bool, SchedExpr)>),
    /// e^n, n a whole number (evaluated by repeated multiplication).
    Pow(Box<SchedExpr>, u32),
    /// f(e).
    Call(Func, Box<SchedExpr>),
}

impl SchedExpr {
    /// The value at `theta` (one entry per declared parameter); NaN or
    /// infinite where the function is undefined.
    pub fn eval(&self, theta: &[f64]) -> f64 {
        match self {
            SchedExpr::Num(c) => *c,
            SchedExpr::Param(i) => theta.get(*i).copied().unwrap_or(f64::NAN),
            SchedExpr::Named(_, e) => e.eval(theta),
            SchedExpr::Neg(e) => -e.eval(theta),
            SchedExpr::Sum(t) => t.iter().fold(0.0, |acc, (neg, e)| {
                let v = e.eval(theta);
                if *neg {
                    acc - v
                } else {
                    acc + v
                }
            }),
            SchedExpr::Product(f) => f.iter().fold(1.0, |acc, (div, e)| {
                let v = e.eval(theta);
                if *div {
                    acc / v
                } else {
                    acc * v
                }
            }),
            SchedExpr::Pow(e, n) => powi(e.eval(theta), *n),
            SchedExpr::Call(f, e) => f.apply(e.eval(theta)),
        }
    }

    /// Bit mask of the declared parameters the function depends on.
    pub fn param_mask(&self) -> u64 {
        match self {
            SchedExpr::Num(_) => 0,
            SchedExpr::Param(i) => 1u64 << i,
            SchedExpr::Named(_, e)
            | SchedExpr::Neg(e)
            | SchedExpr::Pow(e, _)
            | SchedExpr::Call(_, e) => e.param_mask(),
            SchedExpr::Sum(t) | SchedExpr::Product(t) => {
                t.iter().fold(0, |m, (_, e)| m | e.param_mask())
            }
        }
    }

    /// The text of the function with parameter names `params` (a `let`
    /// shown by its name).
    pub fn text(&self, params: &[String]) -> String {
        let mut s = String::new();
        self.write(&mut s, params, false, 0);
        s
    }

    /// A canonical text that identifies the function: `let` names replaced
    /// by their definitions, numbers written exactly. Equal keys mean the
    /// same function, so a recurring sub-expression becomes one φ.
    pub(crate) fn key(&self, params: &[String]) -> String {
        let mut s = String::new();
        self.write(&mut s, params, true, 0);
        s
    }

    /// Writes the expression; `prec` is the binding strength of the context
    /// (0 sum, 1 product, 2 unary, 3 power base).
    fn write(&self, s: &mut String, params: &[String], key: bool, prec: u8) {
        let paren = |s: &mut String, mine: u8, f: &dyn Fn(&mut String)| {
            if mine < prec {
                s.push('(');
                f(s);
                s.push(')');
            } else {
                f(s);
            }
        };
        match self {
            SchedExpr::Num(c) => {
                if key {
                    let _ = write!(s, "{:?}", c);
                } else {
                    let _ = write!(s, "{c}");
                }
            }
            SchedExpr::Param(i) => s.push_str(params.get(*i).map_or("?", |p| p.as_str())),
            SchedExpr::Named(n, e) => {
                if key {
                    e.write(s, params, key, prec)
                } else {
                    s.push_str(n)
                }
            }
            SchedExpr::Neg(e) => paren(s, 2, &|s: &mut String| {
                s.push('-');
                e.write(s, params, key, 2);
            }),
            SchedExpr::Sum(t) => paren(s, 0, &|s: &mut String| {
                for (k, (neg, e)) in t.iter().enumerate() {
                    match (k, neg) {
                        (0, true) => s.push('-'),
                        (0, false) => {}
                        (_, true) => s.push_str(" - "),
                        (_, false) => s.push_str(" + "),
                    }
                    e.write(s, params, key, if *neg || k == 0 { 1 } else { 0 });
                }
            }),
            SchedExpr::Product(f) => paren(s, 1, &|s: &mut String| {
                for (k, (div, e)) in f.iter().enumerate() {
                    match (k, div) {
                        (0, true) => s.push_str("1/"),
                        (0, false) => {}
                        (_, true) => s.push('/'),
                        (_, false) => s.push('*'),
                    }
                    e.write(s, params, key, if *div { 2 } else { 1 });
                }
            }),
            SchedExpr::Pow(e, n) => {
                e.write(s, params, key, 3);
                let _ = write!(s, "^{n}");
            }
            SchedExpr::Call(f, e) => {
                s.push_str(f.name());
                s.push('(');
                e.write(s, params, key, 0);
                s.push(')');
            }
        }
    }
}

/// x^n by repeated multiplication (the generated code does the same).
pub fn powi(x: f64, n: u32) -> f64 {
    let mut v = 1.0;
    for _ in 0..n {
        v *= x;
    }
    v
}

/// A derived scheduling variable φ_j(θ): a non-multi-affine function of
/// the parameters that the polytopic model treats as one more bounded
/// variable.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Derived {
    /// Its name: the `let` name, or `phi1`, `phi2`, ... in order of use.
    pub name: String,
    /// The function, as written (a `let` shown by its name).
    pub text: String,
    /// The function as a tree (serialized through `text`).
    #[serde(skip)]
    pub expr: SchedExpr,
    /// Lower end of the range (contains φ_j(θ) for every θ ∈ Θ).
    pub lo: f64,
    /// Upper end of the range.
    pub hi: f64,
    /// How the range was obtained and how close it is to the values sampled on Θ.
    pub range: RangeInfo,
    /// The matrix entries that use it (`A[1,2]`, `N1[2,3]`, ...).
    pub used_in: Vec<String>,
    /// Where it first appears in the model text.
    pub span: crate::diagnostic::Span,
}

/// How a range was computed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RangeInfo {
    /// In words: interval arithmetic, with or without bisection of Θ.
    pub method: String,
    /// Number of boxes of Θ evaluated.
    pub boxes: usize,
    /// Smallest value sampled on Θ (corners and box midpoints).
    pub sampled_lo: f64,
    /// Largest value sampled on Θ.
    pub sampled_hi: f64,
}

// ===================== Interval arithmetic =====================

/// The next float below `x` (outward rounding of a lower bound).
fn down(x: f64) -> f64 {
    if x.is_nan() || x == f64::NEG_INFINITY {
        x
    } else if x == 0.0 {
        -f64::from_bits(1)
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() - 1)
    } else {
        f64::from_bits(x.to_bits() + 1)
    }
}

/// The next float above `x`.
fn up(x: f64) -> f64 {
    -down(-x)
}

/// `x` moved `k` floats down (for library functions, which are accurate to
/// about one unit in the last place, not correctly rounded).
fn down_k(x: f64, k: u32) -> f64 {
    (0..k).fold(x, |v, _| down(v))
}

fn up_k(x: f64, k: u32) -> f64 {
    (0..k).fold(x, |v, _| up(v))
}

/// Ulps of slack for the library functions.
const LIB_ULPS: u32 = 4;

#[derive(Debug, Clone, Copy, PartialEq)]
struct Iv {
    lo: f64,
    hi: f64,
}

impl Iv {
    fn point(c: f64) -> Iv {
        Iv { lo: c, hi: c }
    }
    fn contains_zero(self) -> bool {
        self.lo <= 0.0 && self.hi >= 0.0
    }
    fn neg(self) -> Iv {
        Iv {
            lo: -self.hi,
            hi: -self.lo,
        }
    }
    fn add(self, o: Iv) -> Iv {
        Iv {
            lo: down(self.lo + o.lo),
            hi: up(self.hi + o.hi),
        }
    }
    fn mul(self, o: Iv) -> Iv {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        hull_rounded(&p)
    }
    fn div(self, o: Iv) -> Iv {
        let p = [
            self.lo / o.lo,
            self.lo / o.hi,
            self.hi / o.lo,
            self.hi / o.hi,
        ];
        hull_rounded(&p)
    }
}

fn hull_rounded(p: &[f64]) -> Iv {
    let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Iv {
        lo: down(lo),
        hi: up(hi),
    }
}

/// Why a function is not defined (or not bounded) on a box.
#[derive(Debug, Clone)]
struct Undefined {
    what: String,
}

/// Interval enclosure of `e` on the box `b` (one interval per declared
/// parameter).
fn enclose(e: &SchedExpr, b: &[Iv], names: &[String]) -> Result<Iv, Undefined> {
    let r = match e {
        SchedExpr::Num(c) => Iv::point(*c),
        SchedExpr::Param(i) => b[*i],
        SchedExpr::Named(_, e) => enclose(e, b, names)?,
        SchedExpr::Neg(e) => enclose(e, b, names)?.neg(),
        SchedExpr::Sum(t) => {
            let mut acc = Iv::point(0.0);
            for (neg, e) in t {
                let v = enclose(e, b, names)?;
                acc = acc.add(if *neg { v.neg() } else { v });
            }
            acc
        }
        SchedExpr::Product(f) => {
            let mut acc = Iv::point(1.0);
            for (div, e) in f {
                let v = enclose(e, b, names)?;
                if *div {
                    if v.contains_zero() {
                        return Err(Undefined {
                            what: format!("division by `{}`, which can be 0", e.text(names)),
                        });
                    }
                    acc = acc.div(v);
                } else {
                    acc = acc.mul(v);
                }
            }
            acc
        }
        SchedExpr::Pow(e, n) => ipow(enclose(e, b, names)?, *n),
        SchedExpr::Call(f, arg) => call(*f, enclose(arg, b, names)?, arg, names)?,
    };
    if !(r.lo.is_finite() && r.hi.is_finite()) {
        return Err(Undefined {
            what: format!(
                "`{}` is unbounded (it overflows a 64-bit float)",
                e.text(names)
            ),
        });
    }
    Ok(r)
}

fn ipow(v: Iv, n: u32) -> Iv {
    if n == 0 {
        return Iv::point(1.0);
    }
    // |x|^n between the smallest and largest magnitude, rounded outward by
    // n floats (one per multiplication)
    let pow_up = |x: f64| up_k(powi(x, n), n);
    let pow_down = |x: f64| down_k(powi(x, n), n).max(0.0);
    if n % 2 == 0 {
        let (mig, mag) = if v.contains_zero() {
            (0.0, v.lo.abs().max(v.hi.abs()))
        } else {
            let (a, b) = (v.lo.abs(), v.hi.abs());
            (a.min(b), a.max(b))
        };
        Iv {
            lo: if mig == 0.0 { 0.0 } else { pow_down(mig) },
            hi: pow_up(mag),
        }
    } else {
        // odd powers are increasing
        let f = |x: f64, lower: bool| {
            let m = if lower == (x >= 0.0) {
                pow_down(x.abs())
            } else {
                pow_up(x.abs())
            };
            if x >= 0.0 {
                m
            } else {
                -m
            }
        };
        Iv {
            lo: f(v.lo, true),
            hi: f(v.hi, false),
        }
    }
}

fn monotone(f: impl Fn(f64) -> f64, v: Iv) -> Iv {
    Iv {
        lo: down_k(f(v.lo), LIB_ULPS),
        hi: up_k(f(v.hi), LIB_ULPS),
    }
}

/// Whether [lo, hi] (padded by a relative 1e-12) contains c + 2kπ·period/2π
/// for some whole k: the points where a periodic function reaches an extremum.
fn hits(v: Iv, c: f64, period: f64) -> bool {
    let pad = 1e-12 * (1.0 + v.lo.abs().max(v.hi.abs()));
    let k_lo = ((v.lo - pad - c) / period).ceil();
    let k_hi = ((v.hi + pad - c) / period).floor();
    k_lo <= k_hi
}

fn call(f: Func, v: Iv, arg: &SchedExpr, names: &[String]) -> Result<Iv, Undefined> {
    use std::f64::consts::{FRAC_PI_2, PI};
    let arg_text = || arg.text(names);
    Ok(match f {
        Func::Sqrt => {
            if v.lo < 0.0 {
                return Err(Undefined {
                    what: format!("sqrt of `{}`, which can be negative", arg_text()),
                });
            }
            Iv {
                lo: down(v.lo.sqrt()).max(0.0),
                hi: up(v.hi.sqrt()),
            }
        }
        Func::Ln => {
            if v.lo <= 0.0 {
                return Err(Undefined {
                    what: format!("ln of `{}`, which can be 0 or negative", arg_text()),
                });
            }
            monotone(f64::ln, v)
        }
        Func::Exp => {
            let r = monotone(f64::exp, v);
            Iv {
                lo: r.lo.max(0.0),
                hi: r.hi,
            }
        }
        Func::Tanh => {
            let r = monotone(f64::tanh, v);
            Iv {
                lo: r.lo.max(-1.0),
                hi: r.hi.min(1.0),
            }
        }
        Func::Atan => monotone(f64::atan, v),
        Func::Abs => {
            if v.contains_zero() {
                Iv {
                    lo: 0.0,
                    hi: v.lo.abs().max(v.hi.abs()),
                }
            } else {
                let (a, b) = (v.lo.abs(), v.hi.abs());
                Iv {
                    lo: a.min(b),
                    hi: a.max(b),
                }
            }
        }
        Func::Sin | Func::Cos => {
            if v.hi - v.lo >= 2.0 * PI {
                return Ok(Iv { lo: -1.0, hi: 1.0 });
            }
            let g = f.apply_fn();
            let (a, b) = (g(v.lo), g(v.hi));
            // maxima of sin at π/2 + 2kπ, of cos at 2kπ; minima half a period later
            let max_at = if f == Func::Sin { FRAC_PI_2 } else { 0.0 };
            let hi = if hits(v, max_at, 2.0 * PI) {
                1.0
            } else {
                up_k(a.max(b), LIB_ULPS).min(1.0)
            };
            let lo = if hits(v, max_at + PI, 2.0 * PI) {
                -1.0
            } else {
                down_k(a.min(b), LIB_ULPS).max(-1.0)
            };
            Iv { lo, hi }
        }
        Func::Tan => {
            if v.hi - v.lo >= PI || hits(v, FRAC_PI_2, PI) {
                return Err(Undefined {
                    what: format!("tan of `{}`, which reaches a pole (π/2 + kπ)", arg_text()),
                });
            }
            monotone(f64::tan, v)
        }
    })
}

impl Func {
    fn apply_fn(self) -> impl Fn(f64) -> f64 {
        move |x| self.apply(x)
    }
}

// ===================== Ranges =====================

/// Why a range could not be computed: the function is undefined or
/// unbounded somewhere on Θ (or could not be proved defined).
#[derive(Debug, Clone)]
pub(crate) struct RangeError {
    /// What goes wrong, in words (with a point of Θ where it does, if found).
    pub message: String,
}

/// One box of the bisection.
struct Cell {
    b: Vec<Iv>,
    enc: Result<Iv, Undefined>,
}

/// A range [lo, hi] of `e` containing e(θ) for every θ in the box `theta`
/// (one `(lo, hi)` per declared parameter), refined by bisection until it
/// is within [`RANGE_TOLERANCE`] of the sampled values.
pub(crate) fn range(
    e: &SchedExpr,
    theta: &[(f64, f64)],
    names: &[String],
) -> Result<(f64, f64, RangeInfo), RangeError> {
    let dims: Vec<usize> = crate::expr::bits(e.param_mask()).collect();
    let full: Vec<Iv> = theta.iter().map(|&(lo, hi)| Iv { lo, hi }).collect();
    let widths: Vec<f64> = theta.iter().map(|&(lo, hi)| hi - lo).collect();
    let mut samples = Samples {
        e,
        names,
        dims: &dims,
        lo: f64::INFINITY,
        hi: f64::NEG_INFINITY,
    };
    samples.corners(&full)?;
    let mut cells = vec![Cell {
        enc: enclose(e, &full, names),
        b: full,
    }];
    let (boxes, exhausted) = bisect(&mut cells, &mut samples, &widths)?;
    if let Some(c) = cells.iter().find(|c| c.enc.is_err()) {
        let why = match &c.enc {
            Err(u) => u.what.clone(),
            Ok(_) => String::new(),
        };
        return Err(RangeError {
            message: format!(
                "it cannot be shown to be defined and bounded on the whole parameter box: {why} \
                 (near {})",
                samples.at(&midpoint(&c.b))
            ),
        });
    }
    let (lo, hi) = bounds(&cells);
    let method = range_method(boxes, exhausted, samples.lo - lo, hi - samples.hi);
    let (lo, hi) = if lo < hi {
        (lo, hi)
    } else {
        (down(lo), up(hi))
    };
    Ok((
        lo,
        hi,
        RangeInfo {
            method,
            boxes,
            sampled_lo: samples.lo,
            sampled_hi: samples.hi,
        },
    ))
}

/// The values of `e` sampled on Θ so far: the range must reach them, and
/// the bisection stops once its bounds are within the tolerance of them.
struct Samples<'a> {
    e: &'a SchedExpr,
    names: &'a [String],
    /// The parameters `e` depends on.
    dims: &'a [usize],
    /// The smallest value sampled.
    lo: f64,
    /// The largest value sampled.
    hi: f64,
}

impl Samples<'_> {
    /// `name = value, ...` of the parameters `e` depends on, at `p`.
    fn at(&self, p: &[f64]) -> String {
        self.dims
            .iter()
            .map(|&i| format!("{} = {}", self.names[i], p[i]))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Evaluates `e` at `p` into the sampled range; an error where the value
    /// is not finite.
    fn sample(&mut self, p: &[f64]) -> Result<(), RangeError> {
        let v = self.e.eval(p);
        if !v.is_finite() {
            return Err(RangeError {
                message: format!(
                    "it is not finite at {} (its value there is {v})",
                    self.at(p)
                ),
            });
        }
        self.lo = self.lo.min(v);
        self.hi = self.hi.max(v);
        Ok(())
    }

    /// Samples the corners of the box of the parameters `e` depends on (the
    /// first 12 of them vary), then the middle of Θ.
    fn corners(&mut self, full: &[Iv]) -> Result<(), RangeError> {
        for c in 0..1usize << self.dims.len().min(12) {
            let mut p = midpoint(full);
            for (k, &i) in self.dims.iter().enumerate() {
                p[i] = if (c >> k) & 1 == 1 {
                    full[i].hi
                } else {
                    full[i].lo
                };
            }
            self.sample(&p)?;
        }
        self.sample(&midpoint(full))
    }

    /// How far a bound may lie outside the sampled range when the
    /// bisection stops.
    fn tolerance(&self) -> f64 {
        RANGE_TOLERANCE * (self.hi - self.lo)
            + 4.0 * f64::EPSILON * self.lo.abs().max(self.hi.abs())
    }
}

/// The middle of a box.
fn midpoint(b: &[Iv]) -> Vec<f64> {
    b.iter().map(|v| 0.5 * (v.lo + v.hi)).collect()
}

/// Splits the deciding cell in two (sampling each half's middle) until the
/// enclosure is within the tolerance of the samples or no cell can be split;
/// returns the number of boxes and whether it stopped short (budget spent,
/// or a cell that cannot be split).
fn bisect(
    cells: &mut Vec<Cell>,
    samples: &mut Samples<'_>,
    widths: &[f64],
) -> Result<(usize, bool), RangeError> {
    let mut boxes = 1usize;
    while let Some(k) = cell_to_split(cells, samples) {
        if boxes >= MAX_BOXES {
            return Ok((boxes, true));
        }
        let cell = cells.swap_remove(k);
        let Some((d, mid)) = split_point(&cell, samples.dims, widths) else {
            cells.push(cell);
            return Ok((boxes, true));
        };
        for half in [(cell.b[d].lo, mid), (mid, cell.b[d].hi)] {
            let mut b = cell.b.clone();
            b[d] = Iv {
                lo: half.0,
                hi: half.1,
            };
            samples.sample(&midpoint(&b))?;
            boxes += 1;
            cells.push(Cell {
                enc: enclose(samples.e, &b, samples.names),
                b,
            });
        }
    }
    Ok((boxes, false))
}

/// The cell to split: an undefined one first, else the one that decides
/// the worse of the two bounds; none when both bounds are within the
/// tolerance of the samples.
fn cell_to_split(cells: &[Cell], samples: &Samples<'_>) -> Option<usize> {
    if let Some(k) = cells.iter().position(|c| c.enc.is_err()) {
        return Some(k);
    }
    let (lo, hi) = bounds(cells);
    let t = samples.tolerance();
    if !(samples.lo - lo > t || hi - samples.hi > t) {
        return None;
    }
    let by_lo = samples.lo - lo >= hi - samples.hi;
    let key = |c: &Cell| match &c.enc {
        Ok(v) if by_lo => v.lo,
        Ok(v) => -v.hi,
        Err(_) => f64::NEG_INFINITY,
    };
    (0..cells.len()).min_by(|&a, &b| key(&cells[a]).total_cmp(&key(&cells[b])))
}

/// The dimension of `cell` to split (the widest relative to Θ) and its
/// middle; none for a constant function (its enclosure cannot be refined)
/// or a cell already as narrow as f64 resolves.
fn split_point(cell: &Cell, dims: &[usize], widths: &[f64]) -> Option<(usize, f64)> {
    let &d = dims.iter().max_by(|&&a, &&b| {
        ((cell.b[a].hi - cell.b[a].lo) / widths[a])
            .total_cmp(&((cell.b[b].hi - cell.b[b].lo) / widths[b]))
    })?;
    let mid = 0.5 * (cell.b[d].lo + cell.b[d].hi);
    if (cell.b[d].hi - cell.b[d].lo) <= 1e-12 * widths[d] || mid <= cell.b[d].lo {
        return None;
    }
    Some((d, mid))
}

/// How a range was computed, in words; `below`/`above`: how far it
/// exceeds the sampled values.
fn range_method(boxes: usize, exhausted: bool, below: f64, above: f64) -> String {
    if exhausted {
        format!(
            "interval arithmetic with outward rounding, Θ bisected into {boxes} boxes (budget \
             reached: the range exceeds the sampled values by {below:.3e} below and {above:.3e} above)"
        )
    } else if boxes == 1 {
        format!(
            "interval arithmetic with outward rounding (within {RANGE_TOLERANCE:e} of the sampled \
             range)"
        )
    } else {
        format!(
            "interval arithmetic with outward rounding, Θ bisected into {boxes} boxes (within \
             {RANGE_TOLERANCE:e} of the sampled range)"
        )
    }
}

/// The hull of the cells' enclosures (the whole line if one is undefined).
fn bounds(cells: &[Cell]) -> (f64, f64) {
    cells
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), c| {
            match &c.enc {
                Ok(v) => (l.min(v.lo), h.max(v.hi)),
                Err(_) => (f64::NEG_INFINITY, f64::INFINITY),
            }
        })
}
