//! Compensated summation: the only place a float reduction is written.
//!
//! Reductions over long slices are done in blocks: inside a block of
//! 256 elements, several plain partial sums (8 lanes in the hot kernels of
//! `scan`, 4 here; the compiler keeps them in registers and vectorises them); the block totals are then added with
//! Neumaier's compensated algorithm. The error is that of a naive sum of at
//! most `BLOCK / 4` terms plus a compensated sum of the blocks: for
//! `H(p)` with 10^8 `f64` elements the result stays within 1e-12 relative of
//! a high-precision reference (a test in `core/tests/golden.rs` checks 10^7
//! elements against a double-double reference).

use crate::Real;

/// Elements per block of the blocked reductions.
pub(crate) const BLOCK: usize = 256;

/// Neumaier's compensated running sum (an improved Kahan–Babuška sum).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Neumaier {
    sum: f64,
    compensation: f64,
}

impl Neumaier {
    /// An empty sum.
    #[must_use]
    pub const fn new() -> Self {
        Self { sum: 0.0, compensation: 0.0 }
    }

    /// Adds one term.
    #[inline]
    pub fn add(&mut self, x: f64) {
        let t = self.sum + x;
        if !t.is_finite() {
            // Infinite terms (KL's +∞) are values: carry them, never ∞ − ∞.
            self.sum = t;
            return;
        }
        if self.sum.abs() >= x.abs() {
            self.compensation += (self.sum - t) + x;
        } else {
            self.compensation += (x - t) + self.sum;
        }
        self.sum = t;
    }

    /// Adds another compensated sum (for merging shards).
    #[inline]
    pub fn merge(&mut self, other: &Self) {
        self.add(other.sum);
        self.add(other.compensation);
    }

    /// The compensated total.
    #[must_use]
    #[inline]
    pub fn value(&self) -> f64 {
        if !self.sum.is_finite() {
            return self.sum;
        }
        self.sum + self.compensation
    }
}

/// Compensated sum of `f(x)` over `xs` in blocks (see the module docs).
#[inline]
pub(crate) fn sum_map<T: Real>(xs: &[T], f: impl Fn(f64) -> f64) -> f64 {
    let mut total = Neumaier::new();
    for block in xs.chunks(BLOCK) {
        let mut acc = [0.0f64; 4];
        let mut quads = block.chunks_exact(4);
        for q in &mut quads {
            acc[0] += f(q[0].to_f64());
            acc[1] += f(q[1].to_f64());
            acc[2] += f(q[2].to_f64());
            acc[3] += f(q[3].to_f64());
        }
        for &x in quads.remainder() {
            acc[0] += f(x.to_f64());
        }
        total.add((acc[0] + acc[1]) + (acc[2] + acc[3]));
    }
    total.value()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neumaier_recovers_cancelled_terms() {
        let mut s = Neumaier::new();
        for x in [1.0, 1e100, 1.0, -1e100] {
            s.add(x);
        }
        assert_eq!(s.value(), 2.0);
    }

    #[test]
    fn blocked_sum_of_many_tenths() {
        let xs = [0.1f64; 100_003];
        let s = sum_map(&xs, |x| x);
        assert!((s - 10_000.3).abs() < 1e-10, "{s}");
    }
}
