//! Merging the counts of shards of one run (`--merge`): checked first,
//! then exact integer and fixed-point sums, so any merge order gives the
//! same counts.

use itgfx_core::PairCount;

use super::counts_binary::{BYTES_PER_BINARY_BYTE, CountsHeader};
use super::counts_valid::{fmt_ranges, overflow, same_scene};
use super::{BlockCounts, CountsError, SceneFingerprint, VisibilityCounts};

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
        same_run(
            (&self.scene, self.local, self.seed, self.blocks.len()),
            (&other.scene, other.local, other.seed, other.blocks.len()),
        )?;
        other.validate()?;
        let joined = join_ranges(&self.ranges, &other.ranges)?;
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

/// Two sets of counts, each as (scene, local lines, seed, blocks), are of
/// one run: same scene, line kind, seed and block count.
fn same_run(
    a: (&SceneFingerprint, bool, u64, usize),
    b: (&SceneFingerprint, bool, u64, usize),
) -> Result<(), CountsError> {
    same_scene(a.0, b.0, "these counts are", "the others")?;
    if a.1 != b.1 {
        return Err(CountsError::Mismatch("cannot merge local-line and global-line counts".into()));
    }
    if a.2 != b.2 {
        return Err(CountsError::Mismatch(format!(
            "the counts are of seed {} and seed {}: shards of one run share a seed",
            a.2, b.2
        )));
    }
    if a.3 != b.3 {
        return Err(CountsError::Mismatch(format!(
            "the counts have {} and {} jackknife blocks: shards of one run share their block count",
            a.3, b.3
        )));
    }
    Ok(())
}

impl CountsHeader {
    /// Checks, from the headers alone, that the counts of `self` and
    /// `other` are of one run (as [`VisibilityCounts::merge`] does).
    ///
    /// # Errors
    /// [`CountsError::Mismatch`] naming what differs.
    pub fn same_run(&self, other: &CountsHeader) -> Result<(), CountsError> {
        same_run(
            (&self.scene, self.local, self.seed, self.blocks.len()),
            (&other.scene, other.local, other.seed, other.blocks.len()),
        )
    }
}

