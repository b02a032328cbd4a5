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

use itgfx_core::scene::{SceneEntropyRunning, SceneEntropySum};
use itgfx_core::sum::Neumaier;
use itgfx_core::{Base, PairCount, SceneMeasures, entropy_nats_of_sums, kl_terms_into};
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

/// Merges the sorted lists `parts` (counts positive), adding the counts of
/// equal pairs, handing each merged row's pairs to `emit` in order. Row by
/// row: a row whose pairs fill a quarter of its columns or more is added
/// into a dense row of counts, then swept in column order; a sparser one is
/// merged k ways. (The k-way merge of every row, comparing each list's head
/// per pair, was a fifth of the measures' time at 10^8 lines.)
///
/// # Panics
/// If a sum passes 64 bits (validated counts never do).
fn merge_rows(parts: &[&[PairCount]], mut emit: impl FnMut(&[PairCount])) {
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
            emit(&row_out[..m]);
        } else {
            segments.clear();
            for ((l, i), &e) in parts.iter().zip(&mut at).zip(&ends) {
                segments.push(&l[*i..e]);
                *i = e;
            }
            row_out.clear();
            merge_k_ways(&segments, |p| row_out.push(p));
            emit(&row_out);
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
/// adjacent in a sorted list).
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

/// The blocks' lists `lists` cut into pieces of whole rows, each piece
/// every list's pairs of its rows: cut at the row starts of about `parts`
/// pieces of the longest list, the last piece running to the end of every
/// list.
fn block_pieces<'a>(lists: &[&'a [PairCount]], parts: usize) -> Vec<Vec<&'a [PairCount]>> {
    let longest = lists.iter().copied().max_by_key(|l| l.len()).unwrap_or(&[]);
    let mut bounds: Vec<u64> = vec![0];
    bounds.extend(row_pieces(longest, parts).iter().skip(1).map(|p| u64::from(p[0].from)));
    bounds.push(u64::MAX);
    bounds
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
        .collect()
}

/// The row totals `N_i` of all `rows` rows of the blocks' lists `lists`,
/// and a bound on the largest total count (the sum of the blocks' largest
/// counts), in one parallel pass over the lists, one array per thread.
fn row_totals(lists: &[&[PairCount]], rows: usize) -> (Vec<u64>, u64) {
    lists
        .par_iter()
        .fold(
            || (vec![0u64; rows], 0u64),
            |(mut totals, max), l| {
                let mut top = 0;
                for p in l.iter() {
                    totals[p.from as usize] += p.count;
                    top = top.max(p.count);
                }
                (totals, max.saturating_add(top))
            },
        )
        .reduce(
            || (vec![0u64; rows], 0u64),
            |(mut a, m), (b, n)| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                (a, m.saturating_add(n))
            },
        )
}

/// Pairs of the blocks' lists per piece of the study (64K: a wave of a
/// few pieces a thread holds a few MB of pair terms).
const STUDY_PIECE: usize = 1 << 16;

/// Pairs whose `I_i` terms [`Study::information`] takes at once (three
/// 32 KB buffers).
const KL_BATCH: usize = 4096;

/// Pieces of [`block_pieces`] per rayon thread.
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

/// What [`Study::piece`] gives for one piece of rows of the totals `N_ij`
/// (all blocks' pairs with background, merged).
#[derive(Default)]
struct PieceSums {
    /// `(i, N_i, S_i)` per row, `S_i = Σ_j N_ij ln N_ij` added in order.
    rows: Vec<(u32, u64, f64)>,
    /// Per block with lines, `(i, R_bi, D_bi)` of the rows it changes (the
    /// module docs), in row order.
    changes: Vec<Vec<(u32, u64, f64)>>,
    /// `(i, I_i)` per row (eq. (65), times `k` per nat).
    info: Vec<(u32, f64)>,
    /// The core's pair terms of `H_S` ([`SceneEntropySum::pair_term`]) in
    /// pair order.
    terms: Vec<f64>,
}

