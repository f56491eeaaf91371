//! Every exported BLAS/LAPACK routine against a straightforward reference:
//! random sizes (including n ≥ 4 and non-square shapes), every trans/uplo
//! option, padded leading dimensions (the padding must stay untouched),
//! alpha/beta ∈ {0, 1, other} (beta = 0 must not read C, alpha = 0 must not
//! read A/B), workspace queries, and the exact call sequences Clarabel uses.
//!
//! The routines (the `qpv-lapack` crate, which qpv-solve links and
//! re-exports as `qpv_solve::lapack` with its default `pure-lapack` feature)
//! are called through their C symbol names (an `extern "C"` block, as the
//! `blas`/`lapack` crates do), so this also checks the names and that
//! [`qpv_solve::lapack::ensure_linked`] pulls them into the link.
#![cfg(feature = "pure-lapack")]
#![allow(clippy::needless_range_loop)]

use std::ffi::{c_char, c_int};

extern "C" {
    fn dgemm_(
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
    );
    fn dgemv_(
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
    );
    fn dsymv_(
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
    );
    fn dsyrk_(
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
    );
    fn dsyr2k_(
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
    );
    fn dpotrf_(
        uplo: *const c_char,
        n: *const c_int,
        a: *mut f64,
        lda: *const c_int,
        info: *mut c_int,
    );
    fn dpotrs_(
        uplo: *const c_char,
        n: *const c_int,
        nrhs: *const c_int,
        a: *const f64,
        lda: *const c_int,
        b: *mut f64,
        ldb: *const c_int,
        info: *mut c_int,
    );
    fn dsyevr_(
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
        abstol: *const f64,
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
    );
    fn dgesdd_(
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
        iwork: *mut c_int,
        info: *mut c_int,
    );
    fn dgesvd_(
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
    );
}

// ---------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------

/// Small deterministic generator (xorshift64*), no extra dependency.
struct Rng(u64);
impl Rng {
    fn new(seed: u64) -> Self {
        qpv_solve::lapack::ensure_linked();
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [-1, 1).
    fn f(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
    /// Uniform in lo..=hi.
    fn int(&mut self, lo: usize, hi: usize) -> usize {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as usize
    }
    /// A column-major rows × cols matrix with leading dimension `ld`;
    /// padding rows hold the sentinel `PAD`.
    fn mat(&mut self, rows: usize, cols: usize, ld: usize) -> Vec<f64> {
        let mut a = vec![PAD; ld * cols.max(1)];
        for j in 0..cols {
            for i in 0..rows {
                a[j * ld + i] = self.f();
            }
        }
        a
    }
    fn scalar(&mut self) -> f64 {
        match self.int(0, 3) {
            0 => 0.0,
            1 => 1.0,
            _ => self.f() * 2.0,
        }
    }
}

/// Sentinel in padding rows: must never change and never leak into results.
const PAD: f64 = 7.77e77;

/// Every byte value, so a `CHARACTER*1` argument can point into static memory.
static CHARS: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        t[i] = i as u8;
        i += 1;
    }
    t
};

/// A Fortran `CHARACTER*1` argument.
fn c(b: u8) -> *const c_char {
    &CHARS[b as usize] as *const u8 as *const c_char
}

/// Asserts the padding rows (`rows..ld` of every column) still hold PAD.
fn assert_padding(a: &[f64], rows: usize, cols: usize, ld: usize, what: &str) {
    for j in 0..cols {
        for i in rows..ld {
            assert_eq!(a[j * ld + i], PAD, "{what}: padding ({i},{j}) overwritten");
        }
    }
}

fn close(x: f64, y: f64, scale: f64) -> bool {
    (x - y).abs() <= 1e-12 * (1.0 + scale)
}

/// Element (i, j) of op(X) where X is stored column-major with leading dim ld.
fn op(x: &[f64], ld: usize, t: bool, i: usize, j: usize) -> f64 {
    if t {
        x[i * ld + j]
    } else {
        x[j * ld + i]
    }
}

// ---------------------------------------------------------------------------
// BLAS
// ---------------------------------------------------------------------------

#[test]
fn dgemm_matches_reference() {
    let mut rng = Rng::new(1);
    for case in 0..400 {
        let ta = [b'N', b'T', b'C', b'n', b't'][case % 5];
        let tb = [b'N', b'T', b'T', b'n', b'N', b'C', b't'][case % 7];
        let (tat, tbt) = (
            !ta.eq_ignore_ascii_case(&b'N'),
            !tb.eq_ignore_ascii_case(&b'N'),
        );
        let (m, n, k) = if case < 20 {
            (case % 3, (case / 3) % 3, case % 2)
        } else if case < 70 {
            // The square sizes 2..=6 that dgemm_ specialises, each with
            // several of the transpose flags.
            let s = 2 + (case / 5) % 5;
            (s, s, s)
        } else {
            (rng.int(1, 9), rng.int(1, 9), rng.int(1, 9))
        };
        let (ar, ac) = if tat { (k, m) } else { (m, k) };
        let (br, bc) = if tbt { (n, k) } else { (k, n) };
        let lda = ar.max(1) + rng.int(0, 3);
        let ldb = br.max(1) + rng.int(0, 3);
        let ldc = m.max(1) + rng.int(0, 3);
        let (alpha, beta) = (rng.scalar(), rng.scalar());
        let mut a = rng.mat(ar, ac, lda);
        let mut b = rng.mat(br, bc, ldb);
        let mut cm = rng.mat(m, n, ldc);
        if beta == 0.0 {
            // beta = 0: C must not be read.
            for j in 0..n {
                cm[j * ldc..j * ldc + m].fill(f64::NAN);
            }
        }
        let c0 = cm.clone();
        if alpha == 0.0 {
            // alpha = 0: A and B must not be read.
            a.iter_mut().for_each(|v| *v = f64::NAN);
            b.iter_mut().for_each(|v| *v = f64::NAN);
        }
        let (mi, ni, ki) = (m as c_int, n as c_int, k as c_int);
        let (ldai, ldbi, ldci) = (lda as c_int, ldb as c_int, ldc as c_int);
        unsafe {
            dgemm_(
                c(ta),
                c(tb),
                &mi,
                &ni,
                &ki,
                &alpha,
                a.as_ptr(),
                &ldai,
                b.as_ptr(),
                &ldbi,
                &beta,
                cm.as_mut_ptr(),
                &ldci,
            );
        }
        for j in 0..n {
            for i in 0..m {
                let mut s = 0.0;
                if alpha != 0.0 {
                    for l in 0..k {
                        s += op(&a, lda, tat, i, l) * op(&b, ldb, tbt, l, j);
                    }
                }
                let cij = if beta == 0.0 {
                    0.0
                } else {
                    beta * c0[j * ldc + i]
                };
                let want = alpha * s + cij;
                let got = cm[j * ldc + i];
                assert!(
                    close(got, want, k as f64),
                    "dgemm {} {} m={m} n={n} k={k} alpha={alpha} beta={beta}: ({i},{j}) {got} vs {want}",
                    ta as char,
                    tb as char
                );
            }
        }
        assert_padding(&cm, m, n, ldc, "dgemm C");
    }
}

