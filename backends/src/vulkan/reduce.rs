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

use itgfx_core::Base;
use itgfx_core::sum::Neumaier;

use super::{Buffer, Gpu, Kernel};
use crate::tracer::BackendError;

const SPIRV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/entropy.spv"));
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
    kernel: Kernel,
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

/// Why a reduction failed.
#[derive(Debug, Clone, PartialEq)]
pub enum ReduceError {
    /// The device failed or is missing.
    Backend(BackendError),
    /// Element `index` is negative, NaN or infinite (the first such).
    Invalid {
        /// Its position.
        index: usize,
    },
    /// Every weight is zero (or the array is empty).
    ZeroMass,
    /// A distribution summed to `sum`, not 1.
    NotNormalized {
        /// The sum found.
        sum: f64,
    },
    /// Row `row` of a conditional matrix summed to `sum`.
    RowNotNormalized {
        /// The row.
        row: usize,
        /// Its sum.
        sum: f64,
    },
    /// Lengths disagree.
    LengthMismatch {
        /// Expected.
        expected: usize,
        /// Found.
        found: usize,
    },
}

impl std::fmt::Display for ReduceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReduceError::Backend(e) => e.fmt(f),
            ReduceError::Invalid { index } => write!(f, "value at index {index} is negative or not finite"),
            ReduceError::ZeroMass => write!(f, "all weights are zero"),
            ReduceError::NotNormalized { sum } => write!(f, "probabilities sum to {sum}, not 1"),
            ReduceError::RowNotNormalized { row, sum } => write!(f, "row {row} sums to {sum}, not 1"),
            ReduceError::LengthMismatch { expected, found } => {
                write!(f, "length mismatch: expected {expected} values, found {found}")
            }
        }
    }
}

impl std::error::Error for ReduceError {}

impl From<BackendError> for ReduceError {
    fn from(e: BackendError) -> Self {
        ReduceError::Backend(e)
    }
}

impl Reducer {
    /// Opens the preferred device.
    ///
    /// # Errors
    /// [`BackendError::Unavailable`] with the fix when Vulkan is missing.
    pub fn new() -> Result<Self, BackendError> {
        let gpu = Gpu::open()?;
        let kernel = gpu.kernel(SPIRV, c"entropy", 3, 16)?;
        let xlogy = gpu.kernel(XLOGY, c"xlogy", 5, 16)?;
        let axis = gpu.kernel(AXIS, c"axis_sum", 4, 32)?;
        let invocations = CHUNK / PER;
        Ok(Self {
            kernel,
            xlogy,
            axis,
            input: gpu.buffer((CHUNK * 4) as u64)?,
            second: gpu.buffer((CHUNK * 4) as u64)?,
            weights: gpu.buffer((CHUNK * 4) as u64)?,
            partial: gpu.buffer((invocations * 32) as u64)?,
            bad: gpu.buffer((CHUNK * 4) as u64)?,
            sums: gpu.buffer((CHUNK * 8) as u64)?,
            gpu,
        })
    }

    /// The device in use.
    #[must_use]
    pub fn device(&self) -> &super::DeviceInfo {
        &self.gpu.info
    }

