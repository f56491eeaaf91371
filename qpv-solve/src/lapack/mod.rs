//! Pure-Rust BLAS/LAPACK symbols for Clarabel's PSD cones (in progress).