#[test]
fn dgemv_matches_reference() {
    let mut rng = Rng::new(2);
    for case in 0..400 {
        let t = [b'N', b'T', b'C'][case % 3];
        let tt = t != b'N';
        let (m, n) = if case < 12 {
            (case % 3, (case / 3) % 4)
        } else {
            (rng.int(1, 10), rng.int(1, 10))
        };
        let lda = m.max(1) + rng.int(0, 3);
        let incx: isize = [1, 1, 2, -1, -3][rng.int(0, 4)];
        let incy: isize = [1, 1, 3, -2, -1][rng.int(0, 4)];
        let (lx, ly) = if tt { (m, n) } else { (n, m) };
        let (alpha, beta) = (rng.scalar(), rng.scalar());
        let a = rng.mat(m, n, lda);
        let x: Vec<f64> = (0..(lx.max(1) - 1) * incx.unsigned_abs() + 1)
            .map(|_| rng.f())
            .collect();
        let mut y: Vec<f64> = (0..(ly.max(1) - 1) * incy.unsigned_abs() + 1)
            .map(|_| rng.f())
            .collect();
        let at = |v: &[f64], i: usize, len: usize, inc: isize| {
            if inc > 0 {
                v[i * inc as usize]
            } else {
                v[(len - 1 - i) * inc.unsigned_abs()]
            }
        };
        let yidx = |i: usize| {
            if incy > 0 {
                i * incy as usize
            } else {
                (ly - 1 - i) * incy.unsigned_abs()
            }
        };
        if beta == 0.0 {
            for i in 0..ly {
                y[yidx(i)] = f64::NAN;
            }
        }
        let y0 = y.clone();
        let (mi, ni, ldai) = (m as c_int, n as c_int, lda as c_int);
        let (incxi, incyi) = (incx as c_int, incy as c_int);
        unsafe {
            dgemv_(
                c(t),
                &mi,
                &ni,
                &alpha,
                a.as_ptr(),
                &ldai,
                x.as_ptr(),
                &incxi,
                &beta,
                y.as_mut_ptr(),
                &incyi,
            );
        }
        if m == 0 || n == 0 {
            assert!(
                y.iter().zip(&y0).all(|(p, q)| p.to_bits() == q.to_bits()),
                "quick return"
            );
            continue;
        }
        for i in 0..ly {
            let mut s = 0.0;
            for l in 0..lx {
                s += op(&a, lda, tt, i, l) * at(&x, l, lx, incx);
            }
            let yi = if beta == 0.0 { 0.0 } else { beta * y0[yidx(i)] };
            let want = alpha * s + yi;
            let got = y[yidx(i)];
            assert!(
                close(got, want, lx as f64),
                "dgemv {} m={m} n={n} incx={incx} incy={incy}: {got} vs {want}",
                t as char
            );
        }
        // Entries between strided elements are untouched.
        for p in 0..y.len() {
            if (0..ly).all(|i| yidx(i) != p) {
                assert_eq!(y[p].to_bits(), y0[p].to_bits());
            }
        }
    }
}

#[test]
fn dsymv_matches_reference() {
    let mut rng = Rng::new(3);
    for case in 0..300 {
        let uplo = [b'U', b'L', b'u', b'l'][case % 4];
        let upper = uplo.eq_ignore_ascii_case(&b'U');
        let n = if case < 8 { case % 3 } else { rng.int(1, 10) };
        let lda = n.max(1) + rng.int(0, 3);
        let incx: isize = [1, 1, 2, -1][rng.int(0, 3)];
        let incy: isize = [1, 1, 2, -2][rng.int(0, 3)];
        let (alpha, beta) = (rng.scalar(), rng.scalar());
        let mut a = rng.mat(n, n, lda);
        // The unreferenced triangle holds NaN: it must not be read.
        for j in 0..n {
            for i in 0..n {
                if (upper && i > j) || (!upper && i < j) {
                    a[j * lda + i] = f64::NAN;
                }
            }
        }
        let sym = |i: usize, j: usize| {
            let (i, j) = if (upper && i > j) || (!upper && i < j) {
                (j, i)
            } else {
                (i, j)
            };
            a[j * lda + i]
        };
        let x: Vec<f64> = (0..(n.max(1) - 1) * incx.unsigned_abs() + 1)
            .map(|_| rng.f())
            .collect();
        let mut y: Vec<f64> = (0..(n.max(1) - 1) * incy.unsigned_abs() + 1)
            .map(|_| rng.f())
            .collect();
        let idx = |i: usize, inc: isize| {
            if inc > 0 {
                i * inc as usize
            } else {
                (n - 1 - i) * inc.unsigned_abs()
            }
        };
        if beta == 0.0 {
            for i in 0..n {
                y[idx(i, incy)] = f64::NAN;
            }
        }
        let y0 = y.clone();
        let (ni, ldai, incxi, incyi) = (n as c_int, lda as c_int, incx as c_int, incy as c_int);
        unsafe {
            dsymv_(
                c(uplo),
                &ni,
                &alpha,
                a.as_ptr(),
                &ldai,
                x.as_ptr(),
                &incxi,
                &beta,
                y.as_mut_ptr(),
                &incyi,
            );
        }
        for i in 0..n {
            let s: f64 = (0..n).map(|l| sym(i, l) * x[idx(l, incx)]).sum();
            let yi = if beta == 0.0 {
                0.0
            } else {
                beta * y0[idx(i, incy)]
            };
            let want = alpha * s + yi;
            let got = y[idx(i, incy)];
            assert!(
                close(got, want, n as f64),
                "dsymv {} n={n}: {got} vs {want}",
                uplo as char
            );
        }
    }
}

