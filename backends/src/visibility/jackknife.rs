//! Evaluating counts: the plug-in measures (Part III eqs. (39)–(51)), `I_S^c`
//! (eq. (59)), the per-patch transfers `I_i` and `I_i^c` (eqs. (65), (68)),
//! and the delete-one-block jackknife.
//!
//! The jackknife needs `I_S` without block `b` for every block. With
//! `S_i = Σ_j N_ij ln N_ij`, `H_S = Σ_i a_i (ln N_i − S_i / N_i)` (eqs.
//! (30)–(31) into (39)), so removing block `b` changes only the rows and
//! pairs it touches: `N_i → N_i − R_bi` and `S_i → S_i − D_bi` with
//! `D_bi = Σ_j [x ln x]_{N_ij − c_bij}^{N_ij}` over the block's own pairs.
//! One pass over each block's sparse counts gives every leave-one-out
//! `H_S`; nothing is re-merged. All inputs are integers taken in a fixed
//! order, so the result is the same bits for any shard order.

use std::borrow::Cow;

use itgfx_core::sum::Neumaier;
use itgfx_core::{
    Base, PairCount, SceneMeasures, entropy_nats_of_sums, kl_terms_into, scene_measures_from_counts_with,
};
use rayon::prelude::*;

use super::merge::merge_sorted;
use super::{BlockCounts, ContinuousSums, VisibilityCounts};

/// What `itgfx complexity` reports.
#[derive(Clone, Debug, PartialEq)]
pub struct Complexity {
    /// Plug-in measures from all lines (Part III eqs. (39)–(51)).
    pub measures: SceneMeasures,
    /// Lines cast.
    pub lines: u64,
    /// Segments (global) or lines that reached a patch (local).
    pub segments: u64,
    /// Crossings counted against the background (0 in a closed scene).
    pub escaped: u64,
    /// `I_S^c` (eq. (59)) in the requested base; `None` without samples.
    pub continuous: Option<f64>,
    /// Jackknife standard error of `I_S`.
    pub mutual_information_stderr: Option<f64>,
    /// Jackknife standard error of `I_S^c`.
    pub continuous_stderr: Option<f64>,
    /// Jackknife bias-corrected `I_S`.
    pub mutual_information_corrected: Option<f64>,
    /// `I_S / I_S^c`, how much of the continuous complexity the
    /// discretisation captures (Part III §6.2), only where `I_S^c` is
    /// resolved: more than [`RESOLVED_STDERRS`] standard errors above zero
    /// (the jackknife's, or with one block the samples' own). Below that the
    /// ratio divides by noise (a sphere's `I_S^c` is 0 up to sampling error
    /// and the ratio came out 2·10⁸).
    pub discretisation_accuracy: Option<f64>,
    /// Per-patch information transfer `I_i` (eq. (65)).
    pub patch_information: Vec<f64>,
    /// Per-patch continuous transfer `I_i^c` (eq. (68)) estimated from the endpoints.
    pub patch_continuous: Vec<f64>,
}

/// `x ln x` of a count, by the core's term (Part II eq. (2)).
#[inline]
fn xlnx(x: u64) -> f64 {
    itgfx_core::xlnx(x as f64)
}

/// `x ln x` of the counts `0..len`, each by [`xlnx`], looked up: the row
/// sums take one per pair and the running totals two per block pair, nearly
/// all of small counts (a logarithm each was most of the measures' time).
/// The same bits as [`xlnx`]: the table holds its values.
struct XlnxTable(Vec<f64>);

/// Most entries of an [`XlnxTable`] (8 MB); larger counts are computed.
const XLNX_TABLE: u64 = 1 << 20;

impl XlnxTable {
    /// The counts up to `max`, the largest total count (every block's count
    /// of a pair is at most its total), or up to [`XLNX_TABLE`].
    fn up_to(max: u64) -> Self {
        Self((0..=max.min(XLNX_TABLE - 1)).into_par_iter().map(xlnx).collect())
    }

    #[inline]
    fn get(&self, x: u64) -> f64 {
        usize::try_from(x).ok().and_then(|i| self.0.get(i)).map_or_else(|| xlnx(x), |&v| v)
    }
}

/// A block's pairs with its background counts as pairs into column `n`
/// (the background: a destination without area), sorted.
fn with_background(b: &BlockCounts, n: usize) -> Cow<'_, [PairCount]> {
    if b.background.is_empty() {
        return Cow::Borrowed(&b.pairs);
    }
    let bg: Vec<PairCount> = b.background.iter().map(|&(i, c)| PairCount { from: i, to: n as u32, count: c }).collect();
    Cow::Owned(add_sorted(&b.pairs, &bg))
}

