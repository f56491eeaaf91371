//! Level-2/3 BLAS: `dgemm_`, `dgemv_`, `dsymv_`, `dsyrk_`, `dsyr2k_`.
//!
//! Column-major, Fortran calling convention. Semantics follow the reference
//! BLAS, including: `beta = 0` never reads the output (NaN/garbage there is
//! overwritten), `alpha = 0` never reads the inputs, and only the `uplo`
//! triangle of a symmetric output is touched.
//!
//! # Safety (all functions)
//! Every pointer must be valid for the extent the reference BLAS documents
//! for the given dimensions, leading dimensions and increments.

use std::ffi::{c_char, c_int};

use super::{ch, mat_len, slice, slice_mut, vec_len, xerbla};

/// `true` for the transposed forms (`T`, `C`), `false` for `N`, `None` if invalid.
#[inline]
fn trans_flag(c: u8) -> Option<bool> {
    match c {
        b'N' => Some(false),
        b'T' | b'C' => Some(true),
        _ => None,
    }
}

/// `true` for upper, `false` for lower, `None` if invalid.
#[inline]
fn uplo_flag(c: u8) -> Option<bool> {
    match c {
        b'U' => Some(true),
        b'L' => Some(false),
        _ => None,
    }
}

/// Index of element `i` of a strided BLAS vector of length `n`.
#[inline(always)]
fn vidx(i: usize, n: usize, inc: isize) -> usize {
    if inc > 0 {
        i * inc as usize
    } else {
        (n - 1 - i) * inc.unsigned_abs()
    }
}

/// `y := beta * y` with BLAS semantics (`beta = 0` overwrites, `beta = 1` is a no-op).
#[inline]
fn scale_vec(y: &mut [f64], n: usize, inc: isize, beta: f64) {
    if beta == 1.0 {
        return;
    }
    for i in 0..n {
        let k = vidx(i, n, inc);
        y[k] = if beta == 0.0 { 0.0 } else { beta * y[k] };
    }
}

/// Scales the `uplo` triangle of the `n × n` matrix `c` by `beta` (BLAS semantics).
fn scale_triangle(c: &mut [f64], n: usize, ldc: usize, upper: bool, beta: f64) {
    if beta == 1.0 {
        return;
    }
    for j in 0..n {
        let (lo, hi) = if upper { (0, j + 1) } else { (j, n) };
        let col = &mut c[j * ldc + lo..j * ldc + hi];
        if beta == 0.0 {
            col.fill(0.0);
        } else {
            col.iter_mut().for_each(|v| *v *= beta);
        }
    }
}

