//! Reductions of the core measures on a Vulkan device: the entropy of a large
//! weight array (Part II eq. (1)), accumulated in f64 per invocation and
//! summed on the host with the core's compensated sum.
//!
//! Logarithms are taken in f32 on the device (naga's f64 `log` is not valid
//! SPIR-V), so each term carries a relative error of about 1e-7; the result
//! agrees with the core's f64 entropy to about 1e-6 relative (tested).

use itgfx_core::Base;
use itgfx_core::sum::Neumaier;

use super::{Buffer, Gpu, Kernel};
use crate::tracer::BackendError;

const SPIRV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/entropy.spv"));
/// Elements per dispatch (64 MiB of f32, half lavapipe's buffer limit).
const CHUNK: usize = 1 << 24;
/// Elements per invocation.
const PER: usize = 256;

/// Entropy of weight arrays on the device. Fields drop before the device.
pub struct EntropyReducer {
    kernel: Kernel,
    input: Buffer,
    partial: Buffer,
    bad: Buffer,
    gpu: Gpu,
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
}

impl std::fmt::Display for ReduceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReduceError::Backend(e) => e.fmt(f),
            ReduceError::Invalid { index } => write!(f, "value at index {index} is negative or not finite"),
            ReduceError::ZeroMass => write!(f, "all weights are zero"),
        }
    }
}

impl std::error::Error for ReduceError {}

impl From<BackendError> for ReduceError {
    fn from(e: BackendError) -> Self {
        ReduceError::Backend(e)
    }
}

impl EntropyReducer {
    /// Opens the preferred device.
    ///
    /// # Errors
    /// [`BackendError::Unavailable`] with the fix when Vulkan is missing.
    pub fn new() -> Result<Self, BackendError> {
        let gpu = Gpu::open()?;
        let kernel = gpu.kernel(SPIRV, c"entropy", 3, 16)?;
        let invocations = CHUNK / PER;
        Ok(Self {
            kernel,
            input: gpu.buffer((CHUNK * 4) as u64)?,
            partial: gpu.buffer((invocations * 16) as u64)?,
            bad: gpu.buffer((invocations * 4) as u64)?,
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
                let lo = u64::from(self.partial.word(4 * i)) | u64::from(self.partial.word(4 * i + 1)) << 32;
                let hi = u64::from(self.partial.word(4 * i + 2)) | u64::from(self.partial.word(4 * i + 3)) << 32;
                sum.add(f64::from_bits(lo));
                xlnx.add(f64::from_bits(hi));
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
