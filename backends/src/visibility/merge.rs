//! Merging the counts of shards of one run (`--merge`): checked first,
//! then exact integer and fixed-point sums, so any merge order gives the
//! same counts.

use itgfx_core::PairCount;

use super::counts_file::{fmt_ranges, overflow, same_scene};
use super::{BlockCounts, CountsError, VisibilityCounts};

impl VisibilityCounts {
    /// Adds the counts of another shard of the same run: same scene, seed,
    /// line kind and block count, line ranges disjoint from these. Integer
    /// and fixed-point sums are exact, so any merge order gives the same
    /// counts. On error `self` is unchanged.
    ///
    /// # Errors
    /// [`CountsError::Mismatch`] naming what differs or the ranges that
    /// overlap; [`CountsError::Overflow`] if a count would pass 64 bits.
    pub fn merge(&mut self, other: VisibilityCounts) -> Result<(), CountsError> {
        same_scene(&self.scene, &other.scene, "these counts are", "the others")?;
        other.validate()?;
        if other.local != self.local {
            return Err(CountsError::Mismatch("cannot merge local-line and global-line counts".into()));
        }
        if other.seed != self.seed {
            return Err(CountsError::Mismatch(format!(
                "the counts are of seed {} and seed {}: shards of one run share a seed",
                self.seed, other.seed
            )));
        }
        if other.blocks.len() != self.blocks.len() {
            return Err(CountsError::Mismatch(format!(
                "the counts have {} and {} jackknife blocks: shards of one run share --blocks",
                self.blocks.len(),
                other.blocks.len()
            )));
        }
        let mut ranges: Vec<(u64, u64)> = self.ranges.iter().chain(&other.ranges).copied().collect();
        ranges.sort_unstable();
        for w in ranges.windows(2) {
            // Sorted: w[0] starts first; one inside the other is a repeat.
            let inner = if w[1].1 <= w[0].1 { Some(w[1]) } else { (w[0].0 == w[1].0).then_some(w[0]) };
            if let (Some(r), true) = (inner, w[1].0 < w[0].1) {
                return Err(CountsError::Mismatch(format!("lines {} are counted twice", fmt_ranges(r))));
            }
            if w[1].0 < w[0].1 {
                return Err(CountsError::Mismatch(format!(
                    "line ranges {} and {} overlap",
                    fmt_ranges(w[0]),
                    fmt_ranges(w[1])
                )));
            }
        }
        let mut joined: Vec<(u64, u64)> = Vec::with_capacity(ranges.len());
        for r in ranges {
            match joined.last_mut() {
                Some(last) if last.1 == r.0 => last.1 = r.1,
                _ => joined.push(r),
            }
        }
        let add = |a: u64, b: u64, what: &str| a.checked_add(b).ok_or_else(|| overflow(what));
        let mut blocks = Vec::with_capacity(self.blocks.len());
        for (a, b) in self.blocks.iter().zip(&other.blocks) {
            blocks.push(BlockCounts {
                lines: add(a.lines, b.lines, "a block's line count")?,
                segments: add(a.segments, b.segments, "a block's segment count")?,
                escaped: add(a.escaped, b.escaped, "a block's background count")?,
                pairs: merge_sorted(
                    &a.pairs,
                    &b.pairs,
                    |p| (p.from, p.to),
                    |p| p.count,
                    |p, c| PairCount { count: c, ..*p },
                )?,
                background: merge_sorted(&a.background, &b.background, |p| p.0, |p| p.1, |p, c| (p.0, c))?,
                continuous: a.continuous.checked_add(&b.continuous).ok_or_else(|| overflow("an I_S^c sum"))?,
            });
        }
        let mut endpoints = self.endpoints.clone();
        let mut endpoint_log = self.endpoint_log.clone();
        for i in 0..endpoints.len() {
            endpoints[i] = add(endpoints[i], other.endpoints[i], "an endpoint count")?;
            endpoint_log[i] =
                endpoint_log[i].checked_add(other.endpoint_log[i]).ok_or_else(|| overflow("an endpoint sum"))?;
        }
        let merged = Self {
            scene: self.scene.clone(),
            areas: self.areas.clone(),
            local: self.local,
            seed: self.seed,
            ranges: joined,
            blocks,
            endpoints,
            endpoint_log,
        };
        merged.validate()?;
        *self = merged;
        Ok(())
    }
}

/// Merges two sorted sparse lists, adding the counts of equal keys.
pub(super) fn merge_sorted<T: Copy, K: Ord>(
    a: &[T],
    b: &[T],
    key: impl Fn(&T) -> K,
    count: impl Fn(&T) -> u64,
    with: impl Fn(&T, u64) -> T,
) -> Result<Vec<T>, CountsError> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match key(&a[i]).cmp(&key(&b[j])) {
            std::cmp::Ordering::Less => {
                out.push(a[i]);
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                out.push(b[j]);
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                let c = count(&a[i]).checked_add(count(&b[j])).ok_or_else(|| overflow("a pair count"))?;
                out.push(with(&a[i], c));
                i += 1;
                j += 1;
            }
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    Ok(out)
}
