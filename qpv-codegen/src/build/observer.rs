//! The certified observer's arithmetic: the scheduled gain
//! L(μ) = Σ_l μ_l L_l, the observer's right-hand side (the plant equations
//! plus the gain times the output residual, and for the filter route the
//! filter rows), and the plant's own derivative and output.

use super::coeffs::Coeffs;
use super::equations::{alone, product_lets, push_equation, Equation};
use crate::design::{CertifiedDesign, Shape};
use crate::ir::{Body, Expr, Let, Sum};

/// The body of `gains(μ)` (μ_l as `m<l>`): the entries g_ko, row-major
/// (NZ rows of NY), with the baked vertex gains as constants. Vertices
/// whose gain entry is the same number share one product: `c * (m0 + m2)`
/// for L_0 = L_2 = c (at the first such vertex's place in the sum), one
/// multiplication instead of two; the rounding bound of the f32 floor
/// walks this same body ([`crate::rounding`]).
pub fn gains_body(d: &CertifiedDesign, shape: Shape) -> Body {
    let Shape { ny, nv, nz, .. } = shape;
    let mut out = Vec::with_capacity(nz * ny);
    for k in 0..nz {
        for o in 0..ny {
            let mut s = Sum::default();
            if nv == 1 {
                s.push(d.gain_entry(ny, 0, k, o), None);
            } else {
                for (c, ls) in equal_gains((0..nv).map(|l| d.gain_entry(ny, l, k, o))) {
                    let weight = |l: usize| Expr::var(format!("m{l}"));
                    let factor = match ls.as_slice() {
                        [l] => weight(*l),
                        _ => {
                            let mut w = Sum::default();
                            for &l in &ls {
                                w.push(1.0, Some(weight(l)));
                            }
                            Expr::paren(w.expr())
                        }
                    };
                    s.push(c, Some(factor));
                }
            }
            out.push(s.expr());
        }
    }
    Body {
        lets: Vec::new(),
        out,
    }
}

/// The non-zero gains of one entry grouped by value (the same bits), in
/// the order of each value's first vertex: (value, its vertices).
fn equal_gains(gains: impl Iterator<Item = f64>) -> Vec<(f64, Vec<usize>)> {
    let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
    for (l, c) in gains.enumerate() {
        if c == 0.0 {
            continue;
        }
        match groups.iter_mut().find(|(v, _)| v.to_bits() == c.to_bits()) {
            Some((_, ls)) => ls.push(l),
            None => groups.push((c, vec![l])),
        }
    }
    groups
}

/// The residual the gain multiplies, `r<o>` per output:
/// y − C(θ)x̂ − M(θ,x̂)x̂ (double sum), x_y − x̂_y (filter).
fn residuals(shape: Shape, out_eqs: &[Equation], coeffs: &mut Coeffs) -> Vec<Let> {
    (0..shape.ny)
        .map(|o| {
            let mut s = Sum::default();
            match (shape.filter, out_eqs.get(o)) {
                (Some(_), _) => {
                    s.push(1.0, Some(Expr::var(format!("zm{o}"))));
                    s.push(-1.0, Some(Expr::var(format!("zh{o}"))));
                }
                (None, eq) => {
                    s.push(1.0, Some(Expr::var(format!("y{o}"))));
                    if let Some(eq) = eq {
                        push_equation(eq, coeffs, &mut s, -1.0);
                    }
                }
            }
            Let::real(format!("r{o}"), s.expr())
        })
        .collect()
}

/// The body of the observer's right-hand side: state products, residuals,
/// then one value per observer state (plant rows with the gain injection;
/// for the filter route the x̂_y and x_y rows). It reads the state names of
/// [`Shape::state_names`], `y<o>`, `u<j>`, the gain `g<k>_<o>` (a constant
/// for a single vertex) and the coefficients.
pub fn rhs_body(
    d: &CertifiedDesign,
    shape: Shape,
    state_eqs: &[Equation],
    out_eqs: &[Equation],
    coeffs: &mut Coeffs,
) -> Body {
    let Shape { nx, ny, nv, .. } = shape;
    let all: Vec<&Equation> = state_eqs.iter().chain(out_eqs.iter()).collect();
    let mut lets = product_lets(&all);
    lets.extend(residuals(shape, out_eqs, coeffs));
    // Σ_o g_ko r_o added to row k of the design state.
    let inject = |s: &mut Sum, k: usize| {
        for o in 0..ny {
            if (0..nv).all(|l| d.gain_entry(ny, l, k, o) == 0.0) {
                continue;
            }
            let r = Expr::var(format!("r{o}"));
            if nv == 1 {
                s.push(d.gain_entry(ny, 0, k, o), Some(r));
            } else {
                s.push(
                    1.0,
                    Some(Expr::Product(vec![Expr::var(format!("g{k}_{o}")), r])),
                );
            }
        }
    };
    let mut out: Vec<Expr> = state_eqs
        .iter()
        .enumerate()
        .map(|(k, eq)| {
            let mut s = Sum::default();
            push_equation(eq, coeffs, &mut s, 1.0);
            inject(&mut s, k);
            s.expr()
        })
        .collect();
    if let Some(f) = shape.filter {
        // x̂_y' = −a x̂_y + b (C(θ)x̂ + M(θ,x̂)x̂) + L_y(θ)(x_y − x̂_y)
        for (k, eq) in out_eqs.iter().enumerate() {
            let mut s = Sum::default();
            s.push(-f.pole, Some(Expr::var(format!("zh{k}"))));
            push_equation(eq, coeffs, &mut s, f.gain);
            inject(&mut s, nx + k);
            out.push(s.expr());
        }
        // x_y' = −a x_y + b y: the observer filters the measurement itself.
        for k in 0..ny {
            let mut s = Sum::default();
            s.push(-f.pole, Some(Expr::var(format!("zm{k}"))));
            s.push(f.gain, Some(Expr::var(format!("y{k}"))));
            out.push(s.expr());
        }
    }
    Body { lets, out }
}

