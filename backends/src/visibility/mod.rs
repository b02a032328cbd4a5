//! The scene visibility channel from lines (Part III §1.4, §2–§8).
//!
//! **Global lines**: every pair of consecutive crossings along a line whose
//! first end faces forward (`n·d > 0`) and second end faces back (`n·d < 0`)
//! is a segment joining two patches that see each other; it counts once for
//! `i → j` and once for `j → i` (Part III Fig. 8), and gives one sample of
//! `log(A_T F(x, y))` for `I_S^c` (eq. (59)). A crossing whose partner is
//! missing (the line leaves the scene, or meets a back face) is counted
//! against the *background*: reported, never silently lost. In a closed,
//! consistently oriented scene traced watertight, the background count is 0.
//!
//! **Local lines** (`--local`): origins uniform on the surface (patches by
//! area), cosine directions; the nearest crossing, if it faces back, is the
//! destination (`F_ij = N_ij / N_i`, eq. (30)).
//!
//! **Jackknife blocks**: line `i` belongs to block `i mod B`, a function of
//! the global line index alone, so shards of a run (disjoint index ranges)
//! fill the same blocks as the run itself. Counts are kept per block
//! (sparse: one entry per distinct pair hit), which gives the delete-one-block
//! jackknife ([`jackknife`]): a standard error for `I_S` and `I_S^c`, and a
//! bias-corrected `I_S` (the plug-in estimate is biased upwards at low line
//! counts, as Part III Table 6 shows).
//!
//! **Exact sums**: every count is an integer and every `log(A_T F)` sum is a
//! fixed-point integer ([`FixedSum`]), so merging is associative and
//! commutative: the numbers do not depend on the thread count, the chunking,
//! the sharding or the order in which shards are merged, and a saved run
//! ([`counts_file`]) evaluates to the same bits as the run itself.
//!
//! Modules: [`count`] casts lines into counts, [`counts_file`] saves, loads,
//! validates them (JSON), [`counts_binary`] in the compact binary format,
//! [`merge`] adds shards, [`jackknife`] evaluates the measures.

pub mod count;
pub mod counts_binary;
pub mod counts_file;
pub mod counts_header;
pub mod counts_valid;
pub mod jackknife;
pub mod merge;
pub mod merge_job;
mod pairs;

use std::fmt;

use itgfx_core::PairCount;

use crate::tracer::BackendError;

pub use count::{CHUNK, SPHERE_SCALE, count_visibility, local_line};
pub use counts_header::FORMAT_VERSION;
pub use counts_valid::SceneFingerprint;
pub use jackknife::Complexity;

/// How to cast lines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineOptions {
    /// Lines to cast (global lines that miss the scene count too).
    pub lines: u64,
    /// Seed of the counter-based generator.
    pub seed: u64,
    /// Local lines instead of global ones.
    pub local: bool,
    /// Jackknife blocks `B` (1 disables the standard errors); line `i` goes
    /// to block `i mod B`.
    pub blocks: u32,
    /// Index of the first line (shards of one run use disjoint ranges).
    pub offset: u64,
}

/// Most jackknife blocks a run or a counts file may have.
pub const MAX_BLOCKS: u32 = 1024;

/// A sum of `log(A_T F)` samples (nats) in fixed point: the integer is the
/// sum of each sample rounded to a multiple of `2^-64`. Integer addition is
/// exact and order-free, which floating-point addition is not. A sample's
/// magnitude is below `2^10` (`|ln x| < 745` for finite positive `x`) and a
/// square's below `2^20`, so `i128` holds `2^43` squared samples even at the
/// bound; [`FixedSum::checked_add`] refuses anything past it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FixedSum(pub i128);

/// `2^64`, the fixed-point scale of [`FixedSum`].
const FIXED_SCALE: f64 = 18_446_744_073_709_551_616.0;

impl FixedSum {
    /// The fixed-point value nearest to a finite `x` with `|x| < 2^62`.
    #[must_use]
    #[inline]
    pub fn of(x: f64) -> Self {
        // `x · 2^64` is exact (a power of two). For 2^52 <= |y| < 2^127 (a
        // sample of magnitude 2^-12 and up: nearly all) `y` is an integer,
        // so `round` leaves it as it is, and `y as i128` (a library call)
        // is the 53-bit mantissa shifted by the exponent; `round` is a
        // library call too without SSE4.1.
        let y = x * FIXED_SCALE;
        let bits = y.to_bits();
        let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
        if (52..127).contains(&e) {
            let m = i128::from((bits & ((1 << 52) - 1)) | (1 << 52)) << (e - 52);
            return Self(if y < 0.0 { -m } else { m });
        }
        let y = y.round();
        if y.abs() < 9_223_372_036_854_775_808.0 {
            // |y| < 2^63: the integer `y` is exact in an i64 (one
            // instruction, where `as i128` is a library call).
            return Self(i128::from(y as i64));
        }
        // |y| >= 2^127, infinite or NaN: `as i128` saturates (NaN to 0).
        Self(y as i128)
    }

    /// Exact sum, `None` on overflow.
    #[must_use]
    #[inline]
    pub fn checked_add(self, o: Self) -> Option<Self> {
        self.0.checked_add(o.0).map(Self)
    }

    /// Exact difference, `None` on overflow.
    #[must_use]
    #[inline]
    pub fn checked_sub(self, o: Self) -> Option<Self> {
        self.0.checked_sub(o.0).map(Self)
    }

    /// The value as `f64` (one rounding).
    #[must_use]
    #[inline]
    pub fn to_f64(self) -> f64 {
        self.0 as f64 / FIXED_SCALE
    }
}

