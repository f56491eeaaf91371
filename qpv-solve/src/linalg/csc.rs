//! The one sparse builder of the SDPs: Clarabel's constraint matrix `A`
//! assembled column by column, with row blocks packed as `svec` (see
//! [`super::svec`]).

use super::svec::{svec_index, svec_scale};
use clarabel::algebra::CscMatrix;
use nalgebra::DMatrix;

/// Column-wise builder of a sparse CSC matrix: entries may arrive in any
/// row order and the same entry may be added more than once (the sum is
/// kept); zeros are not stored.
#[derive(Debug, Clone, Default)]
pub struct Columns {
    cols: Vec<Vec<(usize, f64)>>,
}

impl Columns {
    /// An empty builder for `n` columns (the SDP's variables).
    pub fn new(n: usize) -> Self {
        Columns {
            cols: vec![Vec::new(); n],
        }
    }

    /// Makes room for at least `n` columns.
    pub fn grow(&mut self, n: usize) {
        if self.cols.len() < n {
            self.cols.resize(n, Vec::new());
        }
    }

    /// Number of columns.
    pub fn n(&self) -> usize {
        self.cols.len()
    }

    /// Entry (`row`, `col`) = `v`; zeros are skipped.
    #[inline]
    pub fn push(&mut self, row: usize, col: usize, v: f64) {
        if v != 0.0 {
            if col >= self.cols.len() {
                self.grow(col + 1);
            }
            self.cols[col].push((row, v));
        }
    }

    /// Column `col` of a PSD row block starting at `row0`: the `svec`
    /// packing of the symmetric matrix `m` (upper triangle, column by
    /// column, off-diagonal entries ×√2), times `sign`.
    pub fn push_svec(&mut self, row0: usize, col: usize, m: &DMatrix<f64>, sign: f64) {
        let n = m.nrows();
        for c in 0..n {
            for r in 0..=c {
                self.push(
                    row0 + svec_index(r, c),
                    col,
                    sign * svec_scale(r, c) * m[(r, c)],
                );
            }
        }
    }

    /// The CSC matrix with `m` rows (each column's entries sorted by row,
    /// repeated entries summed, zero sums dropped).
    pub fn into_csc(self, m: usize) -> CscMatrix<f64> {
        let n = self.cols.len();
        let nnz: usize = self.cols.iter().map(|c| c.len()).sum();
        let mut colptr = Vec::with_capacity(n + 1);
        let mut rowval = Vec::with_capacity(nnz);
        let mut nzval = Vec::with_capacity(nnz);
        colptr.push(0);
        for mut col in self.cols {
            // Assemblies fill one row block after the other, so a column is
            // almost always sorted already (the sort then is one pass).
            col.sort_by_key(|e| e.0);
            let start = rowval.len();
            for (r, v) in col {
                if rowval.len() > start && rowval.last() == Some(&r) {
                    *nzval.last_mut().expect("an entry") += v;
                } else {
                    rowval.push(r);
                    nzval.push(v);
                }
            }
            // Drop entries that summed to zero.
            let mut k = start;
            for i in start..rowval.len() {
                if nzval[i] != 0.0 {
                    rowval[k] = rowval[i];
                    nzval[k] = nzval[i];
                    k += 1;
                }
            }
            rowval.truncate(k);
            nzval.truncate(k);
            colptr.push(rowval.len());
        }
        CscMatrix::new(m, n, colptr, rowval, nzval)
    }
}