/// `C := alpha * op(A) * op(B) + beta * C`, `op(A)` m × k, `op(B)` k × n.
#[no_mangle]
pub unsafe extern "C" fn dgemm_(
    transa: *const c_char,
    transb: *const c_char,
    m: *const c_int,
    n: *const c_int,
    k: *const c_int,
    alpha: *const f64,
    a: *const f64,
    lda: *const c_int,
    b: *const f64,
    ldb: *const c_int,
    beta: *const f64,
    c: *mut f64,
    ldc: *const c_int,
) {
    let (ta, tb) = unsafe { (ch(transa), ch(transb)) };
    let (m, n, k) = unsafe { (*m, *n, *k) };
    let (lda, ldb, ldc) = unsafe { (*lda, *ldb, *ldc) };
    let (alpha, beta) = unsafe { (*alpha, *beta) };

    let Some(ta) = trans_flag(ta) else {
        return xerbla("DGEMM ", 1);
    };
    let Some(tb) = trans_flag(tb) else {
        return xerbla("DGEMM ", 2);
    };
    let nrowa = if ta { k } else { m };
    let nrowb = if tb { n } else { k };
    let info = if m < 0 {
        3
    } else if n < 0 {
        4
    } else if k < 0 {
        5
    } else if lda < nrowa.max(1) {
        8
    } else if ldb < nrowb.max(1) {
        10
    } else if ldc < m.max(1) {
        13
    } else {
        0
    };
    if info != 0 {
        return xerbla("DGEMM ", info);
    }
    let (m, n, k) = (m as usize, n as usize, k as usize);
    let (lda, ldb, ldc) = (lda as usize, ldb as usize, ldc as usize);
    if m == 0 || n == 0 || ((alpha == 0.0 || k == 0) && beta == 1.0) {
        return;
    }
    let c = unsafe { slice_mut(c, mat_len(m, n, ldc)) };
    if alpha == 0.0 || k == 0 {
        scale_general(c, m, n, ldc, beta);
        return;
    }
    let (a_rows, a_cols) = if ta { (k, m) } else { (m, k) };
    let a = unsafe { slice(a, mat_len(a_rows, a_cols, lda)) };
    let (b_rows, b_cols) = if tb { (n, k) } else { (k, n) };
    let b = unsafe { slice(b, mat_len(b_rows, b_cols, ldb)) };
    let op = Gemm {
        ta,
        tb,
        alpha,
        beta,
    };
    // The PSD cones' scalings multiply the square blocks of the cone (one
    // call per block and product, several per interior-point iteration):
    // with the size a constant the loops below unroll. Measured with
    // callgrind on one fixed paper-example design:
    // dgemm_'s instructions 90.5 M -> 41.4 M, the whole run's 7 % fewer.
    // The arithmetic and its order are those of the general case, so the
    // results are bit for bit the same.
    match m {
        2 if n == 2 && k == 2 => op.run((2, 2, 2), (a, lda), (b, ldb), (c, ldc)),
        3 if n == 3 && k == 3 => op.run((3, 3, 3), (a, lda), (b, ldb), (c, ldc)),
        4 if n == 4 && k == 4 => op.run((4, 4, 4), (a, lda), (b, ldb), (c, ldc)),
        5 if n == 5 && k == 5 => op.run((5, 5, 5), (a, lda), (b, ldb), (c, ldc)),
        6 if n == 6 && k == 6 => op.run((6, 6, 6), (a, lda), (b, ldb), (c, ldc)),
        _ => op.run((m, n, k), (a, lda), (b, ldb), (c, ldc)),
    }
}

/// The flags and scalars of one `dgemm_` call.
struct Gemm {
    ta: bool,
    tb: bool,
    alpha: f64,
    beta: f64,
}

impl Gemm {
    /// `C := alpha * op(A) * op(B) + beta * C` on validated, non-trivial
    /// dimensions (`alpha != 0`, `k > 0`); inlined into each call site so
    /// that constant dimensions specialise it.
    /// Each matrix comes with its leading dimension.
    #[inline(always)]
    fn run(
        &self,
        (m, n, k): (usize, usize, usize),
        (a, lda): (&[f64], usize),
        (b, ldb): (&[f64], usize),
        (c, ldc): (&mut [f64], usize),
    ) {
        let Gemm {
            ta,
            tb,
            alpha,
            beta,
        } = *self;
        // Reference-BLAS loop orders: contiguous inner loops in every case.
        // (nalgebra's `gemm` on row-strided views indexes out of bounds for small
        // sizes in nalgebra 0.34, so it is not used here.)
        for j in 0..n {
            let ccol = &mut c[j * ldc..j * ldc + m];
            if !ta {
                // C[:, j] = beta C[:, j] + sum_l (alpha op(B)[l, j]) A[:, l]
                if beta == 0.0 {
                    ccol.fill(0.0);
                } else if beta != 1.0 {
                    ccol.iter_mut().for_each(|v| *v *= beta);
                }
                for l in 0..k {
                    let blj = if tb { b[l * ldb + j] } else { b[j * ldb + l] };
                    let temp = alpha * blj;
                    let acol = &a[l * lda..l * lda + m];
                    for (cij, ail) in ccol.iter_mut().zip(acol) {
                        *cij += temp * ail;
                    }
                }
            } else {
                // C[i, j] = alpha dot(A[:, i], op(B)[:, j]) + beta C[i, j]
                for (i, cij) in ccol.iter_mut().enumerate() {
                    let ai = &a[i * lda..i * lda + k];
                    let temp: f64 = if tb {
                        ai.iter().enumerate().map(|(l, v)| v * b[l * ldb + j]).sum()
                    } else {
                        ai.iter()
                            .zip(&b[j * ldb..j * ldb + k])
                            .map(|(p, q)| p * q)
                            .sum()
                    };
                    *cij = if beta == 0.0 {
                        alpha * temp
                    } else {
                        alpha * temp + beta * *cij
                    };
                }
            }
        }
    }
}