/// Shared check for syrk/syr2k: `want(i, j)` for the referenced triangle, the
/// other triangle and the padding unchanged.
fn check_sym_update(
    cm: &[f64],
    c0: &[f64],
    (n, ldc): (usize, usize),
    upper: bool,
    (beta, scale): (f64, f64),
    prod: impl Fn(usize, usize) -> f64,
    what: &str,
) {
    for j in 0..n {
        for i in 0..n {
            let got = cm[j * ldc + i];
            let inside = if upper { i <= j } else { i >= j };
            if inside {
                let cij = if beta == 0.0 {
                    0.0
                } else {
                    beta * c0[j * ldc + i]
                };
                let want = prod(i, j) + cij;
                assert!(close(got, want, scale), "{what} ({i},{j}): {got} vs {want}");
            } else {
                assert_eq!(
                    got.to_bits(),
                    c0[j * ldc + i].to_bits(),
                    "{what}: other triangle ({i},{j}) touched"
                );
            }
        }
    }
    assert_padding(cm, n, n, ldc, what);
}

#[test]
fn dsyrk_matches_reference() {
    let mut rng = Rng::new(4);
    for case in 0..400 {
        let uplo = [b'U', b'L'][case % 2];
        let trans = [b'N', b'T', b'N', b'C'][(case / 2) % 4];
        let (upper, t) = (uplo == b'U', trans != b'N');
        let (n, k) = if case < 16 {
            (case % 3, (case / 3) % 3)
        } else {
            (rng.int(1, 10), rng.int(1, 10))
        };
        let (ar, ac) = if t { (k, n) } else { (n, k) };
        let lda = ar.max(1) + rng.int(0, 3);
        let ldc = n.max(1) + rng.int(0, 3);
        let (alpha, beta) = (rng.scalar(), rng.scalar());
        let mut a = rng.mat(ar, ac, lda);
        let mut cm = rng.mat(n, n, ldc);
        if beta == 0.0 {
            for j in 0..n {
                for i in 0..n {
                    if (upper && i <= j) || (!upper && i >= j) {
                        cm[j * ldc + i] = f64::NAN;
                    }
                }
            }
        }
        if alpha == 0.0 {
            a.iter_mut().for_each(|v| *v = f64::NAN);
        }
        let c0 = cm.clone();
        let (ni, ki, ldai, ldci) = (n as c_int, k as c_int, lda as c_int, ldc as c_int);
        unsafe {
            dsyrk_(
                c(uplo),
                c(trans),
                &ni,
                &ki,
                &alpha,
                a.as_ptr(),
                &ldai,
                &beta,
                cm.as_mut_ptr(),
                &ldci,
            );
        }
        // op(A) is n × k: A (N) or Aᵀ (T).
        let prod = |i: usize, j: usize| {
            if alpha == 0.0 {
                return 0.0;
            }
            alpha
                * (0..k)
                    .map(|l| op(&a, lda, t, i, l) * op(&a, lda, t, j, l))
                    .sum::<f64>()
        };
        let what = format!(
            "dsyrk {} {} n={n} k={k} alpha={alpha} beta={beta}",
            uplo as char, trans as char
        );
        check_sym_update(&cm, &c0, (n, ldc), upper, (beta, k as f64), prod, &what);
    }
}

#[test]
fn dsyr2k_matches_reference() {
    let mut rng = Rng::new(5);
    for case in 0..400 {
        let uplo = [b'U', b'L'][case % 2];
        let trans = [b'N', b'T', b'N', b'C'][(case / 2) % 4];
        let (upper, t) = (uplo == b'U', trans != b'N');
        let (n, k) = if case < 16 {
            (case % 3, (case / 3) % 3)
        } else {
            (rng.int(1, 10), rng.int(1, 10))
        };
        let (ar, ac) = if t { (k, n) } else { (n, k) };
        let lda = ar.max(1) + rng.int(0, 3);
        let ldb = ar.max(1) + rng.int(0, 3);
        let ldc = n.max(1) + rng.int(0, 3);
        let (alpha, beta) = (rng.scalar(), rng.scalar());
        let mut a = rng.mat(ar, ac, lda);
        let mut b = rng.mat(ar, ac, ldb);
        let mut cm = rng.mat(n, n, ldc);
        if beta == 0.0 {
            for j in 0..n {
                for i in 0..n {
                    if (upper && i <= j) || (!upper && i >= j) {
                        cm[j * ldc + i] = f64::NAN;
                    }
                }
            }
        }
        if alpha == 0.0 {
            a.iter_mut().for_each(|v| *v = f64::NAN);
            b.iter_mut().for_each(|v| *v = f64::NAN);
        }
        let c0 = cm.clone();
        let (ni, ki) = (n as c_int, k as c_int);
        let (ldai, ldbi, ldci) = (lda as c_int, ldb as c_int, ldc as c_int);
        unsafe {
            dsyr2k_(
                c(uplo),
                c(trans),
                &ni,
                &ki,
                &alpha,
                a.as_ptr(),
                &ldai,
                b.as_ptr(),
                &ldbi,
                &beta,
                cm.as_mut_ptr(),
                &ldci,
            );
        }
        let prod = |i: usize, j: usize| {
            if alpha == 0.0 {
                return 0.0;
            }
            alpha
                * (0..k)
                    .map(|l| {
                        op(&a, lda, t, i, l) * op(&b, ldb, t, j, l)
                            + op(&b, ldb, t, i, l) * op(&a, lda, t, j, l)
                    })
                    .sum::<f64>()
        };
        let what = format!(
            "dsyr2k {} {} n={n} k={k} alpha={alpha} beta={beta}",
            uplo as char, trans as char
        );
        check_sym_update(&cm, &c0, (n, ldc), upper, (beta, k as f64), prod, &what);
    }
}

#[test]
fn blas_rejects_illegal_arguments_without_touching_output() {
    let _rng = Rng::new(0);
    let a = [1.0; 16];
    let mut cm = [5.0; 16];
    let (two, one, zero) = (2 as c_int, 1 as c_int, 0.0f64);
    unsafe {
        // Invalid trans character.
        dgemm_(
            c(b'X'),
            c(b'N'),
            &two,
            &two,
            &two,
            &1.0,
            a.as_ptr(),
            &two,
            a.as_ptr(),
            &two,
            &zero,
            cm.as_mut_ptr(),
            &two,
        );
        // lda too small.
        dsyrk_(
            c(b'U'),
            c(b'N'),
            &two,
            &two,
            &1.0,
            a.as_ptr(),
            &one,
            &zero,
            cm.as_mut_ptr(),
            &two,
        );
    }
    assert!(cm.iter().all(|v| *v == 5.0));
}

