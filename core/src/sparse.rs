//! Sparse channels: `p(y|x)` kept row by row as `(column, value)` lists
//! (compressed sparse rows), for channels whose dense matrix would not fit,
//! such as the viewpoint channel of a 10^6-polygon mesh (Part V), where each
//! viewpoint sees a small fraction of the polygons.
//!
//! Every measure equals the one [`crate::Channel`] computes on the same
//! matrix stored densely (zeros contribute `0 · log 0 = 0`); the property
//! tests check this.

use crate::math::ln;
use crate::scan::{check_normalized, entropy_nats, mass, mass_xlnx, same_len};
use crate::sum::Neumaier;
use crate::{Base, ChannelMeasures, Error, Real};
use core::ops::Range;

/// A borrowed sparse channel `X → Y`.
///
/// Row `x` holds the columns `cols[starts[x]..starts[x + 1]]` (strictly
/// increasing, below `outputs`) with their probabilities `p(y|x)` in
/// `values` at the same positions.
///
/// # Examples
/// ```
/// use itgfx_core::{Base, SparseChannel};
/// // Two inputs that each see half of four outputs.
/// let ch = SparseChannel::new(&[0.5f64, 0.5], &[0, 2, 4], &[0, 1, 2, 3], &[0.5, 0.5, 0.5, 0.5], 4).unwrap();
/// let mut p_y = [0.0; 4];
/// ch.output_into(&mut p_y).unwrap();
/// assert_eq!(p_y, [0.25; 4]);
/// let m = ch.measures(&p_y, Base::Bits).unwrap();
/// assert!((m.mutual_information - 1.0).abs() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct SparseChannel<'a, T> {
    input: &'a [T],
    starts: &'a [usize],
    cols: &'a [u32],
    values: &'a [T],
    outputs: usize,
}

impl<'a, T: Real> SparseChannel<'a, T> {
    /// Validates the input distribution, the row structure and every row's
    /// normalisation.
    ///
    /// # Errors
    /// [`Error::Empty`]; [`Error::LengthMismatch`] when `starts` does not
    /// have `inputs + 1` entries or `cols` and `values` differ in length or
    /// from `starts`' last entry; [`Error::InvalidParameter`] named
    /// `"starts"` for decreasing offsets and `"cols"` (with the position as
    /// value) for a column out of range or out of order; element errors for
    /// `values`; [`Error::RowNotNormalized`].
    pub fn new(
        input: &'a [T],
        starts: &'a [usize],
        cols: &'a [u32],
        values: &'a [T],
        outputs: usize,
    ) -> Result<Self, Error> {
        if input.is_empty() || outputs == 0 {
            return Err(Error::Empty);
        }
        check_normalized::<T>(mass(input)?)?;
        if starts.len() != input.len() + 1 {
            return Err(Error::LengthMismatch { expected: input.len() + 1, found: starts.len() });
        }
        if cols.len() != values.len() {
            return Err(Error::LengthMismatch { expected: cols.len(), found: values.len() });
        }
        let last = starts[starts.len() - 1];
        if starts[0] != 0 || last != cols.len() {
            return Err(Error::LengthMismatch { expected: cols.len(), found: last });
        }
        mass(values)?;
        for (row, w) in starts.windows(2).enumerate() {
            if w[1] < w[0] {
                return Err(Error::InvalidParameter { name: "starts", value: row as f64 });
            }
            let c = &cols[w[0]..w[1]];
            for (k, &j) in c.iter().enumerate() {
                if j as usize >= outputs || (k > 0 && c[k - 1] >= j) {
                    return Err(Error::InvalidParameter { name: "cols", value: (w[0] + k) as f64 });
                }
            }
            let s = mass(&values[w[0]..w[1]])?;
            if check_normalized::<T>(s).is_err() {
                return Err(Error::RowNotNormalized { row, sum: s });
            }
        }
        Ok(Self { input, starts, cols, values, outputs })
    }

    /// `|X|`.
    #[must_use]
    pub fn inputs(&self) -> usize {
        self.input.len()
    }

    /// `|Y|`.
    #[must_use]
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// Stored entries.
    #[must_use]
    pub fn nonzeros(&self) -> usize {
        self.starts[self.starts.len() - 1] - self.starts[0]
    }

