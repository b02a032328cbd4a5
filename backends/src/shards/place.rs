//! A shard's place `i/n` in its run, and the part of the run it covers:
//! `[⌊i·total/n⌋, ⌊(i+1)·total/n⌋)` of lines, pixel rows or viewpoints
//! (one definition for every engine).

use std::fmt;
use std::ops::Range;

/// Most shards a run may be split into.
pub const MAX_SHARDS: u64 = 1 << 32;

/// Shard `index` of `count` (0-based: `0/4`, `1/4`, `2/4`, `3/4`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Place {
    /// Which shard, `0..count`.
    pub index: u64,
    /// How many shards the run is split into, at least 1.
    pub count: u64,
}

/// The range `[⌊i·total/n⌋, ⌊(i+1)·total/n⌋)` of `0..total` that shard `i`
/// of `n` covers: the `n` ranges are disjoint, contiguous, cover `0..total`,
/// and their lengths differ by at most one (`n = 0` is read as 1).
#[must_use]
pub fn range(i: u64, n: u64, total: u64) -> Range<u64> {
    let at = |k: u64| (u128::from(k) * u128::from(total) / u128::from(n.max(1))) as u64;
    at(i)..at(i + 1)
}

impl Place {
    /// The part of `0..total` this shard covers ([`range`]).
    #[must_use]
    pub fn range(self, total: u64) -> Range<u64> {
        range(self.index, self.count, total)
    }
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Why text is not a place `i/n`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PlaceError {
    /// No `/`.
    NotAPlace,
    /// A part that is not a non-negative integer.
    NotANumber(String),
    /// `n` is 0 or past [`MAX_SHARDS`].
    Count,
    /// `i >= n`.
    Index {
        /// `i`.
        index: u64,
        /// `n`.
        count: u64,
    },
}

impl fmt::Display for PlaceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlaceError::NotAPlace => f.write_str("expected i/n, e.g. 0/16 (shard i of n, 0-based)"),
            PlaceError::NotANumber(t) => write!(f, "{t:?} is not a non-negative integer"),
            PlaceError::Count => write!(f, "the shard count must be in 1..={MAX_SHARDS}"),
            PlaceError::Index { index, count } => {
                write!(f, "{index}/{count}: shards of {count} are numbered 0..={}", count - 1)
            }
        }
    }
}

impl std::error::Error for PlaceError {}

impl std::str::FromStr for Place {
    type Err = PlaceError;

    /// `i/n` with `0 <= i < n <= 2^32`.
    fn from_str(s: &str) -> Result<Self, PlaceError> {
        let (i, n) = s.split_once('/').ok_or(PlaceError::NotAPlace)?;
        let num = |t: &str| t.trim().parse::<u64>().map_err(|_| PlaceError::NotANumber(t.to_string()));
        let (index, count) = (num(i)?, num(n)?);
        if count == 0 || count > MAX_SHARDS {
            return Err(PlaceError::Count);
        }
        if index >= count {
            return Err(PlaceError::Index { index, count });
        }
        Ok(Self { index, count })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_tile_the_run() {
        for total in [1u64, 7, 100, 1_000_000_007, u64::MAX] {
            for count in [1u64, 2, 3, 16, 97] {
                if count > total {
                    continue;
                }
                let mut next = 0;
                let (mut lo, mut hi) = (u64::MAX, 0);
                for index in 0..count {
                    let r = Place { index, count }.range(total);
                    assert_eq!(r.start, next);
                    next = r.end;
                    lo = lo.min(r.end - r.start);
                    hi = hi.max(r.end - r.start);
                }
                assert_eq!(next, total);
                assert!(hi - lo <= 1 && lo >= 1);
            }
        }
    }

    #[test]
    fn parse_refuses_what_is_not_a_place() {
        assert_eq!("3/16".parse(), Ok(Place { index: 3, count: 16 }));
        for bad in ["3", "16/16", "1/0", "-1/4", "a/4", "1/4/5", "0/4294967297"] {
            assert!(bad.parse::<Place>().is_err(), "{bad}");
        }
    }
}
