//! Accumulating a block's pair counts `N_ij` (Part III eq. (30)) from the
//! keys each chunk of lines produces, one per segment, unsorted.
//!
//! **Symmetric counts.** A global-line segment joining patches `i` and `j`
//! counts once for `i → j` and once for `j → i` (Part III Fig. 8), so
//! `N_ij = N_ji`: global lines hand in one key per segment, `(min, max)`,
//! and [`Accumulator::take_pairs`] writes both directions out (a segment
//! from a patch back to itself counts twice on the diagonal, as two keys
//! did). Half the keys to add, half the matrix touched.
//!
//! **Sorted, dense or sparse.** Up to [`DENSE_LIMIT`] cells a block's keys
//! are kept as cell indices `i·n + j` and radix-sorted when the block
//! closes, then counted run by run: a block's cost is its own keys, not the
//! `n × n` matrix they scatter over (at 10^7 lines on cube-enclosure:30 a
//! block's 7.4·10^5 segments hit 5% of the upper cells, and the random adds
//! into the 117 MB matrix, the sweep of the groups they hit and the
//! matrix's page faults were 10% of the run's CPU time). A run whose block
//! passes [`sorted_cap`] keys turns dense for good: one `n × n` matrix of
//! `u32`, with a hash map for the rare pair past `2^32`, its adds in the
//! order the chunks produced them (sorting a chunk's keys first cost more
//! than it saved). Above [`DENSE_LIMIT`] cells, a hash map of the pairs
//! hit.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use itgfx_core::PairCount;
use rayon::prelude::*;

use super::CountsError;

/// A tiny multiplicative hasher for `u64` pair keys.
#[derive(Default)]
struct KeyHasher(u64);
impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(5) ^ u64::from(b)).wrapping_mul(0x51_7C_C1_B7_27_22_0A_95);
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (v ^ (v >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9) ^ (v >> 32);
    }
}
type KeyMap = HashMap<u64, u64, BuildHasherDefault<KeyHasher>>;

/// The key of pair `(i, j)`: `i` in the high half, so keys sort as pairs do.
#[inline]
pub(super) fn key(i: u32, j: u32) -> u64 {
    (u64::from(i) << 32) | u64::from(j)
}

/// The key of the unordered pair `{i, j}` (symmetric counts).
#[inline]
pub(super) fn sym_key(i: u32, j: u32) -> u64 {
    key(i.min(j), i.max(j))
}

/// Where a block's pair counts accumulate (see the module docs).
///
/// One accumulator serves every block of a run: [`Accumulator::take_pairs`]
/// empties it for the next block, keeping its buffers, so their pages are
/// faulted in once per run, not once per block.
pub(super) struct Accumulator {
    store: Store,
    /// Keys are unordered pairs ([`sym_key`]): write both directions out.
    symmetric: bool,
}

enum Store {
    /// The open block's keys as cells `i·n + j`, radix-sorted and counted
    /// run by run when the block closes: a block of few segments for its
    /// `n²` cells (5.9·10^5 segments into 1.5·10^7 upper cells at 10^7 lines
    /// on cube-enclosure:30) costs its own keys, not a sweep of the matrix
    /// they scatter over. Past [`sorted_cap`] keys in one block, the run
    /// goes [`Store::Dense`].
    Sorted {
        n: usize,
        cells: Vec<u32>,
        /// The radix sort's other buffer.
        scratch: Vec<u32>,
        /// The last block's counted runs (its upper pairs), kept for the next.
        runs: Vec<PairCount>,
    },
    Dense(Dense),
    Sparse(KeyMap),
}

/// The dense store: `n × n` counts, `hit` with bit `g % 64` of word `g / 64`
/// set when group `g` (cells `16g .. 16g + 16`) may hold a count. A bitmap
/// marks the 16-cell groups (64 bytes each) a block hit, so reading a
/// block's pairs visits only those, in order, and no list of cells hit has
/// to be sorted.
struct Dense {
    n: usize,
    counts: Vec<u32>,
    hit: Vec<u64>,
    overflow: KeyMap,
    /// The last block's pieces of upper pairs, kept for the next: their
    /// pages are faulted in once per run, not once per block.
    pieces: Vec<Vec<PairCount>>,
}