    /// The channel of rows `rows` alone with the input distribution `input`
    /// (one per row): the rows were checked when `self` was made, so only
    /// `input` is (as [`SparseChannel::new`] checks it). Row `k` of the
    /// result is row `rows.start + k` of `self`.
    ///
    /// # Errors
    /// [`Error::Empty`]; [`Error::InvalidParameter`] named `"rows"` for a
    /// range past the last row; [`Error::LengthMismatch`] when `input` is not
    /// one per row; element errors and [`Error::NotNormalized`] for `input`.
    pub fn rows_with_input<'b>(&self, rows: Range<usize>, input: &'b [T]) -> Result<SparseChannel<'b, T>, Error>
    where
        'a: 'b,
    {
        if rows.start > rows.end || rows.end >= self.starts.len() {
            return Err(Error::InvalidParameter { name: "rows", value: rows.end as f64 });
        }
        if input.is_empty() {
            return Err(Error::Empty);
        }
        check_normalized::<T>(mass(input)?)?;
        if input.len() != rows.len() {
            return Err(Error::LengthMismatch { expected: rows.len(), found: input.len() });
        }
        let starts = &self.starts[rows.start..=rows.end];
        Ok(SparseChannel { input, starts, cols: self.cols, values: self.values, outputs: self.outputs })
    }

    /// [`jensen_shannon_sparse`] of rows `a` and `b` with weights
    /// `(π_a, π_b)` (Part II eq. (17)), the rows checked once when the
    /// channel was made instead of on every call: the same value, bit for bit.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] named `"row"` for a row out of range;
    /// element errors and [`Error::NotNormalized`] for the weights.
    pub fn jensen_shannon(&self, weights: (T, T), a: usize, b: usize, base: Base) -> Result<T, Error> {
        self.check_rows_pair(weights, a, b)?;
        let (ra, rb) = (self.row(a), self.row(b));
        Ok(js_merge(weights, ra, rb, |k| ln(ra.1[k].to_f64()), |k| ln(rb.1[k].to_f64()), base))
    }

    /// [`jensen_shannon_sparse_logs`] of rows `a` and `b`, with `logs` the
    /// logarithm of every stored value of the channel (by position, from
    /// [`sparse_logs`]), the rows checked once when the channel was made:
    /// the same value, bit for bit.
    ///
    /// # Errors
    /// Those of [`SparseChannel::jensen_shannon`]; [`Error::LengthMismatch`]
    /// when `logs` is not one per stored value.
    pub fn jensen_shannon_logs(
        &self,
        weights: (T, T),
        a: usize,
        b: usize,
        logs: &[f64],
        base: Base,
    ) -> Result<T, Error> {
        if logs.len() != self.values.len() {
            return Err(Error::LengthMismatch { expected: self.values.len(), found: logs.len() });
        }
        self.check_rows_pair(weights, a, b)?;
        let (ra, rb) = (self.row(a), self.row(b));
        let (la, lb) = (&logs[self.starts[a]..self.starts[a + 1]], &logs[self.starts[b]..self.starts[b + 1]]);
        Ok(js_merge_batched(weights, (ra.0, ra.1, la), (rb.0, rb.1, lb), base))
    }

    /// The checks of [`check_pair`] that a checked channel's rows still need:
    /// the weights, and both rows in range.
    fn check_rows_pair(&self, weights: (T, T), a: usize, b: usize) -> Result<(), Error> {
        check_normalized::<T>(mass(&[weights.0, weights.1])?)?;
        if let Some(&x) = [a, b].iter().find(|&&x| x + 1 >= self.starts.len()) {
            return Err(Error::InvalidParameter { name: "row", value: x as f64 });
        }
        Ok(())
    }

    /// `p(x)`.
    #[must_use]
    pub fn input(&self) -> &'a [T] {
        self.input
    }

    /// Row `x`: its columns and `p(y|x)`.
    ///
    /// # Panics
    /// If `x >= inputs()`.
    #[must_use]
    pub fn row(&self, x: usize) -> (&'a [u32], &'a [T]) {
        let (a, b) = (self.starts[x], self.starts[x + 1]);
        (&self.cols[a..b], &self.values[a..b])
    }

    /// The output marginal `p(y) = Σ_x p(x) p(y|x)` (Part II §2).
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `out.len() != outputs()`.
    pub fn output_into(&self, out: &mut [T]) -> Result<(), Error> {
        same_len(self.outputs, out.len())?;
        self.output_cols_into(0..self.outputs, out)
    }

    /// [`SparseChannel::output_into`] of the outputs `cols` alone (`out[k]`
    /// for output `cols.start + k`): each output's sum over the rows in row
    /// order, as the whole pass takes it, so blocks of outputs computed
    /// apart (side by side) give the same bits.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] named `"cols"` for a range past the
    /// outputs; [`Error::LengthMismatch`] if `out` is not one per output of `cols`.
    pub fn output_cols_into(&self, cols: Range<usize>, out: &mut [T]) -> Result<(), Error> {
        self.check_cols(&cols, out.len())?;
        out.iter_mut().for_each(|o| *o = T::from_f64(0.0));
        for (x, px) in self.input.iter().enumerate() {
            let (k0, c) = self.row_part(x, &cols);
            for (k, &j) in (k0..).zip(c) {
                let o = &mut out[j as usize - cols.start];
                *o = T::from_f64(o.to_f64() + px.to_f64() * self.values[k].to_f64());
            }
        }
        Ok(())
    }

    /// Refuses a column range past the outputs or an output buffer of
    /// another length.
    fn check_cols(&self, cols: &Range<usize>, len: usize) -> Result<(), Error> {
        if cols.start > cols.end || cols.end > self.outputs {
            return Err(Error::InvalidParameter { name: "cols", value: cols.end as f64 });
        }
        if len != cols.len() {
            return Err(Error::LengthMismatch { expected: cols.len(), found: len });
        }
        Ok(())
    }

    /// The part of row `x` whose columns fall in `cols`: the position of its
    /// first entry and its columns (rows are increasing).
    fn row_part(&self, x: usize, cols: &Range<usize>) -> (usize, &'a [u32]) {
        let (a, b) = (self.starts[x], self.starts[x + 1]);
        let c = &self.cols[a..b];
        let lo = c.partition_point(|&j| (j as usize) < cols.start);
        let hi = lo + c[lo..].partition_point(|&j| (j as usize) < cols.end);
        (a + lo, &c[lo..hi])
    }

    /// `H(Y|x)` of each row (Part V eq. (2) for a viewpoint).
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `out.len() != inputs()`.
    pub fn row_entropies_into(&self, base: Base, out: &mut [T]) -> Result<(), Error> {
        same_len(self.inputs(), out.len())?;
        for (x, o) in out.iter_mut().enumerate() {
            let m = mass_xlnx(self.row(x).1)?;
            *o = T::from_f64(entropy_nats(m) * base.per_nat());
        }
        Ok(())
    }

    /// Specific information `I(x;Y) = D_KL(p(Y|x) ‖ p(Y))` of each input
    /// (Part V eq. (7)); `output` is from [`SparseChannel::output_into`].
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] for wrong buffer lengths.
    pub fn specific_information_into(&self, output: &[T], base: Base, out: &mut [T]) -> Result<(), Error> {
        same_len(self.outputs, output.len())?;
        same_len(self.inputs(), out.len())?;
        // Each row in batches: its `p` and `q`, their logarithms in one
        // vectorised pass each ([`crate::dispatch::ln_into`], the same bits
        // as [`ln`]), then the terms added in order.
        let (mut ps, mut qs, mut lp, mut lq) = ([0.0f64; BATCH], [0.0; BATCH], [0.0; BATCH], [0.0; BATCH]);
        for (x, o) in out.iter_mut().enumerate() {
            let (c, v) = self.row(x);
            let mut acc = Neumaier::new();
            for (c, v) in c.chunks(BATCH).zip(v.chunks(BATCH)) {
                let n = c.len();
                for (k, (&j, p)) in c.iter().zip(v).enumerate() {
                    (ps[k], qs[k]) = (p.to_f64(), output[j as usize].to_f64());
                }
                crate::dispatch::ln_into(&ps[..n], &mut lp[..n]);
                crate::dispatch::ln_into(&qs[..n], &mut lq[..n]);
                for k in 0..n {
                    let (p, q) = (ps[k], qs[k]);
                    if p > 0.0 {
                        acc.add(information_term(p, q, lp[k], lq[k]));
                    }
                }
            }
            let d = acc.value();
            *o = nonnegative_in(d, base);
        }
        Ok(())
    }

    /// [`SparseChannel::specific_information_into`] with the logarithms
    /// given, so that no entry takes one: `logs` of every stored value of the
    /// channel (by position, [`sparse_logs`]) and `output_logs` of `output`
    /// ([`sparse_logs`] of it). The same terms added in the same order: the
    /// same values, bit for bit.
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] for wrong buffer lengths.
    pub fn specific_information_logs_into(
        &self,
        output: &[T],
        output_logs: &[f64],
        logs: &[f64],
        base: Base,
        out: &mut [T],
    ) -> Result<(), Error> {
        same_len(self.outputs, output.len())?;
        same_len(self.outputs, output_logs.len())?;
        same_len(self.values.len(), logs.len())?;
        same_len(self.inputs(), out.len())?;
        for (x, o) in out.iter_mut().enumerate() {
            let mut acc = Neumaier::new();
            let r = self.starts[x]..self.starts[x + 1];
            for ((&j, p), &lp) in self.cols[r.clone()].iter().zip(&self.values[r.clone()]).zip(&logs[r]) {
                let (p, q) = (p.to_f64(), output[j as usize].to_f64());
                if p > 0.0 {
                    acc.add(information_term(p, q, lp, output_logs[j as usize]));
                }
            }
            let d = acc.value();
            *o = nonnegative_in(d, base);
        }
        Ok(())
    }

    /// Specific information of each output, `I(y;X) = D_KL(p(X|y) ‖ p(X))`,
    /// without forming the reversed channel: by Bayes,
    /// `I(y;X) = (1/p(y)) Σ_x p(x) p(y|x) ln(p(y|x)/p(y))` (the polygonal
    /// mutual information of Part V). Outputs with `p(y) = 0` get 0.
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] for wrong buffer lengths.
    pub fn output_specific_information_into(&self, output: &[T], base: Base, out: &mut [T]) -> Result<(), Error> {
        same_len(self.outputs, out.len())?;
        self.output_specific_information_cols_into(output, 0..self.outputs, base, out)
    }

    /// [`SparseChannel::output_specific_information_into`] of the outputs
    /// `cols` alone (`out[k]` for output `cols.start + k`; `output` is the
    /// whole marginal): each output's terms added over the rows in row order,
    /// as the whole pass adds them, so blocks of outputs computed apart (side
    /// by side) give the same bits. The logarithms are taken in batches, one
    /// vectorised pass each (`dispatch::ln_into`, [`ln`]'s bits).
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] for wrong buffer lengths;
    /// [`Error::InvalidParameter`] named `"cols"` for a range past the outputs.
    pub fn output_specific_information_cols_into(
        &self,
        output: &[T],
        cols: Range<usize>,
        base: Base,
        out: &mut [T],
    ) -> Result<(), Error> {
        same_len(self.outputs, output.len())?;
        self.check_cols(&cols, out.len())?;
        out.iter_mut().for_each(|o| *o = T::from_f64(0.0));
        let (mut ps, mut qs, mut lp, mut lq) = ([0.0f64; BATCH], [0.0; BATCH], [0.0; BATCH], [0.0; BATCH]);
        for (x, px) in self.input.iter().enumerate() {
            let px = px.to_f64();
            let (k0, c) = self.row_part(x, &cols);
            for (b, c) in c.chunks(BATCH).enumerate() {
                let (n, k0) = (c.len(), k0 + b * BATCH);
                for (k, &j) in c.iter().enumerate() {
                    (ps[k], qs[k]) = (self.values[k0 + k].to_f64(), output[j as usize].to_f64());
                }
                crate::dispatch::ln_into(&ps[..n], &mut lp[..n]);
                crate::dispatch::ln_into(&qs[..n], &mut lq[..n]);
                for (k, &j) in c.iter().enumerate() {
                    let (p, q) = (ps[k], qs[k]);
                    if p > 0.0 && q > 0.0 {
                        let o = &mut out[j as usize - cols.start];
                        *o = T::from_f64(o.to_f64() + px * p * (lp[k] - lq[k]));
                    }
                }
            }
        }
        for (o, q) in out.iter_mut().zip(&output[cols]) {
            let q = q.to_f64();
            let d = if q > 0.0 { o.to_f64() / q } else { 0.0 };
            *o = nonnegative_in(d, base);
        }
        Ok(())
    }

    /// Weighted specific information of each output: the terms of
    /// [`SparseChannel::output_specific_information_into`] (the Bayes form of
    /// `I(y;X) = Σ_x p(x|y) log(p(x|y)/p(x))`, Part V's polygonal mutual
    /// information) each multiplied by a weight of its input,
    /// `I_w(y;X) = Σ_x w(x) p(x|y) log(p(x|y)/p(x))`. With `w ≡ 1` it is
    /// `I(y;X)`; it is linear in `w`. One weight vector per colour channel
    /// gives the colour voxel mutual information of the viewpoint channel
    /// over voxels (a viewpoint's colour carried to the voxels it informs
    /// about). Single terms may be negative, so the result is not clamped.
    /// Outputs with `p(y) = 0` get 0.
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] for wrong buffer lengths; element errors
    /// (non-finite) for `weights`.
    pub fn output_specific_information_weighted_into(
        &self,
        output: &[T],
        weights: &[T],
        base: Base,
        out: &mut [T],
    ) -> Result<(), Error> {
        same_len(self.outputs, output.len())?;
        same_len(self.outputs, out.len())?;
        same_len(self.inputs(), weights.len())?;
        if let Some(index) = weights.iter().position(|w| !w.to_f64().is_finite()) {
            return Err(Error::NonFinite { index });
        }
        out.iter_mut().for_each(|o| *o = T::from_f64(0.0));
        for (x, px) in self.input.iter().enumerate() {
            let (c, v) = self.row(x);
            let wx = px.to_f64() * weights[x].to_f64();
            for (&j, p) in c.iter().zip(v) {
                let (p, q) = (p.to_f64(), output[j as usize].to_f64());
                if p > 0.0 && q > 0.0 {
                    out[j as usize] = T::from_f64(out[j as usize].to_f64() + wx * p * (ln(p) - ln(q)));
                }
            }
        }
        for (o, q) in out.iter_mut().zip(output) {
            let q = q.to_f64();
            *o = T::from_f64(if q > 0.0 { o.to_f64() / q * base.per_nat() } else { 0.0 });
        }
        Ok(())
    }

    /// Every entropy of the channel, with `I(X;Y) = Σ_x p(x) I(x;Y)`
    /// (Part V eq. (6)) and `H(Y|X) = Σ_x p(x) H(Y|x)` (eq. (5)).
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `output.len() != outputs()`; `output`
    /// must be a distribution.
    pub fn measures(&self, output: &[T], base: Base) -> Result<ChannelMeasures, Error> {
        same_len(self.outputs, output.len())?;
        self.measures_by(output, base, |k| ln(self.values[k].to_f64()), |j| ln(output[j].to_f64()))
    }

    /// [`SparseChannel::measures`] with the logarithms given, so that the
    /// pass over every entry (one thread, in order: compensated sums) takes
    /// none: `logs` of every stored value of the channel (by position,
    /// [`sparse_logs`]) and `output_logs` of `output` ([`sparse_logs`] of
    /// it). The same terms added in the same order: the same values, bit for
    /// bit.
    ///
    /// # Errors
    /// Those of [`SparseChannel::measures`]; [`Error::LengthMismatch`] when
    /// `logs` or `output_logs` is not one per value.
    pub fn measures_logs(
        &self,
        output: &[T],
        output_logs: &[f64],
        logs: &[f64],
        base: Base,
    ) -> Result<ChannelMeasures, Error> {
        same_len(self.outputs, output.len())?;
        same_len(self.outputs, output_logs.len())?;
        same_len(self.values.len(), logs.len())?;
        self.measures_by(output, base, |k| logs[k], |j| output_logs[j])
    }

    /// [`SparseChannel::measures`] with `ln p(y|x)` of the value at position
    /// `k` from `lp(k)` and `ln p(y)` from `lq(y)`.
    fn measures_by(
        &self,
        output: &[T],
        base: Base,
        lp: impl Fn(usize) -> f64,
        lq: impl Fn(usize) -> f64,
    ) -> Result<ChannelMeasures, Error> {
        let h_y = entropy_nats(mass_xlnx(output)?);
        let h_x = entropy_nats(mass_xlnx(self.input)?);
        let (mut mi, mut hyx) = (Neumaier::new(), Neumaier::new());
        for (x, px) in self.input.iter().enumerate() {
            let px = px.to_f64();
            for k in self.starts[x]..self.starts[x + 1] {
                let (j, p) = (self.cols[k] as usize, self.values[k].to_f64());
                // An input of zero weight contributes nothing, even where q = 0.
                if px > 0.0 && p > 0.0 {
                    let q = output[j].to_f64();
                    hyx.add(-px * p * lp(k));
                    mi.add(information_term(px * p, q, lp(k), lq(j)));
                }
            }
        }
        let k = base.per_nat();
        let (mi, hyx) = (mi.value().max(0.0), hyx.value().max(0.0));
        Ok(ChannelMeasures {
            h_x: h_x * k,
            h_y: h_y * k,
            h_y_given_x: hyx * k,
            h_x_given_y: (h_x - mi).max(0.0) * k,
            h_xy: (h_x + hyx) * k,
            mutual_information: mi * k,
        })
    }
}