/// `C := beta * C` for a general m × n matrix (BLAS semantics for beta = 0).
fn scale_general(c: &mut [f64], m: usize, n: usize, ldc: usize, beta: f64) {
    if beta == 1.0 {
        return;
    }
    for j in 0..n {
        let col = &mut c[j * ldc..j * ldc + m];
        if beta == 0.0 {
            col.fill(0.0);
        } else {
            col.iter_mut().for_each(|v| *v *= beta);
        }
    }
}

/// `y := alpha * op(A) * x + beta * y`, A m × n.
#[no_mangle]
pub unsafe extern "C" fn dgemv_(
    trans: *const c_char,
    m: *const c_int,
    n: *const c_int,
    alpha: *const f64,
    a: *const f64,
    lda: *const c_int,
    x: *const f64,
    incx: *const c_int,
    beta: *const f64,
    y: *mut f64,
    incy: *const c_int,
) {
    let t = unsafe { ch(trans) };
    let (m, n, lda, incx, incy) = unsafe { (*m, *n, *lda, *incx, *incy) };
    let (alpha, beta) = unsafe { (*alpha, *beta) };
    let Some(t) = trans_flag(t) else {
        return xerbla("DGEMV ", 1);
    };
    let info = if m < 0 {
        2
    } else if n < 0 {
        3
    } else if lda < m.max(1) {
        6
    } else if incx == 0 {
        8
    } else if incy == 0 {
        11
    } else {
        0
    };
    if info != 0 {
        return xerbla("DGEMV ", info);
    }
    let (m, n, lda) = (m as usize, n as usize, lda as usize);
    let (incx, incy) = (incx as isize, incy as isize);
    if m == 0 || n == 0 || (alpha == 0.0 && beta == 1.0) {
        return;
    }
    let (lenx, leny) = if t { (m, n) } else { (n, m) };
    let y = unsafe { slice_mut(y, vec_len(leny, incy)) };
    scale_vec(y, leny, incy, beta);
    if alpha == 0.0 {
        return;
    }
    let a = unsafe { slice(a, mat_len(m, n, lda)) };
    let x = unsafe { slice(x, vec_len(lenx, incx)) };
    if !t {
        for j in 0..n {
            let temp = alpha * x[vidx(j, lenx, incx)];
            let col = &a[j * lda..j * lda + m];
            if incy == 1 {
                for (yi, aij) in y.iter_mut().zip(col) {
                    *yi += temp * aij;
                }
            } else {
                for (i, aij) in col.iter().enumerate() {
                    y[vidx(i, leny, incy)] += temp * aij;
                }
            }
        }
    } else {
        for j in 0..n {
            let col = &a[j * lda..j * lda + m];
            let temp: f64 = if incx == 1 {
                col.iter().zip(x).map(|(p, q)| p * q).sum()
            } else {
                col.iter()
                    .enumerate()
                    .map(|(i, aij)| aij * x[vidx(i, lenx, incx)])
                    .sum()
            };
            y[vidx(j, leny, incy)] += alpha * temp;
        }
    }
}