// ---------------------------------------------------------------------------
// LAPACK references
// ---------------------------------------------------------------------------

/// Cyclic Jacobi eigenvalues of a dense symmetric matrix (ascending): an
/// independent, slow, very accurate reference.
fn jacobi_eigenvalues(mut a: Vec<Vec<f64>>) -> Vec<f64> {
    let n = a.len();
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        if off < 1e-30 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if a[p][q].abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let (cs, sn) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
                for k in 0..n {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = cs * akp - sn * akq;
                    a[k][q] = sn * akp + cs * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = cs * apk - sn * aqk;
                    a[q][k] = sn * apk + cs * aqk;
                }
            }
        }
    }
    let mut w: Vec<f64> = (0..n).map(|i| a[i][i]).collect();
    w.sort_by(f64::total_cmp);
    w
}

fn random_symmetric(rng: &mut Rng, n: usize) -> Vec<Vec<f64>> {
    let mut s = vec![vec![0.0; n]; n];
    for j in 0..n {
        for i in 0..=j {
            let v = rng.f();
            s[i][j] = v;
            s[j][i] = v;
        }
    }
    s
}

/// Stores the `uplo` triangle of `s` with leading dimension `ld`; the other
/// triangle holds NaN (must not be read).
fn store_triangle(s: &[Vec<f64>], ld: usize, upper: bool) -> Vec<f64> {
    let n = s.len();
    let mut a = vec![PAD; ld * n.max(1)];
    for j in 0..n {
        for i in 0..n {
            a[j * ld + i] = if (upper && i <= j) || (!upper && i >= j) {
                s[i][j]
            } else {
                f64::NAN
            };
        }
    }
    a
}

// ---------------------------------------------------------------------------
// Cholesky
// ---------------------------------------------------------------------------

fn random_spd(rng: &mut Rng, n: usize) -> Vec<Vec<f64>> {
    let b: Vec<Vec<f64>> = (0..n).map(|_| (0..n).map(|_| rng.f()).collect()).collect();
    let mut s = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..n {
            s[i][j] =
                (0..n).map(|l| b[i][l] * b[j][l]).sum::<f64>() + if i == j { 0.5 } else { 0.0 };
        }
    }
    s
}

#[test]
fn dpotrf_dpotrs_match_reference() {
    let mut rng = Rng::new(6);
    for case in 0..200 {
        let uplo = [b'U', b'L'][case % 2];
        let upper = uplo == b'U';
        let n = if case < 6 { case % 3 } else { rng.int(1, 12) };
        let lda = n.max(1) + rng.int(0, 3);
        let s = random_spd(&mut rng, n);
        let mut a = store_triangle(&s, lda, upper);
        let (ni, ldai) = (n as c_int, lda as c_int);
        let mut info = -99;
        unsafe { dpotrf_(c(uplo), &ni, a.as_mut_ptr(), &ldai, &mut info) };
        assert_eq!(info, 0, "dpotrf {} n={n}", uplo as char);
        assert_padding(&a, n, n, lda, "dpotrf");
        // Factor F (upper U or lower L) from the referenced triangle;
        // the other triangle must be untouched (still NaN).
        let f = |i: usize, j: usize| -> f64 {
            if (upper && i <= j) || (!upper && i >= j) {
                a[j * lda + i]
            } else {
                0.0
            }
        };
        for j in 0..n {
            for i in 0..n {
                if (upper && i > j) || (!upper && i < j) {
                    assert!(a[j * lda + i].is_nan(), "dpotrf touched the other triangle");
                }
                // A = UᵀU or LLᵀ.
                let r: f64 = if upper {
                    (0..n).map(|l| f(l, i) * f(l, j)).sum()
                } else {
                    (0..n).map(|l| f(i, l) * f(j, l)).sum()
                };
                assert!(
                    (r - s[i][j]).abs() < 1e-12 * n as f64 * 4.0,
                    "dpotrf reconstruct ({i},{j})"
                );
            }
            assert!(f(j, j) > 0.0);
        }
        // Solve with several right-hand sides and padded ldb.
        let nrhs = rng.int(0, 4);
        let ldb = n.max(1) + rng.int(0, 2);
        let x = rng.mat(n, nrhs, ldb);
        let mut bm = vec![PAD; ldb * nrhs.max(1)];
        for r in 0..nrhs {
            for i in 0..n {
                bm[r * ldb + i] = (0..n).map(|l| s[i][l] * x[r * ldb + l]).sum();
            }
        }
        let (nrhsi, ldbi) = (nrhs as c_int, ldb as c_int);
        unsafe {
            dpotrs_(
                c(uplo),
                &ni,
                &nrhsi,
                a.as_ptr(),
                &ldai,
                bm.as_mut_ptr(),
                &ldbi,
                &mut info,
            )
        };
        assert_eq!(info, 0);
        for r in 0..nrhs {
            for i in 0..n {
                assert!(
                    (bm[r * ldb + i] - x[r * ldb + i]).abs() < 1e-8,
                    "dpotrs {} n={n}",
                    uplo as char
                );
            }
        }
        assert_padding(&bm, n, nrhs, ldb, "dpotrs B");
    }
}