/// The rows of a sparse channel, owned and checked once (every check of
/// [`SparseChannel::new`]) when made, so that the channel over them
/// ([`SparseRows::channel`]) checks only its input: a channel whose rows
/// are read by many passes (the viewpoint channel, 67M entries on the
/// 1.1M-triangle bunny) validates them once instead of on every pass and
/// every pair of rows.
#[cfg(feature = "alloc")]
#[derive(Clone, Debug, PartialEq)]
pub struct SparseRows<T> {
    starts: alloc::vec::Vec<usize>,
    cols: alloc::vec::Vec<u32>,
    values: alloc::vec::Vec<T>,
    outputs: usize,
}

#[cfg(feature = "alloc")]
impl<T: Real> SparseRows<T> {
    /// Takes the rows over after [`SparseChannel::new`]`(input, ...)` accepts
    /// them (the same checks, in the same order, the same errors).
    ///
    /// # Errors
    /// Those of [`SparseChannel::new`].
    pub fn new(
        input: &[T],
        starts: alloc::vec::Vec<usize>,
        cols: alloc::vec::Vec<u32>,
        values: alloc::vec::Vec<T>,
        outputs: usize,
    ) -> Result<Self, Error> {
        SparseChannel::new(input, &starts, &cols, &values, outputs)?;
        Ok(Self { starts, cols, values, outputs })
    }