    /// `H(w / Σw)` of non-negative weights, in `base`.
    ///
    /// # Errors
    /// [`ReduceError::Invalid`] naming the first bad element,
    /// [`ReduceError::ZeroMass`], device errors.
    pub fn entropy(&mut self, weights: &[f32], base: Base) -> Result<f64, ReduceError> {
        let (mut sum, mut xlnx) = (Neumaier::new(), Neumaier::new());
        for (c, chunk) in weights.chunks(CHUNK).enumerate() {
            let words: Vec<u32> = chunk.iter().map(|x| x.to_bits()).collect();
            self.input.write_words(0, &words);
            let inv = chunk.len().div_ceil(PER);
            let push: Vec<u8> = [chunk.len() as u32, PER as u32, 0, 0].iter().flat_map(|w| w.to_le_bytes()).collect();
            self.gpu.dispatch(
                &self.kernel,
                &[&self.input, &self.partial, &self.bad],
                &push,
                inv.div_ceil(64) as u32,
            )?;
            for i in 0..inv {
                if self.bad.word(i) != 0 {
                    let start = i * PER;
                    let k = chunk[start..].iter().position(|x| !(*x >= 0.0 && x.is_finite())).unwrap_or(0);
                    return Err(ReduceError::Invalid { index: c * CHUNK + start + k });
                }
                sum.add(f64_at(&self.partial, 2 * i));
                xlnx.add(f64_at(&self.partial, 2 * i + 1));
            }
        }
        let s = sum.value();
        if !(s > 0.0) {
            return Err(ReduceError::ZeroMass);
        }
        let h = (s.ln() - xlnx.value() / s).max(0.0);
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

fn words(xs: &[f32]) -> Vec<u32> {
    xs.iter().map(|x| x.to_bits()).collect()
}

/// The first negative, NaN or infinite value of `xs`, offset by `base`.
fn first_bad(xs: &[f32], base: usize) -> ReduceError {
    let k = xs.iter().position(|x| !(*x >= 0.0 && x.is_finite())).unwrap_or(0);
    ReduceError::Invalid { index: base + k }
}

fn normalized(sum: f64) -> Result<(), ReduceError> {
    if sum == 0.0 {
        return Err(ReduceError::ZeroMass);
    }
    if (sum - 1.0).abs() > TOLERANCE {
        return Err(ReduceError::NotNormalized { sum });
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
    fn xlogy_pass(&self, n: usize, bcols: usize, wcols: usize, t: &mut Terms) -> Result<bool, BackendError> {
        let inv = n.div_ceil(PER);
        let p = push(&[n as u32, PER as u32, bcols as u32, wcols as u32]);
        let buffers = [&self.input, &self.second, &self.weights, &self.partial, &self.bad];
        self.gpu.dispatch(&self.xlogy, &buffers, &p, inv.div_ceil(64) as u32)?;
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
    fn axis_pass(&self, count: usize, len: usize, s1: usize, s2: usize, weighted: bool) -> Result<bool, BackendError> {
        let p = push(&[count as u32, len as u32, s1 as u32, s2 as u32, u32::from(weighted), 0, 0, 0]);
        let buffers = [&self.input, &self.weights, &self.sums, &self.bad];
        self.gpu.dispatch(&self.axis, &buffers, &p, count.div_ceil(64) as u32)?;
        Ok((0..count).any(|j| self.bad.word(j) != 0))
    }

    /// `D_KL(p ‖ q)` (Part II eq. (8)); `+∞` when `p > 0 = q` somewhere.
    ///
    /// # Errors
    /// [`ReduceError::LengthMismatch`], [`ReduceError::Invalid`] (the first bad
    /// element of `p`, then of `q`), [`ReduceError::NotNormalized`] or
    /// [`ReduceError::ZeroMass`] for either, device errors.
    pub fn kl_divergence(&mut self, p: &[f32], q: &[f32], base: Base) -> Result<f64, ReduceError> {
        if p.len() != q.len() || p.is_empty() {
            return Err(ReduceError::LengthMismatch { expected: p.len(), found: q.len() });
        }
        let mut t = Terms::new();
        self.weights.write_words(0, &[1f32.to_bits()]);
        for (c, (pc, qc)) in p.chunks(CHUNK).zip(q.chunks(CHUNK)).enumerate() {
            self.input.write_words(0, &words(pc));
            self.second.write_words(0, &words(qc));
            if self.xlogy_pass(pc.len(), pc.len(), pc.len(), &mut t)? {
                let p_ok = pc.iter().all(|x| *x >= 0.0 && x.is_finite());
                return Err(if p_ok { first_bad(qc, c * CHUNK) } else { first_bad(pc, c * CHUNK) });
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
    /// [`ReduceError::LengthMismatch`] (also when one row exceeds a dispatch),
    /// [`ReduceError::Invalid`] with the row-major index,
    /// [`ReduceError::RowNotNormalized`], [`ReduceError::NotNormalized`] for
    /// the input, device errors.
    pub fn channel(
        &mut self,
        input: &[f32],
        matrix: &[f32],
        cols: usize,
        base: Base,
    ) -> Result<ChannelInformation, ReduceError> {
        let rows = input.len();
        if rows == 0 || cols == 0 || cols > CHUNK || matrix.len() != rows * cols {
            return Err(ReduceError::LengthMismatch { expected: rows * cols, found: matrix.len() });
        }
        if let Some(k) = input.iter().position(|x| !(*x >= 0.0 && x.is_finite())) {
            return Err(ReduceError::Invalid { index: k });
        }
        normalized(input.iter().map(|&x| f64::from(x)).sum())?;
        let per_chunk = (CHUNK / cols).max(1);
        let chunks = rows.div_ceil(per_chunk);
        // Pass 1: row sums (normalisation) and p(y) = Σ_x p(x) p(y|x).
        let mut p_y = vec![Neumaier::new(); cols];
        for c in 0..chunks {
            let (r0, r1) = (c * per_chunk, ((c + 1) * per_chunk).min(rows));
            let m = &matrix[r0 * cols..r1 * cols];
            self.input.write_words(0, &words(m));
            self.weights.write_words(0, &words(&input[r0..r1]));
            if self.axis_pass(r1 - r0, cols, cols, 1, false)? {
                return Err(first_bad(m, r0 * cols));
            }
            for r in 0..r1 - r0 {
                let s = f64_at(&self.sums, r);
                if (s - 1.0).abs() > TOLERANCE {
                    return Err(ReduceError::RowNotNormalized { row: r0 + r, sum: s });
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
        self.second.write_words(0, &words(&p_y32));
        let mut t = Terms::new();
        for c in 0..chunks {
            let (r0, r1) = (c * per_chunk, ((c + 1) * per_chunk).min(rows));
            if chunks > 1 {
                self.input.write_words(0, &words(&matrix[r0 * cols..r1 * cols]));
                self.weights.write_words(0, &words(&input[r0..r1]));
            }
            self.xlogy_pass((r1 - r0) * cols, cols, cols, &mut t)?;
        }
        let h_y = itgfx_core::entropy_of_weights(&p_y, Base::Nats).map_err(|_| ReduceError::ZeroMass)?;
        let k = base.per_nat();
        Ok(ChannelInformation {
            mutual_information: t.div.value().max(0.0) * k,
            h_y: h_y * k,
            h_y_given_x: (-t.xlnx.value()).max(0.0) * k,
        })
    }
}