/// Largest `n²` counted densely (6000 patches: 144 MB of `u32`).
const DENSE_LIMIT: usize = 36_000_000;

/// Cells per bit of the dense store's `hit` bitmap: a 64-byte cache line.
const GROUP: usize = 16;

/// Cells per word of the `hit` bitmap.
const WORD_CELLS: usize = GROUP * 64;

/// How many keys ahead [`Dense::add`] prefetches a cell: about a memory
/// latency's worth of adds.
const PREFETCH_AHEAD: usize = 16;

/// Most keys one block of a [`Store::Sorted`] holds: `n²/2`, 8 bytes a key
/// with the sort's buffer, the `4n²` bytes of the dense matrix it replaces.
/// A run past it turns dense: its keys go into the matrix, its buffers are
/// freed, so no run holds more than the dense store did, but for the
/// matrix and one block's capped keys at the moment it turns.
fn sorted_cap(n: usize) -> usize {
    n * n / 2
}

/// Keys per top bucket of [`radix_sort`].
const RADIX_BUCKET: usize = 1024;

/// Bits of [`radix_sort`]'s top digit at most (2048 buckets: the scatter's
/// write heads stay in the L1 and L2 caches).
const RADIX_TOP_BITS: u32 = 11;

/// Bits of the widest digit [`radix_sort`] sorts a bucket by.
const RADIX_BITS: u32 = 8;

impl Accumulator {
    /// An empty accumulator for `n` patches; `symmetric` for global lines
    /// (one [`sym_key`] per segment).
    pub(super) fn new(n: usize, symmetric: bool) -> Self {
        let store = if n.saturating_mul(n) <= DENSE_LIMIT {
            Store::Sorted { n, cells: Vec::new(), scratch: Vec::new(), runs: Vec::new() }
        } else {
            Store::Sparse(KeyMap::default())
        };
        Self { store, symmetric }
    }

    /// Counts each of `keys` once, in any order (a chunk's keys as its
    /// lines produced them: exact integer counts, so no order shows).
    pub(super) fn add_keys(&mut self, keys: &[u64]) {
        match &mut self.store {
            Store::Sorted { n, cells, .. } => {
                let n = *n;
                cells.extend(keys.iter().map(|&k| ((k >> 32) as usize * n + (k as u32) as usize) as u32));
                if cells.len() > sorted_cap(n) {
                    let mut dense = Dense::new(n);
                    dense.add(cells, |&c| c as usize);
                    self.store = Store::Dense(dense);
                }
            }
            Store::Dense(dense) => {
                let n = dense.n;
                dense.add(keys, |&k| (k >> 32) as usize * n + (k as u32) as usize);
            }
            Store::Sparse(map) => {
                for &k in keys {
                    *map.entry(k).or_insert(0) += 1;
                }
            }
        }
    }

    /// The pairs counted so far, sorted, leaving the accumulator empty for
    /// the next block.
    ///
    /// # Errors
    /// [`CountsError::Overflow`] if a doubled diagonal count would pass 64 bits.
    pub(super) fn take_pairs(&mut self) -> Result<Vec<PairCount>, CountsError> {
        let too_big = || CountsError::Overflow("a pair count".into());
        let symmetric = self.symmetric;
        match &mut self.store {
            Store::Sorted { n, cells, scratch, runs } => {
                let bits = usize::BITS - (*n * *n).saturating_sub(1).leading_zeros();
                radix_sort(cells, scratch, bits);
                count_runs(cells, *n, runs);
                cells.clear();
                if symmetric {
                    // Cut anywhere: `both_directions` takes any pieces.
                    let step = runs.len().div_ceil(pieces_per_thread()).max(1);
                    let pieces: Vec<&[PairCount]> = runs.chunks(step).collect();
                    both_directions(&pieces).ok_or_else(too_big)
                } else {
                    Ok(runs.clone())
                }
            }
            Store::Dense(dense) => {
                let pieces = dense.take_pieces();
                if symmetric { both_directions(&pieces).ok_or_else(too_big) } else { Ok(pieces.concat()) }
            }
            Store::Sparse(map) => {
                let mut v: Vec<PairCount> =
                    map.drain().map(|(k, c)| PairCount { from: (k >> 32) as u32, to: k as u32, count: c }).collect();
                v.par_sort_unstable();
                // One piece: a sparse store may have 10^6 rows.
                if symmetric { both_directions(&[&v]).ok_or_else(too_big) } else { Ok(v) }
            }
        }
    }
}

