//! Reductions of the core measures on a Vulkan device, for arrays too large
//! to want on the CPU: the entropy of a weight array (Part II eq. (1)), the
//! Kullback–Leibler divergence (eq. (8)) and a channel's `I(X;Y)`, `H(Y)`
//! and `H(Y|X)` (eqs. (5)-(7)). Sums are accumulated in f64 per invocation and
//! added on the host with the core's compensated sum; every input is checked
//! on the device (negative, NaN, infinite values; row and total
//! normalisation) with the same tolerance as the core's f32 measures.
//!
//! Logarithms are taken in f32 on the device (naga's f64 `log` is not valid
//! SPIR-V), so each term carries a relative error of about 1e-7: results agree
//! with the core's f64 measures to about 1e-6 of the entropies involved
//! (tested).

use itgfx_core::sum::Neumaier;
use itgfx_core::{Base, Error};

use super::{Buffer, Gpu, Kernel, Use};
use crate::tracer::BackendError;

const XLOGY: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/xlogy.spv"));
const AXIS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/axis_sum.spv"));
/// Elements per dispatch (32 MiB of f32, a quarter of lavapipe's buffer limit).
const CHUNK: usize = 1 << 23;
/// `|Σ − 1|` allowed for a distribution (the core's f32 tolerance).
const TOLERANCE: f64 = 1e-5;
/// Elements per invocation.
const PER: usize = 256;

/// Reductions on the device. Fields drop before the device.
pub struct Reducer {
    xlogy: Kernel,
    axis: Kernel,
    input: Buffer,
    second: Buffer,
    weights: Buffer,
    partial: Buffer,
    bad: Buffer,
    sums: Buffer,
    gpu: Gpu,
}

/// A channel's information, in one unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelInformation {
    /// `I(X;Y)`.
    pub mutual_information: f64,
    /// `H(Y)`.
    pub h_y: f64,
    /// `H(Y|X)`.
    pub h_y_given_x: f64,
}

/// Why a reduction failed: the device, or the input (the core's own error,
/// with the same indices and tolerances as its f32 measures).
#[derive(Debug, Clone, PartialEq)]
pub enum ReduceError {
    /// The device failed or is missing.
    Backend(BackendError),
    /// The input was refused.
    Measure(Error),
}

