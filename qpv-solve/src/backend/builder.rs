//! The one builder of the crate's SDPs: named variables, PSD and
//! nonnegative blocks, a linear and a diagonal quadratic objective, and
//! [`SdpBuilder::finish`] into Clarabel's standard form
//! `min ½xᵀPx + qᵀx  s.t.  Ax + s = b, s ∈ K` (the backend's [`Sdp`]).
//!
//! Every assembly site (the condition families, the noise blocks, the skew
//! step, the state bound, the discrete family) writes its rows here, in
//! order, and a block's cone is declared when the block is opened, so the
//! rows and the cones cannot drift apart. A PSD block of side d holds the
//! svec packing of a d × d symmetric matrix (upper triangle column by
//! column, off-diagonal entries ×√2, see [`crate::linalg::svec`]);
//! [`SdpBuilder::entry`] and [`SdpBuilder::rhs`] apply that scale, so no
//! caller writes √2.

use super::Sdp;
use crate::linalg::csc::Columns;
use crate::linalg::svec::{svec_index, svec_len, svec_scale};
use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;
use nalgebra::DMatrix;
use std::ops::Range;

/// A PSD block opened in a builder: its first row and its side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Psd {
    /// The block's first row.
    pub row0: usize,
    /// The side d of the d × d matrix it holds.
    pub side: usize,
}

impl Psd {
    /// The row of entry (r, c) (either order) of the block's matrix.
    #[inline]
    pub fn row(&self, r: usize, c: usize) -> usize {
        let (r, c) = if r <= c { (r, c) } else { (c, r) };
        self.row0 + svec_index(r, c)
    }
}

/// An SDP under construction (see the module documentation).
#[derive(Debug, Clone, Default)]
pub struct SdpBuilder {
    cols: Columns,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
    q: Vec<f64>,
    quad: Vec<(usize, f64)>,
    names: Vec<(&'static str, Range<usize>)>,
}

impl SdpBuilder {
    /// An empty problem.
    pub fn new() -> Self {
        Self::default()
    }

    /// Declares `n` variables named `name` after those declared so far;
    /// returns their indices.
    pub fn vars(&mut self, name: &'static str, n: usize) -> Range<usize> {
        let start = self.n_vars();
        let range = start..start + n;
        self.names.push((name, range.clone()));
        self.cols.grow(range.end);
        range
    }

    /// Declares one scalar variable; returns its index.
    pub fn var(&mut self, name: &'static str) -> usize {
        self.vars(name, 1).start
    }

    /// Declares the nx(nx+1)/2 entries of a symmetric matrix variable
    /// (upper triangle, column by column); returns the first index.
    pub fn sym_var(&mut self, name: &'static str, side: usize) -> usize {
        self.vars(name, svec_len(side)).start
    }

    /// Number of variables declared.
    pub fn n_vars(&self) -> usize {
        self.names.last().map_or(0, |(_, r)| r.end)
    }

    /// Number of rows written so far.
    pub fn n_rows(&self) -> usize {
        self.b.len()
    }

    /// Opens a PSD block of side `side` holding M(x) − eps·I ⪰ 0 (the
    /// right-hand side starts at −eps on the diagonal; [`Self::rhs`] adds
    /// the constant part of M, [`Self::entry`] its linear part).
    pub fn psd(&mut self, side: usize, eps: f64) -> Psd {
        let blk = Psd {
            row0: self.b.len(),
            side,
        };
        self.b.resize(blk.row0 + svec_len(side), 0.0);
        if eps != 0.0 {
            for d in 0..side {
                self.b[blk.row(d, d)] = -eps;
            }
        }
        self.cones.push(SupportedConeT::PSDTriangleConeT(side));
        blk
    }

    /// Opens `len` rows of a nonnegative cone (s = b − Ax ≥ 0); returns the
    /// first row. Their right-hand sides start at 0 ([`Self::set_b`]).
    pub fn nonneg(&mut self, len: usize) -> usize {
        let row0 = self.b.len();
        self.b.resize(row0 + len, 0.0);
        self.cones.push(SupportedConeT::NonnegativeConeT(len));
        row0
    }

    /// Entry of A at (`row`, `var`), added to what is there (s = b − Ax).
    #[inline]
    pub fn a(&mut self, row: usize, var: usize, v: f64) {
        self.cols.push(row, var, v);
    }

    /// The right-hand side b of `row`.
    #[inline]
    pub fn set_b(&mut self, row: usize, v: f64) {
        self.b[row] = v;
    }

    /// The coefficient of `var` at entry (r, c) of a PSD block's slack,
    /// in A's sign convention (s = b − Ax: −v adds v·x to the matrix), with
    /// the block's svec scale applied.
    #[inline]
    pub fn entry(&mut self, blk: &Psd, r: usize, c: usize, var: usize, v: f64) {
        self.cols.push(blk.row(r, c), var, svec_scale(r, c) * v);
    }

    /// Sets the constant entry (r, c) of a PSD block's matrix (its
    /// right-hand side, svec scale applied), replacing what is there.
    #[inline]
    pub fn rhs(&mut self, blk: &Psd, r: usize, c: usize, v: f64) {
        self.b[blk.row(r, c)] = svec_scale(r, c) * v;
    }

    /// Sets the whole constant part of a PSD block's matrix (its
    /// right-hand side) to svec(`m`), `m` symmetric (upper triangle read).
    pub fn rhs_matrix(&mut self, blk: &Psd, m: &DMatrix<f64>) {
        for c in 0..blk.side {
            for r in 0..=c {
                self.rhs(blk, r, c, m[(r, c)]);
            }
        }
    }

    /// The column of `var` in a PSD block: `sign`·svec(m) (m symmetric, its
    /// upper triangle read), in A's sign convention.
    pub fn matrix(&mut self, blk: &Psd, var: usize, m: &DMatrix<f64>, sign: f64) {
        self.cols.push_svec(blk.row0, var, m, sign);
    }

    /// Charnes–Cooper homogenisation of every row written so far: its
    /// right-hand side moves into the column of `var` (A x − var·b + s = 0)
    /// and becomes 0.
    pub fn homogenise(&mut self, var: usize) {
        for (r, b) in self.b.iter_mut().enumerate() {
            self.cols.push(r, var, -*b);
            *b = 0.0;
        }
    }

    /// Adds c·x_var to the linear objective.
    pub fn cost(&mut self, var: usize, c: f64) {
        if self.q.len() <= var {
            self.q.resize(var + 1, 0.0);
        }
        self.q[var] += c;
    }

    /// Adds ½·w·x_var² to the objective.
    pub fn quadratic(&mut self, var: usize, w: f64) {
        if w != 0.0 {
            self.quad.push((var, w));
        }
    }

    /// The problem in Clarabel's standard form.
    pub fn finish(self) -> Sdp {
        let n = self.cols.n();
        let mut q = self.q;
        q.resize(n, 0.0);
        let mut diag = vec![0.0; n];
        for (v, w) in self.quad {
            diag[v] += w;
        }
        let mut colptr = Vec::with_capacity(n + 1);
        let (mut rowval, mut nzval) = (Vec::new(), Vec::new());
        colptr.push(0);
        for (c, &w) in diag.iter().enumerate() {
            if w != 0.0 {
                rowval.push(c);
                nzval.push(w);
            }
            colptr.push(rowval.len());
        }
        let m = self.b.len();
        Sdp {
            p: CscMatrix::new(n, n, colptr, rowval, nzval),
            q,
            a: self.cols.into_csc(m),
            b: self.b,
            cones: self.cones,
        }
    }
}
