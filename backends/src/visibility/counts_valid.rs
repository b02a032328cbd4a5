//! What a set of counts must satisfy before it is evaluated or merged: the
//! scene's fingerprint, and every invariant of the counts (areas, ranges,
//! block shares, sparse entries, totals, the `I_S^c` sums), checked on every
//! file read, whatever its form (JSON or binary).

use super::{ContinuousSums, CountsError, MAX_BLOCKS, VisibilityCounts};
use crate::scene::Scene;

/// The lines of block `b` of `blocks` in `[start, end)`: the first index
/// `i ≡ b (mod blocks)` and how many there are (stride `blocks`).
#[must_use]
pub fn block_lines(start: u64, end: u64, b: u64, blocks: u64) -> (u64, u64) {
    let first = start.saturating_add((b + blocks - start % blocks) % blocks);
    if first >= end { (first, 0) } else { (first, (end - 1 - first) / blocks + 1) }
}

/// Bound on `|ln(A_T F)|` for any finite positive `A_T F` (`ln(2^-1074)` is
/// −744.4): the sums of a block are checked against it.
pub(super) const LOG_BOUND: f64 = 746.0;

/// What identifies the scene counted.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneFingerprint {
    /// The scene's name.
    pub name: String,
    /// Number of patches.
    pub patches: u64,
    /// FNV-1a (64 bits) of the patch areas' IEEE bits, little-endian, in order.
    pub areas_hash: u64,
}

impl SceneFingerprint {
    /// The fingerprint of a scene given its name and patch areas.
    #[must_use]
    pub fn of(name: &str, areas: &[f64]) -> Self {
        let mut h = crate::shards::Fnv::default();
        for a in areas {
            h.eat(&a.to_bits().to_le_bytes());
        }
        Self { name: name.to_string(), patches: areas.len() as u64, areas_hash: h.value() }
    }
}

pub(super) fn invalid(m: impl Into<String>) -> CountsError {
    CountsError::Invalid(m.into())
}

pub(super) fn overflow(m: &str) -> CountsError {
    CountsError::Overflow(m.into())
}

/// Sorted, strictly increasing keys below `n`, positive counts.
pub(super) fn check_sparse<K: PartialOrd + Copy>(
    what: &str,
    items: impl Iterator<Item = (K, u64)>,
    in_range: impl Fn(K) -> bool,
) -> Result<u64, CountsError> {
    let mut prev: Option<K> = None;
    let mut total = 0u64;
    for (k, c) in items {
        if !in_range(k) {
            return Err(invalid(format!("{what}: a patch index is out of range")));
        }
        if prev.is_some_and(|p| p >= k) {
            return Err(invalid(format!("{what}: entries are not sorted or repeat")));
        }
        if c == 0 {
            return Err(invalid(format!("{what}: a count is zero")));
        }
        prev = Some(k);
        total = total.checked_add(c).ok_or_else(|| overflow(&format!("the sum of {what}")))?;
    }
    Ok(total)
}

pub(super) fn fmt_ranges(r: (u64, u64)) -> String {
    format!("{}..{}", r.0, r.1)
}