impl std::fmt::Display for ReduceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReduceError::Backend(e) => e.fmt(f),
            ReduceError::Measure(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for ReduceError {}

impl From<BackendError> for ReduceError {
    fn from(e: BackendError) -> Self {
        ReduceError::Backend(e)
    }
}

impl From<Error> for ReduceError {
    fn from(e: Error) -> Self {
        ReduceError::Measure(e)
    }
}

impl Reducer {
    /// Opens the preferred device.
    ///
    /// # Errors
    /// [`BackendError::Unavailable`] with the fix when Vulkan is missing.
    pub fn new() -> Result<Self, BackendError> {
        let gpu = Gpu::open()?;
        let xlogy = gpu.kernel(XLOGY, c"xlogy", 5, 16)?;
        let axis = gpu.kernel(AXIS, c"axis_sum", 4, 32)?;
        let invocations = CHUNK / PER;
        Ok(Self {
            xlogy,
            axis,
            input: gpu.buffer((CHUNK * 4) as u64)?,
            second: gpu.buffer((CHUNK * 4) as u64)?,
            weights: gpu.buffer((CHUNK * 4) as u64)?,
            partial: gpu.buffer_for((invocations * 32) as u64, Use::Readback)?,
            bad: gpu.buffer_for((CHUNK * 4) as u64, Use::Readback)?,
            sums: gpu.buffer_for((CHUNK * 8) as u64, Use::Readback)?,
            gpu,
        })
    }

    /// The device in use.
    #[must_use]
    pub fn device(&self) -> &super::DeviceInfo {
        &self.gpu.info
    }

    /// `H(w / Σw)` of non-negative weights, in `base`: the `xlogy` kernel
    /// with `b = 1` gives `Σ w` and `Σ w ln w`.
    ///
    /// # Errors
    /// [`Error::NonFinite`] or [`Error::Negative`] naming the first bad
    /// element, [`Error::ZeroMass`], device errors.
    pub fn entropy(&mut self, weights: &[f32], base: Base) -> Result<f64, ReduceError> {
        let mut t = Terms::new();
        self.second.write_words(0, [1f32.to_bits()]);
        self.weights.write_words(0, [1f32.to_bits()]);
        for (c, chunk) in weights.chunks(CHUNK).enumerate() {
            self.input.write_words(0, chunk.iter().map(|x| x.to_bits()));
            if self.xlogy_pass(chunk.len(), 1, chunk.len(), &mut t)? {
                return Err(first_bad(chunk, c * CHUNK).into());
            }
        }
        let s = t.wa.value();
        if !(s > 0.0) {
            return Err(Error::ZeroMass.into());
        }
        let h = itgfx_core::entropy_nats_of_sums(s, t.xlnx.value());
        Ok(h * base.per_nat())
    }
}

/// The `i`-th f64 of a buffer.
fn f64_at(b: &Buffer, i: usize) -> f64 {
    f64::from_bits(u64::from(b.word(2 * i)) | u64::from(b.word(2 * i + 1)) << 32)
}

fn push(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

fn words(xs: &[f32]) -> impl Iterator<Item = u32> + '_ {
    xs.iter().map(|x| x.to_bits())
}

/// The core's error for the first NaN, infinite or negative value of `xs`
/// (offset by `base`); `ZeroMass` if there is none.
fn first_bad(xs: &[f32], base: usize) -> Error {
    match xs.iter().position(|x| !(*x >= 0.0 && x.is_finite())) {
        Some(k) if xs[k].is_finite() => Error::Negative { index: base + k },
        Some(k) => Error::NonFinite { index: base + k },
        None => Error::ZeroMass,
    }
}

fn normalized(sum: f64) -> Result<(), Error> {
    if sum == 0.0 {
        return Err(Error::ZeroMass);
    }
    if !((sum - 1.0).abs() <= TOLERANCE) {
        return Err(Error::NotNormalized { sum });
    }
    Ok(())
}

/// Sums of one `xlogy` dispatch: `(Σ w a, Σ w a ln(a/b), Σ w a ln a, Σ b, flags)`.
struct Terms {
    wa: Neumaier,
    div: Neumaier,
    xlnx: Neumaier,
    b: Neumaier,
    infinite: bool,
}

impl Terms {
    fn new() -> Self {
        Self { wa: Neumaier::new(), div: Neumaier::new(), xlnx: Neumaier::new(), b: Neumaier::new(), infinite: false }
    }
}

impl Reducer {
    /// Runs `xlogy` over the `n` elements already in `input`/`second`/`weights`;
    /// returns whether any input was invalid.
    fn xlogy_pass(&mut self, n: usize, bcols: usize, wcols: usize, t: &mut Terms) -> Result<bool, BackendError> {
        let inv = n.div_ceil(PER);
        let p = push(&[n as u32, PER as u32, bcols as u32, wcols as u32]);
        let read = [&self.input, &self.second, &self.weights];
        self.gpu.dispatch(&self.xlogy, &read, &mut [&mut self.partial, &mut self.bad], &p, inv.div_ceil(64) as u32)?;
        let mut invalid = false;
        for i in 0..inv {
            let f = self.bad.word(i);
            invalid |= f & 1 != 0;
            t.infinite |= f & 2 != 0;
            t.wa.add(f64_at(&self.partial, 4 * i));
            t.div.add(f64_at(&self.partial, 4 * i + 1));
            t.xlnx.add(f64_at(&self.partial, 4 * i + 2));
            t.b.add(f64_at(&self.partial, 4 * i + 3));
        }
        Ok(invalid)
    }

    /// Runs `axis_sum` over the matrix in `input`; sums land in `sums`.
    fn axis_pass(
        &mut self,
        count: usize,
        len: usize,
        s1: usize,
        s2: usize,
        weighted: bool,
    ) -> Result<bool, BackendError> {
        let p = push(&[count as u32, len as u32, s1 as u32, s2 as u32, u32::from(weighted), 0, 0, 0]);
        let read = [&self.input, &self.weights];
        self.gpu.dispatch(&self.axis, &read, &mut [&mut self.sums, &mut self.bad], &p, count.div_ceil(64) as u32)?;
        Ok((0..count).any(|j| self.bad.word(j) != 0))
    }

    /// `D_KL(p ‖ q)` (Part II eq. (8)); `+∞` when `p > 0 = q` somewhere.
    ///
    /// # Errors
    /// [`Error::Empty`], [`Error::LengthMismatch`], [`Error::NonFinite`] or
    /// [`Error::Negative`] (the first bad element of `p`, then of `q`),
    /// [`Error::NotNormalized`] or [`Error::ZeroMass`] for either, device errors.
    pub fn kl_divergence(&mut self, p: &[f32], q: &[f32], base: Base) -> Result<f64, ReduceError> {
        if p.is_empty() {
            return Err(Error::Empty.into());
        }
        if p.len() != q.len() {
            return Err(Error::LengthMismatch { expected: p.len(), found: q.len() }.into());
        }
        let mut t = Terms::new();
        self.weights.write_words(0, [1f32.to_bits()]);
        for (c, (pc, qc)) in p.chunks(CHUNK).zip(q.chunks(CHUNK)).enumerate() {
            self.input.write_words(0, words(pc));
            self.second.write_words(0, words(qc));
            if self.xlogy_pass(pc.len(), pc.len(), pc.len(), &mut t)? {
                let p_ok = pc.iter().all(|x| *x >= 0.0 && x.is_finite());
                return Err(if p_ok { first_bad(qc, c * CHUNK) } else { first_bad(pc, c * CHUNK) }.into());
            }
        }
        normalized(t.wa.value())?;
        normalized(t.b.value())?;
        if t.infinite {
            return Ok(f64::INFINITY);
        }
        Ok(t.div.value().max(0.0) * base.per_nat())
    }

    /// `I(X;Y)`, `H(Y)` and `H(Y|X)` of the channel with input `p(x)` and
    /// the row-major `|X| × cols` matrix `p(y|x)` (Part II eqs. (5)-(7)).
    ///
    /// # Errors
    /// [`Error::Empty`], [`Error::LengthMismatch`],
    /// [`Error::InvalidParameter`] when one row exceeds a dispatch,
    /// [`Error::NonFinite`] or [`Error::Negative`] with the row-major index,
    /// [`Error::RowNotNormalized`], [`Error::NotNormalized`] for the input,
    /// device errors.
    pub fn channel(
        &mut self,
        input: &[f32],
        matrix: &[f32],
        cols: usize,
        base: Base,
    ) -> Result<ChannelInformation, ReduceError> {
        let rows = input.len();
        if rows == 0 || cols == 0 {
            return Err(Error::Empty.into());
        }
        if cols > CHUNK {
            return Err(Error::InvalidParameter { name: "cols", value: cols as f64 }.into());
        }
        if matrix.len() != rows * cols {
            return Err(Error::LengthMismatch { expected: rows * cols, found: matrix.len() }.into());
        }
        if input.iter().any(|x| !(*x >= 0.0 && x.is_finite())) {
            return Err(first_bad(input, 0).into());
        }
        normalized(input.iter().map(|&x| f64::from(x)).sum())?;
        let per_chunk = (CHUNK / cols).max(1);
        let chunks = rows.div_ceil(per_chunk);
        // Pass 1: row sums (normalisation) and p(y) = Σ_x p(x) p(y|x).
        let mut p_y = vec![Neumaier::new(); cols];
        for c in 0..chunks {
            let (r0, r1) = (c * per_chunk, ((c + 1) * per_chunk).min(rows));
            let m = &matrix[r0 * cols..r1 * cols];
            self.input.write_words(0, words(m));
            self.weights.write_words(0, words(&input[r0..r1]));
            if self.axis_pass(r1 - r0, cols, cols, 1, false)? {
                return Err(first_bad(m, r0 * cols).into());
            }
            for r in 0..r1 - r0 {
                let s = f64_at(&self.sums, r);
                if !((s - 1.0).abs() <= TOLERANCE) {
                    return Err(Error::RowNotNormalized { row: r0 + r, sum: s }.into());
                }
            }
            self.axis_pass(cols, r1 - r0, 1, cols, true)?;
            for (j, acc) in p_y.iter_mut().enumerate() {
                acc.add(f64_at(&self.sums, j));
            }
        }
        let p_y: Vec<f64> = p_y.iter().map(Neumaier::value).collect();
        // Pass 2: Σ p(x) p(y|x) ln(p(y|x)/p(y)) and Σ p(x) p(y|x) ln p(y|x).
        let p_y32: Vec<f32> = p_y.iter().map(|&x| x as f32).collect();
        self.second.write_words(0, words(&p_y32));
        let mut t = Terms::new();
        for c in 0..chunks {
            let (r0, r1) = (c * per_chunk, ((c + 1) * per_chunk).min(rows));
            if chunks > 1 {
                self.input.write_words(0, words(&matrix[r0 * cols..r1 * cols]));
                self.weights.write_words(0, words(&input[r0..r1]));
            }
            self.xlogy_pass((r1 - r0) * cols, cols, cols, &mut t)?;
        }
        let h_y = itgfx_core::entropy_of_weights(&p_y, Base::Nats)?;
        let k = base.per_nat();
        Ok(ChannelInformation {
            mutual_information: t.div.value().max(0.0) * k,
            h_y: h_y * k,
            h_y_given_x: (-t.xlnx.value()).max(0.0) * k,
        })
    }
}
