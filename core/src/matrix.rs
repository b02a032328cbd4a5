//! Row-major matrices borrowed from slices, and column-block traversal
//! (the validating checks, which need the dispatched kernels, are in
//! [`crate::scan`]).

use crate::{Error, Real};

/// Columns handled per block by the allocation-free column reductions.
pub(crate) const COL_BLOCK: usize = 256;

/// A borrowed row-major `rows × cols` matrix.
#[derive(Clone, Copy, Debug)]
pub struct MatrixRef<'a, T> {
    data: &'a [T],
    rows: usize,
    cols: usize,
}

impl<'a, T: Real> MatrixRef<'a, T> {
    /// Wraps `data` as a `rows × cols` matrix.
    ///
    /// # Errors
    /// [`Error::Empty`] if either dimension is zero, [`Error::LengthMismatch`]
    /// if `data.len() != rows * cols`.
    pub fn new(data: &'a [T], rows: usize, cols: usize) -> Result<Self, Error> {
        if rows == 0 || cols == 0 {
            return Err(Error::Empty);
        }
        let expected =
            rows.checked_mul(cols).ok_or(Error::LengthMismatch { expected: usize::MAX, found: data.len() })?;
        if data.len() != expected {
            return Err(Error::LengthMismatch { expected, found: data.len() });
        }
        Ok(Self { data, rows, cols })
    }

    /// Number of rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    #[must_use]
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The row-major data.
    #[must_use]
    pub fn data(&self) -> &'a [T] {
        self.data
    }

    /// Row `i`.
    ///
    /// # Panics
    /// If `i >= rows` (an indexing bug, never a data error).
    #[must_use]
    pub fn row(&self, i: usize) -> &'a [T] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }
}

/// Shifts an element index by `by` (row offsets in row-wise scans).
pub(crate) fn offset(e: Error, by: usize) -> Error {
    match e {
        Error::NonFinite { index } => Error::NonFinite { index: index + by },
        Error::Negative { index } => Error::Negative { index: index + by },
        other => other,
    }
}

/// Calls `f(c0, m)` for each block of at most [`COL_BLOCK`] columns, where
/// `m[j - c0] = Σ_i w_i M_ij` (or `Σ_i M_ij` when `weights` is `None`).
/// Rows with zero weight are skipped.
#[inline(always)]
pub(crate) fn for_column_blocks<T: Real, W: Real>(
    m: &MatrixRef<'_, T>,
    weights: Option<&[W]>,
    mut f: impl FnMut(usize, &[f64]),
) {
    let mut buf = [0.0f64; COL_BLOCK];
    let mut c0 = 0;
    while c0 < m.cols {
        let c1 = (c0 + COL_BLOCK).min(m.cols);
        let w = c1 - c0;
        let col = &mut buf[..w];
        col.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..m.rows {
            let wi = weights.map_or(1.0, |ws| ws[i].to_f64());
            if wi == 0.0 {
                continue;
            }
            for (acc, x) in col.iter_mut().zip(&m.row(i)[c0..c1]) {
                *acc += wi * x.to_f64();
            }
        }
        f(c0, col);
        c0 = c1;
    }
}