impl VisibilityCounts {
    /// Checks every invariant the evaluation relies on: areas positive and
    /// finite and matching the fingerprint, sorted disjoint line ranges,
    /// each block's line count equal to its share of the ranges, sorted
    /// sparse counts in range, totals consistent (`Σ N_ij` = 2 × segments
    /// for global lines, = segments for local ones; background = escaped),
    /// `I_S^c` sums within what finite samples can give, all totals within
    /// 64 bits.
    ///
    /// # Errors
    /// [`CountsError::Invalid`] or [`CountsError::Overflow`] naming the first violation.
    pub fn validate(&self) -> Result<(), CountsError> {
        let n = self.areas.len();
        if n == 0 || self.scene.patches != n as u64 {
            return Err(invalid(format!("the scene has {} patches but {n} areas are listed", self.scene.patches)));
        }
        if let Some((i, a)) = self.areas.iter().enumerate().find(|(_, a)| !(a.is_finite() && **a > 0.0)) {
            return Err(invalid(format!("patch {i} has area {a}: areas must be positive and finite")));
        }
        if !self.areas.iter().sum::<f64>().is_finite() {
            return Err(invalid("the total area is not finite"));
        }
        if SceneFingerprint::of(&self.scene.name, &self.areas).areas_hash != self.scene.areas_hash {
            return Err(invalid("the areas do not match the scene's areas hash"));
        }
        let b = self.blocks.len();
        if !(1..=MAX_BLOCKS as usize).contains(&b) {
            return Err(invalid(format!("{b} jackknife blocks: expected 1..={MAX_BLOCKS}")));
        }
        if self.ranges.is_empty() {
            return Err(invalid("no line ranges"));
        }
        for (k, r) in self.ranges.iter().enumerate() {
            if r.0 >= r.1 {
                return Err(invalid(format!("line range {} is empty or reversed", fmt_ranges(*r))));
            }
            if let Some(next) = self.ranges.get(k + 1)
                && next.0 < r.1
            {
                return Err(CountsError::Mismatch(format!(
                    "line ranges {} and {} overlap or are out of order",
                    fmt_ranges(*r),
                    fmt_ranges(*next)
                )));
            }
        }
        let per_pair = if self.local { 1 } else { 2 };
        let mut grand = 0u64;
        let mut samples = 0u64;
        let mut sums = ContinuousSums::default();
        for (k, blk) in self.blocks.iter().enumerate() {
            let mut lines = 0u64;
            for r in &self.ranges {
                lines = lines
                    .checked_add(block_lines(r.0, r.1, k as u64, b as u64).1)
                    .ok_or_else(|| overflow("the line count"))?;
            }
            if blk.lines != lines {
                return Err(invalid(format!("block {k} has {} lines, its share of the ranges is {lines}", blk.lines)));
            }
            let what = format!("block {k} pairs");
            let pairs = check_sparse(&what, blk.pairs.iter().map(|p| ((p.from, p.to), p.count)), |(i, j)| {
                (i as usize) < n && (j as usize) < n
            })?;
            let what = format!("block {k} background");
            let bg = check_sparse(&what, blk.background.iter().copied(), |i| (i as usize) < n)?;
            if Some(pairs) != blk.segments.checked_mul(per_pair) || bg != blk.escaped {
                return Err(invalid(format!("block {k}: pair and background counts do not add up to its totals")));
            }
            if self.local && blk.segments.checked_add(blk.escaped) != Some(blk.lines) {
                return Err(invalid(format!("block {k}: local lines reaching a patch and escaping do not add up")));
            }
            grand =
                grand.checked_add(pairs).and_then(|g| g.checked_add(bg)).ok_or_else(|| overflow("the total count"))?;
            let c = &blk.continuous;
            let s = c.samples as f64 * (1.0 + 1e-9);
            let (sum, sq) = (c.sum.to_f64(), c.sum_sq.to_f64());
            if c.samples > blk.segments || sum.abs() > LOG_BOUND * s || !(sq >= 0.0 && sq <= LOG_BOUND * LOG_BOUND * s)
            {
                return Err(invalid(format!("block {k}: the I_S^c sums are out of range")));
            }
            samples = samples.checked_add(c.samples).ok_or_else(|| overflow("the sample count"))?;
            sums = sums.checked_add(c).ok_or_else(|| overflow("the I_S^c sums"))?;
        }
        if self.endpoints.len() != n || self.endpoint_log.len() != n {
            return Err(invalid("endpoint sums are not one per patch"));
        }
        let mut ends = 0u64;
        for (i, (&e, l)) in self.endpoints.iter().zip(&self.endpoint_log).enumerate() {
            ends = ends.checked_add(e).ok_or_else(|| overflow("the endpoint count"))?;
            if l.to_f64().abs() > LOG_BOUND * e as f64 * (1.0 + 1e-9) {
                return Err(invalid(format!("patch {i}: the endpoint log sum is out of range")));
            }
        }
        if Some(ends) != samples.checked_mul(per_pair) {
            return Err(invalid("endpoint counts do not add up to the I_S^c samples"));
        }
        Ok(())
    }

    /// Checks that these counts are of `scene` (name, patch count, areas).
    ///
    /// # Errors
    /// [`CountsError::Mismatch`] saying what differs.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), CountsError> {
        same_scene(&self.scene, &SceneFingerprint::of(&scene.name, &scene.areas()), "the counts are", "the scene")
    }
}

pub(super) fn same_scene(
    a: &SceneFingerprint,
    b: &SceneFingerprint,
    what_a: &str,
    what_b: &str,
) -> Result<(), CountsError> {
    if a.name != b.name {
        return Err(CountsError::Mismatch(format!("{what_a} of scene {:?}, {what_b} of {:?}", a.name, b.name)));
    }
    if a.patches != b.patches {
        return Err(CountsError::Mismatch(format!(
            "{what_a} of {} patches, {what_b} of {} patches",
            a.patches, b.patches
        )));
    }
    if a.areas_hash != b.areas_hash {
        return Err(CountsError::Mismatch(format!(
            "{what_a} of scene {:?} with other patch areas than {what_b}",
            a.name
        )));
    }
    Ok(())
}
