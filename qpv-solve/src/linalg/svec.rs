//! Packing of symmetric matrices for Clarabel's `PSDTriangleConeT(n)`.
//!
//! Clarabel stores a symmetric `n × n` matrix `S` as the vector `svec(S)` of
//! length `n(n+1)/2`: the **upper triangle, column by column**
//! (`(0,0), (0,1), (1,1), (0,2), (1,2), (2,2), …`), with every
//! **off-diagonal entry multiplied by √2** ([`SQRT2`]) and diagonal entries
//! unscaled. The scaling makes the packing an isometry:
//! `⟨svec(A), svec(B)⟩ = trace(A B)` for symmetric `A`, `B`, so
//!
//! * an objective `trace(C X)` over `x = svec(X)` is `q = svec(C)`;
//! * an LMI `F₀ + Σₖ xₖ Fₖ ⪰ 0` in Clarabel's form `A x + s = b`, `s ∈ K`
//!   is `b = svec(F₀)`, column k of `A` = `-svec(Fₖ)` (so `s = svec(F(x))`);
//! * the dual `z` of such a row block is `svec(Z)` with the same convention,
//!   i.e. `Z = smat(z)` is the PSD multiplier with `trace(Z F(x)) = ⟨z, s⟩`.
//!
//! (This matches Clarabel 0.11's internal `mat_to_svec` / `svec_to_mat`.)

use nalgebra::DMatrix;

/// √2, the factor applied to off-diagonal entries by [`svec`].
pub const SQRT2: f64 = std::f64::consts::SQRT_2;

/// Length `n(n+1)/2` of `svec` of an `n × n` matrix.
pub const fn svec_len(n: usize) -> usize {
    n * (n + 1) / 2
}

/// The `n` with `svec_len(n) == len`, if any.
pub fn svec_side(len: usize) -> Option<usize> {
    // n = (sqrt(8 len + 1) - 1) / 2, checked exactly.
    let n = ((((8 * len + 1) as f64).sqrt() - 1.0) / 2.0).round() as usize;
    (svec_len(n) == len).then_some(n)
}

/// Position of entry `(i, j)` (either order: the matrix is symmetric) in
/// `svec`: `j(j+1)/2 + i` for `i ≤ j`.
#[inline]
pub const fn svec_index(i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    j * (j + 1) / 2 + i
}

/// The factor applied to entry `(i, j)`: 1 on the diagonal, √2 off it.
#[inline]
pub fn svec_scale(i: usize, j: usize) -> f64 {
    if i == j {
        1.0
    } else {
        SQRT2
    }
}

/// Inverse of [`svec_index`]: the `(i, j)` with `i ≤ j` stored at `k`.
pub fn svec_entry(k: usize) -> (usize, usize) {
    // Largest j with j(j+1)/2 ≤ k.
    let mut j = ((((8 * k + 1) as f64).sqrt() - 1.0) / 2.0) as usize;
    while svec_len(j + 1) <= k {
        j += 1;
    }
    while svec_len(j) > k {
        j -= 1;
    }
    (k - svec_len(j), j)
}

/// Writes `svec(m)` into `out` (length `svec_len(n)`). An asymmetric `m` is
/// symmetrised first: the off-diagonal value is `(m[i,j] + m[j,i]) / √2`,
/// exactly as Clarabel does.
pub fn svec_into(m: &DMatrix<f64>, out: &mut [f64]) {
    let n = m.nrows();
    assert_eq!(m.ncols(), n, "svec: matrix must be square");
    assert_eq!(
        out.len(),
        svec_len(n),
        "svec: output length must be n(n+1)/2"
    );
    let mut k = 0;
    for j in 0..n {
        for i in 0..j {
            out[k] = (m[(i, j)] + m[(j, i)]) * std::f64::consts::FRAC_1_SQRT_2;
            k += 1;
        }
        out[k] = m[(j, j)];
        k += 1;
    }
}

/// `svec(m)` (see [`svec_into`]).
pub fn svec(m: &DMatrix<f64>) -> Vec<f64> {
    let mut out = vec![0.0; svec_len(m.nrows())];
    svec_into(m, &mut out);
    out
}

/// The symmetric matrix `S` with `svec(S) = v`. Panics if `v.len()` is not
/// a triangular number.
pub fn smat(v: &[f64]) -> DMatrix<f64> {
    let n = svec_side(v.len()).expect("smat: length is not n(n+1)/2");
    let mut m = DMatrix::zeros(n, n);
    let mut k = 0;
    for j in 0..n {
        for i in 0..j {
            let x = v[k] * std::f64::consts::FRAC_1_SQRT_2;
            m[(i, j)] = x;
            m[(j, i)] = x;
            k += 1;
        }
        m[(j, j)] = v[k];
        k += 1;
    }
    m
}