impl Dense {
    /// An empty matrix for `n` patches (`n² ≤ DENSE_LIMIT`).
    fn new(n: usize) -> Self {
        let cells = n * n;
        Self {
            n,
            counts: vec![0; cells],
            hit: vec![0; cells.div_ceil(WORD_CELLS)],
            overflow: KeyMap::default(),
            pieces: Vec::new(),
        }
    }

    /// Counts each of `items` once, at its cell `cell(item)`.
    fn add<T>(&mut self, items: &[T], cell: impl Fn(&T) -> usize) {
        let n = self.n;
        for (r, item) in items.iter().enumerate() {
            // Consecutive keys are kilobytes apart in a matrix of 100+ MB:
            // each add misses the cache, and the hardware prefetcher cannot
            // guess the next. Ask for the cell [`PREFETCH_AHEAD`] keys on.
            #[cfg(target_arch = "x86_64")]
            if let Some(ahead) = items.get(r + PREFETCH_AHEAD) {
                use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
                let p = self.counts.as_ptr().wrapping_add(cell(ahead)).cast::<i8>();
                // SAFETY: a prefetch reads nothing architecturally and never faults.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(p) };
            }
            #[cfg(not(target_arch = "x86_64"))]
            let _ = r;
            let idx = cell(item);
            self.hit[idx / WORD_CELLS] |= 1 << ((idx / GROUP) % 64);
            match self.counts[idx].checked_add(1) {
                Some(c) => self.counts[idx] = c,
                // A pair counted 2^32 times: the excess kept exactly.
                None => *self.overflow.entry(key((idx / n) as u32, (idx % n) as u32)).or_insert(0) += 1,
            }
        }
    }

    /// The block's upper pairs as sorted pieces, in order, the matrix zeroed
    /// where it was written and kept, so its pages are touched once per run,
    /// not once per block (fresh pages cost two page faults each: 13% of a
    /// 10^7-line run). Only the groups of cells the bitmap marks are read,
    /// in order, on every thread.
    fn take_pieces(&mut self) -> Vec<&[PairCount]> {
        let Self { n, counts, hit, overflow, pieces } = self;
        let n = *n;
        let pair = |idx: usize, c: u32| PairCount { from: (idx / n) as u32, to: (idx % n) as u32, count: u64::from(c) };
        // The bitmap in pieces of words, each with its cells, on every
        // thread, kept in order: the sorted list.
        let words = hit.len().div_ceil(pieces_per_thread()).max(1);
        pieces.resize_with(hit.len().div_ceil(words), Vec::new);
        hit.par_chunks_mut(words)
            .zip(counts.par_chunks_mut(words * WORD_CELLS))
            .zip(pieces.par_iter_mut())
            .enumerate()
            .for_each(|(p, ((bits, part), v))| {
                v.clear();
                let len = part.len();
                for (w, word) in bits.iter_mut().enumerate() {
                    let mut b = std::mem::take(word);
                    while b != 0 {
                        let at = w * WORD_CELLS + b.trailing_zeros() as usize * GROUP;
                        b &= b - 1;
                        let group = &mut part[at..(at + GROUP).min(len)];
                        for (k, x) in group.iter_mut().enumerate().filter(|(_, x)| **x > 0) {
                            v.push(pair(p * words * WORD_CELLS + at + k, std::mem::take(x)));
                        }
                    }
                }
            });
        if !overflow.is_empty() {
            // Counts past 2^32 for one pair (rare): into one list.
            let mut v = pieces.concat();
            for (k, c) in overflow.drain() {
                let (i, j) = ((k >> 32) as u32, k as u32);
                match v.binary_search_by_key(&(i, j), |p| (p.from, p.to)) {
                    Ok(pos) => v[pos].count += c,
                    Err(pos) => v.insert(pos, PairCount { from: i, to: j, count: c }),
                }
            }
            *pieces = vec![v];
        }
        // Sorted pieces, in order: their concatenation is the sorted list.
        // One piece per row set: the per-piece row counts of
        // `both_directions` cost `rows` entries per piece.
        pieces.iter().map(|p| &p[..]).collect()
    }
}

