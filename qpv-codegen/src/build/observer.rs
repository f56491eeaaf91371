//! The certified observer's arithmetic: the scheduled gain
//! L(μ) = Σ_l μ_l L_l, the observer's right-hand side (the plant equations
//! plus the gain times the output residual, and for the filter route the
//! filter rows), and the plant's own derivative and output.

use super::coeffs::Coeffs;
use super::equations::{alone, product_lets, push_equation, Equation};
use crate::design::{CertifiedDesign, Shape};
use crate::ir::{Body, Expr, Let, Sum};

/// The body of `gains(μ)` (μ_l as `m<l>`): the entries g_ko, row-major
/// (NZ rows of NY), with the baked vertex gains as constants.
pub fn gains_body(d: &CertifiedDesign, shape: Shape) -> Body {
    let Shape { ny, nv, nz, .. } = shape;
    let mut out = Vec::with_capacity(nz * ny);
    for k in 0..nz {
        for o in 0..ny {
            let mut s = Sum::default();
            if nv == 1 {
                s.push(d.gain_entry(ny, 0, k, o), None);
            } else {
                for l in 0..nv {
                    s.push(d.gain_entry(ny, l, k, o), Some(Expr::var(format!("m{l}"))));
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
