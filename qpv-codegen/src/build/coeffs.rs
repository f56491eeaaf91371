//! θ-dependent coefficients: every distinct non-constant θ-polynomial of
//! the equations becomes one coefficient `k<i>` of the generated `Coeffs`
//! struct, computed (with each product of parameters it uses) once per
//! evaluation.

use crate::ir::{Body, Expr, Let, Sum};
use qpv_dsl::ThetaPoly;

/// Interned θ-dependent coefficients: each distinct non-constant polynomial
/// becomes the coefficient `k<i>` ([`Expr::Coef`]).
#[derive(Debug, Clone, Default)]
pub struct Coeffs {
    /// The polynomials, in the order they were interned.
    pub polys: Vec<ThetaPoly>,
}

impl Coeffs {
    /// The constant, or the number of the interned polynomial.
    fn intern(&mut self, p: &ThetaPoly) -> Result<f64, usize> {
        if let Some(c) = p.as_constant() {
            return Ok(c);
        }
        Err(match self.polys.iter().position(|q| q == p) {
            Some(i) => i,
            None => {
                self.polys.push(p.clone());
                self.polys.len() - 1
            }
        })
    }

    /// Adds `sign × p(θ) × factor` to a sum: a number for a constant `p`,
    /// else the coefficient `c.k<i>` of the interned polynomial.
    pub fn push_term(&mut self, sum: &mut Sum, p: &ThetaPoly, factor: Expr, sign: f64) {
        match self.intern(p) {
            Ok(c) => sum.push(sign * c, Some(factor)),
            Err(k) => sum.push(sign, Some(Expr::Product(vec![Expr::Coef(k), factor]))),
        }
    }

    /// The masks (≥ 2 parameters) of θ monomials the coefficients use.
    fn products(&self) -> Vec<u64> {
        let mut v: Vec<u64> = self
            .polys
            .iter()
            .flat_map(|p| p.terms.iter().map(|t| t.0))
            .filter(|m| m.count_ones() >= 2)
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// The body of `coeffs(θ)`: the θ products, then one value per
    /// coefficient `k<i>` (over `t<i>`, and `t<nθ + j>` for φ_j).
    pub fn body(&self) -> Body {
        Body {
            lets: self.products().into_iter().map(product_let).collect(),
            out: self.polys.iter().map(poly_expr).collect(),
        }
    }
}

/// The name of a θ monomial (`t0`, `t0_1`, ...) for a term mask.
fn theta_mono(mask: u64) -> String {
    let idx: Vec<String> = (0..64usize)
        .filter(|i| mask >> i & 1 == 1)
        .map(|i| i.to_string())
        .collect();
    format!("t{}", idx.join("_"))
}

/// A θ-polynomial as a sum of its monomials.
fn poly_expr(p: &ThetaPoly) -> Expr {
    let mut s = Sum::default();
    for &(mask, c) in &p.terms {
        if mask == 0 {
            s.push(c, None);
        } else {
            s.push(c, Some(Expr::var(theta_mono(mask))));
        }
    }
    s.expr()
}

/// `let t0_1 = t0 * t1;` for a product of parameters.
fn product_let(mask: u64) -> Let {
    let factors = (0..64usize)
        .filter(|i| mask >> i & 1 == 1)
        .map(|i| Expr::var(format!("t{i}")))
        .collect();
    Let::real(theta_mono(mask), Expr::Product(factors))
}
