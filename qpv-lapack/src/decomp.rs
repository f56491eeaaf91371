//! LAPACK: `dpotrf_`, `dpotrs_`, `dsyevr_`, `dgesdd_`, `dgesvd_`.
//!
//! Argument checks and `info` codes follow the LAPACK documentation. The
//! symmetric eigendecomposition is nalgebra's; the SVD is a one-sided Jacobi
//! written here (nalgebra 0.34's `SVD` is wrong on some rank-deficient
//! inputs); the workspace arguments are only used to answer workspace
//! queries.
//!
//! # Safety (all functions)
//! Every pointer must be valid for the extent LAPACK documents for the given
//! dimensions and options (e.g. `Z` is not touched when `jobz = 'N'`).

use std::ffi::{c_char, c_int};

use nalgebra::{DMatrix, SymmetricEigen};

use super::{ch, mat_len, slice, slice_mut, xerbla};

// ---------------------------------------------------------------------------
// Cholesky
// ---------------------------------------------------------------------------

/// Cholesky factorisation of a symmetric positive definite matrix:
/// `A = Uᵀ U` (`uplo = 'U'`) or `A = L Lᵀ` (`uplo = 'L'`), in place in the
/// `uplo` triangle (the other triangle is not referenced). `info = k > 0` if
/// the leading minor of order k is not positive definite (then the
/// factorisation is incomplete, as in LAPACK).
#[no_mangle]
pub unsafe extern "C" fn dpotrf_(
    uplo: *const c_char,
    n: *const c_int,
    a: *mut f64,
    lda: *const c_int,
    info: *mut c_int,
) {
    let u = unsafe { ch(uplo) };
    let (n, lda) = unsafe { (*n, *lda) };
    let code = if u != b'U' && u != b'L' {
        -1
    } else if n < 0 {
        -2
    } else if lda < n.max(1) {
        -4
    } else {
        0
    };
    unsafe { *info = code };
    if code != 0 {
        return xerbla("DPOTRF", -code);
    }
    let (n, lda) = (n as usize, lda as usize);
    if n == 0 {
        return;
    }
    let a = unsafe { slice_mut(a, mat_len(n, n, lda)) };
    let r = if u == b'U' {
        potrf_upper(a, n, lda)
    } else {
        potrf_lower(a, n, lda)
    };
    unsafe { *info = r };
}

/// `A = Uᵀ U`: column j of U from dot products of columns (contiguous).
fn potrf_upper(a: &mut [f64], n: usize, lda: usize) -> c_int {
    for j in 0..n {
        // Column j (rows 0..=j) is left of the split, columns i > j right of it.
        let (left, right) = a.split_at_mut(j * lda + n);
        let colj = &mut left[j * lda..j * lda + n];
        let ajj = colj[j] - colj[..j].iter().map(|v| v * v).sum::<f64>();
        if ajj <= 0.0 || ajj.is_nan() {
            colj[j] = ajj;
            return (j + 1) as c_int;
        }
        let ajj = ajj.sqrt();
        colj[j] = ajj;
        let uj = &colj[..j];
        for i in j + 1..n {
            let off = (i * lda) - (j * lda + n);
            let coli = &mut right[off..off + j + 1];
            let d: f64 = coli[..j].iter().zip(uj).map(|(p, q)| p * q).sum();
            coli[j] = (coli[j] - d) / ajj;
        }
    }
    0
}

/// `A = L Lᵀ`: left-looking column updates (contiguous, gaxpy form).
fn potrf_lower(a: &mut [f64], n: usize, lda: usize) -> c_int {
    for j in 0..n {
        let (prev, rest) = a.split_at_mut(j * lda);
        let colj = &mut rest[..n];
        for k in 0..j {
            let colk = &prev[k * lda..k * lda + n];
            let ljk = colk[j];
            if ljk != 0.0 {
                for (v, lik) in colj[j..].iter_mut().zip(&colk[j..]) {
                    *v -= ljk * lik;
                }
            }
        }
        let ajj = colj[j];
        if ajj <= 0.0 || ajj.is_nan() {
            return (j + 1) as c_int;
        }
        let ajj = ajj.sqrt();
        colj[j] = ajj;
        let r = 1.0 / ajj;
        colj[j + 1..].iter_mut().for_each(|v| *v *= r);
    }
    0
}