/// Buffers of [`Study::information`]'s batches.
#[derive(Default)]
struct KlScratch {
    f: Vec<f64>,
    aj: Vec<f64>,
    terms: Vec<f64>,
}

/// What every piece of the study reads: the totals are never listed, each
/// row is merged from the blocks and every measure takes its part of the
/// row at once (the list of totals, its copy into one list and the five
/// passes over it were a sixth of a 10^7-line run, a third of it in page
/// faults).
struct Study<'a> {
    /// Patch areas (scene units).
    areas: &'a [f64],
    /// Their sum, for the relative areas of `I_i`.
    total: f64,
    /// The areas with the background's zero appended, for `H_S`.
    with_background: Vec<f64>,
    sum: SceneEntropySum,
    table: XlnxTable,
    /// Per nat, in the requested base.
    k: f64,
    /// Blocks with lines, as indices into the pieces' lists, whose
    /// changes the leave-one-out `H_S` needs (none below two).
    used: Vec<usize>,
}

impl Study<'_> {
    /// The sums of one piece, `parts` every block's pairs of its rows;
    /// `dense` is `n + 1` columns of scratch.
    fn piece(&self, parts: &[&[PairCount]], dense: &mut [u64], mut terms: Vec<f64>) -> PieceSums {
        terms.clear();
        terms.reserve(parts.iter().map(|p| p.len()).sum());
        let mut out = PieceSums { changes: vec![Vec::new(); self.used.len()], terms, ..PieceSums::default() };
        let mut mine: Vec<&[PairCount]> = self.used.iter().map(|&b| parts[b]).collect();
        let mut kl = KlScratch::default();
        merge_rows(parts, |row| self.row(row, &mut mine, dense, &mut kl, &mut out));
        out
    }

    /// One row's part of every measure, `row` its merged pairs (none
    /// empty), `blocks` the blocks' pairs from this row on.
    fn row(
        &self,
        row: &[PairCount],
        blocks: &mut [&[PairCount]],
        dense: &mut [u64],
        kl: &mut KlScratch,
        out: &mut PieceSums,
    ) {
        let i = row[0].from;
        let (mut count, mut s) = (0u64, Neumaier::new());
        for p in row {
            count += p.count;
            s.add(self.table.get(p.count));
        }
        out.rows.push((i, count, s.value()));
        if !self.used.is_empty() {
            // The row's totals spread densely, where each block looks its
            // pairs' totals up (a search of the totals per block pair was
            // most of the measures' time).
            for p in row {
                dense[p.to as usize] = p.count;
            }
            for (pairs, o) in blocks.iter_mut().zip(&mut out.changes) {
                let len = pairs.partition_point(|p| p.from == i);
                let (r, d) = row_change(&pairs[..len], dense, &self.table);
                *pairs = &pairs[len..];
                if r > 0 {
                    o.push((i, r, d));
                }
            }
        }
        out.info.push((i, self.information(row, count, kl)));
        let a = self.sum.relative_area(self.with_background[i as usize]);
        out.terms.extend(
            row.iter().filter_map(|p| SceneEntropySum::pair_term(a, count, p.count, || self.table.get(p.count))),
        );
    }

    /// `I_i` (eq. (65), times `k` per nat) of row `row` of total `count`:
    /// its terms `a_i kl_term(N_ij / N_i, a_j) k` added in order, their
    /// logarithms taken [`KL_BATCH`] pairs at a time by the core's
    /// vectorised [`kl_terms_into`] (the bits of [`itgfx_core::kl_term`]; a
    /// scalar call per pair was 2.5% of a one-thread 10^7-line run).
    fn information(&self, row: &[PairCount], count: u64, kl: &mut KlScratch) -> f64 {
        let n = self.areas.len();
        let ai = self.areas[row[0].from as usize] / self.total;
        let mut acc = 0.0;
        for batch in row.chunks(KL_BATCH) {
            kl.f.clear();
            kl.aj.clear();
            for p in batch.iter().filter(|p| (p.to as usize) < n) {
                kl.f.push(p.count as f64 / count as f64);
                kl.aj.push(self.areas[p.to as usize] / self.total);
            }
            kl.terms.resize(kl.f.len(), 0.0);
            kl_terms_into(&kl.f, &kl.aj, &mut kl.terms);
            for t in &kl.terms {
                acc += ai * t * self.k;
            }
        }
        acc
    }
}

