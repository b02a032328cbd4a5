//! Merging the counts of shards of one run (`--merge`): checked first,
//! then exact integer and fixed-point sums, so any merge order gives the
//! same counts.

use itgfx_core::PairCount;

use super::counts_valid::{fmt_ranges, overflow, same_scene};
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
        // Check every sum first (nothing changes on error), then merge in
        // place one block at a time: the merged counts are held once, plus
        // one block (a copy of all blocks took 7 GB at 10^9 lines).
        let mut totals = Vec::with_capacity(self.blocks.len());
        let mut grow = Vec::with_capacity(self.blocks.len());
        for (a, b) in self.blocks.iter().zip(&other.blocks) {
            totals.push(BlockCounts {
                lines: add(a.lines, b.lines, "a block's line count")?,
                segments: add(a.segments, b.segments, "a block's segment count")?,
                escaped: add(a.escaped, b.escaped, "a block's background count")?,
                pairs: Vec::new(),
                background: Vec::new(),
                continuous: a.continuous.checked_add(&b.continuous).ok_or_else(|| overflow("an I_S^c sum"))?,
            });
            let new_pairs = new_keys(&a.pairs, &b.pairs, |p| (p.from, p.to), |p| p.count)
                .ok_or_else(|| overflow("a pair count"))?;
            let new_bg =
                new_keys(&a.background, &b.background, |p| p.0, |p| p.1).ok_or_else(|| overflow("a pair count"))?;
            grow.push((new_pairs, new_bg));
        }
        let mut endpoints = self.endpoints.clone();
        let mut endpoint_log = self.endpoint_log.clone();
        for i in 0..endpoints.len() {
            endpoints[i] = add(endpoints[i], other.endpoints[i], "an endpoint count")?;
            endpoint_log[i] =
                endpoint_log[i].checked_add(other.endpoint_log[i]).ok_or_else(|| overflow("an endpoint sum"))?;
        }
        grand_totals_fit(&totals, self.local)?;
        // Both inputs are valid and every sum fits, so the merge is valid:
        // sorted merges of sorted lists stay sorted, each block's totals and
        // bounds add up as its parts' do (`validate` would sweep every pair
        // of the merged counts again, once per shard merged).
        for (((a, b), t), (new_pairs, new_bg)) in self.blocks.iter_mut().zip(other.blocks).zip(totals).zip(grow) {
            merge_into(
                &mut a.pairs,
                &b.pairs,
                new_pairs,
                |p| (p.from, p.to),
                |p, q| PairCount { count: p.count + q.count, ..*p },
            );
            merge_into(&mut a.background, &b.background, new_bg, |p| p.0, |p, q| (p.0, p.1 + q.1));
            let (pairs, background) = (std::mem::take(&mut a.pairs), std::mem::take(&mut a.background));
            *a = BlockCounts { pairs, background, ..t };
        }
        self.ranges = joined;
        self.endpoints = endpoints;
        self.endpoint_log = endpoint_log;
        debug_assert!(self.validate().is_ok(), "{:?}", self.validate());
        Ok(())
    }
}

/// How many keys of the sorted list `b` the sorted list `a` lacks; `None`
/// if the counts of an equal key do not add within 64 bits.
fn new_keys<T, K: Ord>(a: &[T], b: &[T], key: impl Fn(&T) -> K, count: impl Fn(&T) -> u64) -> Option<usize> {
    let (mut i, mut j, mut new) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match key(&a[i]).cmp(&key(&b[j])) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => {
                new += 1;
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                count(&a[i]).checked_add(count(&b[j]))?;
                i += 1;
                j += 1;
            }
        }
    }
    Some(new + b.len() - j)
}

/// Adds the sorted list `b` into the sorted list `a` in place, `add`ing
/// the entries of equal keys (their sums checked by [`new_keys`], which
/// gave `new`): `a` grows by `new` entries and the merge runs from the
/// back, so the merged list is neither allocated twice nor copied (the
/// copies and their page faults were half of a 16-shard merge's time).
fn merge_into<T: Copy, K: Ord>(a: &mut Vec<T>, b: &[T], new: usize, key: impl Fn(&T) -> K, add: impl Fn(&T, &T) -> T) {
    let (mut i, mut j) = (a.len(), b.len());
    // Placeholders, all overwritten below.
    a.extend_from_slice(&b[..new]);
    let mut k = a.len();
    while j > 0 {
        k -= 1;
        if i > 0 {
            match key(&a[i - 1]).cmp(&key(&b[j - 1])) {
                std::cmp::Ordering::Greater => {
                    a[k] = a[i - 1];
                    i -= 1;
                    continue;
                }
                std::cmp::Ordering::Equal => {
                    a[k] = add(&a[i - 1], &b[j - 1]);
                    i -= 1;
                    j -= 1;
                    continue;
                }
                std::cmp::Ordering::Less => {}
            }
        }
        a[k] = b[j - 1];
        j -= 1;
    }
    debug_assert_eq!(k, i, "the merged list fills the grown one exactly");
}

/// The totals [`VisibilityCounts::validate`] sums over all blocks fit in
/// 64 bits: pair counts (`2 ×` or `1 ×` segments) plus background counts,
/// the `I_S^c` samples and their endpoints.
fn grand_totals_fit(blocks: &[BlockCounts], local: bool) -> Result<(), CountsError> {
    let per_pair = if local { 1 } else { 2 };
    let (mut grand, mut samples) = (0u64, 0u64);
    for b in blocks {
        grand = b
            .segments
            .checked_mul(per_pair)
            .and_then(|p| p.checked_add(b.escaped))
            .and_then(|c| c.checked_add(grand))
            .ok_or_else(|| overflow("the total count"))?;
        samples = samples.checked_add(b.continuous.samples).ok_or_else(|| overflow("the sample count"))?;
    }
    samples.checked_mul(per_pair).ok_or_else(|| overflow("the endpoint count"))?;
    Ok(())
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