/// Solves `A X = B` with the factor from [`dpotrf_`] (same `uplo`).
#[no_mangle]
pub unsafe extern "C" fn dpotrs_(
    uplo: *const c_char,
    n: *const c_int,
    nrhs: *const c_int,
    a: *const f64,
    lda: *const c_int,
    b: *mut f64,
    ldb: *const c_int,
    info: *mut c_int,
) {
    let u = unsafe { ch(uplo) };
    let (n, nrhs, lda, ldb) = unsafe { (*n, *nrhs, *lda, *ldb) };
    let code = if u != b'U' && u != b'L' {
        -1
    } else if n < 0 {
        -2
    } else if nrhs < 0 {
        -3
    } else if lda < n.max(1) {
        -5
    } else if ldb < n.max(1) {
        -7
    } else {
        0
    };
    unsafe { *info = code };
    if code != 0 {
        return xerbla("DPOTRS", -code);
    }
    let (n, nrhs, lda, ldb) = (n as usize, nrhs as usize, lda as usize, ldb as usize);
    if n == 0 || nrhs == 0 {
        return;
    }
    let a = unsafe { slice(a, mat_len(n, n, lda)) };
    let b = unsafe { slice_mut(b, mat_len(n, nrhs, ldb)) };
    let col = |k: usize| &a[k * lda..k * lda + n];
    for r in 0..nrhs {
        let x = &mut b[r * ldb..r * ldb + n];
        if u == b'U' {
            // Uᵀ y = b (forward, dot form: U[0..i, i] is contiguous).
            for i in 0..n {
                let ci = col(i);
                let d: f64 = ci[..i].iter().zip(&x[..i]).map(|(p, q)| p * q).sum();
                x[i] = (x[i] - d) / ci[i];
            }
            // U x = y (backward, column form).
            for k in (0..n).rev() {
                let ck = col(k);
                x[k] /= ck[k];
                let xk = x[k];
                for (xi, uik) in x[..k].iter_mut().zip(&ck[..k]) {
                    *xi -= xk * uik;
                }
            }
        } else {
            // L y = b (forward, column form).
            for k in 0..n {
                let ck = col(k);
                x[k] /= ck[k];
                let xk = x[k];
                for (xi, lik) in x[k + 1..].iter_mut().zip(&ck[k + 1..]) {
                    *xi -= xk * lik;
                }
            }
            // Lᵀ x = y (backward, dot form: L[i+1.., i] is contiguous).
            for i in (0..n).rev() {
                let ci = col(i);
                let d: f64 = ci[i + 1..]
                    .iter()
                    .zip(&x[i + 1..])
                    .map(|(p, q)| p * q)
                    .sum();
                x[i] = (x[i] - d) / ci[i];
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Symmetric eigenproblem
// ---------------------------------------------------------------------------

/// The eigenvalues (unordered) and, if `wantz`, eigenvectors of the
/// symmetric matrix whose `upper` (else lower) triangle is stored in `a`
/// (column-major, leading dimension `lda`); NaN throughout for non-finite
/// input.
fn symmetric_eigen(
    a: &[f64],
    n: usize,
    lda: usize,
    upper: bool,
    wantz: bool,
) -> (Vec<f64>, Option<DMatrix<f64>>) {
    // Full symmetric matrix from the referenced triangle.
    let mut s = DMatrix::<f64>::zeros(n, n);
    let mut finite = true;
    for j in 0..n {
        let (lo, hi) = if upper { (0, j + 1) } else { (j, n) };
        for i in lo..hi {
            let v = a[j * lda + i];
            finite &= v.is_finite();
            s[(i, j)] = v;
            s[(j, i)] = v;
        }
    }
    if !finite {
        let vecs = wantz.then(|| DMatrix::from_element(n, n, f64::NAN));
        (vec![f64::NAN; n], vecs)
    } else if wantz {
        let e = SymmetricEigen::new(s);
        (e.eigenvalues.as_slice().to_vec(), Some(e.eigenvectors))
    } else {
        (s.symmetric_eigenvalues().as_slice().to_vec(), None)
    }
}

/// Eigenvalues (ascending) and optionally eigenvectors of a symmetric
/// matrix, of which only the `uplo` triangle is read (A is left unchanged;
/// LAPACK would overwrite it). `range` = `A` (all), `V` (in `(vl, vu]`) or
/// `I` (indices `il..=iu`, 1-based). `abstol` is ignored (nalgebra's implicit
/// QR converges to machine precision). `lwork = -1` or `liwork = -1` is a
/// workspace query: `work[0] = max(1, 26n)`, `iwork[0] = max(1, 10n)`.
/// `isuppz` receives, for each eigenvector, the 1-based first and last
/// indices of its non-zero entries.
#[no_mangle]
pub unsafe extern "C" fn dsyevr_(
    jobz: *const c_char,
    range: *const c_char,
    uplo: *const c_char,
    n: *const c_int,
    a: *mut f64,
    lda: *const c_int,
    vl: *const f64,
    vu: *const f64,
    il: *const c_int,
    iu: *const c_int,
    _abstol: *const f64,
    m: *mut c_int,
    w: *mut f64,
    z: *mut f64,
    ldz: *const c_int,
    isuppz: *mut c_int,
    work: *mut f64,
    lwork: *const c_int,
    iwork: *mut c_int,
    liwork: *const c_int,
    info: *mut c_int,
) {
    let (jobz, range, uplo) = unsafe { (ch(jobz), ch(range), ch(uplo)) };
    let (n, lda, ldz, lwork, liwork) = unsafe { (*n, *lda, *ldz, *lwork, *liwork) };
    let wantz = jobz == b'V';
    let lwmin = (26 * n).max(1);
    let liwmin = (10 * n).max(1);
    let lquery = lwork == -1 || liwork == -1;

    let code = if jobz != b'V' && jobz != b'N' {
        -1
    } else if range != b'A' && range != b'V' && range != b'I' {
        -2
    } else if uplo != b'U' && uplo != b'L' {
        -3
    } else if n < 0 {
        -4
    } else if lda < n.max(1) {
        -6
    } else if range == b'V' && n > 0 && unsafe { *vu <= *vl } {
        -8
    } else if range == b'I' && unsafe { *il < 1 || *il > n.max(1) } {
        -9
    } else if range == b'I' && unsafe { *iu < n.min(*il) || *iu > n } {
        -10
    } else if ldz < 1 || (wantz && ldz < n) {
        -15
    } else if lwork < lwmin && !lquery {
        -18
    } else if liwork < liwmin && !lquery {
        -20
    } else {
        0
    };
    unsafe { *info = code };
    if code != 0 {
        return xerbla("DSYEVR", -code);
    }
    if lquery {
        unsafe {
            *work = lwmin as f64;
            *iwork = liwmin;
        }
        return;
    }
    unsafe { *m = 0 };
    if n == 0 {
        return;
    }
    let (n, lda, ldz) = (n as usize, lda as usize, ldz as usize);
    let a = unsafe { slice(a as *const f64, mat_len(n, n, lda)) };

    let (vals, vecs) = symmetric_eigen(a, n, lda, uplo == b'U', wantz);

    // Ascending order (NaN last; only occurs for non-finite input).
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&p, &q| vals[p].total_cmp(&vals[q]));
    let selected: Vec<usize> = match range {
        b'A' => order,
        b'I' => {
            let (il, iu) = unsafe { (*il as usize, *iu as usize) };
            order[il - 1..iu].to_vec()
        }
        _ => {
            let (vl, vu) = unsafe { (*vl, *vu) };
            order
                .into_iter()
                .filter(|&p| vals[p] > vl && vals[p] <= vu)
                .collect()
        }
    };
    let count = selected.len();
    unsafe { *m = count as c_int };
    if count == 0 {
        return;
    }
    let w = unsafe { slice_mut(w, count) };
    for (wk, &p) in w.iter_mut().zip(&selected) {
        *wk = vals[p];
    }
    if let Some(v) = vecs {
        let z = unsafe { slice_mut(z, mat_len(n, count, ldz)) };
        let isuppz = unsafe { slice_mut(isuppz, 2 * count) };
        for (k, &p) in selected.iter().enumerate() {
            let src = v.column(p);
            let dst = &mut z[k * ldz..k * ldz + n];
            for (d, s) in dst.iter_mut().zip(src.iter()) {
                *d = *s;
            }
            let first = dst.iter().position(|x| *x != 0.0).unwrap_or(0);
            let last = dst.iter().rposition(|x| *x != 0.0).unwrap_or(n - 1);
            isuppz[2 * k] = (first + 1) as c_int;
            isuppz[2 * k + 1] = (last + 1) as c_int;
        }
    }
}

// ---------------------------------------------------------------------------
// Singular value decomposition
// ---------------------------------------------------------------------------

/// How much of U / Vᵀ a caller wants.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Vecs {
    None,
    /// The first min(m, n) vectors.
    Thin,
}

/// Thin SVD of the m × n matrix in `a` (leading dimension `lda`) into `s`
/// (descending) and the requested factors, each given as (which, where,
/// leading dimension). Returns LAPACK's `info` (always 0).
unsafe fn svd_into(
    (m, n): (usize, usize),
    (a, lda): (&[f64], usize),
    s: *mut f64,
    (want_u, u, ldu): (Vecs, *mut f64, usize),
    (want_vt, vt, ldvt): (Vecs, *mut f64, usize),
) -> c_int {
    let k = m.min(n);
    let (cu, cv) = (want_u == Vecs::Thin, want_vt == Vecs::Thin);
    let s = unsafe { slice_mut(s, k) };
    let u = if cu {
        unsafe { slice_mut(u, mat_len(m, k, ldu)) }
    } else {
        &mut []
    };
    let vt = if cv {
        unsafe { slice_mut(vt, mat_len(k, n, ldvt)) }
    } else {
        &mut []
    };
    let finite = (0..n).all(|j| a[j * lda..j * lda + m].iter().all(|v| v.is_finite()));
    if !finite {
        s.fill(f64::NAN);
        if cu {
            for j in 0..k {
                u[j * ldu..j * ldu + m].fill(f64::NAN);
            }
        }
        if cv {
            for j in 0..n {
                vt[j * ldvt..j * ldvt + k].fill(f64::NAN);
            }
        }
        return 0;
    }
    // One-sided Jacobi works on a tall matrix: use Aᵀ = V Σ Uᵀ when m < n.
    let tall = m >= n;
    let (rows, cols) = if tall { (m, n) } else { (n, m) };
    let mut w = vec![0.0; rows * cols];
    for j in 0..n {
        for i in 0..m {
            let v = a[j * lda + i];
            if tall {
                w[j * rows + i] = v;
            } else {
                w[i * rows + j] = v;
            }
        }
    }
    // Left factor of the tall problem = U (tall) or V (wide); right = the other.
    let (want_left, want_right) = if tall { (cu, cv) } else { (cv, cu) };
    let svd = jacobi_svd(w, rows, cols, want_left, want_right);
    s.copy_from_slice(&svd.sigma);
    // Tall problem: W = L Σ Rᵀ with L rows × cols, R cols × cols.
    for l in 0..k {
        if tall {
            if cu {
                u[l * ldu..l * ldu + m].copy_from_slice(&svd.left[l * rows..l * rows + m]);
            }
            if cv {
                for j in 0..n {
                    vt[j * ldvt + l] = svd.right[l * cols + j];
                }
            }
        } else {
            // A = R Σ Lᵀ: U = R (m × m), Vᵀ = Lᵀ (m × n).
            if cu {
                u[l * ldu..l * ldu + m].copy_from_slice(&svd.right[l * cols..l * cols + m]);
            }
            if cv {
                for j in 0..n {
                    vt[j * ldvt + l] = svd.left[l * rows + j];
                }
            }
        }
    }
    0
}

/// Result of [`jacobi_svd`]: `W = left · diag(sigma) · rightᵀ`, column-major,
/// `left` rows × cols (orthonormal columns), `right` cols × cols orthogonal.
struct JacobiSvd {
    sigma: Vec<f64>,
    left: Vec<f64>,
    right: Vec<f64>,
}

/// Maximum number of Jacobi sweeps (convergence is quadratic: typically
/// 5-10 sweeps for the sizes Clarabel uses).
const JACOBI_MAX_SWEEPS: usize = 100;

/// Squared column norm (of the matrix scaled to max-abs entry 1) below which
/// a column is treated as zero: its entries are near the denormal range, where
/// rotations lose their accuracy and the sweeps can cycle.
const JACOBI_TINY_SQ: f64 = 1e-280;

/// One-sided (Hestenes) Jacobi SVD of the column-major `rows × cols` matrix
/// `w` (rows ≥ cols): rotate column pairs until all are orthogonal to
/// `rows · ε` relative accuracy. Singular values come out descending and
/// with high relative accuracy; columns of `left` for zero singular values are
/// completed to an orthonormal set.
///
/// (nalgebra 0.34's `SVD` returns wrong factors for some rank-deficient
/// inputs, e.g. an 11 × 2 matrix with two equal columns, so it is not used.)
fn jacobi_svd(
    mut w: Vec<f64>,
    rows: usize,
    cols: usize,
    want_left: bool,
    want_right: bool,
) -> JacobiSvd {
    debug_assert!(rows >= cols);
    // Scale to unit max-abs entry to keep squared norms in range.
    let amax = w.iter().fold(0.0f64, |acc, v| acc.max(v.abs()));
    if amax > 0.0 {
        w.iter_mut().for_each(|v| *v /= amax);
    }
    let mut v = if want_right {
        let mut v = vec![0.0; cols * cols];
        for j in 0..cols {
            v[j * cols + j] = 1.0;
        }
        v
    } else {
        Vec::new()
    };
    // Rounding in the dot products is ~rows·ε relative: a tighter threshold
    // can cycle on columns that are pure rounding noise (rank deficiency).
    let tol = rows as f64 * f64::EPSILON;
    let mut converged = cols < 2;
    for _sweep in 0..JACOBI_MAX_SWEEPS {
        if converged {
            break;
        }
        let mut rotated = false;
        for p in 0..cols - 1 {
            for q in p + 1..cols {
                let (wp, wq) = two_cols(&mut w, rows, p, q);
                let mut alpha = 0.0;
                let mut beta = 0.0;
                let mut gamma = 0.0;
                for (x, y) in wp.iter().zip(wq.iter()) {
                    alpha += x * x;
                    beta += y * y;
                    gamma += x * y;
                }
                // Columns with a (sub)denormal squared norm cannot be rotated
                // accurately: they are zero for the factorisation's purposes.
                if alpha < JACOBI_TINY_SQ
                    || beta < JACOBI_TINY_SQ
                    || gamma.abs() <= tol * (alpha.sqrt() * beta.sqrt())
                {
                    continue;
                }
                rotated = true;
                let zeta = (beta - alpha) / (2.0 * gamma);
                let t = zeta.signum() / (zeta.abs() + (1.0 + zeta * zeta).sqrt());
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = c * t;
                rotate(wp, wq, c, s);
                if want_right {
                    let (vp, vq) = two_cols(&mut v, cols, p, q);
                    rotate(vp, vq, c, s);
                }
            }
        }
        converged = !rotated;
    }
    // Not converged after JACOBI_MAX_SWEEPS (never seen in tests): the
    // factors are still an exact-to-rounding factorisation with columns
    // orthogonal to a slightly looser tolerance, so they are returned.
    let _ = converged;
    // Singular values = column norms; sort descending.
    let norms: Vec<f64> = (0..cols)
        .map(|j| {
            w[j * rows..(j + 1) * rows]
                .iter()
                .map(|x| x * x)
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    let mut order: Vec<usize> = (0..cols).collect();
    order.sort_by(|&p, &q| norms[q].total_cmp(&norms[p]));
    let sigma: Vec<f64> = order.iter().map(|&j| norms[j] * amax).collect();
    let right = if want_right {
        let mut r = vec![0.0; cols * cols];
        for (l, &j) in order.iter().enumerate() {
            r[l * cols..(l + 1) * cols].copy_from_slice(&v[j * cols..(j + 1) * cols]);
        }
        r
    } else {
        Vec::new()
    };
    let left = if want_left {
        let mut u = vec![0.0; rows * cols];
        let mut zero_cols = Vec::new();
        for (l, &j) in order.iter().enumerate() {
            let nrm = norms[j];
            if nrm * nrm >= JACOBI_TINY_SQ {
                for (d, x) in u[l * rows..(l + 1) * rows]
                    .iter_mut()
                    .zip(&w[j * rows..(j + 1) * rows])
                {
                    *d = x / nrm;
                }
            } else {
                zero_cols.push(l);
            }
        }
        complete_orthonormal(&mut u, rows, cols, &zero_cols);
        u
    } else {
        Vec::new()
    };
    JacobiSvd { sigma, left, right }
}

/// Mutable views of columns p < q of a column-major matrix with `rows` rows.
fn two_cols(a: &mut [f64], rows: usize, p: usize, q: usize) -> (&mut [f64], &mut [f64]) {
    let (lo, hi) = a.split_at_mut(q * rows);
    (&mut lo[p * rows..(p + 1) * rows], &mut hi[..rows])
}

/// `[x y] := [x y] · [[c, s], [-s, c]]`.
fn rotate(x: &mut [f64], y: &mut [f64], c: f64, s: f64) {
    for (xi, yi) in x.iter_mut().zip(y.iter_mut()) {
        let (a, b) = (*xi, *yi);
        *xi = c * a - s * b;
        *yi = s * a + c * b;
    }
}

/// Fills the columns `missing` of the column-major `rows × cols` matrix `u`
/// (whose other columns are orthonormal) with unit vectors orthogonal to all
/// other columns: Gram-Schmidt (twice) on the canonical basis vectors.
fn complete_orthonormal(u: &mut [f64], rows: usize, cols: usize, missing: &[usize]) {
    if missing.is_empty() {
        return;
    }
    let mut done: Vec<usize> = (0..cols).filter(|j| !missing.contains(j)).collect();
    let mut e = 0;
    for &l in missing {
        loop {
            assert!(e < rows, "complete_orthonormal: ran out of basis vectors");
            let mut x = vec![0.0; rows];
            x[e] = 1.0;
            e += 1;
            for _ in 0..2 {
                for &j in &done {
                    let uj = &u[j * rows..(j + 1) * rows];
                    let d: f64 = uj.iter().zip(&x).map(|(p, q)| p * q).sum();
                    x.iter_mut().zip(uj).for_each(|(xi, ui)| *xi -= d * ui);
                }
            }
            let nrm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
            if nrm > 0.5 / (rows as f64).sqrt() {
                for (d, xi) in u[l * rows..(l + 1) * rows].iter_mut().zip(&x) {
                    *d = xi / nrm;
                }
                done.push(l);
                break;
            }
        }
    }
}

/// SVD `A = U Σ Vᵀ` (LAPACK's divide-and-conquer driver; here one-sided
/// Jacobi). `jobz = 'N'` (values only) or `'S'` (thin U, Vᵀ);
/// `'A'` is accepted when m = n (it then equals `'S'`); `'O'` and `'A'` with
/// m ≠ n are not supported (`info = -1`). A is left unchanged. `lwork = -1`
/// is a workspace query writing LAPACK's minimum `lwork` into `work[0]`.
#[no_mangle]
pub unsafe extern "C" fn dgesdd_(
    jobz: *const c_char,
    m: *const c_int,
    n: *const c_int,
    a: *mut f64,
    lda: *const c_int,
    s: *mut f64,
    u: *mut f64,
    ldu: *const c_int,
    vt: *mut f64,
    ldvt: *const c_int,
    work: *mut f64,
    lwork: *const c_int,
    _iwork: *mut c_int,
    info: *mut c_int,
) {
    let jobz = unsafe { ch(jobz) };
    let (m, n, lda, ldu, ldvt, lwork) = unsafe { (*m, *n, *lda, *ldu, *ldvt, *lwork) };
    let (mn, mx) = (m.min(n).max(0), m.max(n).max(0));
    let wntqa = jobz == b'A';
    let wntqs = jobz == b'S';
    let wntqn = jobz == b'N';
    let minwrk = if m <= 0 || n <= 0 {
        1
    } else if wntqn {
        3 * mn + mx.max(7 * mn)
    } else if wntqs {
        4 * mn * mn + 7 * mn
    } else {
        4 * mn * mn + 6 * mn + mx
    };
    let lquery = lwork == -1;
    let supported = wntqn || wntqs || (wntqa && m == n);
    let code = if !supported {
        -1
    } else if m < 0 {
        -2
    } else if n < 0 {
        -3
    } else if lda < m.max(1) {
        -5
    } else if ldu < 1 || (!wntqn && ldu < m) {
        -8
    } else if ldvt < 1 || (wntqa && ldvt < n) || (wntqs && ldvt < mn) {
        -10
    } else if lwork < minwrk && !lquery {
        -12
    } else {
        0
    };
    unsafe { *info = code };
    if code != 0 {
        if code == -1 && (jobz == b'O' || wntqa) {
            eprintln!(
                " ** DGESDD (qpv-solve pure-Rust LAPACK): JOBZ = '{}' is not supported for {m}x{n}",
                jobz as char
            );
        }
        return xerbla("DGESDD", -code);
    }
    if lquery {
        unsafe { *work = minwrk as f64 };
        return;
    }
    if m == 0 || n == 0 {
        return;
    }
    let (m, n) = (m as usize, n as usize);
    let (lda, ldu, ldvt) = (lda as usize, ldu as usize, ldvt as usize);
    let a = unsafe { slice(a as *const f64, mat_len(m, n, lda)) };
    let want = if wntqn { Vecs::None } else { Vecs::Thin };
    let r = unsafe { svd_into((m, n), (a, lda), s, (want, u, ldu), (want, vt, ldvt)) };
    unsafe { *info = r };
}

/// SVD `A = U Σ Vᵀ` (LAPACK's QR driver; here one-sided Jacobi). `jobu`/`jobvt` =
/// `'N'` or `'S'`; `'A'` is accepted where it equals `'S'` (jobu with m ≤ n,
/// jobvt with n ≤ m); `'O'` is not supported (`info = -1`/`-2`). A is left
/// unchanged. `lwork = -1` is a workspace query writing LAPACK's minimum
/// `max(1, 3 min(m,n) + max(m,n), 5 min(m,n))` into `work[0]`.
#[no_mangle]
pub unsafe extern "C" fn dgesvd_(
    jobu: *const c_char,
    jobvt: *const c_char,
    m: *const c_int,
    n: *const c_int,
    a: *mut f64,
    lda: *const c_int,
    s: *mut f64,
    u: *mut f64,
    ldu: *const c_int,
    vt: *mut f64,
    ldvt: *const c_int,
    work: *mut f64,
    lwork: *const c_int,
    info: *mut c_int,
) {
    let (jobu, jobvt) = unsafe { (ch(jobu), ch(jobvt)) };
    let (m, n, lda, ldu, ldvt, lwork) = unsafe { (*m, *n, *lda, *ldu, *ldvt, *lwork) };
    let mn = m.min(n).max(0);
    let mx = m.max(n).max(0);
    let minwrk = if m <= 0 || n <= 0 {
        1
    } else {
        (3 * mn + mx).max(5 * mn).max(1)
    };
    let lquery = lwork == -1;
    let ok_u = jobu == b'N' || jobu == b'S' || (jobu == b'A' && m <= n);
    let ok_vt = jobvt == b'N' || jobvt == b'S' || (jobvt == b'A' && n <= m);
    let wntuas = jobu == b'A' || jobu == b'S';
    let code = if !ok_u {
        -1
    } else if !ok_vt {
        -2
    } else if m < 0 {
        -3
    } else if n < 0 {
        -4
    } else if lda < m.max(1) {
        -6
    } else if ldu < 1 || (wntuas && ldu < m) {
        -9
    } else if ldvt < 1 || (jobvt == b'A' && ldvt < n) || (jobvt == b'S' && ldvt < mn) {
        -11
    } else if lwork < minwrk && !lquery {
        -13
    } else {
        0
    };
    unsafe { *info = code };
    if code != 0 {
        if code == -1 || code == -2 {
            eprintln!(
                " ** DGESVD (qpv-solve pure-Rust LAPACK): JOBU = '{}', JOBVT = '{}' not supported for {m}x{n}",
                jobu as char, jobvt as char
            );
        }
        return xerbla("DGESVD", -code);
    }
    if lquery {
        unsafe { *work = minwrk as f64 };
        return;
    }
    if m == 0 || n == 0 {
        return;
    }
    let (m, n) = (m as usize, n as usize);
    let (lda, ldu, ldvt) = (lda as usize, ldu as usize, ldvt as usize);
    let a = unsafe { slice(a as *const f64, mat_len(m, n, lda)) };
    let wu = if jobu == b'N' { Vecs::None } else { Vecs::Thin };
    let wv = if jobvt == b'N' {
        Vecs::None
    } else {
        Vecs::Thin
    };
    let r = unsafe { svd_into((m, n), (a, lda), s, (wu, u, ldu), (wv, vt, ldvt)) };
    unsafe { *info = r };
}