fn add_sorted(a: &[PairCount], b: &[PairCount]) -> Vec<PairCount> {
    merge_sorted(a, b, |p| (p.from, p.to), |p| p.count, |p, c| PairCount { count: c, ..*p })
        .expect("validated counts: totals fit in 64 bits")
}

/// `N_ij` of all blocks, sorted, background as column `n`: one k-way merge
/// of the blocks' sorted lists (exact integer sums, so the same list as any
/// merge order), in parallel over pieces of whole rows, then the pieces
/// copied into one list. A pairwise merge tree wrote every pair once per
/// level (three levels for 8 blocks), each level into fresh pages (the
/// kernel zeroes each): 1 GB more peak memory at 10^8 lines. With the
/// largest count, found while the pieces are copied (a pass of its own over
/// the totals was 1-2% of a 10^7-line run's wall time).
fn total_pairs(blocks: &[Cow<'_, [PairCount]>]) -> (Vec<PairCount>, u64) {
    let lists: Vec<&[PairCount]> = blocks.iter().map(|b| &b[..]).filter(|b| !b.is_empty()).collect();
    let Some(&longest) = lists.iter().max_by_key(|l| l.len()) else { return (Vec::new(), 0) };
    if lists.len() == 1 {
        return (longest.to_vec(), longest.iter().map(|p| p.count).max().unwrap_or(0));
    }
    // Rows `[lo, hi)` of each piece, cut at the row starts of the longest
    // list's pieces; the last piece runs to the end of every list.
    let mut bounds: Vec<u64> = vec![0];
    bounds.extend(row_pieces(longest, pieces_per_thread()).iter().skip(1).map(|p| u64::from(p[0].from)));
    bounds.push(u64::MAX);
    let pieces: Vec<Vec<&[PairCount]>> = bounds
        .windows(2)
        .map(|w| {
            lists
                .iter()
                .map(|l| {
                    let at = |r: u64| l.partition_point(|p| u64::from(p.from) < r);
                    &l[at(w[0])..at(w[1])]
                })
                .collect()
        })
        .collect();
    // Each piece merged into its own list (only the pages written are
    // touched: the capacity is an upper bound), then copied into place.
    let merged: Vec<Vec<PairCount>> = pieces
        .par_iter()
        .map(|parts| {
            let mut v = Vec::with_capacity(parts.iter().map(|l| l.len()).sum());
            merge_lists(parts, |p| v.push(p));
            v
        })
        .collect();
    let total = merged.iter().map(Vec::len).sum();
    let mut out: Vec<PairCount> = Vec::with_capacity(total);
    let mut slots: Vec<&mut [std::mem::MaybeUninit<PairCount>]> = Vec::with_capacity(merged.len());
    let mut rest = &mut out.spare_capacity_mut()[..total];
    for m in &merged {
        let (head, tail) = rest.split_at_mut(m.len());
        slots.push(head);
        rest = tail;
    }
    let max = merged
        .par_iter()
        .zip(slots)
        .map(|(m, slot)| {
            let mut max = 0;
            for (d, &p) in slot.iter_mut().zip(m) {
                d.write(p);
                max = max.max(p.count);
            }
            max
        })
        .max()
        .unwrap_or(0);
    // SAFETY: the slots cover the first `total` entries of the spare
    // capacity, each as long as its piece's list, and every entry of each
    // was written just above.
    unsafe { out.set_len(total) };
    (out, max)
}

/// Merges the sorted lists `parts` (counts positive), adding the counts of
/// equal pairs, handing each merged pair to `emit` in order. Row by row: a
/// row whose pairs fill a quarter of its columns or more is added into a
/// dense row of counts, then swept in column order; a sparser one is merged
/// k ways. (The k-way merge of every row, comparing each list's head per
/// pair, was a fifth of the measures' time at 10^8 lines.)
///
/// # Panics
/// If a sum passes 64 bits (validated counts never do).
fn merge_lists(parts: &[&[PairCount]], mut emit: impl FnMut(PairCount)) {
    let mut at = vec![0usize; parts.len()];
    let mut ends = vec![0usize; parts.len()];
    let mut dense: Vec<u64> = Vec::new();
    let mut row_out: Vec<PairCount> = Vec::new();
    let mut segments: Vec<&[PairCount]> = Vec::with_capacity(parts.len());
    let add = |a: u64, b: u64| a.checked_add(b).expect("validated counts: totals fit in 64 bits");
    loop {
        let Some(row) = parts.iter().zip(&at).filter_map(|(l, &i)| l.get(i)).map(|p| p.from).min() else { return };
        let (mut len, mut width) = (0, 0);
        for ((l, &i), e) in parts.iter().zip(&at).zip(&mut ends) {
            let j = i + row_len(&l[i.min(l.len())..], row);
            *e = j;
            if j > i {
                len += j - i;
                width = width.max(l[j - 1].to as usize + 1);
            }
        }
        if 4 * len >= width {
            if dense.len() < width {
                dense.resize(width, 0);
            }
            for ((l, i), &e) in parts.iter().zip(&mut at).zip(&ends) {
                for p in &l[*i..e] {
                    dense[p.to as usize] = add(dense[p.to as usize], p.count);
                }
                *i = e;
            }
            // The row's pairs gathered without a branch per column (a
            // tenth or so of the columns hold a count: the filter's
            // mispredictions were most of this sweep), then handed on.
            if row_out.len() < width {
                row_out.resize(width, PairCount::default());
            }
            let mut m = 0;
            for (to, c) in dense[..width].iter_mut().enumerate() {
                let count = std::mem::take(c);
                row_out[m] = PairCount { from: row, to: to as u32, count };
                m += usize::from(count > 0);
            }
            row_out[..m].iter().for_each(|&p| emit(p));
        } else {
            segments.clear();
            for ((l, i), &e) in parts.iter().zip(&mut at).zip(&ends) {
                segments.push(&l[*i..e]);
                *i = e;
            }
            merge_k_ways(&segments, &mut emit);
        }
    }
}

/// How many of the first pairs of `rest` (sorted, rows `>= row`) are in
/// `row`: galloping, then bisection, so a row costs the logarithm of its
/// own length, not of the list's (a bisection of the whole list per row
/// and block was 2.5% of a one-thread 10^7-line run).
fn row_len(rest: &[PairCount], row: u32) -> usize {
    let mut hi = 1;
    while hi < rest.len() && rest[hi].from == row {
        hi *= 2;
    }
    let (lo, hi) = (hi / 2, hi.min(rest.len()));
    lo + rest[lo..hi].partition_point(|p| p.from == row)
}

/// Merges the sorted lists `parts`, adding the counts of equal pairs,
/// handing each merged pair to `emit` in order, by comparing the lists'
/// heads.
///
/// # Panics
/// If a sum passes 64 bits (validated counts never do).
fn merge_k_ways(parts: &[&[PairCount]], mut emit: impl FnMut(PairCount)) {
    let key = pair_key;
    let mut at = vec![0usize; parts.len()];
    loop {
        let mut best: Option<u64> = None;
        for (l, &i) in parts.iter().zip(&at) {
            if let Some(p) = l.get(i)
                && best.is_none_or(|b| key(p) < b)
            {
                best = Some(key(p));
            }
        }
        let Some(best) = best else { return };
        let mut count = 0u64;
        for (l, i) in parts.iter().zip(&mut at) {
            if let Some(p) = l.get(*i)
                && key(p) == best
            {
                count = count.checked_add(p.count).expect("validated counts: totals fit in 64 bits");
                *i += 1;
            }
        }
        emit(PairCount { from: (best >> 32) as u32, to: best as u32, count });
    }
}

/// `totals` cut into about `parts` runs of whole rows (a row's pairs are
/// adjacent in a sorted list): the pieces per-row sums can be computed on
/// in parallel, each row's terms still added in their order.
fn row_pieces(totals: &[PairCount], parts: usize) -> Vec<&[PairCount]> {
    let step = totals.len().div_ceil(parts.max(1)).max(1);
    let mut pieces = Vec::with_capacity(parts + 1);
    let mut at = 0;
    while at < totals.len() {
        let mut end = (at + step).min(totals.len());
        while end < totals.len() && totals[end].from == totals[end - 1].from {
            end += 1;
        }
        pieces.push(&totals[at..end]);
        at = end;
    }
    pieces
}

/// Pairs whose `I_i` terms [`VisibilityCounts::patch_information_rows`]
/// takes at once (three 32 KB buffers).
const KL_BATCH: usize = 4096;

/// Pieces of [`row_pieces`] per rayon thread.
fn pieces_per_thread() -> usize {
    rayon::current_num_threads() * 8
}

/// `(from, to)` as one integer, ordered as the pairs are (one comparison
/// where the tuple's took two, with a branch between).
#[inline]
fn pair_key(p: &PairCount) -> u64 {
    (u64::from(p.from) << 32) | u64::from(p.to)
}

/// `a_i (ln N − S / N)`, the row's part of `H_S` (0 for an empty row): the
/// core's entropy of sums (Part II eq. (2)), which clamps rounding below 0.
#[inline]
fn row_term(a: f64, n: u64, s: f64) -> f64 {
    a * entropy_nats_of_sums(n as f64, s)
}

/// Per row of `totals` (`rows` rows): `N_i` and `S_i = Σ_j N_ij ln N_ij`,
/// over pieces of whole rows in parallel; a row's terms are added in their
/// order, so the sums have the serial sums' bits.
fn row_sums(totals: &[PairCount], rows: usize, table: &XlnxTable) -> (Vec<u64>, Vec<f64>) {
    let (mut n, mut s) = (vec![0u64; rows], vec![0.0; rows]);
    let sums: Vec<Vec<(u32, u64, f64)>> = row_pieces(totals, pieces_per_thread())
        .into_par_iter()
        .map(|piece| {
            let mut out = Vec::new();
            let (mut count, mut acc) = (0u64, Neumaier::new());
            for (k, p) in piece.iter().enumerate() {
                count += p.count;
                acc.add(table.get(p.count));
                if piece.get(k + 1).is_none_or(|q| q.from != p.from) {
                    out.push((p.from, count, acc.value()));
                    (count, acc) = (0, Neumaier::new());
                }
            }
            out
        })
        .collect();
    for (i, c, v) in sums.into_iter().flatten() {
        n[i as usize] = c;
        s[i as usize] = v;
    }
    (n, s)
}

/// Pairs of the totals per piece of [`leave_one_out_scene_entropy`] (1 MB:
/// a piece stays in the L2 cache while every block walks it).
const LOO_PIECE: usize = 1 << 16;

/// `H_S` in nats without each block, in block order, by the running-totals
/// identity of the module docs. `totals` are the pairs with background of
/// all blocks, `rows` and `s` their row totals `N_i` and sums `S_i`
/// ([`row_sums`]).
///
/// The totals are cut into pieces of whole rows, in parallel; row by row,
/// the row's totals are spread into a dense row (every block's pair of the
/// row is one of them) where each block looks its pairs' totals up (a
/// search of the totals per block pair was most of the measures' time).
/// A block's changed rows come out in row order, each row's change summed
/// over its pairs in order: every sum has the bits of a walk block by block.
fn leave_one_out_scene_entropy(
    a: &[f64],
    per_block: &[&[PairCount]],
    totals: &[PairCount],
    (rows, s): (&[u64], &[f64]),
    table: &XlnxTable,
) -> Vec<f64> {
    let n = a.len();
    let terms: Vec<f64> = (0..n).map(|i| row_term(a[i], rows[i], s[i])).collect();
    let mut full = Neumaier::new();
    terms.iter().for_each(|&t| full.add(t));
    let full = full.value();
    let pieces = row_pieces(totals, (totals.len() / LOO_PIECE).max(pieces_per_thread()));
    // Per piece, per block: the rows it changes, `(i, R_bi, D_bi)`.
    let changes: Vec<Vec<Vec<(u32, u64, f64)>>> = pieces
        .par_iter()
        .map_init(
            || vec![0u64; n],
            |dense, piece| {
                let lo = piece.first().map_or(0, |p| u64::from(p.from));
                let hi = piece.last().map_or(0, |p| u64::from(p.from) + 1);
                let mut mine: Vec<&[PairCount]> = per_block
                    .iter()
                    .map(|pairs| {
                        let at = |row: u64| pairs.partition_point(|p| u64::from(p.from) < row);
                        &pairs[at(lo)..at(hi)]
                    })
                    .collect();
                let mut out: Vec<Vec<(u32, u64, f64)>> = vec![Vec::new(); per_block.len()];
                let mut rest = *piece;
                while let Some(first) = rest.first() {
                    let row = first.from;
                    let len = rest.partition_point(|p| p.from == row);
                    for p in &rest[..len] {
                        dense[p.to as usize] = p.count;
                    }
                    rest = &rest[len..];
                    for (pairs, o) in mine.iter_mut().zip(&mut out) {
                        let len = pairs.partition_point(|p| p.from == row);
                        let (r, d) = row_change(&pairs[..len], dense, table);
                        *pairs = &pairs[len..];
                        if r > 0 {
                            o.push((row, r, d));
                        }
                    }
                }
                out
            },
        )
        .collect();
    (0..per_block.len())
        .into_par_iter()
        .map(|b| {
            let mut h = Neumaier::new();
            h.add(full);
            for &(i, r, d) in changes.iter().flat_map(|piece| &piece[b]) {
                let i = i as usize;
                h.add(-terms[i]);
                h.add(row_term(a[i], rows[i] - r, s[i] - d));
            }
            h.value().max(0.0)
        })
        .collect()
}

/// A block's change to one row: `R_bi = Σ_j c_bij` and
/// `D_bi = Σ_j [x ln x]_{N_ij − c_bij}^{N_ij}` over its pairs `pairs` of
/// the row, in order, `N_ij` looked up in the row's `totals` by column.
#[inline]
fn row_change(pairs: &[PairCount], totals: &[u64], table: &XlnxTable) -> (u64, f64) {
    let mut r = 0;
    let mut d = Neumaier::new();
    for p in pairs {
        let total = totals[p.to as usize];
        r += p.count;
        d.add(table.get(total) - table.get(total - p.count));
    }
    (r, d.value())
}

/// [`VisibilityCounts::pair_tables`]: per-block pairs with background, the
/// total pairs, the areas with the background's zero, the `x ln x` table.
type PairTables<'a> = (Vec<Cow<'a, [PairCount]>>, Vec<PairCount>, Vec<f64>, XlnxTable);