/// Sorts `v`, whose values are below `2^bits`: one stable scatter by the
/// top digit into `scratch`, in buckets of about [`RADIX_BUCKET`] keys
/// (at most `2^`[`RADIX_TOP_BITS`] of them), then each bucket least
/// significant digit first, digits of at most [`RADIX_BITS`] bits, between
/// its places in the two buffers: a bucket stays in the L1 and L2 caches,
/// where three passes over all of a block's keys went to memory (paired
/// micro-benchmark, 25-bit cells: 6.6 -> 5.4 ns a key at 7.4·10^5 keys,
/// 18.5-19.9 -> 14.7-15.3 at 7.4·10^6). The buffers are kept, as `v`, for
/// the next block.
fn radix_sort(v: &mut Vec<u32>, scratch: &mut Vec<u32>, bits: u32) {
    let buckets = (v.len() / RADIX_BUCKET).max(1);
    let top = buckets.ilog2().min(RADIX_TOP_BITS).min(bits);
    let low = bits - top;
    scratch.resize(v.len(), 0);
    let mut ends = vec![0; 1 << top];
    scatter(v, scratch, (low, top), &mut ends);
    let passes = low.div_ceil(RADIX_BITS);
    if passes > 0 {
        let digit = low.div_ceil(passes);
        let mut heads = vec![0; 1 << digit];
        let mut start = 0;
        for &end in &ends {
            let (mut from, mut to) = (&mut scratch[start..end], &mut v[start..end]);
            for p in 0..passes {
                scatter(from, to, (p * digit, digit), &mut heads);
                std::mem::swap(&mut from, &mut to);
            }
            start = end;
        }
    }
    // An even number of passes per bucket leaves it in `scratch`.
    if passes.is_multiple_of(2) {
        std::mem::swap(v, scratch);
    }
}

/// Scatters `from` into `to` stably by the digit of `bits` bits (at most
/// 31) at `shift`, one bucket per entry of `heads`, which ends as each
/// bucket's end. A digit of 0 bits (one bucket: a copy) may sit at shift
/// 32, past the key's top.
fn scatter(from: &[u32], to: &mut [u32], (shift, bits): (u32, u32), heads: &mut [usize]) {
    let mask = (1u32 << bits) - 1;
    let digit = |x: u32| (x.checked_shr(shift).unwrap_or(0) & mask) as usize;
    heads.fill(0);
    for &x in from {
        heads[digit(x)] += 1;
    }
    let mut at = 0;
    for h in heads.iter_mut() {
        (*h, at) = (at, at + *h);
    }
    for &x in from {
        let h = &mut heads[digit(x)];
        to[*h] = x;
        *h += 1;
    }
}

/// The sorted cells `sorted` of an `n`-column matrix counted run by run
/// into `out` (cleared first), as the sorted pairs `N_ij`.
fn count_runs(sorted: &[u32], n: usize, out: &mut Vec<PairCount>) {
    out.clear();
    let (mut row, mut row_end) = (0u32, n as u32);
    let mut k = 0;
    while k < sorted.len() {
        let c = sorted[k];
        let len = sorted[k..].iter().take_while(|&&x| x == c).count();
        while c >= row_end {
            row += 1;
            row_end += n as u32;
        }
        out.push(PairCount { from: row, to: c - (row_end - n as u32), count: len as u64 });
        k += len;
    }
}

/// Pieces of the dense sweep per rayon thread.
fn pieces_per_thread() -> usize {
    rayon::current_num_threads() * 8
}