    /// The channel of these rows with the input distribution `input`, which
    /// alone is checked.
    ///
    /// # Errors
    /// Those of [`SparseChannel::rows_with_input`].
    pub fn channel<'a>(&'a self, input: &'a [T]) -> Result<SparseChannel<'a, T>, Error> {
        self.all().rows_with_input(0..self.rows(), input)
    }

    /// Every row as a channel with no input yet (the rows' own view).
    fn all(&self) -> SparseChannel<'_, T> {
        SparseChannel {
            input: &[],
            starts: &self.starts,
            cols: &self.cols,
            values: &self.values,
            outputs: self.outputs,
        }
    }

    /// Rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.starts.len() - 1
    }

    /// Outputs (columns).
    #[must_use]
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// Row offsets: row `x` is at `starts()[x]..starts()[x + 1]`.
    #[must_use]
    pub fn starts(&self) -> &[usize] {
        &self.starts
    }

    /// Every row's columns, in row order.
    #[must_use]
    pub fn cols(&self) -> &[u32] {
        &self.cols
    }

    /// Every row's values, in row order.
    #[must_use]
    pub fn values(&self) -> &[T] {
        &self.values
    }
}

/// Jensen–Shannon divergence of two sparse distributions with weights
/// `(π_a, π_b)` (Part II eq. (17)): `Σ π_i D_KL(p_i ‖ π_a p_a + π_b p_b)`.
/// Each is given by strictly increasing indices and values summing to 1;
/// indices present in one only count against a mixture that is `π_i p_i`.
///
/// # Errors
/// [`Error::LengthMismatch`], element errors, [`Error::NotNormalized`] for the
/// weights or either distribution, and [`Error::InvalidParameter`] named
/// `"index"` for indices out of order.
pub fn jensen_shannon_sparse<T: Real>(
    weights: (T, T),
    a: (&[u32], &[T]),
    b: (&[u32], &[T]),
    base: Base,
) -> Result<T, Error> {
    check_pair(weights, a, b)?;
    let (va, vb) = (a.1, b.1);
    Ok(js_merge(weights, a, b, |k| ln(va[k].to_f64()), |k| ln(vb[k].to_f64()), base))
}