/// The line ranges of two sets of counts of one run joined (adjacent
/// ranges fused), as a merge of the two covers them: what a partial merge
/// (a node of a merge tree) records and the next merge checks.
///
/// # Errors
/// [`CountsError::Mismatch`] if a line would be counted twice: one range
/// repeats or holds another, or two overlap.
pub fn join_ranges(a: &[(u64, u64)], b: &[(u64, u64)]) -> Result<Vec<(u64, u64)>, CountsError> {
    let mut ranges: Vec<(u64, u64)> = a.iter().chain(b).copied().collect();
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
    Ok(joined)
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
    // Exactly `new` more (no doubling of a list of gigabytes); placeholders, all overwritten below.
    a.reserve_exact(new);
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

/// Bytes of memory a `--merge` of the binary counts files `headers` may
/// hold at its peak, from their headers alone (before any counts are read):
///
/// * the merged counts: per block at most the sum of the files' pairs and
///   at most `P²` (16 bytes a pair), the background entries likewise
///   (12 bytes, at most `P`), and 40 bytes per patch;
/// * plus the largest of: reading one file (its bytes and its parsed
///   pairs, [`BYTES_PER_BINARY_BYTE`] covers both),
///   writing the merged file (`save`: at most 12 bytes a pair, 4 per patch
///   and block), and evaluating the measures (each block with its
///   background as pairs, then the pairwise tree of block sums of
///   `Complexity`'s totals: two levels alive at once, each list at most
///   `P·(P+1)` pairs).
///
/// An estimate: allocator overhead and the few per-patch arrays of the
/// evaluation are left out (measured against peak RSS in docs/CLUSTER.md).
#[must_use]
pub fn merge_memory(headers: &[CountsHeader], save: bool, measures: bool) -> u64 {
    let Some(first) = headers.first() else { return 0 };
    let p = first.scene.patches;
    let (cells, rows) = (p.saturating_mul(p), p.saturating_mul(p.saturating_add(1)));
    let nb = first.blocks.len();
    // Per block: merged pairs and background entries.
    let merged: Vec<(u64, u64)> = (0..nb)
        .map(|k| {
            let (pairs, bg) = headers
                .iter()
                .filter_map(|h| h.blocks.get(k))
                .fold((0u64, 0u64), |(a, b), &(x, y)| (a.saturating_add(x), b.saturating_add(y)));
            (pairs.min(cells), bg.min(p))
        })
        .collect();
    let sum = |f: &dyn Fn(&(u64, u64)) -> u64| merged.iter().map(f).fold(0u64, u64::saturating_add);
    let (pairs, bg) = (sum(&|b| b.0), sum(&|b| b.1));
    let held = pairs.saturating_mul(16).saturating_add(bg.saturating_mul(12)).saturating_add(p.saturating_mul(40));
    let read = headers.iter().map(|h| h.bytes.saturating_mul(BYTES_PER_BINARY_BYTE)).max();
    let write = if save {
        pairs
            .saturating_mul(12)
            .saturating_add(bg.saturating_mul(12))
            .saturating_add(p.saturating_mul(4 * nb as u64 + 40))
    } else {
        0
    };
    // Evaluation: blocks with background become owned lists; then levels of pairwise sums.
    let owned = sum(&|b| if b.1 > 0 { b.0 + b.1 } else { 0 });
    let total = |l: &[u64]| l.iter().fold(0u64, |a, &x| a.saturating_add(x));
    let up = |l: &[u64]| -> Vec<u64> { l.chunks(2).map(|w| total(w).min(rows)).collect() };
    // The first level is new lists beside the blocks (counted above); then two levels at once.
    let mut level = up(&merged.iter().map(|b| b.0.saturating_add(b.1)).collect::<Vec<_>>());
    let mut tree = total(&level);
    while level.len() > 1 {
        let next = up(&level);
        tree = tree.max(total(&level).saturating_add(total(&next)));
        level = next;
    }
    let evaluate = if measures { owned.saturating_add(tree).saturating_mul(16) } else { 0 };
    held.saturating_add(read.unwrap_or(0).max(write).max(evaluate))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(blocks: Vec<(u64, u64)>, bytes: u64) -> CountsHeader {
        let scene = SceneFingerprint { name: "s".into(), patches: 10, areas_hash: 1 };
        CountsHeader { scene, local: false, seed: 1, ranges: vec![(0, 1)], blocks, bytes }
    }

    /// The estimate as documented, for 10 patches and two blocks: merged
    /// pairs capped at 10² per block, background at 10; plus the largest of
    /// reading a file, writing the merge and the evaluation's lists.
    #[test]
    fn merge_memory_follows_its_terms() {
        let (a, b) = (header(vec![(30, 0), (50, 2)], 100), header(vec![(90, 0), (60, 1)], 100));
        let held = (100 + 100) * 16 + 3 * 12 + 10 * 40;
        // Block 1 has background: an owned list of 103; the sum of both blocks is capped at 10·11.
        let evaluate = (103 + 110) * 16;
        assert_eq!(merge_memory(&[a.clone(), b.clone()], false, true), held + evaluate);
        assert_eq!(merge_memory(&[a.clone(), b.clone()], false, false), held + 100 * 5);
        let write = 200 * 12 + 3 * 12 + 10 * (4 * 2 + 40);
        assert!(write < evaluate);
        let big = header(vec![(1, 0), (1, 0)], 10_000);
        // Reading the big file (5 bytes a byte) passes writing and evaluating.
        assert_eq!(merge_memory(&[a.clone(), big.clone()], true, true), (31 + 51) * 16 + 2 * 12 + 400 + 10_000 * 5);
        assert_eq!(merge_memory(&[], false, true), 0);
        // More files never estimate less.
        assert!(merge_memory(&[a.clone(), b.clone(), big], false, true) >= merge_memory(&[a, b], false, true));
    }
}