#[test]
fn dpotrf_reports_the_failing_minor() {
    let _rng = Rng::new(0);
    // Leading minors: 2 > 0, det [[2,1],[1,2]] = 3 > 0, 3rd minor < 0.
    let s = [
        [2.0, 1.0, 3.0, 0.0],
        [1.0, 2.0, 0.0, 0.0],
        [3.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    for uplo in [b'U', b'L'] {
        let mut a: Vec<f64> = (0..4).flat_map(|j| (0..4).map(move |i| s[i][j])).collect();
        let (n, mut info) = (4 as c_int, 0);
        unsafe { dpotrf_(c(uplo), &n, a.as_mut_ptr(), &n, &mut info) };
        assert_eq!(info, 3, "uplo {}", uplo as char);
    }
    // NaN on the diagonal is not positive definite either.
    let mut a = vec![1.0, 0.0, 0.0, f64::NAN];
    let (n, mut info) = (2 as c_int, 0);
    unsafe { dpotrf_(c(b'L'), &n, a.as_mut_ptr(), &n, &mut info) };
    assert_eq!(info, 2);
    // Illegal argument.
    unsafe { dpotrf_(c(b'X'), &n, a.as_mut_ptr(), &n, &mut info) };
    assert_eq!(info, -1);
}

// ---------------------------------------------------------------------------
// Symmetric eigenproblem
// ---------------------------------------------------------------------------

/// Calls dsyevr exactly like Clarabel's `EigEngine::syevr`: a workspace query
/// (lwork = liwork = -1) into 1-element work vectors, resize, then the call.
/// Returns (m, w, z, isuppz).
fn syevr_like_clarabel(
    (jobz, range, uplo): (u8, u8, u8),
    a: &mut [f64],
    n: usize,
    lda: usize,
    ldz: usize,
    (vl, vu, il, iu): (f64, f64, c_int, c_int),
) -> (usize, Vec<f64>, Vec<f64>, Vec<c_int>) {
    let mut work = vec![1.0];
    let mut iwork: Vec<c_int> = vec![1];
    let mut isuppz: Vec<c_int> = vec![0; 2 * n];
    let mut w = vec![f64::NAN; n];
    let mut z = if jobz == b'V' {
        vec![PAD; ldz * n]
    } else {
        vec![0.0]
    };
    let (ni, ldai, ldzi) = (n as c_int, lda as c_int, ldz as c_int);
    let (mut lwork, mut liwork, mut m, mut info) = (-1, -1, -7, -7);
    for pass in 0..2 {
        unsafe {
            dsyevr_(
                c(jobz),
                c(range),
                c(uplo),
                &ni,
                a.as_mut_ptr(),
                &ldai,
                &vl,
                &vu,
                &il,
                &iu,
                &-1.0,
                &mut m,
                w.as_mut_ptr(),
                z.as_mut_ptr(),
                &ldzi,
                isuppz.as_mut_ptr(),
                work.as_mut_ptr(),
                &lwork,
                iwork.as_mut_ptr(),
                &liwork,
                &mut info,
            );
        }
        assert_eq!(info, 0);
        if pass == 0 {
            assert!(work[0] >= (26 * n).max(1) as f64, "lwork query {}", work[0]);
            assert!(
                iwork[0] >= (10 * n).max(1) as c_int,
                "liwork query {}",
                iwork[0]
            );
            lwork = work[0] as c_int;
            liwork = iwork[0];
            work.resize(lwork as usize, 0.0);
            iwork.resize(liwork as usize, 0);
        }
    }
    (m as usize, w, z, isuppz)
}

#[test]
fn dsyevr_matches_reference() {
    let mut rng = Rng::new(7);
    for case in 0..240 {
        let jobz = [b'N', b'V'][case % 2];
        let uplo = [b'U', b'U', b'L', b'L'][case % 4];
        let range = [
            b'A', b'A', b'A', b'A', b'I', b'I', b'I', b'I', b'V', b'V', b'V', b'V',
        ][case % 12];
        let n = if case < 24 { case % 5 } else { rng.int(4, 16) };
        let lda = n.max(1) + rng.int(0, 3);
        let ldz = n.max(1) + rng.int(0, 2);
        let mut s = random_symmetric(&mut rng, n);
        if case % 7 == 3 && n >= 4 {
            // Repeated eigenvalues: a scaled identity block.
            for i in 0..n {
                for j in 0..n {
                    s[i][j] = if i == j {
                        2.0
                    } else if i < 2 && j < 2 {
                        0.0
                    } else {
                        s[i][j] * 0.1
                    };
                }
            }
        }
        let reference = jacobi_eigenvalues(s.clone());
        let (il, iu) = if n == 0 {
            (1, 0)
        } else {
            let il = rng.int(1, n);
            (il as c_int, rng.int(il, n) as c_int)
        };
        let (vl, vu) = if n == 0 {
            (0.0, 1.0)
        } else {
            (
                reference[0] + 0.3 * (reference[n - 1] - reference[0]) - 1e-3,
                reference[n - 1] + 1.0,
            )
        };
        let mut a = store_triangle(&s, lda, uplo == b'U');
        let (m, w, z, isuppz) =
            syevr_like_clarabel((jobz, range, uplo), &mut a, n, lda, ldz, (vl, vu, il, iu));
        let want: Vec<f64> = match range {
            b'A' => reference.clone(),
            b'I' => reference[(il as usize - 1).min(n)..(iu as usize).min(n)].to_vec(),
            _ => reference
                .iter()
                .copied()
                .filter(|&x| x > vl && x <= vu)
                .collect(),
        };
        assert_eq!(
            m,
            want.len(),
            "dsyevr {} {} {} n={n}: m",
            jobz as char,
            range as char,
            uplo as char
        );
        for k in 0..m {
            assert!(
                (w[k] - want[k]).abs() < 1e-12 * (1.0 + n as f64),
                "eigenvalue {k}: {} vs {}",
                w[k],
                want[k]
            );
            if k > 0 {
                assert!(w[k] >= w[k - 1], "ascending");
            }
        }
        if jobz == b'V' {
            // Residual ‖S z − λ z‖, orthonormality, support indices.
            for k in 0..m {
                let zk = &z[k * ldz..k * ldz + n];
                for i in 0..n {
                    let r: f64 = (0..n).map(|l| s[i][l] * zk[l]).sum::<f64>() - w[k] * zk[i];
                    assert!(r.abs() < 1e-11 * (1.0 + n as f64), "residual");
                }
                for q in 0..m {
                    let zq = &z[q * ldz..q * ldz + n];
                    let d: f64 = zk.iter().zip(zq).map(|(p, r)| p * r).sum();
                    assert!(
                        (d - if k == q { 1.0 } else { 0.0 }).abs() < 1e-11,
                        "orthonormal"
                    );
                }
                let (first, last) = (isuppz[2 * k] as usize, isuppz[2 * k + 1] as usize);
                assert!(1 <= first && first <= last && last <= n);
                assert!(zk[..first - 1].iter().chain(&zk[last..]).all(|v| *v == 0.0));
            }
            assert_padding(&z, n, m, ldz, "dsyevr Z");
        }
    }
}

#[test]
fn dsyevr_special_inputs() {
    let _rng = Rng::new(0);
    // jobz = 'N' with a 1-element dummy Z, and non-finite input → NaN, info 0.
    let n = 4;
    let mut a = vec![1.0; n * n];
    a[5] = f64::NAN;
    let (m, w, _, _) = syevr_like_clarabel((b'N', b'A', b'U'), &mut a, n, n, n, (0.0, 0.0, 0, 0));
    assert_eq!(m, n);
    assert!(w.iter().all(|v| v.is_nan()));
    // Diagonal input: exact eigenvalues.
    let mut a = vec![0.0; n * n];
    for (i, d) in [3.0, -1.0, 2.0, 0.5].iter().enumerate() {
        a[i * n + i] = *d;
    }
    let (_, w, _, _) = syevr_like_clarabel((b'V', b'A', b'U'), &mut a, n, n, n, (0.0, 0.0, 0, 0));
    assert_eq!(w, vec![-1.0, 0.5, 2.0, 3.0]);
    // Illegal arguments are reported in info.
    let (ni, mut m, mut info) = (n as c_int, 0, 0);
    let (mut work, mut iwork, mut isuppz) = (vec![0.0; 26 * n], vec![0; 10 * n], vec![0; 2 * n]);
    let mut wv = vec![0.0; n];
    let mut z = vec![0.0];
    for (jobz, range, uplo, lwork, want) in [
        (b'X', b'A', b'U', 26 * n as c_int, -1),
        (b'N', b'X', b'U', 26 * n as c_int, -2),
        (b'N', b'A', b'X', 26 * n as c_int, -3),
        (b'N', b'A', b'U', 5, -18),
    ] {
        unsafe {
            dsyevr_(
                c(jobz),
                c(range),
                c(uplo),
                &ni,
                a.as_mut_ptr(),
                &ni,
                &0.0,
                &0.0,
                &0,
                &0,
                &-1.0,
                &mut m,
                wv.as_mut_ptr(),
                z.as_mut_ptr(),
                &ni,
                isuppz.as_mut_ptr(),
                work.as_mut_ptr(),
                &lwork,
                iwork.as_mut_ptr(),
                &(10 * n as c_int),
                &mut info,
            );
        }
        assert_eq!(info, want);
    }
}

// ---------------------------------------------------------------------------
// SVD
// ---------------------------------------------------------------------------

/// dgesdd/dgesvd exactly like Clarabel's `SVDEngine::factorblas`: query
/// (lwork = -1) into a 1-element work vector, resize, call.
fn svd_like_clarabel(
    gesdd: bool,
    job: u8,
    a: &mut [f64],
    (m, n): (usize, usize),
    (lda, ldu, ldvt): (usize, usize, usize),
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let k = m.min(n);
    let mut s = vec![f64::NAN; k];
    let mut u = vec![PAD; ldu * k.max(1)];
    let mut vt = vec![PAD; ldvt * n.max(1)];
    let mut work = vec![1.0];
    let mut iwork: Vec<c_int> = vec![1];
    let (mi, ni, ldai, ldui, ldvti) = (
        m as c_int,
        n as c_int,
        lda as c_int,
        ldu as c_int,
        ldvt as c_int,
    );
    let (mut lwork, mut info) = (-1, -7);
    for pass in 0..2 {
        if gesdd {
            iwork.resize(8 * k, 0);
            unsafe {
                dgesdd_(
                    c(job),
                    &mi,
                    &ni,
                    a.as_mut_ptr(),
                    &ldai,
                    s.as_mut_ptr(),
                    u.as_mut_ptr(),
                    &ldui,
                    vt.as_mut_ptr(),
                    &ldvti,
                    work.as_mut_ptr(),
                    &lwork,
                    iwork.as_mut_ptr(),
                    &mut info,
                );
            }
        } else {
            unsafe {
                dgesvd_(
                    c(job),
                    c(job),
                    &mi,
                    &ni,
                    a.as_mut_ptr(),
                    &ldai,
                    s.as_mut_ptr(),
                    u.as_mut_ptr(),
                    &ldui,
                    vt.as_mut_ptr(),
                    &ldvti,
                    work.as_mut_ptr(),
                    &lwork,
                    &mut info,
                );
            }
        }
        assert_eq!(info, 0);
        if pass == 0 {
            let (mn, mx) = (k, m.max(n));
            let min = if m == 0 || n == 0 {
                1
            } else if !gesdd {
                (3 * mn + mx).max(5 * mn)
            } else if job == b'N' {
                3 * mn + mx.max(7 * mn)
            } else {
                4 * mn * mn + 7 * mn
            };
            assert!(work[0] >= min as f64, "lwork query {} < {min}", work[0]);
            lwork = work[0] as c_int;
            work.resize(lwork as usize, 0.0);
        }
    }
    (s, u, vt)
}

fn check_svd(gesdd: bool, rng: &mut Rng, cases: usize) {
    for case in 0..cases {
        let job = [b'S', b'S', b'N'][case % 3];
        let (m, n) = if case < 9 {
            (case % 3, (case / 3) % 3)
        } else {
            (rng.int(1, 12), rng.int(1, 12))
        };
        let k = m.min(n);
        let lda = m.max(1) + rng.int(0, 3);
        let ldu = m.max(1) + rng.int(0, 2);
        let ldvt = k.max(1) + rng.int(0, 2);
        let mut a = rng.mat(m, n, lda);
        if case % 5 == 4 && n >= 2 && m >= 1 {
            // Rank deficient: duplicate a column.
            for i in 0..m {
                a[lda + i] = a[i];
            }
        }
        let a0 = a.clone();
        let (s, u, vt) = svd_like_clarabel(gesdd, job, &mut a, (m, n), (lda, ldu, ldvt));
        let name = format!(
            "{} job={} m={m} n={n}",
            if gesdd { "dgesdd" } else { "dgesvd" },
            job as char
        );
        // Singular values: descending, = sqrt(eig(AᵀA)) from the Jacobi reference.
        let ata: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..m).map(|l| a0[i * lda + l] * a0[j * lda + l]).sum())
                    .collect()
            })
            .collect();
        let mut want: Vec<f64> = jacobi_eigenvalues(ata)
            .into_iter()
            .rev()
            .take(k)
            .map(|x| x.max(0.0).sqrt())
            .collect();
        want.resize(k, 0.0);
        for i in 0..k {
            assert!(
                (s[i] - want[i]).abs() < 1e-7,
                "{name}: σ{i} {} vs {} s={s:?} want={want:?} a0={a0:?} lda={lda} case={case}",
                s[i],
                want[i]
            );
            assert!(s[i] >= 0.0 && (i == 0 || s[i] <= s[i - 1]), "{name}: order");
        }
        if job == b'S' && k > 0 {
            // A = U Σ Vᵀ, UᵀU = I, VᵀV = I.
            for j in 0..n {
                for i in 0..m {
                    let r: f64 = (0..k)
                        .map(|l| u[l * ldu + i] * s[l] * vt[j * ldvt + l])
                        .sum();
                    assert!(
                        (r - a0[j * lda + i]).abs() < 1e-12 * 10.0 * (k as f64),
                        "{name}: reconstruct"
                    );
                }
            }
            for p in 0..k {
                for q in 0..k {
                    let uu: f64 = (0..m).map(|i| u[p * ldu + i] * u[q * ldu + i]).sum();
                    let vv: f64 = (0..n).map(|j| vt[j * ldvt + p] * vt[j * ldvt + q]).sum();
                    let e = if p == q { 1.0 } else { 0.0 };
                    assert!(
                        (uu - e).abs() < 1e-11 && (vv - e).abs() < 1e-11,
                        "{name}: orthonormal"
                    );
                }
            }
            assert_padding(&u, m, k, ldu, "U");
            assert_padding(&vt, k, n, ldvt, "Vt");
        }
        if job == b'N' {
            assert!(
                u.iter().all(|v| *v == PAD) && vt.iter().all(|v| *v == PAD),
                "{name}: U/Vt touched"
            );
        }
    }
}