/// [`jensen_shannon_sparse`] with `ln p` of every value given (`la[k] =
/// ln(a.1[k])`, as the core's own `ln` computes it: pass
/// [`sparse_logs`]'s output), so that rows compared with many others take
/// their logarithms once. Bit for bit the same value as
/// [`jensen_shannon_sparse`] for such logs: the same merge in batches
/// (`js_merge_batched`, tested against `js_merge` bit for bit), each
/// batch's mixture logarithms taken in one vectorised pass.
///
/// # Errors
/// Those of [`jensen_shannon_sparse`], and [`Error::LengthMismatch`] when a
/// log slice is not as long as its values.
pub fn jensen_shannon_sparse_logs<T: Real>(
    weights: (T, T),
    a: (&[u32], &[T], &[f64]),
    b: (&[u32], &[T], &[f64]),
    base: Base,
) -> Result<T, Error> {
    for (v, l) in [(a.1, a.2), (b.1, b.2)] {
        if v.len() != l.len() {
            return Err(Error::LengthMismatch { expected: v.len(), found: l.len() });
        }
    }
    check_pair(weights, (a.0, a.1), (b.0, b.1))?;
    Ok(js_merge_batched(weights, a, b, base))
}

/// `ln p` of every value, as [`jensen_shannon_sparse_logs`] takes them.
pub fn sparse_logs<T: Real>(values: &[T], out: &mut [f64]) {
    // In batches, one vectorised pass each ([`crate::dispatch::ln_into`]).
    let mut x = [0.0f64; BATCH];
    for (o, v) in out.chunks_mut(BATCH).zip(values.chunks(BATCH)) {
        let n = o.len().min(v.len());
        for (x, v) in x.iter_mut().zip(v) {
            *x = v.to_f64();
        }
        crate::dispatch::ln_into(&x[..n], &mut o[..n]);
    }
}

