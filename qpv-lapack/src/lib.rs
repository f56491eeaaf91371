//! Pure-Rust BLAS/LAPACK symbols for Clarabel's PSD cones.
//!
//! Clarabel's SDP code (`clarabel/sdp`) calls Fortran BLAS/LAPACK through the
//! `blas`/`lapack` crates. Its own `sdp-*` features need a system library or a
//! download; this workspace instead enables `["sdp", "blas-src", "lapack-src"]`
//! (the provider crates then compile empty) and this crate exports, with the
//! Fortran ABI (every argument by pointer, trailing underscore, no hidden
//! string lengths read), the double-precision routines Clarabel 0.11 calls:
//!
//! | symbol | what Clarabel uses | supported here |
//! |---|---|---|
//! | `dgemm_`  | `transa, transb` ∈ {N, T} | N, T, C (= T) |
//! | `dgemv_`  | `trans` ∈ {N, T}, inc = 1 | N, T, C; any non-zero inc |
//! | `dsymv_`  | `uplo` U/L, inc = 1 | U, L; any non-zero inc |
//! | `dsyrk_`  | `uplo` U/L, `trans` N/T | U, L × N, T, C |
//! | `dsyr2k_` | `uplo` U, `trans` N | U, L × N, T, C |
//! | `dpotrf_` | `uplo` L | U, L (`info` = order of the failing minor) |
//! | `dpotrs_` | `uplo` L | U, L |
//! | `dsyevr_` | `jobz` N/V, `range` A, `uplo` U, `lwork = liwork = -1` query first | jobz N/V, range A/V/I, uplo U/L |
//! | `dgesdd_` | `jobz` S, `lwork = -1` query first | jobz N, S (A only where it equals S) |
//! | `dgesvd_` | `jobu = jobvt` = S, `lwork = -1` query first | N, S (A only where it equals S) |
//!
//! Level-3/2 BLAS follow the reference implementation's loop structure
//! (contiguous inner loops, no blocking: Clarabel's PSD blocks are small);
//! the symmetric eigendecomposition is nalgebra's (`SymmetricEigen`); the SVD
//! is a one-sided Jacobi written here, because nalgebra 0.34's `SVD` returns
//! wrong factors for some rank-deficient inputs (and Clarabel's SVD input
//! `L₂ᵀL₁` becomes nearly rank-deficient as the iterates converge);
//! Cholesky is written out too (LAPACK's `info` semantics matter: Clarabel
//! uses a failed factorisation as a signal).
//! Workspace queries (`lwork = -1`) write LAPACK's documented minimum sizes
//! into `work[0]` / `iwork[0]`; the routines do not use the workspace.
//! With `jobz = 'N'` the eigenvector/singular-vector arguments are never read
//! or written (Clarabel passes a 1-element dummy).
//!
//! Non-finite input to `dsyevr_`/`dgesdd_`/`dgesvd_` gives NaN results with
//! `info = 0` (as a Fortran LAPACK typically does) instead of aborting:
//! Clarabel `expect`s these calls to succeed.
//!
//! # Who links it
//! The symbols are unmangled and global, so they are a choice of the final
//! binary, like any BLAS/LAPACK provider: a program that also links OpenBLAS
//! (or any other provider of `dgemm_`, ...) must not get them twice. This
//! crate is therefore separate from the solver library: `qpv-solve` links it
//! only with its `pure-lapack` feature (on by default for `qpv-solve`; the
//! `qpv` facade turns it on with its own `pure-lapack` feature, which its
//! `cli` feature implies), and the `qpv!` proc-macro links it for the solve
//! it runs inside rustc, where it never reaches the user's binary. Switch the
//! feature off and link a system library instead (see the README's
//! "Dependencies and features").
//!
//! # Linking
//! GNU ld pulls an archive member only if it resolves a symbol that is
//! undefined *at that point*, and rustc lists rlibs dependents-first
//! (`libqpv_lapack.rlib` before `libclarabel.rlib`). Measured with rustc 1.95
//! and GNU ld (`-Clinker-features=-lld`): rustc puts a synthetic `symbols.o`
//! first on the link line that references every `#[no_mangle]` symbol of each
//! linked rlib, so the definitions here are pulled in as soon as this crate is
//! linked at all (any item used, or `use qpv_lapack as _;`); a binary that
//! calls Clarabel without using anything from it fails with undefined
//! references to `dgemm_` etc. (reproduced). Code that runs Clarabel should
//! therefore call [`ensure_linked`] (cheap; `qpv_solve::backend::ensure_lapack`
//! does, before every solve): it references every exported symbol, so the
//! objects defining them are part of every link that contains the caller,
//! whatever the linker. (`rust-lld`, rustc's default on x86_64 Linux,
//! resolves archive members regardless of order.)