#[test]
fn dgesdd_matches_reference() {
    check_svd(true, &mut Rng::new(8), 240);
}

#[test]
fn dgesvd_matches_reference() {
    check_svd(false, &mut Rng::new(9), 240);
}

#[test]
fn svd_special_inputs() {
    let _rng = Rng::new(0);
    // Non-finite input: NaN out, info 0 (no abort inside the FFI call).
    let mut a = vec![1.0, f64::NAN, 0.0, 2.0, 1.0, 3.0, 4.0, 0.0];
    let (s, _, _) = svd_like_clarabel(true, b'S', &mut a, (4, 2), (4, 4, 2));
    assert!(s.iter().all(|v| v.is_nan()));
    // Unsupported jobz = 'O' and jobz = 'A' for a non-square matrix: info = -1.
    let (m, n) = (3 as c_int, 2 as c_int);
    let mut a = vec![1.0; 6];
    let (mut s, mut u, mut vt, mut work, mut iwork) = (
        vec![0.0; 2],
        vec![0.0; 9],
        vec![0.0; 4],
        vec![0.0; 100],
        vec![0; 16],
    );
    let mut info = 0;
    for job in [b'O', b'A'] {
        unsafe {
            dgesdd_(
                c(job),
                &m,
                &n,
                a.as_mut_ptr(),
                &m,
                s.as_mut_ptr(),
                u.as_mut_ptr(),
                &m,
                vt.as_mut_ptr(),
                &n,
                work.as_mut_ptr(),
                &100,
                iwork.as_mut_ptr(),
                &mut info,
            );
        }
        assert_eq!(info, -1);
    }
    // Too small a workspace.
    unsafe {
        dgesvd_(
            c(b'S'),
            c(b'S'),
            &m,
            &n,
            a.as_mut_ptr(),
            &m,
            s.as_mut_ptr(),
            u.as_mut_ptr(),
            &m,
            vt.as_mut_ptr(),
            &n,
            work.as_mut_ptr(),
            &2,
            &mut info,
        );
    }
    assert_eq!(info, -13);
}