fn check_pair<T: Real>(weights: (T, T), a: (&[u32], &[T]), b: (&[u32], &[T])) -> Result<(), Error> {
    check_normalized::<T>(mass(&[weights.0, weights.1])?)?;
    for (idx, val) in [a, b] {
        if idx.len() != val.len() {
            return Err(Error::LengthMismatch { expected: idx.len(), found: val.len() });
        }
        if let Some(k) = idx.windows(2).position(|w| w[0] >= w[1]) {
            return Err(Error::InvalidParameter { name: "index", value: (k + 1) as f64 });
        }
        check_normalized::<T>(mass(val)?)?;
    }
    Ok(())
}

/// `Σ_i π_i p_i (ln p_i − ln m)` over the merged support (`m` the mixture;
/// `ln m` taken once per index), with `ln p` from `la`/`lb` by position.
fn js_merge<T: Real>(
    weights: (T, T),
    a: (&[u32], &[T]),
    b: (&[u32], &[T]),
    la: impl Fn(usize) -> f64,
    lb: impl Fn(usize) -> f64,
    base: Base,
) -> T {
    let (wa, wb) = (weights.0.to_f64(), weights.1.to_f64());
    let term = js_term;
    let (mut i, mut j) = (0, 0);
    let mut acc = Neumaier::new();
    while i < a.0.len() || j < b.0.len() {
        let ia = a.0.get(i).copied().unwrap_or(u32::MAX);
        let ib = b.0.get(j).copied().unwrap_or(u32::MAX);
        let (ka, kb) = match (ia.cmp(&ib), i < a.0.len(), j < b.0.len()) {
            (core::cmp::Ordering::Less, true, _) | (_, true, false) => {
                i += 1;
                (Some(i - 1), None)
            }
            (core::cmp::Ordering::Greater, _, true) | (_, false, true) => {
                j += 1;
                (None, Some(j - 1))
            }
            _ => {
                i += 1;
                j += 1;
                (Some(i - 1), Some(j - 1))
            }
        };
        let pa = ka.map_or(0.0, |k| a.1[k].to_f64());
        let pb = kb.map_or(0.0, |k| b.1[k].to_f64());
        let m = wa * pa + wb * pb;
        let lm = ln(m);
        let ta = ka.map_or(0.0, |k| term(wa, pa, la(k), lm));
        let tb = kb.map_or(0.0, |k| term(wb, pb, lb(k), lm));
        acc.add(ta + tb);
    }
    let d = acc.value();
    nonnegative_in(d, base)
}

