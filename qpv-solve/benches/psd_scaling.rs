//! How Clarabel's solve time grows with the size of one PSD cone, on the
//! pure-Rust BLAS/LAPACK of `qpv_solve::lapack`, and what the individual
//! routines cost at those sizes. Prints numbers; run with
//! `cargo bench --bench psd_scaling` (add `-- quick` for one
//! repetition). Needs the default `pure-lapack` feature.
//!
//! Problem: min trace(C X) s.t. trace(X) = 1, X ⪰ 0 (optimum λmin(C)),
//! one `PSDTriangleConeT(n)` with n(n+1)/2 variables.

use std::ffi::c_int;
use std::hint::black_box;
use std::time::Instant;

use nalgebra::DMatrix;
use qpv_clarabel::clarabel::algebra::*;
use qpv_clarabel::clarabel::solver::*;
use qpv_solve::lapack;
use qpv_solve::svec::{svec, svec_index, svec_len};

fn rand_sym(n: usize, seed: u64) -> DMatrix<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let m = DMatrix::from_fn(n, n, |_, _| next());
    (&m + m.transpose()) * 0.5
}

struct Run {
    iters: u32,
    solve_ms: f64,
    wall_ms: f64,
    err: f64,
}

fn solve_min_eig(n: usize, seed: u64) -> Run {
    lapack::ensure_linked();
    let c = rand_sym(n, seed);
    let lmin = c.clone().symmetric_eigenvalues().min();
    let d = svec_len(n);
    let q = svec(&c);
    let mut rows = vec![vec![0.0; d]; 1 + d];
    for j in 0..n {
        rows[0][svec_index(j, j)] = 1.0;
    }
    for (k, row) in rows.iter_mut().skip(1).enumerate() {
        row[k] = -1.0;
    }
    let t0 = Instant::now();
    let a = CscMatrix::from(&rows);
    let mut b = vec![0.0; 1 + d];
    b[0] = 1.0;
    let p = CscMatrix::<f64>::zeros((d, d));
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .build()
        .unwrap();
    let cones = [ZeroConeT(1), PSDTriangleConeT(n)];
    let sdp = qpv_clarabel::Sdp {
        p,
        q,
        a,
        b,
        cones: cones.to_vec(),
    };
    let solver = qpv_clarabel::solve(sdp, settings).unwrap();
    let wall = t0.elapsed().as_secs_f64() * 1e3;
    assert_eq!(solver.solution.status, SolverStatus::Solved, "n = {n}");
    Run {
        iters: solver.solution.iterations,
        solve_ms: solver.solution.solve_time * 1e3,
        wall_ms: wall,
        err: (solver.solution.obj_val - lmin).abs(),
    }
}