#[test]
fn ensure_linked_lists_every_symbol() {
    qpv_solve::lapack::ensure_linked();
    assert_eq!(qpv_solve::lapack::SYMBOLS.len(), 10);
}
/// Thin SVD through dgesdd (jobz = 'S') of a dense row-major matrix; checks
/// the factorisation to `tol` relative to max|A| and returns σ.
fn check_svd_dense(a: &[Vec<f64>], tol: f64, what: &str) -> Vec<f64> {
    let (m, n) = (a.len(), a[0].len());
    let k = m.min(n);
    let mut col: Vec<f64> = (0..n).flat_map(|j| (0..m).map(move |i| a[i][j])).collect();
    let (s, u, vt) = svd_like_clarabel(true, b'S', &mut col, (m, n), (m, m, k));
    let amax = a.iter().flatten().fold(0.0f64, |x, v| x.max(v.abs()));
    for i in 0..m {
        for j in 0..n {
            let r: f64 = (0..k).map(|l| u[l * m + i] * s[l] * vt[j * k + l]).sum();
            assert!(
                (r - a[i][j]).abs() <= tol * amax,
                "{what}: reconstruct ({i},{j}) {r} vs {}",
                a[i][j]
            );
        }
    }
    for p in 0..k {
        assert!(
            s[p] >= 0.0 && (p == 0 || s[p] <= s[p - 1]),
            "{what}: σ order {s:?}"
        );
        for q in 0..k {
            let uu: f64 = (0..m).map(|i| u[p * m + i] * u[q * m + i]).sum();
            let vv: f64 = (0..n).map(|j| vt[j * k + p] * vt[j * k + q]).sum();
            let e = if p == q { 1.0 } else { 0.0 };
            assert!(
                (uu - e).abs() < 1e-12 * (m as f64) && (vv - e).abs() < 1e-12 * (n as f64),
                "{what}: orthonormal"
            );
        }
    }
    s
}

#[test]
fn svd_regression_rank_deficient() {
    let _rng = Rng::new(0);
    // nalgebra 0.34's SVD returns σ₀ ≈ 3.52 here (‖A‖_F ≈ 2.51 with eps = ε).
    let v = [
        0.35637729788199723,
        0.11735911054676862,
        -0.010875735100779993,
        -0.6509700320379217,
        0.40057256747701064,
        0.23113179240597903,
        0.8653705187880156,
        0.044416141567128475,
        -0.2910988151527818,
        0.8579815064628744,
        -0.8968832756078455,
    ];
    let a: Vec<Vec<f64>> = v.iter().map(|x| vec![*x, *x]).collect();
    let s = check_svd_dense(&a, 1e-14, "11x2 equal columns");
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(
        (s[0] - norm * 2f64.sqrt()).abs() < 1e-14 && s[1].abs() < 1e-15,
        "{s:?}"
    );
    // Zero matrix: σ = 0 and U, V still orthonormal.
    check_svd_dense(&vec![vec![0.0; 3]; 5], 0.0, "zero 5x3");
    check_svd_dense(&vec![vec![0.0; 5]; 3], 0.0, "zero 3x5");
}

