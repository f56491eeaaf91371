//! The scheduling side: the derived scheduling variables φ(θ) (the model's
//! expressions, evaluated in the model compiler's order), the piece of a
//! cover that contains θ, and the vertex weights μ(θ), products of
//! normalised positions built as a prefix tree.

use crate::ir::{Body, Expr, Let, Op, Ty};
use qpv_dsl::{Cover, Model, SchedExpr};

/// The body of `phi(θ)`: one value per derived variable, over `t<i>`.
pub fn phi_body(m: &Model) -> Body {
    Body {
        lets: Vec::new(),
        out: m.derived.iter().map(|d| sched_expr(&d.expr)).collect(),
    }
}

/// A scheduling function as an expression over `t0`, `t1`, ... (the
/// parameters), in the evaluation order of [`SchedExpr::eval`].
pub fn sched_expr(e: &SchedExpr) -> Expr {
    match e {
        SchedExpr::Num(c) => Expr::paren(Expr::Num(*c)),
        SchedExpr::Param(i) => Expr::var(format!("t{i}")),
        SchedExpr::Named(_, e) => sched_expr(e),
        SchedExpr::Neg(e) => Expr::paren(Expr::Neg(Box::new(sched_expr(e)))),
        SchedExpr::Sum(terms) => terms.iter().fold(Expr::Num(0.0), |acc, (neg, t)| {
            let op = if *neg { Op::Sub } else { Op::Add };
            Expr::paren(Expr::bin(op, acc, sched_expr(t)))
        }),
        SchedExpr::Product(factors) => factors.iter().fold(Expr::Num(1.0), |acc, (div, f)| {
            let op = if *div { Op::Div } else { Op::Mul };
            Expr::paren(Expr::bin(op, acc, sched_expr(f)))
        }),
        SchedExpr::Pow(e, n) => Expr::PowI(Box::new(sched_expr(e)), *n),
        SchedExpr::Call(f, e) => Expr::Call(*f, Box::new(sched_expr(e))),
    }
}

/// The body of `mu` for a clamped θ (`t<i>`) and φ(θ) (`f<j>`, clamped
/// into its range here: it contains φ up to rounding; NaN → lo): w_i the
/// normalised position, v_i = 1 − w_i, the vertex products as a prefix
/// tree (first variable most significant). With a cover, the piece is
/// located first and the weights are those of its box (see [`covered_mu`]).
pub fn mu_body(m: &Model, scheduling: &[usize]) -> Body {
    if let Some(c) = &m.cover {
        return covered_mu(m, c, scheduling);
    }
    let mut lets = Vec::new();
    let params = scheduling.iter().map(|&pi| {
        let (lo, hi) = m.params.get(pi).map_or((0.0, 1.0), |p| (p.lo, p.hi));
        (format!("t{pi}"), lo, hi, false)
    });
    let derived = m
        .derived
        .iter()
        .enumerate()
        .map(|(j, d)| (format!("f{j}"), d.lo, d.hi, true));
    for (i, (t, lo, hi, clamp)) in params.chain(derived).enumerate() {
        let t = if clamp {
            clamp_let(&t, Expr::Num(lo), Expr::Num(hi), &mut lets)
        } else {
            t
        };
        let num = if lo == 0.0 {
            Expr::var(t)
        } else {
            Expr::paren(Expr::bin(Op::Sub, Expr::var(t), Expr::paren(Expr::Num(lo))))
        };
        let w = if hi - lo == 1.0 {
            num
        } else {
            Expr::Product(vec![num, Expr::Num(1.0 / (hi - lo))])
        };
        weight_lets(i, w, &mut lets);
    }
    let ns = scheduling.len() + m.derived.len();
    let out = products(ns, &mut lets);
    Body { lets, out }
}

/// `let <t>c = clamp(t, lo, hi);`: a derived variable clamped into its
/// range before its weight is taken; returns the clamped variable's name.
fn clamp_let(t: &str, lo: Expr, hi: Expr, lets: &mut Vec<Let>) -> String {
    let name = format!("{t}c");
    lets.push(Let::real(
        &name,
        Expr::Clamp(Box::new(Expr::var(t)), Box::new(lo), Box::new(hi)),
    ));
    name
}