/// Median time in µs of `f` over `reps` calls (after one warm-up).
fn time_us(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64() * 1e6
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn routine_costs(n: usize, reps: usize) -> [f64; 6] {
    let ni = n as c_int;
    let a = rand_sym(n, 7);
    let spd = &a * &a + DMatrix::identity(n, n) * n as f64;
    let b = rand_sym(n, 8);
    let mut c = DMatrix::<f64>::zeros(n, n);
    let ch = |x: u8| x as std::ffi::c_char;
    let gemm = time_us(reps, || unsafe {
        lapack::dgemm_(
            &ch(b'N'),
            &ch(b'T'),
            &ni,
            &ni,
            &ni,
            &1.0,
            a.as_ptr(),
            &ni,
            b.as_ptr(),
            &ni,
            &0.0,
            c.as_mut_ptr(),
            &ni,
        );
        black_box(&c);
    });
    let syrk = time_us(reps, || unsafe {
        lapack::dsyrk_(
            &ch(b'U'),
            &ch(b'N'),
            &ni,
            &ni,
            &1.0,
            a.as_ptr(),
            &ni,
            &0.0,
            c.as_mut_ptr(),
            &ni,
        );
        black_box(&c);
    });
    let potrf = time_us(reps, || unsafe {
        let mut l = spd.clone();
        let mut info = 0;
        lapack::dpotrf_(&ch(b'L'), &ni, l.as_mut_ptr(), &ni, &mut info);
        assert_eq!(info, 0);
        black_box(&l);
    });
    let mut w = vec![0.0; n];
    let mut z = vec![0.0; n * n];
    let mut isuppz = vec![0; 2 * n];
    let mut work = vec![0.0; 26 * n];
    let mut iwork = vec![0; 10 * n];
    let (lw, liw) = (26 * ni, 10 * ni);
    let mut syevr = |jobz: u8| {
        time_us(reps, || unsafe {
            let mut m = 0;
            let mut info = 0;
            let mut x = a.clone();
            lapack::dsyevr_(
                &ch(jobz),
                &ch(b'A'),
                &ch(b'U'),
                &ni,
                x.as_mut_ptr(),
                &ni,
                &0.0,
                &0.0,
                &0,
                &0,
                &-1.0,
                &mut m,
                w.as_mut_ptr(),
                z.as_mut_ptr(),
                &ni,
                isuppz.as_mut_ptr(),
                work.as_mut_ptr(),
                &lw,
                iwork.as_mut_ptr(),
                &liw,
                &mut info,
            );
            assert_eq!(info, 0);
            black_box(&w);
        })
    };
    let eig_n = syevr(b'N');
    let eig_v = syevr(b'V');
    let mut s = vec![0.0; n];
    let mut u = vec![0.0; n * n];
    let mut vt = vec![0.0; n * n];
    let lwork = (4 * n * n + 7 * n) as c_int;
    let mut work = vec![0.0; lwork as usize];
    let mut iwork = vec![0; 8 * n];
    let gesdd = time_us(reps, || unsafe {
        let mut x = &spd * &b;
        let mut info = 0;
        lapack::dgesdd_(
            &ch(b'S'),
            &ni,
            &ni,
            x.as_mut_ptr(),
            &ni,
            s.as_mut_ptr(),
            u.as_mut_ptr(),
            &ni,
            vt.as_mut_ptr(),
            &ni,
            work.as_mut_ptr(),
            &lwork,
            iwork.as_mut_ptr(),
            &mut info,
        );
        assert_eq!(info, 0);
        black_box(&s);
    });
    [gemm, syrk, potrf, eig_n, eig_v, gesdd]
}

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    let sizes = [6usize, 12, 24, 48];
    println!("# Clarabel 0.11, one PSDTriangleConeT(n): min trace(CX), trace X = 1");
    println!(
        "{:>4} {:>6} {:>6} {:>12} {:>12} {:>12} {:>10}",
        "n", "vars", "iters", "solve ms", "wall ms", "ms/iter", "|obj-λmin|"
    );
    for &n in &sizes {
        let reps = if quick || n >= 48 { 1 } else { 5 };
        let mut runs: Vec<Run> = (0..reps)
            .map(|r| solve_min_eig(n, 100 + r as u64))
            .collect();
        runs.sort_by(|a, b| a.solve_ms.total_cmp(&b.solve_ms));
        let r = &runs[runs.len() / 2];
        println!(
            "{:>4} {:>6} {:>6} {:>12.3} {:>12.3} {:>12.3} {:>10.1e}",
            n,
            svec_len(n),
            r.iters,
            r.solve_ms,
            r.wall_ms,
            r.solve_ms / r.iters.max(1) as f64,
            r.err
        );
    }
    println!();
    println!("# pure-Rust routines, median µs per call on n × n");
    println!(
        "{:>4} {:>10} {:>10} {:>10} {:>12} {:>12} {:>10}",
        "n", "dgemm NT", "dsyrk UN", "dpotrf L", "dsyevr N", "dsyevr V", "dgesdd S"
    );
    for &n in &sizes {
        let reps = if quick { 3 } else { 51 };
        let t = routine_costs(n, reps);
        println!(
            "{:>4} {:>10.2} {:>10.2} {:>10.2} {:>12.2} {:>12.2} {:>10.2}",
            n, t[0], t[1], t[2], t[3], t[4], t[5]
        );
    }
}