#![allow(clippy::missing_safety_doc)]

mod blas;
mod decomp;

pub use blas::{dgemm_, dgemv_, dsymv_, dsyr2k_, dsyrk_};
pub use decomp::{dgesdd_, dgesvd_, dpotrf_, dpotrs_, dsyevr_};

use std::hint::black_box;

/// Keeps every exported symbol in the link (see the module docs).
///
/// Call it before every Clarabel solve that may involve a PSD cone of size
/// ≥ 4. It costs a handful of loads: the function pointers are passed through
/// [`black_box`] so the references cannot be optimised away.
#[inline(never)]
pub fn ensure_linked() {
    let fns: [*const (); 10] = [
        dgemm_ as *const (),
        dgemv_ as *const (),
        dsymv_ as *const (),
        dsyrk_ as *const (),
        dsyr2k_ as *const (),
        dpotrf_ as *const (),
        dpotrs_ as *const (),
        dsyevr_ as *const (),
        dgesdd_ as *const (),
        dgesvd_ as *const (),
    ];
    black_box(fns);
}

/// The exported symbol names, in the order [`ensure_linked`] references them.
pub const SYMBOLS: [&str; 10] = [
    "dgemm_", "dgemv_", "dsymv_", "dsyrk_", "dsyr2k_", "dpotrf_", "dpotrs_", "dsyevr_", "dgesdd_",
    "dgesvd_",
];

/// Reads a Fortran `CHARACTER*1` argument, upper-cased.
#[inline]
unsafe fn ch(p: *const std::ffi::c_char) -> u8 {
    (unsafe { *p } as u8).to_ascii_uppercase()
}

/// Length of the storage of an `rows × cols` column-major matrix with leading
/// dimension `ld` (0 if empty), so that slices never exceed what the caller
/// must have allocated.
#[inline]
fn mat_len(rows: usize, cols: usize, ld: usize) -> usize {
    if rows == 0 || cols == 0 {
        0
    } else {
        ld * (cols - 1) + rows
    }
}

/// Length of the storage of a strided vector of `n` elements.
#[inline]
fn vec_len(n: usize, inc: isize) -> usize {
    if n == 0 {
        0
    } else {
        (n - 1) * inc.unsigned_abs() + 1
    }
}

/// Builds a slice from a possibly dangling pointer when `len == 0`.
#[inline]
unsafe fn slice<'a, T>(p: *const T, len: usize) -> &'a [T] {
    if len == 0 {
        &[]
    } else {
        unsafe { std::slice::from_raw_parts(p, len) }
    }
}

#[inline]
unsafe fn slice_mut<'a, T>(p: *mut T, len: usize) -> &'a mut [T] {
    if len == 0 {
        &mut []
    } else {
        unsafe { std::slice::from_raw_parts_mut(p, len) }
    }
}

/// Reports an illegal argument like the reference `XERBLA` (but returns
/// instead of stopping the program).
#[cold]
fn xerbla(name: &str, arg: i32) {
    eprintln!(" ** On entry to {name} parameter number {arg} had an illegal value");
}