/// `let w<i> = w; let v<i> = 1.0 - w<i>;`
fn weight_lets(i: usize, w: Expr, lets: &mut Vec<Let>) {
    lets.push(Let::real(format!("w{i}"), w));
    lets.push(Let::real(
        format!("v{i}"),
        Expr::bin(Op::Sub, Expr::Num(1.0), Expr::var(format!("w{i}"))),
    ));
}

/// The products of the prefix tree over `ns` weights `w<i>`/`v<i>` (first
/// most significant), as lets `p<bits>` for the inner nodes and one
/// expression per leaf, in vertex order.
fn products(ns: usize, lets: &mut Vec<Let>) -> Vec<Expr> {
    let mut level: Vec<(String, Expr)> = vec![(String::new(), Expr::Num(1.0))];
    for i in 0..ns {
        let mut next = Vec::with_capacity(level.len() * 2);
        for (bits, expr) in &level {
            for (bit, f) in [("0", format!("v{i}")), ("1", format!("w{i}"))] {
                let nb = format!("{bits}{bit}");
                let e = if i == 0 {
                    Expr::var(f)
                } else {
                    Expr::Product(vec![expr.clone(), Expr::var(f)])
                };
                if i > 0 && i + 1 < ns {
                    let id = format!("p{nb}");
                    lets.push(Let::real(&id, e));
                    next.push((nb, Expr::var(id)));
                } else {
                    next.push((nb, e));
                }
            }
        }
        level = next;
    }
    level.into_iter().map(|(_, e)| e).collect()
}

/// μ(θ) of a model with a cover: the piece index `k` ([`locate`]), the
/// ranges of that piece's box selected by `k`, the multilinear weights in
/// it (φ clamped into the piece's range), and these in the piece's slots,
/// zero in every other slot.
fn covered_mu(m: &Model, c: &Cover, scheduling: &[usize]) -> Body {
    let nd = m.derived.len();
    let ns = scheduling.len() + nd;
    let per = 1usize << ns;
    let mut lets = locate(c);
    let ranges = |k: usize| -> Vec<(f64, f64)> {
        let piece = &c.pieces[k];
        scheduling
            .iter()
            .map(|&pi| piece.theta.get(pi).copied().unwrap_or((0.0, 1.0)))
            .chain(piece.phi.iter().copied())
            .collect()
    };
    let all: Vec<Vec<(f64, f64)>> = (0..c.pieces.len()).map(ranges).collect();
    let select = |f: &dyn Fn(&(f64, f64)) -> f64, i: usize| -> Expr {
        Expr::Select(
            "k".into(),
            all.iter().map(|r| Expr::Num(f(&r[i]))).collect(),
        )
    };
    let vars = scheduling
        .iter()
        .map(|&pi| (format!("t{pi}"), false))
        .chain((0..nd).map(|j| (format!("f{j}"), true)));
    for (i, (t, clamp)) in vars.enumerate() {
        let (lo, hi, inv) = (format!("lo{i}"), format!("hi{i}"), format!("inv{i}"));
        lets.push(Let::real(&lo, select(&|r| r.0, i)));
        if clamp {
            lets.push(Let::real(&hi, select(&|r| r.1, i)));
        }
        lets.push(Let::real(&inv, select(&|r| 1.0 / (r.1 - r.0), i)));
        let t = if clamp {
            clamp_let(&t, Expr::var(&lo), Expr::var(&hi), &mut lets)
        } else {
            t
        };
        let w = Expr::Product(vec![
            Expr::paren(Expr::bin(Op::Sub, Expr::var(t), Expr::var(lo))),
            Expr::var(inv),
        ]);
        weight_lets(i, w, &mut lets);
    }
    let local = products(ns, &mut lets);
    for (j, e) in local.into_iter().enumerate() {
        lets.push(Let::real(format!("q{j}"), e));
    }
    let pieces = c.pieces.len();
    let out = (0..pieces * per)
        .map(|slot| {
            let (k, j) = (slot / per, slot % per);
            Expr::Select(
                "k".into(),
                (0..pieces)
                    .map(|p| {
                        if p == k {
                            Expr::var(format!("q{j}"))
                        } else {
                            Expr::Num(0.0)
                        }
                    })
                    .collect(),
            )
        })
        .collect();
    Body { lets, out }
}