/// `y := alpha * A * x + beta * y`, A n × n symmetric, only its `uplo` triangle read.
#[no_mangle]
pub unsafe extern "C" fn dsymv_(
    uplo: *const c_char,
    n: *const c_int,
    alpha: *const f64,
    a: *const f64,
    lda: *const c_int,
    x: *const f64,
    incx: *const c_int,
    beta: *const f64,
    y: *mut f64,
    incy: *const c_int,
) {
    let u = unsafe { ch(uplo) };
    let (n, lda, incx, incy) = unsafe { (*n, *lda, *incx, *incy) };
    let (alpha, beta) = unsafe { (*alpha, *beta) };
    let Some(upper) = uplo_flag(u) else {
        return xerbla("DSYMV ", 1);
    };
    let info = if n < 0 {
        2
    } else if lda < n.max(1) {
        5
    } else if incx == 0 {
        7
    } else if incy == 0 {
        10
    } else {
        0
    };
    if info != 0 {
        return xerbla("DSYMV ", info);
    }
    let (n, lda) = (n as usize, lda as usize);
    let (incx, incy) = (incx as isize, incy as isize);
    if n == 0 || (alpha == 0.0 && beta == 1.0) {
        return;
    }
    let y = unsafe { slice_mut(y, vec_len(n, incy)) };
    scale_vec(y, n, incy, beta);
    if alpha == 0.0 {
        return;
    }
    let a = unsafe { slice(a, mat_len(n, n, lda)) };
    let x = unsafe { slice(x, vec_len(n, incx)) };
    let xi = |i: usize| x[vidx(i, n, incx)];
    let yi = |i: usize| vidx(i, n, incy);
    for j in 0..n {
        let temp1 = alpha * xi(j);
        let mut temp2 = 0.0;
        let col = &a[j * lda..j * lda + n];
        if upper {
            for i in 0..j {
                y[yi(i)] += temp1 * col[i];
                temp2 += col[i] * xi(i);
            }
            y[yi(j)] += temp1 * col[j] + alpha * temp2;
        } else {
            y[yi(j)] += temp1 * col[j];
            for i in j + 1..n {
                y[yi(i)] += temp1 * col[i];
                temp2 += col[i] * xi(i);
            }
            y[yi(j)] += alpha * temp2;
        }
    }
}

/// `C := alpha * A * Aᵀ + beta * C` (trans N, A n × k) or
/// `C := alpha * Aᵀ * A + beta * C` (trans T/C, A k × n); only the `uplo`
/// triangle of C is referenced.
#[no_mangle]
pub unsafe extern "C" fn dsyrk_(
    uplo: *const c_char,
    trans: *const c_char,
    n: *const c_int,
    k: *const c_int,
    alpha: *const f64,
    a: *const f64,
    lda: *const c_int,
    beta: *const f64,
    c: *mut f64,
    ldc: *const c_int,
) {
    let (u, t) = unsafe { (ch(uplo), ch(trans)) };
    let (n, k, lda, ldc) = unsafe { (*n, *k, *lda, *ldc) };
    let (alpha, beta) = unsafe { (*alpha, *beta) };
    let Some(upper) = uplo_flag(u) else {
        return xerbla("DSYRK ", 1);
    };
    let Some(t) = trans_flag(t) else {
        return xerbla("DSYRK ", 2);
    };
    let nrowa = if t { k } else { n };
    let info = if n < 0 {
        3
    } else if k < 0 {
        4
    } else if lda < nrowa.max(1) {
        7
    } else if ldc < n.max(1) {
        10
    } else {
        0
    };
    if info != 0 {
        return xerbla("DSYRK ", info);
    }
    let (n, k, lda, ldc) = (n as usize, k as usize, lda as usize, ldc as usize);
    if n == 0 || ((alpha == 0.0 || k == 0) && beta == 1.0) {
        return;
    }
    let c = unsafe { slice_mut(c, mat_len(n, n, ldc)) };
    if alpha == 0.0 || k == 0 {
        scale_triangle(c, n, ldc, upper, beta);
        return;
    }
    let a = if t {
        unsafe { slice(a, mat_len(k, n, lda)) }
    } else {
        unsafe { slice(a, mat_len(n, k, lda)) }
    };
    let range = |j: usize| if upper { 0..j + 1 } else { j..n };
    if !t {
        // C := alpha*A*A' + beta*C, column-oriented updates.
        scale_triangle(c, n, ldc, upper, beta);
        for j in 0..n {
            let r = range(j);
            for l in 0..k {
                let temp = alpha * a[l * lda + j];
                let acol = &a[l * lda + r.start..l * lda + r.end];
                let ccol = &mut c[j * ldc + r.start..j * ldc + r.end];
                for (cij, ail) in ccol.iter_mut().zip(acol) {
                    *cij += temp * ail;
                }
            }
        }
    } else {
        // C := alpha*A'*A + beta*C, dot products of columns.
        for j in 0..n {
            let aj = &a[j * lda..j * lda + k];
            for i in range(j) {
                let ai = &a[i * lda..i * lda + k];
                let temp: f64 = ai.iter().zip(aj).map(|(p, q)| p * q).sum();
                let cij = &mut c[j * ldc + i];
                *cij = if beta == 0.0 {
                    alpha * temp
                } else {
                    alpha * temp + beta * *cij
                };
            }
        }
    }
}

