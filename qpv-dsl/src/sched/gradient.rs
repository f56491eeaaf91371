//! Interval enclosures of a scheduling function's gradient: forward-mode
//! differentiation of the expression tree in interval arithmetic with
//! outward rounding (docs/method.md §16, "The real plant is continuous":
//! a derived scheduling variable φ(θ) moves at |φ̇| ≤ Σ_i |∂φ/∂θ_i| |θ̇_i|).
//!
//! Every node yields an enclosure of its value and of each partial
//! derivative on a box of Θ; the rules are the sum, product and quotient
//! rules, n·vⁿ⁻¹ for powers and the chain rule with an enclosure of f′ for
//! the library functions (f′ itself enclosed by the same outward-rounded
//! interval functions as the values). A derivative that is not bounded on
//! the box (√ at 0) is an error, never a clipped enclosure.

use super::{call, ipow, Func, Iv, SchedExpr, Undefined};

/// An enclosure of a scheduling function and of its gradient on a box of
/// Θ: every value and every partial derivative at a point of the box lies
/// in the corresponding interval.
#[derive(Debug, Clone, PartialEq)]
pub struct GradientEnclosure {
    /// (lo, hi) of the function's values on the box.
    pub value: (f64, f64),
    /// (lo, hi) of ∂/∂θ_i on the box, one per declared parameter.
    pub grad: Vec<(f64, f64)>,
}

/// Encloses `e` and its gradient on the box `theta` (one `(lo, hi)` per
/// declared parameter); `names` name the parameters in error messages.
/// An error says where the function or its derivative is undefined or not
/// bounded on the box.
pub fn enclose_gradient(
    e: &SchedExpr,
    theta: &[(f64, f64)],
    names: &[String],
) -> Result<GradientEnclosure, String> {
    let b: Vec<Iv> = theta.iter().map(|&(lo, hi)| Iv { lo, hi }).collect();
    let (v, g) = dual(e, &b, names).map_err(|u| u.what)?;
    Ok(GradientEnclosure {
        value: (v.lo, v.hi),
        grad: g.iter().map(|d| (d.lo, d.hi)).collect(),
    })
}

/// Most sub-boxes [`gradient_bound`] evaluates.
const GRID_CELLS: usize = 4096;

/// Most pieces per parameter in [`gradient_bound`]'s grid.
const GRID_PER_DIM: usize = 64;

/// sup |∂e/∂θ_i| over the box `theta`, one per declared parameter (0 for
/// the parameters `e` does not depend on): the largest magnitude of
/// [`gradient_hull`].
pub fn gradient_bound(
    e: &SchedExpr,
    theta: &[(f64, f64)],
    names: &[String],
) -> Result<Vec<f64>, String> {
    Ok(gradient_hull(e, theta, names)?
        .into_iter()
        .map(|(lo, hi)| 0.0f64.max(lo.abs()).max(hi.abs()))
        .collect())
}

/// An interval (lo, hi) containing ∂e/∂θ_i at every point of the box
/// `theta`, one per variable ((0, 0) for the variables `e` does not depend
/// on): the hull of [`enclose_gradient`] over a uniform grid of sub-boxes
/// (at most 64 pieces per variable and 4096 boxes), which removes most of
/// the dependency overestimate of one enclosure on the whole box.
pub fn gradient_hull(
    e: &SchedExpr,
    theta: &[(f64, f64)],
    names: &[String],
) -> Result<Vec<(f64, f64)>, String> {
    let dims: Vec<usize> = crate::expr::bits(e.param_mask()).collect();
    let per = if dims.is_empty() {
        1
    } else {
        let m = (GRID_CELLS as f64).powf(1.0 / dims.len() as f64).floor() as usize;
        m.clamp(1, GRID_PER_DIM)
    };
    let cells = per.saturating_pow(dims.len() as u32);
    let mut hull: Vec<Option<(f64, f64)>> = vec![None; theta.len()];
    let mut b = theta.to_vec();
    for cell in 0..cells {
        let mut rest = cell;
        for &d in &dims {
            let k = rest % per;
            rest /= per;
            let (lo, hi) = theta[d];
            let w = (hi - lo) / per as f64;
            let a = lo + w * k as f64;
            // the last piece ends exactly at hi
            let z = if k + 1 == per {
                hi
            } else {
                lo + w * (k + 1) as f64
            };
            b[d] = (a, z);
        }
        let g = enclose_gradient(e, &b, names)?;
        for (h, &(lo, hi)) in hull.iter_mut().zip(&g.grad) {
            *h = Some(match *h {
                None => (lo, hi),
                Some((l, u)) => (l.min(lo), u.max(hi)),
            });
        }
    }
    Ok(hull.into_iter().map(|h| h.unwrap_or((0.0, 0.0))).collect())
}