/// A pointer into the output of [`both_directions`], written by every
/// thread at indices that no two pieces share.
#[derive(Clone, Copy)]
struct Slots(*mut PairCount);
// SAFETY: `Slots` is only written through at disjoint indices (see
// `both_directions`), each inside the allocation it points into.
unsafe impl Send for Slots {}
// SAFETY: as above: no index is written by two threads, none is read.
unsafe impl Sync for Slots {}

impl Slots {
    /// Writes `p` into slot `i`.
    ///
    /// # Safety
    /// `i` is below the capacity of the vector `self` points into, and no
    /// other thread writes slot `i`.
    #[inline]
    unsafe fn write(&self, i: u32, p: PairCount) {
        // SAFETY: the caller's contract.
        unsafe { self.0.add(i as usize).write(p) };
    }
}

/// The full sorted pair list from the sorted unordered pairs `upper`
/// (`from <= to`), given as consecutive sorted pieces: `(i, j)` and
/// `(j, i)` with the same count, the diagonal doubled; `None` if a doubled
/// count passes 64 bits (or the list would have 2^32 entries: 64 GB). A
/// counting sort by row, no comparison sort: row `r` is its mirrored
/// entries `(r, i < r)`, in the order of `i` (the order `upper` lists
/// them), then its own. Each piece counts its entries per row, the prefix
/// sums give every piece its slots in each row, and the pieces are written
/// out side by side (the serial version of this, with the zeroing of its
/// output, was most of a block's serial step: ~5% of a 2-thread run).
fn both_directions(upper: &[&[PairCount]]) -> Option<Vec<PairCount>> {
    // The per-row counters below are `u32`: no piece may hold 2^32 entries
    // or more, or a row's count could wrap and two entries share a slot
    // (unreachable under `MAX_PATCHES`, refused rather than assumed).
    if upper.iter().any(|p| u32::try_from(p.len()).is_err()) {
        return None;
    }
    let rows = upper.par_iter().filter_map(|p| p.iter().map(|p| p.to as usize + 1).max()).max().unwrap_or(0);
    // Per piece: its own entries per row, then its mirrored ones; as
    // slots, all below 2^32 (the dense store's 2·n² ≤ 2·DENSE_LIMIT).
    let mut per_piece: Vec<(Vec<u32>, Vec<u32>)> = upper
        .par_iter()
        .map(|piece| {
            let (mut own, mut mirrored) = (vec![0u32; rows], vec![0u32; rows]);
            for p in piece.iter() {
                own[p.from as usize] += 1;
                if p.from != p.to {
                    mirrored[p.to as usize] += 1;
                }
            }
            (own, mirrored)
        })
        .collect();
    // Counts into first slots: row r's mirrored entries from piece 0, 1,
    // ..., then its own entries from piece 0, 1, ...
    let mut at = 0u64;
    for r in 0..rows {
        for (_, m) in per_piece.iter_mut() {
            let c = m[r];
            m[r] = u32::try_from(at).ok()?;
            at += u64::from(c);
        }
        for (o, _) in per_piece.iter_mut() {
            let c = o[r];
            o[r] = u32::try_from(at).ok()?;
            at += u64::from(c);
        }
    }
    // The last slot handed out is below `at`, which must fit too.
    let total = u32::try_from(at).ok()? as usize;
    let mut out: Vec<PairCount> = Vec::with_capacity(total);
    let slots = Slots(out.as_mut_ptr());
    let fits = upper
        .par_iter()
        .zip(per_piece.par_iter_mut())
        .map(|(piece, (own, mirrored))| {
            for p in piece.iter() {
                let entry = if p.from == p.to { PairCount { count: p.count.checked_mul(2)?, ..*p } } else { *p };
                let o = &mut own[p.from as usize];
                // SAFETY: the slots of a row and kind are handed out once
                // each by the prefix sums above (exact: no piece holds
                // 2^32 entries, checked at the top, so no count wrapped),
                // all below `total`, the capacity of `out`; no piece writes
                // another's slot.
                unsafe { slots.write(*o, entry) };
                *o += 1;
                if p.from != p.to {
                    let m = &mut mirrored[p.to as usize];
                    // SAFETY: as above.
                    unsafe { slots.write(*m, PairCount { from: p.to, to: p.from, count: p.count }) };
                    *m += 1;
                }
            }
            Some(())
        })
        .collect::<Option<Vec<()>>>();
    fits?;
    // SAFETY: every one of the `total` slots was written exactly once: the
    // prefix sums above count each entry of each piece into one slot.
    unsafe { out.set_len(total) };
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One key per segment in symmetric mode gives exactly the pairs two
    /// keys per segment (both directions) give, diagonal included, dense and
    /// sparse, and both are the counts of a plain map of the keys; the
    /// accumulator is empty again for the next block.
    #[test]
    fn symmetric_keys_give_the_pairs_of_both_directions() {
        let mut state = 12_345u64;
        let mut next = |m: u64| {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) % m
        };
        for (n, segments) in [(7usize, 40usize), (60, 3_000), (2_000, 500), (9_000, 500), (33, 20_000)] {
            let segs: Vec<(u32, u32)> = (0..segments).map(|_| (next(n as u64) as u32, next(n as u64) as u32)).collect();
            let both: Vec<u64> = segs.iter().flat_map(|&(i, j)| [key(i, j), key(j, i)]).collect();
            let once: Vec<u64> = segs.iter().map(|&(i, j)| sym_key(i, j)).collect();
            let mut reference = std::collections::BTreeMap::new();
            for &k in &both {
                *reference.entry(k).or_insert(0u64) += 1;
            }
            let reference: Vec<PairCount> = reference
                .into_iter()
                .map(|(k, count)| PairCount { from: (k >> 32) as u32, to: k as u32, count })
                .collect();
            let (mut plain, mut sym) = (Accumulator::new(n, false), Accumulator::new(n, true));
            for _block in 0..2 {
                for half in [&both[..both.len() / 2], &both[both.len() / 2..]] {
                    plain.add_keys(half);
                }
                for half in [&once[..once.len() / 2], &once[once.len() / 2..]] {
                    sym.add_keys(half);
                }
                let want = plain.take_pairs().unwrap();
                assert_eq!(want, reference, "n = {n}");
                assert_eq!(sym.take_pairs().unwrap(), want, "n = {n}");
            }
            assert!(plain.take_pairs().unwrap().is_empty() && sym.take_pairs().unwrap().is_empty());
        }
    }

    /// A dense cell that reaches `2^32` keeps the excess exactly, and the
    /// cells hit in the last, partial bitmap group are read.
    #[test]
    fn dense_counts_past_32_bits_and_the_last_group() {
        let n = 5; // 25 cells: one full group of 16 and a partial one.
        let mut dense = Dense::new(n);
        dense.counts[key_cell(n, 1, 2)] = u32::MAX - 1;
        let mut acc = Accumulator { store: Store::Dense(dense), symmetric: false };
        acc.add_keys(&[key(1, 2), key(4, 4), key(1, 2), key(1, 2), key(0, 0), key(4, 4)]);
        let want = [
            PairCount { from: 0, to: 0, count: 1 },
            PairCount { from: 1, to: 2, count: u64::from(u32::MAX) + 2 },
            PairCount { from: 4, to: 4, count: 2 },
        ];
        assert_eq!(acc.take_pairs().unwrap(), want);
        assert!(acc.take_pairs().unwrap().is_empty());
    }

    /// The radix sort sorts whatever the width: one digit, several, a
    /// partial last one, digits every key shares, no keys at all.
    #[test]
    fn radix_sort_sorts() {
        let mut state = 3u64;
        let mut next = |m: u64| {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) % m
        };
        // Top digits of 0 to 11 bits, as wide as the keys (no bucket pass)
        // or not, an odd and an even number of bucket passes.
        let cases = [(1u32, 10usize), (5, 1_000), (3, 50_000), (11, 3_000), (12, 3_000), (25, 20_000), (26, 5_000)];
        for (bits, len) in cases.into_iter().chain([(32, 100), (32, 100_000), (17, 70_000), (26, 2_200_000)]) {
            let mut v: Vec<u32> = (0..len).map(|_| next(1 << bits) as u32).collect();
            let mut want = v.clone();
            want.sort_unstable();
            let mut scratch = vec![7; 3];
            radix_sort(&mut v, &mut scratch, bits);
            assert_eq!(v, want, "{bits} bits");
            let mut same = vec![1u32 << (bits - 1); len];
            radix_sort(&mut same, &mut scratch, bits);
            assert!(same.iter().all(|&x| x == 1 << (bits - 1)));
        }
        let mut empty: Vec<u32> = Vec::new();
        radix_sort(&mut empty, &mut Vec::new(), 25);
        assert!(empty.is_empty());
    }

    /// A run turns dense in the middle of a block once its keys pass the
    /// cap, and counts the same pairs the sorted store would.
    #[test]
    fn the_sorted_store_turns_dense_past_its_cap() {
        let n = 40;
        let keys: Vec<u64> =
            (0..3 * sorted_cap(n) as u64).map(|k| sym_key((k * 7 % 40) as u32, (k * 13 % 40) as u32)).collect();
        let mut acc = Accumulator::new(n, true);
        acc.add_keys(&keys[..10]);
        assert!(matches!(acc.store, Store::Sorted { .. }));
        let first = acc.take_pairs().unwrap();
        acc.add_keys(&keys[..10]);
        assert_eq!(acc.take_pairs().unwrap(), first);
        let mut sorted = Accumulator::new(n, true);
        sorted.store = Store::Sorted { n, cells: Vec::new(), scratch: Vec::new(), runs: Vec::new() };
        let mut reference = Vec::new();
        for part in keys.chunks(1_000) {
            acc.add_keys(part);
            // The reference stays sorted however many keys it holds.
            if let Store::Sorted { cells, .. } = &mut sorted.store {
                cells.extend(part.iter().map(|&k| ((k >> 32) as usize * n + (k as u32) as usize) as u32));
            }
        }
        assert!(matches!(acc.store, Store::Dense(_)));
        reference.extend(sorted.take_pairs().unwrap());
        assert_eq!(acc.take_pairs().unwrap(), reference);
        assert!(acc.take_pairs().unwrap().is_empty());
    }

    /// The dense cell of pair `(i, j)`.
    fn key_cell(n: usize, i: usize, j: usize) -> usize {
        i * n + j
    }

    /// The pieces written side by side give the sorted list of both
    /// directions whatever the cut: one piece, many, empty ones, a row
    /// split across pieces; and a doubled diagonal past 64 bits is refused.
    #[test]
    fn both_directions_is_the_sorted_mirror_for_any_cut() {
        let mut state = 7u64;
        let mut next = |m: u64| {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) % m
        };
        let mut upper: Vec<PairCount> = (0..5_000)
            .map(|_| {
                let (i, j) = (next(300) as u32, next(300) as u32);
                PairCount { from: i.min(j), to: i.max(j), count: 1 + next(1_000) }
            })
            .collect();
        upper.sort_unstable_by_key(|p| (p.from, p.to));
        upper.dedup_by_key(|p| (p.from, p.to));
        let mut want: Vec<PairCount> = upper
            .iter()
            .flat_map(|p| {
                if p.from == p.to {
                    vec![PairCount { count: 2 * p.count, ..*p }]
                } else {
                    vec![*p, PairCount { from: p.to, to: p.from, count: p.count }]
                }
            })
            .collect();
        want.sort_unstable();
        for cuts in [vec![], vec![0, 0, 17], vec![1, 2, 3, 2_000], (1..40).map(|k| k * 97).collect(), vec![4_999]] {
            let mut pieces: Vec<&[PairCount]> = Vec::new();
            let mut at = 0;
            for c in cuts.into_iter().map(|c: usize| c.min(upper.len())) {
                pieces.push(&upper[at.min(c)..c]);
                at = at.max(c);
            }
            pieces.push(&upper[at..]);
            assert_eq!(both_directions(&pieces).unwrap(), want, "{} pieces", pieces.len());
        }
        assert_eq!(both_directions(&[]).unwrap(), vec![]);
        let huge = [PairCount { from: 3, to: 3, count: 1 << 63 }];
        assert!(both_directions(&[&huge]).is_none());
    }
}