/// Index lets `c<a>` and `k`: the piece of the cover that contains the
/// clamped θ (`t<i>`): along each cut parameter the number of inner
/// breakpoints ≤ θ_i (a breakpoint belongs to the piece above it), then
/// the mixed-radix index, first parameter most significant (the rule of
/// `Cover::locate`).
pub fn locate(c: &Cover) -> Vec<Let> {
    let mut lets = Vec::new();
    let mut k: Option<Expr> = None;
    for (a, axis) in c.axes.iter().enumerate() {
        let t = format!("t{}", axis.param);
        let n = axis.breaks.len().saturating_sub(1).max(1);
        let ci = format!("c{a}");
        let count = axis
            .breaks
            .iter()
            .skip(1)
            .take(n - 1)
            .fold(Expr::Int(0), |acc, &b| {
                Expr::bin(
                    Op::Add,
                    acc,
                    Expr::Ge(Box::new(Expr::var(&t)), Box::new(Expr::Num(b))),
                )
            });
        lets.push(Let {
            name: ci.clone(),
            ty: Ty::Index,
            value: count,
        });
        k = Some(match k {
            None => Expr::var(ci),
            // (k) · n_a + c_a: the index so far, scaled by this axis's count
            Some(prev) => Expr::bin(
                Op::Add,
                Expr::bin(Op::Mul, Expr::paren(prev), Expr::Int(n)),
                Expr::var(ci),
            ),
        });
    }
    lets.push(Let {
        name: "k".into(),
        ty: Ty::Index,
        value: k.unwrap_or(Expr::Int(0)),
    });
    lets
}

#[cfg(test)]
mod tests {
    use super::*;
    use qpv_dsl::CoverAxis;
    use std::collections::BTreeMap;

    /// Evaluates the index lets of [`locate`] at θ.
    fn eval(e: &Expr, theta: &[f64], env: &BTreeMap<String, f64>) -> f64 {
        match e {
            Expr::Num(v) => *v,
            Expr::Int(n) => *n as f64,
            Expr::Var(v) => match v.strip_prefix('t').and_then(|i| i.parse::<usize>().ok()) {
                Some(i) => theta[i],
                None => env[v],
            },
            Expr::Paren(a) => eval(a, theta, env),
            Expr::Ge(a, b) => f64::from(u8::from(eval(a, theta, env) >= eval(b, theta, env))),
            Expr::Bin(op, a, b) => {
                let (a, b) = (eval(a, theta, env), eval(b, theta, env));
                match op {
                    Op::Add => a + b,
                    Op::Sub => a - b,
                    Op::Mul => a * b,
                    Op::Div => a / b,
                }
            }
            other => panic!("not an index expression: {other:?}"),
        }
    }

    #[test]
    fn the_piece_index_is_mixed_radix_for_three_cut_parameters() {
        // 3 × 4 × 2 pieces: the old `c0 * n + c1 * n + c2` was wrong here
        let axis = |param: usize, n: usize| CoverAxis {
            param,
            name: format!("p{param}"),
            breaks: (0..=n).map(|k| k as f64 / n as f64).collect(),
        };
        let cover = Cover {
            axes: vec![axis(0, 3), axis(1, 4), axis(2, 2)],
            pieces: Vec::new(),
        };
        let lets = locate(&cover);
        let mut seen = std::collections::BTreeSet::new();
        for i in 0..3 {
            for j in 0..4 {
                for l in 0..2 {
                    let theta = [
                        (i as f64 + 0.5) / 3.0,
                        (j as f64 + 0.5) / 4.0,
                        (l as f64 + 0.5) / 2.0,
                    ];
                    let mut env = BTreeMap::new();
                    for let_ in &lets {
                        let v = eval(&let_.value, &theta, &env);
                        env.insert(let_.name.clone(), v);
                    }
                    let k = env["k"] as usize;
                    assert_eq!(k, cover.locate(&theta), "θ = {theta:?}");
                    assert_eq!(k, (i * 4 + j) * 2 + l);
                    seen.insert(k);
                }
            }
        }
        assert_eq!(seen.len(), 24, "every piece reached once");
    }
}