#[test]
fn svd_stress_rank_deficient_and_graded() {
    let mut rng = Rng::new(10);
    for case in 0..3000 {
        let (m, n) = (rng.int(1, 12), rng.int(1, 12));
        let mut a: Vec<Vec<f64>> = (0..m).map(|_| (0..n).map(|_| rng.f()).collect()).collect();
        match case % 6 {
            0 if n >= 2 => (0..m).for_each(|i| a[i][n - 1] = a[i][0]),
            1 if m >= 2 => a[m - 1] = a[0].clone(),
            2 => {
                // Graded columns: 1, 1e-3, 1e-6, ...
                for i in 0..m {
                    for j in 0..n {
                        a[i][j] *= 10f64.powi(-3 * j as i32);
                    }
                }
            }
            3 => a.iter_mut().flatten().for_each(|v| *v *= 1e-150),
            4 => a.iter_mut().flatten().for_each(|v| *v *= 1e150),
            _ => {}
        }
        let s = check_svd_dense(
            &a,
            1e-13 * (m.max(n) as f64),
            &format!("case {case} {m}x{n}"),
        );
        // σ² = eigenvalues of AᵀA (Jacobi reference), relative to σ₀².
        if case % 6 == 5 || case % 6 == 0 || case % 6 == 1 {
            let ata: Vec<Vec<f64>> = (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| (0..m).map(|l| a[l][i] * a[l][j]).sum())
                        .collect()
                })
                .collect();
            let ev: Vec<f64> = jacobi_eigenvalues(ata).into_iter().rev().collect();
            for (l, sl) in s.iter().enumerate() {
                assert!(
                    (sl * sl - ev[l]).abs() < 1e-12 * (1.0 + ev[0]),
                    "case {case}: σ{l}² {} vs {}",
                    sl * sl,
                    ev[l]
                );
            }
        }
    }
}

#[test]
fn svd_of_clarabel_like_nearly_singular_products() {
    // Clarabel factors S = L₁L₁ᵀ, Z = L₂L₂ᵀ and takes the SVD of L₂ᵀL₁; near
    // the optimum S and Z are complementary and nearly singular.
    let mut rng = Rng::new(11);
    for case in 0..200 {
        let n = rng.int(4, 12);
        let q: Vec<Vec<f64>> = {
            // Random orthogonal matrix from Gram-Schmidt.
            let mut q: Vec<Vec<f64>> = Vec::new();
            while q.len() < n {
                let mut x: Vec<f64> = (0..n).map(|_| rng.f()).collect();
                for _ in 0..2 {
                    for y in &q {
                        let d: f64 = x.iter().zip(y).map(|(a, b)| a * b).sum();
                        x.iter_mut().zip(y).for_each(|(a, b)| *a -= d * b);
                    }
                }
                let nrm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
                q.push(x.into_iter().map(|v| v / nrm).collect());
            }
            q
        };
        let mu = 10f64.powi(-(case % 12));
        let r = n / 2;
        let ds: Vec<f64> = (0..n)
            .map(|i| if i < r { 1.0 + rng.f().abs() } else { mu })
            .collect();
        let dz: Vec<f64> = (0..n)
            .map(|i| if i < r { mu } else { 1.0 + rng.f().abs() })
            .collect();
        // L = Qᵀ diag(√d) (a square root, not triangular, is enough for the SVD).
        let l1: Vec<Vec<f64>> = (0..n)
            .map(|i| (0..n).map(|j| q[j][i] * ds[j].sqrt()).collect())
            .collect();
        let l2: Vec<Vec<f64>> = (0..n)
            .map(|i| (0..n).map(|j| q[j][i] * dz[j].sqrt()).collect())
            .collect();
        let prod: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..n).map(|l| l2[l][i] * l1[l][j]).sum())
                    .collect()
            })
            .collect();
        let s = check_svd_dense(
            &prod,
            1e-13 * n as f64,
            &format!("clarabel-like case {case}"),
        );
        assert!(s.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn dsyevr_stress_graded_and_clustered() {
    let mut rng = Rng::new(12);
    for case in 0..600 {
        let n = rng.int(4, 14);
        let mut a = random_symmetric(&mut rng, n);
        match case % 4 {
            0 => {
                for i in 0..n {
                    for j in 0..n {
                        a[i][j] *= 10f64.powi(-2 * (i + j) as i32);
                    }
                }
            }
            1 => {
                for i in 0..n {
                    for j in 0..n {
                        a[i][j] = if i == j { 1.0 } else { a[i][j] * 1e-9 };
                    }
                }
            }
            2 => a.iter_mut().flatten().for_each(|v| *v *= 1e-200),
            _ => {}
        }
        let amax = a.iter().flatten().fold(0.0f64, |x, v| x.max(v.abs()));
        let mut col = store_triangle(&a, n, case % 2 == 0);
        let uplo = if case % 2 == 0 { b'U' } else { b'L' };
        let (m, w, z, _) =
            syevr_like_clarabel((b'V', b'A', uplo), &mut col, n, n, n, (0.0, 0.0, 0, 0));
        assert_eq!(m, n);
        for k in 0..n {
            let zk = &z[k * n..(k + 1) * n];
            for i in 0..n {
                let r: f64 = (0..n).map(|l| a[i][l] * zk[l]).sum::<f64>() - w[k] * zk[i];
                assert!(
                    r.abs() <= 1e-13 * n as f64 * amax,
                    "case {case}: residual {r}"
                );
            }
            for q in 0..n {
                let d: f64 = zk
                    .iter()
                    .zip(&z[q * n..(q + 1) * n])
                    .map(|(p, r)| p * r)
                    .sum();
                assert!(
                    (d - if k == q { 1.0 } else { 0.0 }).abs() < 1e-12,
                    "case {case}: orthonormal"
                );
            }
        }
        // Eigenvalues only: same values.
        let mut col = store_triangle(&a, n, true);
        let (_, w2, _, _) =
            syevr_like_clarabel((b'N', b'A', b'U'), &mut col, n, n, n, (0.0, 0.0, 0, 0));
        for k in 0..n {
            assert!((w[k] - w2[k]).abs() <= 1e-13 * n as f64 * amax);
        }
    }
}
