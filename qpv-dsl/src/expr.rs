//! θ-polynomials: multi-affine polynomials in the scheduling parameters, the
//! entries of the matrices A(θ), N_k(θ), B(θ), C(θ), M_k(θ).

use serde::Serialize;

/// A multi-affine polynomial Σ_S c_S Π_{i∈S} θ_i in the declared parameters.
///
/// Each term is `(mask, c)` where bit `i` of `mask` set means θ_i (the i-th
/// declared parameter) is a factor. Terms are sorted by mask, masks are unique
/// and no coefficient is exactly zero, so equal polynomials compare equal.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct ThetaPoly {
    /// The terms `(mask, coefficient)`, sorted by mask.
    pub terms: Vec<(u64, f64)>,
}

impl ThetaPoly {
    /// The zero polynomial.
    pub fn zero() -> Self {
        ThetaPoly { terms: Vec::new() }
    }

    /// The constant polynomial `c`.
    pub fn constant(c: f64) -> Self {
        let mut p = ThetaPoly::zero();
        p.add_term(0, c);
        p
    }

    /// Adds `c * Π_{i∈mask} θ_i`, keeping the invariants (sorted, unique, nonzero).
    pub fn add_term(&mut self, mask: u64, c: f64) {
        match self.terms.binary_search_by_key(&mask, |t| t.0) {
            Ok(i) => {
                self.terms[i].1 += c;
                if self.terms[i].1 == 0.0 {
                    self.terms.remove(i);
                }
            }
            Err(i) => {
                if c != 0.0 {
                    self.terms.insert(i, (mask, c));
                }
            }
        }
    }

    /// True if the polynomial is identically zero.
    pub fn is_zero(&self) -> bool {
        self.terms.is_empty()
    }

    /// The constant value if the polynomial does not depend on θ.
    pub fn as_constant(&self) -> Option<f64> {
        match self.terms.as_slice() {
            [] => Some(0.0),
            [(0, c)] => Some(*c),
            _ => None,
        }
    }

    /// Union of the masks of all terms: the parameters this entry depends on.
    pub fn param_mask(&self) -> u64 {
        self.terms.iter().fold(0, |m, t| m | t.0)
    }

    /// Evaluates the polynomial at `theta` (indexed by declared parameter).
    pub fn eval(&self, theta: &[f64]) -> f64 {
        self.terms
            .iter()
            .map(|&(mask, c)| {
                let mut v = c;
                let mut m = mask;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    v *= theta.get(i).copied().unwrap_or(0.0);
                    m &= m - 1;
                }
                v
            })
            .fold(0.0, |acc, v| acc + v)
    }
}

/// A matrix of θ-polynomials, stored row-major.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct PolyMatrix {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// Entries, row-major: entry (i, j) is `entries[i * cols + j]`.
    pub entries: Vec<ThetaPoly>,
}

impl PolyMatrix {
    /// A `rows × cols` matrix of zeros.
    pub fn zeros(rows: usize, cols: usize) -> Self {
        PolyMatrix {
            rows,
            cols,
            entries: vec![ThetaPoly::zero(); rows * cols],
        }
    }

    /// Entry (i, j).
    pub fn get(&self, i: usize, j: usize) -> &ThetaPoly {
        &self.entries[i * self.cols + j]
    }

    /// Mutable entry (i, j).
    pub fn get_mut(&mut self, i: usize, j: usize) -> &mut ThetaPoly {
        &mut self.entries[i * self.cols + j]
    }

    /// Whether every entry is the zero polynomial.
    pub fn is_zero(&self) -> bool {
        self.entries.iter().all(ThetaPoly::is_zero)
    }

    /// Union of the parameter masks of all entries.
    pub fn param_mask(&self) -> u64 {
        self.entries.iter().fold(0, |m, p| m | p.param_mask())
    }

    /// The numeric matrix at `theta`.
    pub fn eval(&self, theta: &[f64]) -> nalgebra::DMatrix<f64> {
        nalgebra::DMatrix::from_fn(self.rows, self.cols, |i, j| self.get(i, j).eval(theta))
    }
}

/// The indices of the set bits of `mask`, lowest first.
pub(crate) fn bits(mask: u64) -> impl Iterator<Item = usize> {
    let mut m = mask;
    std::iter::from_fn(move || {
        if m == 0 {
            None
        } else {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            Some(i)
        }
    })
}
