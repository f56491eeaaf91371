//! LAPACK: `dpotrf_`, `dpotrs_`, `dsyevr_`, `dgesdd_`, `dgesvd_`.
//!
//! Argument checks and `info` codes follow the LAPACK documentation. The
//! eigen- and singular-value decompositions use nalgebra; the workspace
//! arguments are only used to answer workspace queries.
//!
//! # Safety (all functions)
//! Every pointer must be valid for the extent LAPACK documents for the given
//! dimensions and options (e.g. `Z` is not touched when `jobz = 'N'`).

use std::ffi::{c_char, c_int};

use nalgebra::{DMatrix, SymmetricEigen, SVD};

use super::{ch, mat_len, slice, slice_mut, xerbla};

/// Iteration cap for nalgebra's SVD (total implicit-QR sweeps); reaching it
/// means no convergence (LAPACK `info > 0`). Generous: typical use is ~2 per
/// singular value.
const SVD_MAX_ITER_PER_VALUE: usize = 1000;

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

    // Full symmetric matrix from the referenced triangle.
    let upper = uplo == b'U';
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

    let (vals, vecs): (Vec<f64>, Option<DMatrix<f64>>) = if !finite {
        let vecs = wantz.then(|| DMatrix::from_element(n, n, f64::NAN));
        (vec![f64::NAN; n], vecs)
    } else if wantz {
        let e = SymmetricEigen::new(s);
        (e.eigenvalues.as_slice().to_vec(), Some(e.eigenvectors))
    } else {
        (s.symmetric_eigenvalues().as_slice().to_vec(), None)
    };

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

/// Thin SVD of the m × n matrix in `a` into `s` (descending) and the
/// requested factors. Returns LAPACK's `info` (0, or 1 = no convergence).
unsafe fn svd_into(
    m: usize,
    n: usize,
    a: &[f64],
    lda: usize,
    s: *mut f64,
    want_u: Vecs,
    u: *mut f64,
    ldu: usize,
    want_vt: Vecs,
    vt: *mut f64,
    ldvt: usize,
) -> c_int {
    let k = m.min(n);
    let mut mat = DMatrix::<f64>::zeros(m, n);
    let mut finite = true;
    for j in 0..n {
        for i in 0..m {
            let v = a[j * lda + i];
            finite &= v.is_finite();
            mat[(i, j)] = v;
        }
    }
    let s = unsafe { slice_mut(s, k) };
    let (cu, cv) = (want_u == Vecs::Thin, want_vt == Vecs::Thin);
    if !finite {
        s.fill(f64::NAN);
        if cu {
            let u = unsafe { slice_mut(u, mat_len(m, k, ldu)) };
            for j in 0..k {
                u[j * ldu..j * ldu + m].fill(f64::NAN);
            }
        }
        if cv {
            let vt = unsafe { slice_mut(vt, mat_len(k, n, ldvt)) };
            for j in 0..n {
                vt[j * ldvt..j * ldvt + k].fill(f64::NAN);
            }
        }
        return 0;
    }
    let max_iter = SVD_MAX_ITER_PER_VALUE * (k + 1);
    let svd = match SVD::try_new(mat.clone(), cu, cv, f64::EPSILON, max_iter) {
        Some(svd) => svd,
        // Retry on the transpose (a different sweep path) before giving up.
        None => match SVD::try_new(mat.transpose(), cv, cu, f64::EPSILON, max_iter) {
            Some(t) => SVD {
                u: t.v_t.map(|vt| vt.transpose()),
                v_t: t.u.map(|u| u.transpose()),
                singular_values: t.singular_values,
            },
            None => return 1,
        },
    };
    s.copy_from_slice(svd.singular_values.as_slice());
    if cu {
        let src = svd.u.as_ref().expect("U requested");
        let u = unsafe { slice_mut(u, mat_len(m, k, ldu)) };
        for j in 0..k {
            for i in 0..m {
                u[j * ldu + i] = src[(i, j)];
            }
        }
    }
    if cv {
        let src = svd.v_t.as_ref().expect("Vt requested");
        let vt = unsafe { slice_mut(vt, mat_len(k, n, ldvt)) };
        for j in 0..n {
            for i in 0..k {
                vt[j * ldvt + i] = src[(i, j)];
            }
        }
    }
    0
}

/// SVD `A = U Σ Vᵀ` (LAPACK's divide-and-conquer driver; here nalgebra's
/// implicit-shift QR). `jobz = 'N'` (values only) or `'S'` (thin U, Vᵀ);
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
    let r = unsafe { svd_into(m, n, a, lda, s, want, u, ldu, want, vt, ldvt) };
    unsafe { *info = r };
}

/// SVD `A = U Σ Vᵀ` (LAPACK's QR driver; here nalgebra). `jobu`/`jobvt` =
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
    let r = unsafe { svd_into(m, n, a, lda, s, wu, u, ldu, wv, vt, ldvt) };
    unsafe { *info = r };
}