/// Standard errors by which `I_S^c` must exceed zero before
/// [`Complexity::discretisation_accuracy`] is reported.
/// Three: the chance that noise alone passes is about 0.1% (a sphere at
/// 10⁵ lines, seed 3, has `I_S^c` 2.07 standard errors above zero).
pub const RESOLVED_STDERRS: f64 = 3.0;

/// Delete-one-block jackknife: (standard error, bias-corrected estimate).
fn jackknife(full: f64, leave_out: &[f64]) -> (f64, f64) {
    let b = leave_out.len() as f64;
    let mean = leave_out.iter().sum::<f64>() / b;
    let var = (b - 1.0) / b * leave_out.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>();
    (var.sqrt(), b * full - (b - 1.0) * mean)
}

impl VisibilityCounts {
    /// Per-block pairs with background, the total pairs, areas with the
    /// background's zero appended (the blocks and the merge levels in
    /// parallel: exact integer sums, the same lists), and the table of
    /// `x ln x` up to the largest total count.
    fn pair_tables(&self) -> PairTables<'_> {
        let n = self.areas.len();
        let per_block: Vec<Cow<'_, [PairCount]>> = self.blocks.par_iter().map(|b| with_background(b, n)).collect();
        let (totals, max) = total_pairs(&per_block);
        let mut a = self.areas.clone();
        a.push(0.0);
        (per_block, totals, a, XlnxTable::up_to(max))
    }

    /// `H_S` in nats without each block that has lines (block order), from
    /// [`VisibilityCounts::pair_tables`]'s lists and [`row_sums`].
    fn leave_one_out_scene_entropies(
        &self,
        per_block: &[Cow<'_, [PairCount]>],
        totals: &[PairCount],
        sums: (&[u64], &[f64]),
        table: &XlnxTable,
    ) -> Vec<f64> {
        let total: f64 = self.areas.iter().sum();
        let mut a: Vec<f64> = self.areas.iter().map(|x| x / total).collect();
        a.push(0.0);
        let used: Vec<&[PairCount]> =
            self.blocks.iter().zip(per_block).filter(|(b, _)| b.lines > 0).map(|(_, p)| &p[..]).collect();
        leave_one_out_scene_entropy(&a, &used, totals, sums, table)
    }

    /// `I_i` (eq. (65), times `k` per nat) of each row of `piece`, whole
    /// rows of the total pairs with background, as `(row, I_i)`: each row's
    /// terms `a_i kl_term(N_ij / N_i, a_j) k` added in order, their
    /// logarithms taken [`KL_BATCH`] pairs at a time by the core's
    /// vectorised [`kl_terms_into`] (the bits of [`itgfx_core::kl_term`]; a
    /// scalar call per pair was 2.5% of a one-thread 10^7-line run).
    fn patch_information_rows(&self, piece: &[PairCount], rows: &[u64], k: f64) -> Vec<(u32, f64)> {
        let n = self.areas.len();
        let total: f64 = self.areas.iter().sum();
        let mut out: Vec<(u32, f64)> = Vec::new();
        let (mut f, mut aj, mut terms) = (Vec::new(), Vec::new(), Vec::new());
        let mut acc = 0.0;
        for (b, batch) in piece.chunks(KL_BATCH).enumerate() {
            f.clear();
            aj.clear();
            for p in batch.iter().filter(|p| (p.to as usize) < n) {
                f.push(p.count as f64 / rows[p.from as usize] as f64);
                aj.push(self.areas[p.to as usize] / total);
            }
            terms.resize(f.len(), 0.0);
            kl_terms_into(&f, &aj, &mut terms);
            let mut term = terms.iter();
            for (e, p) in batch.iter().enumerate() {
                if (p.to as usize) < n {
                    let ai = self.areas[p.from as usize] / total;
                    acc += ai * term.next().expect("one term per pair into a patch") * k;
                }
                if piece.get(b * KL_BATCH + e + 1).is_none_or(|q| q.from != p.from) {
                    out.push((p.from, acc));
                    acc = 0.0;
                }
            }
        }
        out
    }

    /// Evaluates the measures in `base`.
    ///
    /// # Panics
    /// If the counts break the invariants [`VisibilityCounts::validate`]
    /// checks (counts from [`super::count_visibility`], `load` and `merge`
    /// always hold them; only edited public fields can break them).
    #[must_use]
    pub fn complexity(&self, base: Base) -> Complexity {
        let n = self.areas.len();
        let (per_block, totals, a, table) = self.pair_tables();
        let used: Vec<&BlockCounts> = self.blocks.iter().filter(|b| b.lines > 0).collect();
        let total: f64 = self.areas.iter().sum();
        let k = base.per_nat();
        // The core's measures (one serial pass over the totals, in nats, its
        // `x ln x` from the table) beside everything else, which needs only
        // the row totals: the leave-one-out `H_S` and the per-patch `I_i`
        // (eq. (65)), each row's `I_i` adding its pairs in order (pieces of
        // whole rows give the serial sums' bits).
        let (nats, (hs_without, info_rows)) = rayon::join(
            || {
                scene_measures_from_counts_with(&a, &totals, &mut vec![0; n + 1], Base::Nats, |c| table.get(c))
                    .expect("validated counts")
            },
            || {
                let (rows, s) = row_sums(&totals, n + 1, &table);
                rayon::join(
                    || {
                        (used.len() >= 2)
                            .then(|| self.leave_one_out_scene_entropies(&per_block, &totals, (&rows, &s), &table))
                    },
                    || {
                        row_pieces(&totals, pieces_per_thread())
                            .into_par_iter()
                            .map(|piece| self.patch_information_rows(piece, &rows, k))
                            .collect::<Vec<_>>()
                    },
                )
            },
        );
        // The measures in `base` from those in nats: the bits the core's
        // pass in `base` gives (it computes in nats and converts the same way).
        let hp = nats.positional_entropy;
        let measures = SceneMeasures::from_nats(n, nats.unsampled_patches, hp, nats.scene_entropy, base);
        let mi = hs_without.map(|hs| hs.into_iter().map(|h| (hp - h) * k).collect::<Vec<f64>>());
        let cont = self
            .blocks
            .iter()
            .try_fold(ContinuousSums::default(), |acc, b| acc.checked_add(&b.continuous))
            .expect("validated: sums fit");
        let estimate = |c: &ContinuousSums| (c.samples > 0).then(|| c.sum.to_f64() / c.samples as f64 * k);
        let continuous = estimate(&cont);
        let (mut se, mut corrected, mut cse) = (None, None, None);
        if let Some(mi) = mi {
            let (s, c) = jackknife(measures.mutual_information, &mi);
            se = Some(s);
            corrected = Some(c);
            let ci: Vec<f64> = used
                .iter()
                .filter_map(|b| {
                    let c = &b.continuous;
                    let rest = ContinuousSums {
                        samples: cont.samples - c.samples,
                        sum: cont.sum.checked_sub(c.sum)?,
                        sum_sq: cont.sum_sq.checked_sub(c.sum_sq)?,
                    };
                    estimate(&rest)
                })
                .collect();
            if let (Some(full), true) = (continuous, ci.len() == used.len()) {
                cse = Some(jackknife(full, &ci).0);
            }
        }
        let mut info = vec![0.0; n];
        for (i, v) in info_rows.into_iter().flatten() {
            info[i as usize] = v;
        }
        let patch_continuous = (0..n)
            .map(|i| {
                let e = self.endpoints[i];
                if e > 0 { self.areas[i] / total * self.endpoint_log[i].to_f64() / e as f64 * k } else { 0.0 }
            })
            .collect();
        // The samples' own standard error where the jackknife has none.
        let sample_se = || {
            let (sum, sum_sq) = (cont.sum.to_f64(), cont.sum_sq.to_f64());
            itgfx_core::scene::ContinuousMutualInformation::from_parts(1.0, cont.samples, sum, sum_sq)
                .ok()
                .and_then(|c| c.standard_error(base))
        };
        let discretisation_accuracy = continuous.and_then(|ic| {
            let se = cse.or_else(sample_se)?;
            (ic > RESOLVED_STDERRS * se && ic > 0.0).then(|| measures.mutual_information / ic)
        });
        Complexity {
            discretisation_accuracy,
            measures,
            lines: self.lines(),
            segments: self.blocks.iter().map(|b| b.segments).sum(),
            escaped: self.blocks.iter().map(|b| b.escaped).sum(),
            continuous,
            mutual_information_stderr: se,
            continuous_stderr: cse,
            mutual_information_corrected: corrected,
            patch_information: info,
            patch_continuous,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::built_in;
    use crate::tracer::Prepared;
    use crate::visibility::{LineOptions, count_visibility};
    use crate::{BackendChoice, open};
    use itgfx_core::scene_measures_from_counts;

    fn counts(spec: &str, lines: u64, local: bool, blocks: u32) -> VisibilityCounts {
        let scene = built_in(spec).unwrap();
        let p = Prepared::new(&scene);
        let t = open(BackendChoice::Cpu, &p).unwrap();
        let opts = LineOptions { lines, seed: 7, local, blocks, offset: 3 };
        count_visibility(&scene, &p, t.as_ref(), &opts, &mut |_, _| {}).unwrap()
    }

    /// The jackknife as it was: each leave-one-out `I_S` from the other
    /// blocks' pairs concatenated, sorted and evaluated by the core.
    fn remerged(c: &VisibilityCounts, base: Base) -> Vec<f64> {
        let n = c.areas.len();
        let mut a = c.areas.clone();
        a.push(0.0);
        let used: Vec<&BlockCounts> = c.blocks.iter().filter(|b| b.lines > 0).collect();
        (0..used.len())
            .map(|skip| {
                let mut pairs: Vec<PairCount> = used
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| *k != skip)
                    .flat_map(|(_, b)| with_background(b, n).into_owned())
                    .collect();
                pairs.sort_unstable_by_key(|p| (p.from, p.to));
                let mut rows = vec![0; n + 1];
                scene_measures_from_counts(&a, &pairs, &mut rows, base).unwrap().mutual_information
            })
            .collect()
    }

    /// The one-pass k-way merge of the blocks' pairs is the pairwise merge
    /// tree's list (empty blocks, one block, disjoint and shared rows, keys
    /// only some blocks hold, rows past the longest list's last), for several
    /// piece counts.
    #[test]
    fn total_pairs_is_the_pairwise_merge() {
        let mut state = 99u64;
        let mut next = |m: u64| {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) % m
        };
        for (blocks, rows, cells) in [(8usize, 40u64, 300usize), (3, 5, 20), (1, 9, 30), (5, 2_000, 4_000), (2, 1, 3)] {
            let mut lists: Vec<Vec<PairCount>> = (0..blocks)
                .map(|b| {
                    let mut v: Vec<PairCount> = (0..cells / (b + 1))
                        .map(|_| PairCount { from: next(rows) as u32, to: next(rows + 1) as u32, count: 1 + next(9) })
                        .collect();
                    v.sort_unstable_by_key(|p| (p.from, p.to));
                    v.dedup_by_key(|p| (p.from, p.to));
                    v
                })
                .collect();
            if blocks > 2 {
                lists[1].clear();
                lists[2].retain(|p| u64::from(p.from) > rows / 2);
            }
            let cows: Vec<Cow<'_, [PairCount]>> = lists.iter().map(|l| Cow::Borrowed(&l[..])).collect();
            let want = lists.iter().fold(Vec::new(), |acc: Vec<PairCount>, l| add_sorted(&acc, l));
            for threads in [1, 2, 5] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                assert_eq!(
                    pool.install(|| total_pairs(&cows)),
                    (want.clone(), want.iter().map(|p| p.count).max().unwrap_or(0)),
                    "{blocks} blocks, {rows} rows, {threads} threads"
                );
            }
        }
        assert_eq!(total_pairs(&[]), (Vec::new(), 0));
    }

    /// The running-totals jackknife equals the re-merge to 1e-12 bits per
    /// leave-one-out value. Not bit for bit: the core takes logarithms with
    /// its own `ln` (within 1 ulp of libm) and sums the `N_ij ln N_ij` of
    /// all pairs in one compensated sum, while the running totals subtract
    /// each block's change from per-row sums; both errors are a few ulp of
    /// `H_S ≤ 13` bits, far below 1e-12.
    #[test]
    fn row_terms_are_the_cores_entropy_of_the_counts() {
        let counts = [0u64, 1, 7, 7, 30, 1 << 40];
        let (n, s) = counts.iter().fold((0, 0.0), |(n, s), &c| (n + c, s + xlnx(c)));
        let core = itgfx_core::entropy_of_weights(&counts.map(|c| c as f64), Base::Nats).unwrap();
        assert!((row_term(0.25, n, s) - 0.25 * core).abs() <= 1e-13, "{} vs {}", row_term(0.25, n, s), 0.25 * core);
        assert_eq!(row_term(0.25, 0, 0.0), 0.0);
        assert_eq!(xlnx(0), 0.0);
        assert_eq!(xlnx(1 << 40), itgfx_core::xlnx((1u64 << 40) as f64));
    }

    /// The table's `x ln x` is the core's, bit for bit, inside it and past it.
    #[test]
    fn the_xlnx_table_is_the_cores() {
        let table = XlnxTable::up_to(999);
        assert_eq!(table.0.len(), 1_000);
        for x in (0..3_000).chain([1 << 40, u64::MAX]) {
            assert_eq!(table.get(x).to_bits(), itgfx_core::xlnx(x as f64).to_bits(), "{x}");
        }
    }

    #[test]
    fn running_totals_equal_the_remerge() {
        for (spec, lines, local, blocks) in [
            ("cube-enclosure:3", 200_000, false, 8),
            ("cornell-box", 50_000, true, 5),
            ("tetrahedron", 21, false, 8),
            ("tetrahedron", 30, true, 3),
        ] {
            let c = counts(spec, lines, local, blocks);
            let (per_block, totals, a, table) = c.pair_tables();
            let nats = scene_measures_from_counts(&a, &totals, &mut vec![0; a.len()], Base::Nats).unwrap();
            let (rows, s) = row_sums(&totals, a.len(), &table);
            let fast: Vec<f64> = c
                .leave_one_out_scene_entropies(&per_block, &totals, (&rows, &s), &table)
                .into_iter()
                .map(|hs| (nats.positional_entropy - hs) * Base::Bits.per_nat())
                .collect();
            let slow = remerged(&c, Base::Bits);
            assert_eq!(fast.len(), slow.len());
            assert!(fast.len() >= 2, "{spec}");
            for (f, s) in fast.iter().zip(&slow) {
                assert!((f - s).abs() <= 1e-12, "{spec}: {f} vs {s}");
            }
            let full = c.complexity(Base::Bits);
            let (se, corrected) = jackknife(full.measures.mutual_information, &slow);
            let got_se = full.mutual_information_stderr.unwrap();
            assert!((got_se - se).abs() <= 1e-9 * se.max(1e-12), "{spec}: {got_se} vs {se}");
            assert!((full.mutual_information_corrected.unwrap() - corrected).abs() <= 1e-10, "{spec}");
        }
    }

    /// Blocks are a function of the line index: one run equals its two
    /// shards merged in either order, bit for bit, and a saved run reloads
    /// to the same numbers.
    #[test]
    fn shards_merge_into_the_run_bit_for_bit() {
        let scene = built_in("cube-enclosure:2").unwrap();
        let p = Prepared::new(&scene);
        let t = open(BackendChoice::Cpu, &p).unwrap();
        let run = |offset, lines| {
            let opts = LineOptions { lines, seed: 3, local: false, blocks: 4, offset };
            count_visibility(&scene, &p, t.as_ref(), &opts, &mut |_, _| {}).unwrap()
        };
        let whole = run(5, 30_001);
        let (a, b, c) = (run(5, 10_007), run(10_012, 9_000), run(19_012, 10_994));
        let mut abc = a.clone();
        abc.merge(b.clone()).unwrap();
        abc.merge(c.clone()).unwrap();
        let mut cba = c;
        cba.merge(b).unwrap();
        cba.merge(a).unwrap();
        assert_eq!(abc, whole);
        assert_eq!(cba, whole);
        let mut text = Vec::new();
        whole.save(&scene.name, &mut text).unwrap();
        let (name, back) = VisibilityCounts::load(std::str::from_utf8(&text).unwrap()).unwrap();
        assert_eq!(name, scene.name);
        assert_eq!(back, whole);
        assert_eq!(back.complexity(Base::Bits), whole.complexity(Base::Bits));
    }
}