/// Value and gradient enclosures of `e` on the box `b`.
fn dual(e: &SchedExpr, b: &[Iv], names: &[String]) -> Result<(Iv, Vec<Iv>), Undefined> {
    let zero = || vec![Iv::point(0.0); b.len()];
    let (v, g) = match e {
        SchedExpr::Num(c) => (Iv::point(*c), zero()),
        SchedExpr::Param(i) => {
            let mut g = zero();
            g[*i] = Iv::point(1.0);
            (b[*i], g)
        }
        SchedExpr::Named(_, e) => dual(e, b, names)?,
        SchedExpr::Neg(e) => {
            let (v, g) = dual(e, b, names)?;
            (v.neg(), g.into_iter().map(Iv::neg).collect())
        }
        SchedExpr::Sum(t) => {
            let (mut v, mut g) = (Iv::point(0.0), zero());
            for (neg, e) in t {
                let (w, gw) = dual(e, b, names)?;
                let s = |x: Iv| if *neg { x.neg() } else { x };
                v = v.add(s(w));
                for (gi, wi) in g.iter_mut().zip(gw) {
                    *gi = gi.add(s(wi));
                }
            }
            (v, g)
        }
        SchedExpr::Product(f) => product(f, b, names)?,
        SchedExpr::Pow(e, n) => {
            let (w, gw) = dual(e, b, names)?;
            if *n == 0 {
                (Iv::point(1.0), zero())
            } else {
                let d = ipow(w, n - 1).mul(Iv::point(f64::from(*n)));
                (ipow(w, *n), gw.into_iter().map(|x| d.mul(x)).collect())
            }
        }
        SchedExpr::Call(f, arg) => {
            let (w, gw) = dual(arg, b, names)?;
            let v = call(*f, w, arg, names)?;
            let d = derivative(*f, w, v, arg, names)?;
            (v, gw.into_iter().map(|x| d.mul(x)).collect())
        }
    };
    let finite = |x: &Iv| x.lo.is_finite() && x.hi.is_finite();
    if !(finite(&v) && g.iter().all(finite)) {
        return Err(Undefined {
            what: format!(
                "`{}` or its derivative is unbounded (it overflows a 64-bit float)",
                e.text(names)
            ),
        });
    }
    Ok((v, g))
}

/// The product rule, and the quotient rule for the divided factors:
/// (p/w)′ = (p′ − (p/w)w′)/w.
fn product(
    f: &[(bool, SchedExpr)],
    b: &[Iv],
    names: &[String],
) -> Result<(Iv, Vec<Iv>), Undefined> {
    let mut v = Iv::point(1.0);
    let mut g = vec![Iv::point(0.0); b.len()];
    for (div, e) in f {
        let (w, gw) = dual(e, b, names)?;
        if *div {
            if w.contains_zero() {
                return Err(Undefined {
                    what: format!("division by `{}`, which can be 0", e.text(names)),
                });
            }
            let q = v.div(w);
            for (gi, wi) in g.iter_mut().zip(gw) {
                *gi = gi.add(q.mul(wi).neg()).div(w);
            }
            v = q;
        } else {
            for (gi, wi) in g.iter_mut().zip(gw) {
                *gi = gi.mul(w).add(v.mul(wi));
            }
            v = v.mul(w);
        }
    }
    Ok((v, g))
}

/// An enclosure of f′ on the argument's enclosure `w` (`v` encloses f(w)).
fn derivative(f: Func, w: Iv, v: Iv, arg: &SchedExpr, names: &[String]) -> Result<Iv, Undefined> {
    let one = Iv::point(1.0);
    Ok(match f {
        Func::Sqrt => {
            if v.lo <= 0.0 {
                return Err(Undefined {
                    what: format!(
                        "the derivative of sqrt at `{}` = 0 is unbounded",
                        arg.text(names)
                    ),
                });
            }
            Iv::point(0.5).div(v)
        }
        Func::Ln => one.div(w),
        Func::Exp => v,
        Func::Tanh => {
            let d = one.add(ipow(v, 2).neg());
            Iv {
                lo: d.lo.max(0.0),
                hi: d.hi.min(1.0),
            }
        }
        Func::Atan => one.div(one.add(ipow(w, 2))),
        Func::Abs => {
            if w.lo > 0.0 {
                one
            } else if w.hi < 0.0 {
                one.neg()
            } else {
                // |·| is 1-Lipschitz: its a.e. derivative lies in [−1, 1]
                Iv { lo: -1.0, hi: 1.0 }
            }
        }
        Func::Sin => call(Func::Cos, w, arg, names)?,
        Func::Cos => call(Func::Sin, w, arg, names)?.neg(),
        Func::Tan => one.add(ipow(v, 2)),
    })
}