/// `I_S^c` samples of a block (Part III eq. (59)): their number, `Σ l` and
/// `Σ l²` with `l = ln(A_T F(x, y))` in nats.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContinuousSums {
    /// Samples.
    pub samples: u64,
    /// `Σ l`.
    pub sum: FixedSum,
    /// `Σ l²`.
    pub sum_sq: FixedSum,
}

impl ContinuousSums {
    /// Adds one sample `l` (finite); `false` (and nothing added) on overflow.
    #[inline]
    #[must_use]
    pub fn add(&mut self, l: f64) -> bool {
        self.add_fixed(FixedSum::of(l), l)
    }

    /// [`ContinuousSums::add`] with `FixedSum::of(l)` already at hand.
    #[inline]
    #[must_use]
    pub fn add_fixed(&mut self, fixed: FixedSum, l: f64) -> bool {
        let one = Self { samples: 1, sum: fixed, sum_sq: FixedSum::of(l * l) };
        match self.checked_add(&one) {
            Some(s) => {
                *self = s;
                true
            }
            None => false,
        }
    }

    /// Exact merge, `None` on overflow.
    #[must_use]
    pub fn checked_add(&self, o: &Self) -> Option<Self> {
        Some(Self {
            samples: self.samples.checked_add(o.samples)?,
            sum: self.sum.checked_add(o.sum)?,
            sum_sq: self.sum_sq.checked_add(o.sum_sq)?,
        })
    }
}

/// Counts of one jackknife block (the lines `i ≡ b mod B` of the ranges run).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BlockCounts {
    /// Lines cast.
    pub lines: u64,
    /// Segments (global) or lines reaching a patch (local).
    pub segments: u64,
    /// Crossings counted against the background.
    pub escaped: u64,
    /// `N_ij`, sorted by `(from, to)`, one entry per pair, counts positive.
    pub pairs: Vec<PairCount>,
    /// Background counts `(patch, count)`, sorted by patch, counts positive.
    pub background: Vec<(u32, u64)>,
    /// The `I_S^c` samples.
    pub continuous: ContinuousSums,
}

/// All counts of a run or of merged shards.
#[derive(Clone, Debug, PartialEq)]
pub struct VisibilityCounts {
    /// The scene counted.
    pub scene: SceneFingerprint,
    /// Patch areas (scene units), all positive and finite.
    pub areas: Vec<f64>,
    /// Whether local lines were used.
    pub local: bool,
    /// Seed of the line generator.
    pub seed: u64,
    /// Line index ranges `[start, end)` covered, sorted, disjoint, adjacent
    /// ones joined.
    pub ranges: Vec<(u64, u64)>,
    /// Per-block counts: `blocks[b]` holds the lines `i` with `i mod B = b`,
    /// `B = blocks.len()`.
    pub blocks: Vec<BlockCounts>,
    /// Segment endpoints (samples of `I_S^c` with an end) on each patch.
    pub endpoints: Vec<u64>,
    /// `Σ ln(A_T F)` over the endpoints on each patch (nats).
    pub endpoint_log: Vec<FixedSum>,
}

/// Why counting, loading or merging counts failed. One line each.
#[derive(Debug)]
pub enum CountsError {
    /// The tracing backend failed.
    Backend(BackendError),
    /// The text is not a counts file of this version.
    Format(String),
    /// The file parses but its contents are inconsistent or out of range.
    Invalid(String),
    /// Two sets of counts cannot be merged (another scene, seed, line kind,
    /// block count, or overlapping line ranges).
    Mismatch(String),
    /// A count or sum would overflow.
    Overflow(String),
    /// The input needs more memory than the process may use ([`crate::memory`]).
    TooLarge(crate::memory::OutOfMemory),
}

impl fmt::Display for CountsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CountsError::Backend(e) => write!(f, "{e}"),
            CountsError::Format(m) | CountsError::Invalid(m) | CountsError::Mismatch(m) => {
                write!(f, "{}", m.replace(['\n', '\r'], " "))
            }
            CountsError::Overflow(m) => write!(f, "{} overflows 64 bits", m.replace(['\n', '\r'], " ")),
            CountsError::TooLarge(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for CountsError {}

impl From<BackendError> for CountsError {
    fn from(e: BackendError) -> Self {
        CountsError::Backend(e)
    }
}

impl VisibilityCounts {
    /// Lines cast in all blocks.
    #[must_use]
    pub fn lines(&self) -> u64 {
        self.blocks.iter().map(|b| b.lines).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`FixedSum::of`]'s shifted mantissa is `as i128`'s integer, on both
    /// sides of every exponent it handles and past them.
    #[test]
    fn fixed_point_conversion_is_the_library_one() {
        let mut xs = vec![0.0, -0.0, 0.49, 0.5, -0.5, 1.0, 3.7, -745.0, 1e10, -2.0f64.powi(62) + 1e3, 2.0f64.powi(70)];
        xs.extend([f64::INFINITY, f64::NEG_INFINITY, f64::NAN, f64::MIN_POSITIVE, -f64::MIN_POSITIVE]);
        let mut state = 99u64;
        for _ in 0..200_000 {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let mag = 2.0f64.powi((state >> 58) as i32 - 40);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            xs.push(if state & 1 == 0 { u * mag } else { -u * mag });
        }
        for e in -70..63 {
            let p = 2.0f64.powi(e);
            xs.extend([p, -p, p.next_up(), p.next_down(), -p.next_down()]);
        }
        for x in xs {
            assert_eq!(FixedSum::of(x).0, (x * FIXED_SCALE).round() as i128, "{x:e}");
        }
    }
}