/// The plant's derivative x' = A(θ)x + N(θ,x)x + B(θ)u and output
/// y = C(θ)x + M(θ,x)x, over `x<i>`, `u<j>` and the coefficients.
pub fn plant_bodies(
    state_eqs: &[Equation],
    out_eqs: &[Equation],
    coeffs: &mut Coeffs,
) -> (Body, Body) {
    let f = state_eqs.iter().map(|eq| alone(eq, coeffs)).collect();
    let h = out_eqs.iter().map(|eq| alone(eq, coeffs)).collect();
    (
        Body {
            lets: product_lets(&state_eqs.iter().collect::<Vec<_>>()),
            out: f,
        },
        Body {
            lets: product_lets(&out_eqs.iter().collect::<Vec<_>>()),
            out: h,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rounding::{eval, Env, Val};

    fn design(l: Vec<Vec<f64>>) -> CertifiedDesign {
        CertifiedDesign {
            request: String::new(),
            mode: "sound".into(),
            certifies: true,
            alpha: 1.0,
            gamma: 1.0,
            p: vec![1.0],
            l,
            margins: Vec::new(),
            status: String::new(),
            iterations: 0,
            filter: None,
            float: qpv_dsl::Float::F32,
            figures: Default::default(),
            noise_missing: None,
            alpha_sup: None,
            sample: None,
            time_unit: Default::default(),
        }
    }

    /// Vertices with the same gain entry share one product, at the first
    /// one's place; zero gains are dropped; the f32 rounding bound walks
    /// the folded sum and holds on sampled weights.
    #[test]
    fn equal_vertex_gains_share_one_product() {
        let c = f64::from(12.777_471_f32);
        let d = design(vec![vec![c], vec![0.25], vec![c], vec![0.0], vec![c]]);
        let shape = Shape {
            nx: 1,
            ny: 1,
            nu: 0,
            nv: 5,
            nz: 1,
            ns: 1,
            filter: None,
        };
        let b = gains_body(&d, shape);
        let printed = crate::c::literal(c, crate::c::Float::F32);
        let Expr::Sum(terms) = &b.out[0] else {
            panic!("a sum: {:?}", b.out[0])
        };
        assert_eq!(terms.len(), 2, "{terms:?}");
        assert_eq!(terms[0].0, c);
        let Some(Expr::Paren(inner)) = &terms[0].1 else {
            panic!("c * (m0 + m2 + m4): {terms:?}")
        };
        assert!(inner.uses("m0") && inner.uses("m2") && inner.uses("m4") && !inner.uses("m1"));
        assert_eq!(terms[1], (0.25, Some(Expr::var("m1"))));
        assert!(printed.starts_with("12.77747"), "{printed}");
        // the bound of the folded sum holds for f32 weights summing to 1
        let mut env = Env::new();
        for l in 0..5 {
            env.insert(format!("m{l}"), Val::rounded_input(0.0, 1.0));
        }
        let v = eval(&b.out[0], &env, &[]).expect("bounded");
        for k in 0..500u32 {
            let w: Vec<f64> = (0..5)
                .map(|l| f64::from((k * 7 + l * 13) % 17 + 1))
                .collect();
            let total: f64 = w.iter().sum();
            let m: Vec<f32> = w.iter().map(|x| (x / total) as f32).collect();
            let exact = c * f64::from(m[0])
                + 0.25 * f64::from(m[1])
                + c * f64::from(m[2])
                + c * f64::from(m[4]);
            let comp = 12.777_471_f32 * (m[0] + m[2] + m[4]) + 0.25f32 * m[1];
            assert!(
                (f64::from(comp) - exact).abs() <= v.err,
                "{} > {}",
                (f64::from(comp) - exact).abs(),
                v.err
            );
        }
    }
}