/// One entry's term of an information sum `Σ p ln(p_cond / q)`: `p (ln p_cond
/// − ln q)` from the two logarithms, `+∞` where `q = 0` (a mass that the
/// reference distribution lacks). One definition for the specific
/// information (Part II) and the channel's `I(X;Y)`, with or without
/// precomputed logarithms.
#[inline(always)]
fn information_term(p: f64, q: f64, lp: f64, lq: f64) -> f64 {
    if q > 0.0 { p * (lp - lq) } else { f64::INFINITY }
}

/// A sum of nonnegative terms (in nats) as `T` in `base`, rounding's
/// negative residue taken as 0.
#[inline(always)]
fn nonnegative_in<T: Real>(d: f64, base: Base) -> T {
    T::from_f64(if d < 0.0 { 0.0 } else { d * base.per_nat() })
}

/// One index's term of the Jensen–Shannon divergence (Part II eq. (17)):
/// `π_i p_i (ln p_i − ln m)`, 0 where `π_i` or `p_i` is (an index absent
/// from `p_i` has `p_i = 0`).
#[inline(always)]
fn js_term(w: f64, p: f64, lp: f64, lm: f64) -> f64 {
    if w > 0.0 && p > 0.0 { w * p * (lp - lm) } else { 0.0 }
}

/// Entries a batch of [`js_merge_batched`] (merged indices) and of
/// [`SparseChannel::specific_information_into`] (a row's) holds: arrays on
/// the stack whose logarithms are taken in one pass.
const BATCH: usize = 128;