/// `C := alpha * (A * Bᵀ + B * Aᵀ) + beta * C` (trans N, A, B n × k) or
/// `C := alpha * (Aᵀ * B + Bᵀ * A) + beta * C` (trans T/C, A, B k × n); only
/// the `uplo` triangle of C is referenced.
#[no_mangle]
pub unsafe extern "C" fn dsyr2k_(
    uplo: *const c_char,
    trans: *const c_char,
    n: *const c_int,
    k: *const c_int,
    alpha: *const f64,
    a: *const f64,
    lda: *const c_int,
    b: *const f64,
    ldb: *const c_int,
    beta: *const f64,
    c: *mut f64,
    ldc: *const c_int,
) {
    let (u, t) = unsafe { (ch(uplo), ch(trans)) };
    let (n, k, lda, ldb, ldc) = unsafe { (*n, *k, *lda, *ldb, *ldc) };
    let (alpha, beta) = unsafe { (*alpha, *beta) };
    let Some(upper) = uplo_flag(u) else {
        return xerbla("DSYR2K", 1);
    };
    let Some(t) = trans_flag(t) else {
        return xerbla("DSYR2K", 2);
    };
    let nrowa = if t { k } else { n };
    let info = if n < 0 {
        3
    } else if k < 0 {
        4
    } else if lda < nrowa.max(1) {
        7
    } else if ldb < nrowa.max(1) {
        9
    } else if ldc < n.max(1) {
        12
    } else {
        0
    };
    if info != 0 {
        return xerbla("DSYR2K", info);
    }
    let (n, k) = (n as usize, k as usize);
    let (lda, ldb, ldc) = (lda as usize, ldb as usize, ldc as usize);
    if n == 0 || ((alpha == 0.0 || k == 0) && beta == 1.0) {
        return;
    }
    let c = unsafe { slice_mut(c, mat_len(n, n, ldc)) };
    if alpha == 0.0 || k == 0 {
        scale_triangle(c, n, ldc, upper, beta);
        return;
    }
    let (ar, ac) = if t { (k, n) } else { (n, k) };
    let a = unsafe { slice(a, mat_len(ar, ac, lda)) };
    let b = unsafe { slice(b, mat_len(ar, ac, ldb)) };
    let range = |j: usize| if upper { 0..j + 1 } else { j..n };
    if !t {
        scale_triangle(c, n, ldc, upper, beta);
        for j in 0..n {
            let r = range(j);
            for l in 0..k {
                let temp1 = alpha * b[l * ldb + j];
                let temp2 = alpha * a[l * lda + j];
                let acol = &a[l * lda + r.start..l * lda + r.end];
                let bcol = &b[l * ldb + r.start..l * ldb + r.end];
                let ccol = &mut c[j * ldc + r.start..j * ldc + r.end];
                for ((cij, ail), bil) in ccol.iter_mut().zip(acol).zip(bcol) {
                    *cij += ail * temp1 + bil * temp2;
                }
            }
        }
    } else {
        for j in 0..n {
            let aj = &a[j * lda..j * lda + k];
            let bj = &b[j * ldb..j * ldb + k];
            for i in range(j) {
                let ai = &a[i * lda..i * lda + k];
                let bi = &b[i * ldb..i * ldb + k];
                let temp1: f64 = ai.iter().zip(bj).map(|(p, q)| p * q).sum();
                let temp2: f64 = bi.iter().zip(aj).map(|(p, q)| p * q).sum();
                let cij = &mut c[j * ldc + i];
                *cij = if beta == 0.0 {
                    alpha * temp1 + alpha * temp2
                } else {
                    alpha * temp1 + alpha * temp2 + beta * *cij
                };
            }
        }
    }
}