/// `H_S` in nats without each block, in block order, by the running-totals
/// identity of the module docs, from the pieces' changes and the row
/// totals `N_i` and sums `S_i` (`a` the relative areas with the
/// background's zero). Each block's changed rows are taken in row order:
/// every sum has the bits of a walk block by block.
fn leave_one_out_scene_entropy(a: &[f64], sums: &[PieceSums], blocks: usize, (rows, s): (&[u64], &[f64])) -> Vec<f64> {
    let terms: Vec<f64> = (0..a.len()).map(|i| row_term(a[i], rows[i], s[i])).collect();
    let mut full = Neumaier::new();
    terms.iter().for_each(|&t| full.add(t));
    let full = full.value();
    (0..blocks)
        .into_par_iter()
        .map(|b| {
            let mut h = Neumaier::new();
            h.add(full);
            for &(i, r, d) in sums.iter().flat_map(|piece| &piece.changes[b]) {
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

/// What [`VisibilityCounts::study`] gives: the measures in nats, the
/// leave-one-out `H_S` in nats (two blocks with lines or more) and `I_i`
/// per patch.
type StudyResult = (SceneMeasures, Option<Vec<f64>>, Vec<f64>);

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
    /// The measures in nats, the leave-one-out `H_S` and `I_i` (times `k`
    /// per nat) in one pass over pieces of whole rows of the blocks' pairs
    /// with background ([`Study`]), in parallel, in waves of a few pieces
    /// per thread: the core's sum of `H_S` takes a wave's pair terms in
    /// pair order while the next wave runs, and their buffers go to the
    /// wave after (all pieces' terms at once were 75 MB of fresh pages at
    /// 10^7 lines); then the jackknife's sums.
    fn study(&self, k: f64) -> StudyResult {
        let n = self.areas.len();
        let per_block: Vec<Cow<'_, [PairCount]>> = self.blocks.par_iter().map(|b| with_background(b, n)).collect();
        let lists: Vec<&[PairCount]> = per_block.iter().map(|b| &b[..]).collect();
        let used: Vec<usize> = (0..lists.len()).filter(|&b| self.blocks[b].lines > 0).collect();
        let (rows, max) = row_totals(&lists, n + 1);
        let mut with_background = self.areas.clone();
        with_background.push(0.0);
        let study = Study {
            areas: &self.areas,
            total: self.areas.iter().sum(),
            sum: SceneEntropySum::new(&with_background).expect("validated areas"),
            with_background,
            table: XlnxTable::up_to(max),
            k,
            used: if used.len() >= 2 { used } else { Vec::new() },
        };
        let mut running = study.sum.rows(&study.with_background, &rows);
        let pairs: usize = lists.iter().map(|l| l.len()).sum();
        let pieces = block_pieces(&lists, (pairs / STUDY_PIECE).max(pieces_per_thread()));
        let mut sums: Vec<PieceSums> = Vec::with_capacity(pieces.len());
        let mut spare: Vec<Vec<f64>> = Vec::new();
        let add_terms = |running: &mut SceneEntropyRunning, wave: &mut [PieceSums]| -> Vec<Vec<f64>> {
            wave.iter_mut()
                .map(|piece| {
                    piece.terms.iter().for_each(|&t| running.add(t));
                    std::mem::take(&mut piece.terms)
                })
                .collect()
        };
        for wave in pieces.chunks(pieces_per_thread()) {
            let buffers: Vec<Vec<f64>> = wave.iter().map(|_| spare.pop().unwrap_or_default()).collect();
            let last = sums.len().saturating_sub(pieces_per_thread());
            let (done, freed) = rayon::join(
                || {
                    wave.par_iter()
                        .zip(buffers)
                        .map_init(|| vec![0u64; n + 1], |dense, (parts, terms)| study.piece(parts, dense, terms))
                        .collect::<Vec<_>>()
                },
                || add_terms(&mut running, &mut sums[last..]),
            );
            spare.extend(freed);
            sums.extend(done);
        }
        let last = sums.len().saturating_sub(pieces_per_thread());
        add_terms(&mut running, &mut sums[last..]);
        let (mut s, mut info) = (vec![0.0; n + 1], vec![0.0; n]);
        for piece in &sums {
            for &(i, c, v) in &piece.rows {
                debug_assert_eq!(rows[i as usize], c, "the rows' totals are the blocks'");
                s[i as usize] = v;
            }
            for &(i, v) in &piece.info {
                info[i as usize] = v;
            }
        }
        let hs_without = (!study.used.is_empty()).then(|| {
            let a: Vec<f64> = study.with_background.iter().map(|x| x / study.total).collect();
            leave_one_out_scene_entropy(&a, &sums, study.used.len(), (&rows, &s))
        });
        (running.measures(Base::Nats), hs_without, info)
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
        let used: Vec<&BlockCounts> = self.blocks.iter().filter(|b| b.lines > 0).collect();
        let total: f64 = self.areas.iter().sum();
        let k = base.per_nat();
        let (nats, hs_without, info) = self.study(k);
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

    /// The blocks' pairs cut into pieces of rows and merged row by row are
    /// the pairwise merge tree's list (empty blocks, one block, disjoint and
    /// shared rows, keys only some blocks hold, rows past the longest list's
    /// last), for several piece counts.
    #[test]
    fn merged_rows_are_the_pairwise_merge() {
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
            let refs: Vec<&[PairCount]> = lists.iter().map(|l| &l[..]).collect();
            let want = lists.iter().fold(Vec::new(), |acc: Vec<PairCount>, l| add_sorted(&acc, l));
            for parts in [1, 2, 5, 40] {
                let mut got = Vec::new();
                for piece in block_pieces(&refs, parts) {
                    assert_eq!(piece.len(), blocks);
                    merge_rows(&piece, |row| {
                        assert!(row.iter().all(|p| p.from == row[0].from), "one row at a time");
                        got.extend_from_slice(row);
                    });
                }
                assert_eq!(got, want, "{blocks} blocks, {rows} rows, {parts} pieces");
            }
        }
        let mut none = Vec::new();
        for piece in block_pieces(&[], 3) {
            merge_rows(&piece, |row| none.extend_from_slice(row));
        }
        assert!(none.is_empty());
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
            // Over 10^6 pairs: the study's pieces come in several waves.
            ("cube-enclosure:30", 1_000_000, false, 8),
            ("cornell-box", 50_000, true, 5),
            ("tetrahedron", 21, false, 8),
            ("tetrahedron", 30, true, 3),
        ] {
            let c = counts(spec, lines, local, blocks);
            let n = c.areas.len();
            let totals =
                c.blocks.iter().fold(Vec::new(), |acc: Vec<PairCount>, b| add_sorted(&acc, &with_background(b, n)));
            let mut a = c.areas.clone();
            a.push(0.0);
            let core = scene_measures_from_counts(&a, &totals, &mut vec![0; a.len()], Base::Nats).unwrap();
            let k = Base::Bits.per_nat();
            let (nats, hs_without, info) = c.study(k);
            // The study's measures are the core's on the listed totals, bit for bit.
            assert_eq!(nats, core, "{spec}");
            // And its `I_i` each row's terms added in order (eq. (65)).
            let (total, mut rows, mut want) = (c.areas.iter().sum::<f64>(), vec![0u64; n], vec![0.0f64; n]);
            totals.iter().for_each(|p| rows[p.from as usize] += p.count);
            for p in totals.iter().filter(|p| (p.to as usize) < n) {
                let (i, j) = (p.from as usize, p.to as usize);
                let f = p.count as f64 / rows[i] as f64;
                want[i] += c.areas[i] / total * itgfx_core::kl_term(f, c.areas[j] / total) * k;
            }
            assert_eq!(
                info.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                want.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
            );
            let fast: Vec<f64> = hs_without
                .unwrap()
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