/// [`js_merge`] on given logarithms, bit for bit (the same mixture, terms and
/// compensated sum in the same order): the merge fills a batch of mixture
/// values, their logarithms are taken in one pass ([`crate::dispatch::ln_into`],
/// vectorised: [`ln`] has no branches), then the terms are summed in order.
/// An index present in one row only reads `p = 0` for the other, whose
/// term is then 0, as [`js_merge`]'s absent term is.
fn js_merge_batched<T: Real>(weights: (T, T), a: (&[u32], &[T], &[f64]), b: (&[u32], &[T], &[f64]), base: Base) -> T {
    let (wa, wb) = (weights.0.to_f64(), weights.1.to_f64());
    let (na, nb) = (a.0.len(), b.0.len());
    let (mut i, mut j) = (0, 0);
    let mut acc = Neumaier::new();
    let mut m = [0.0f64; BATCH];
    let mut lm = [0.0f64; BATCH];
    let mut pa = [0.0f64; BATCH];
    let mut pb = [0.0f64; BATCH];
    let mut lpa = [0.0f64; BATCH];
    let mut lpb = [0.0f64; BATCH];
    while i < na || j < nb {
        let mut n = 0;
        while n < BATCH && (i < na || j < nb) {
            let ia = if i < na { a.0[i] } else { u32::MAX };
            let ib = if j < nb { b.0[j] } else { u32::MAX };
            // `js_merge`'s choice: the smaller index, both when equal; an
            // exhausted row is never taken.
            let take_a = i < na && (ia <= ib || j >= nb);
            let take_b = j < nb && (ib <= ia || i >= na);
            (pa[n], lpa[n]) = if take_a { (a.1[i].to_f64(), a.2[i]) } else { (0.0, 0.0) };
            (pb[n], lpb[n]) = if take_b { (b.1[j].to_f64(), b.2[j]) } else { (0.0, 0.0) };
            i += usize::from(take_a);
            j += usize::from(take_b);
            m[n] = wa * pa[n] + wb * pb[n];
            n += 1;
        }
        crate::dispatch::ln_into(&m[..n], &mut lm[..n]);
        for k in 0..n {
            acc.add(js_term(wa, pa[k], lpa[k], lm[k]) + js_term(wb, pb[k], lpb[k], lm[k]));
        }
    }
    let d = acc.value();
    nonnegative_in(d, base)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three rows over five outputs, uneven, with `p(y)` and every logarithm.
    #[allow(clippy::type_complexity)]
    fn channel() -> ([f64; 3], [usize; 4], [u32; 8], [f64; 8]) {
        ([0.2, 0.5, 0.3], [0, 3, 5, 8], [0, 1, 3, 1, 4, 0, 2, 3], [0.3, 0.6, 0.1, 0.25, 0.75, 0.125, 0.5, 0.375])
    }

    fn logs(xs: &[f64]) -> alloc::vec::Vec<f64> {
        let mut l = alloc::vec![0.0; xs.len()];
        sparse_logs(xs, &mut l);
        l
    }

    #[test]
    fn logs_and_blocks_give_the_whole_passes_bits() {
        let (input, starts, cols, values) = channel();
        let ch = SparseChannel::new(&input, &starts, &cols, &values, 5).unwrap();
        let mut p_y = [0.0; 5];
        ch.output_into(&mut p_y).unwrap();
        let (lv, ly) = (logs(&values), logs(&p_y));
        // Output blocks of two, apart.
        let (mut q, mut info, mut block) = ([0.0; 5], [0.0; 5], [0.0; 5]);
        ch.output_specific_information_into(&p_y, Base::Bits, &mut info).unwrap();
        for a in (0..5).step_by(2) {
            let r = a..(a + 2).min(5);
            ch.output_cols_into(r.clone(), &mut q[r.clone()]).unwrap();
            ch.output_specific_information_cols_into(&p_y, r.clone(), Base::Bits, &mut block[r]).unwrap();
        }
        assert_eq!(q.map(f64::to_bits), p_y.map(f64::to_bits));
        assert_eq!(block.map(f64::to_bits), info.map(f64::to_bits));
        let m = ch.measures(&p_y, Base::Bits).unwrap();
        assert_eq!(ch.measures_logs(&p_y, &ly, &lv, Base::Bits).unwrap(), m);
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        ch.specific_information_into(&p_y, Base::Bits, &mut a).unwrap();
        ch.specific_information_logs_into(&p_y, &ly, &lv, Base::Bits, &mut b).unwrap();
        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
        assert!(ch.measures_logs(&p_y, &ly, &lv[1..], Base::Bits).is_err());
    }

    #[test]
    fn checked_rows_give_the_pairs_bits() {
        let (input, starts, cols, values) = channel();
        let rows = SparseRows::new(&input, starts.to_vec(), cols.to_vec(), values.to_vec(), 5).unwrap();
        let ch = rows.channel(&input).unwrap();
        let lv = logs(&values);
        for (a, b) in [(0, 1), (1, 2), (2, 0)] {
            let w = (input[a] / (input[a] + input[b]), input[b] / (input[a] + input[b]));
            let (ra, rb) = (ch.row(a), ch.row(b));
            let (la, lb) = (&lv[starts[a]..starts[a + 1]], &lv[starts[b]..starts[b + 1]]);
            let plain = jensen_shannon_sparse(w, ra, rb, Base::Bits).unwrap();
            let with = jensen_shannon_sparse_logs(w, (ra.0, ra.1, la), (rb.0, rb.1, lb), Base::Bits).unwrap();
            assert_eq!(ch.jensen_shannon(w, a, b, Base::Bits).unwrap().to_bits(), plain.to_bits());
            assert_eq!(ch.jensen_shannon_logs(w, a, b, &lv, Base::Bits).unwrap().to_bits(), with.to_bits());
        }
        assert!(ch.jensen_shannon((0.5, 0.5), 0, 3, Base::Bits).is_err());
        assert!(ch.jensen_shannon((0.5, 0.6), 0, 1, Base::Bits).is_err());
        // Rows 1..3 alone: row 0 of the part is row 1.
        let part = ch.rows_with_input(1..3, &[0.5, 0.5]).unwrap();
        assert_eq!((part.inputs(), part.nonzeros(), part.row(0)), (2, 5, ch.row(1)));
        assert!(ch.rows_with_input(1..3, &[0.5, 0.6]).is_err());
        assert!(ch.rows_with_input(2..4, &[0.5, 0.5]).is_err());
        assert!(rows.channel(&[0.5, 0.5]).is_err());
        assert!(SparseRows::new(&input, starts.to_vec(), cols.to_vec(), alloc::vec![0.5; 8], 5).is_err());
    }
}
