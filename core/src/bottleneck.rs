//! Agglomerative information bottleneck (Slonim & Tishby; cited in Part II §5).
//!
//! Start with every `x` of a joint `p(x, y)` in its own cluster `t`; at each
//! step merge the two clusters whose merge loses the least `I(T;Y)`:
//!
//! ```text
//! δI(t_a, t_b) = (p_a + p_b) · JS_{π_a, π_b}(p(y|t_a), p(y|t_b)),  π_a = p_a/(p_a + p_b)
//! ```
//! so that `I(T;Y)` decreases from `I(X;Y)` to 0 along the merge sequence.

use alloc::vec::Vec;

use crate::math::{ln, xlnx};
use crate::matrix::MatrixRef;
use crate::scan::{check_normalized, mass};
use crate::{Base, Error, Real};

/// One merge of the agglomerative bottleneck.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Merge {
    /// The surviving cluster (smaller original index).
    pub into: usize,
    /// The cluster merged into it.
    pub from: usize,
    /// Information lost by this merge, `δI`, in the requested base.
    pub loss: f64,
    /// `I(T;Y)` after the merge, in the requested base.
    pub information: f64,
    /// Clusters remaining after the merge.
    pub clusters: usize,
}

/// The whole merge sequence, from `|X|` clusters down to one.
#[derive(Clone, Debug, PartialEq)]
pub struct Bottleneck {
    /// `I(X;Y)` before any merge.
    pub initial_information: f64,
    /// Merges in order.
    pub merges: Vec<Merge>,
    rows: usize,
}

impl Bottleneck {
    /// Cluster label of each `x` when `k` clusters remain (`1 ≤ k ≤ |X|`),
    /// labels numbered `0..k` by first appearance.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for `k` out of range.
    pub fn assignment(&self, k: usize) -> Result<Vec<usize>, Error> {
        if k == 0 || k > self.rows {
            return Err(Error::InvalidParameter { name: "k", value: k as f64 });
        }
        let mut parent: Vec<usize> = (0..self.rows).collect();
        for m in &self.merges[..self.rows - k] {
            parent[m.from] = m.into;
        }
        let find = |mut i: usize| {
            while parent[i] != i {
                i = parent[i];
            }
            i
        };
        let mut label = alloc::vec![usize::MAX; self.rows];
        let mut next = 0;
        let mut out = Vec::with_capacity(self.rows);
        for i in 0..self.rows {
            let r = find(i);
            if label[r] == usize::MAX {
                label[r] = next;
                next += 1;
            }
            out.push(label[r]);
        }
        Ok(out)
    }
}

fn merge_loss(pa: f64, ca: &[f64], pb: f64, cb: &[f64]) -> f64 {
    // (p_a+p_b) JS = Σ_y [p_a c_a ln c_a + p_b c_b ln c_b − (p_a c_a + p_b c_b) ln m]
    let s = pa + pb;
    if s == 0.0 {
        return 0.0;
    }
    let mut acc = 0.0;
    for (&x, &y) in ca.iter().zip(cb) {
        let m = (pa * x + pb * y) / s;
        acc +=
            pa * xlnx(x) + pb * xlnx(y) - s * xlnx(m) - (pa * x + pb * y - s * m) * if m > 0.0 { ln(m) } else { 0.0 };
    }
    acc.max(0.0)
}

/// Runs the agglomerative bottleneck on a row-major joint `p(x, y)`.
///
/// Each pair's `δI` is computed once and kept (`|X|(|X|−1)/2` values);
/// a merge recomputes only the pairs of the merged cluster, so the
/// logarithms cost `O(|X|² |Y|)` and the search for the cheapest merge
/// `O(|X|³)` comparisons in all ([`bottleneck_work`]). The merges are
/// those of the plain search (same values, same ties: the first pair in
/// row order).
///
/// # Errors
/// As [`crate::joint_entropies`]; [`Error::OutOfMemory`] when the pair
/// table cannot be had.
pub fn agglomerative_bottleneck<T: Real>(
    joint: &[T],
    rows: usize,
    cols: usize,
    base: Base,
) -> Result<Bottleneck, Error> {
    agglomerative_bottleneck_with_progress(joint, rows, cols, base, |_, _| {})
}

/// The work of [`agglomerative_bottleneck`] on `rows × cols`: merge-loss
/// terms (each a few logarithms; `|X|(|X|−1)/2 · |Y|` for the table, as
/// many again for the updates) and comparisons of the cheapest-merge search
/// (`Σ_{k=2}^{|X|} k(k−1)/2 = C(|X|+1, 3)`), saturating.
#[must_use]
pub fn bottleneck_work(rows: usize, cols: usize) -> (u64, u64) {
    let n = rows as u64;
    let pairs = n.saturating_mul(n.saturating_sub(1)) / 2;
    let terms = pairs.saturating_mul(2).saturating_mul(cols as u64);
    let compares = (n + 1).saturating_mul(n).saturating_mul(n.saturating_sub(1)) / 6;
    (terms, compares)
}

/// [`agglomerative_bottleneck`], calling `progress(done, total)` with the
/// comparisons of [`bottleneck_work`] done so far after each merge.
///
/// # Errors
/// As [`agglomerative_bottleneck`].
pub fn agglomerative_bottleneck_with_progress<T: Real>(
    joint: &[T],
    rows: usize,
    cols: usize,
    base: Base,
    mut progress: impl FnMut(u64, u64),
) -> Result<Bottleneck, Error> {
    let m = MatrixRef::new(joint, rows, cols)?;
    let s = mass(joint)?;
    check_normalized::<T>(s)?;
    let k = base.per_nat();
    let mut weight: Vec<f64> = (0..rows).map(|i| m.row(i).iter().map(|x| x.to_f64()).sum::<f64>() / s).collect();
    let mut cond: Vec<Vec<f64>> = (0..rows)
        .map(|i| {
            let w = weight[i] * s;
            m.row(i).iter().map(|x| if w > 0.0 { x.to_f64() / w } else { 0.0 }).collect()
        })
        .collect();
    let py: Vec<f64> = (0..cols).map(|j| (0..rows).map(|i| weight[i] * cond[i][j]).sum()).collect();
    let info = |weight: &[f64], cond: &[Vec<f64>], alive: &[bool]| -> f64 {
        let mut acc = 0.0;
        for i in 0..rows {
            if alive[i] && weight[i] > 0.0 {
                for (x, y) in cond[i].iter().zip(&py) {
                    if *x > 0.0 {
                        acc += weight[i] * x * (ln(*x) - ln(*y));
                    }
                }
            }
        }
        acc.max(0.0)
    };
    let mut alive = alloc::vec![true; rows];
    let initial = info(&weight, &cond, &alive);
    let mut merges = Vec::with_capacity(rows.saturating_sub(1));
    // δI of each pair a < b, row by row: pair (a, b) at start(a) + b − a − 1.
    let pairs = rows * rows.saturating_sub(1) / 2;
    let start = |a: usize| a * (2 * rows - a - 1) / 2;
    let at = |a: usize, b: usize| start(a) + b - a - 1;
    let mut table: Vec<f64> = Vec::new();
    table
        .try_reserve_exact(pairs)
        .map_err(|_| Error::OutOfMemory { bytes: pairs.saturating_mul(core::mem::size_of::<f64>()) })?;
    for a in 0..rows {
        for b in a + 1..rows {
            table.push(merge_loss(weight[a], &cond[a], weight[b], &cond[b]));
        }
    }
    let total = bottleneck_work(rows, cols).1;
    let mut done = 0u64;
    for step in 1..rows {
        let mut best = (f64::INFINITY, 0, 0);
        for a in 0..rows {
            if !alive[a] {
                continue;
            }
            let row = &table[start(a)..start(a) + rows - a - 1];
            for (l, b) in row.iter().zip(a + 1..rows) {
                if alive[b] && *l < best.0 {
                    best = (*l, a, b);
                }
            }
        }
        let k_alive = (rows - step + 1) as u64;
        done += k_alive * (k_alive - 1) / 2;
        let (loss, a, b) = best;
        let s = weight[a] + weight[b];
        if s > 0.0 {
            let merged: Vec<f64> =
                cond[a].iter().zip(&cond[b]).map(|(x, y)| (weight[a] * x + weight[b] * y) / s).collect();
            cond[a] = merged;
        }
        weight[a] = s;
        alive[b] = false;
        for c in (0..rows).filter(|&c| alive[c] && c != a) {
            let (lo, hi) = if c < a { (c, a) } else { (a, c) };
            table[at(lo, hi)] = merge_loss(weight[lo], &cond[lo], weight[hi], &cond[hi]);
        }
        progress(done, total);
        merges.push(Merge {
            into: a,
            from: b,
            loss: loss * k,
            information: info(&weight, &cond, &alive) * k,
            clusters: rows - step,
        });
    }
    Ok(Bottleneck { initial_information: initial * k, merges, rows })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pair table gives the merges of the plain search, which
    /// recomputes every pair's loss at every step (ties included: the
    /// duplicated rows tie exactly).
    #[test]
    fn table_matches_the_plain_search() {
        let (rows, cols) = (23, 5);
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut joint: Vec<f64> = (0..rows * cols).map(|_| next()).collect();
        joint.copy_within(0..cols, 3 * cols); // rows 0 and 3 equal: a zero-loss tie
        joint[7 * cols + 2] = 0.0;
        let s: f64 = joint.iter().sum();
        joint.iter_mut().for_each(|x| *x /= s);
        let mut calls = 0;
        let got = agglomerative_bottleneck_with_progress(&joint, rows, cols, Base::Bits, |d, t| {
            calls += 1;
            assert!(d <= t);
            if calls == rows - 1 {
                assert_eq!(d, t);
            }
        })
        .unwrap();
        assert_eq!(calls, rows - 1);
        // The plain search.
        let mut weight: Vec<f64> = (0..rows).map(|i| joint[i * cols..(i + 1) * cols].iter().sum()).collect();
        let mut cond: Vec<Vec<f64>> =
            (0..rows).map(|i| joint[i * cols..(i + 1) * cols].iter().map(|x| x / weight[i]).collect()).collect();
        let mut alive = alloc::vec![true; rows];
        for m in &got.merges {
            let mut best = (f64::INFINITY, 0, 0);
            for a in (0..rows).filter(|&a| alive[a]) {
                for b in (a + 1..rows).filter(|&b| alive[b]) {
                    let l = merge_loss(weight[a], &cond[a], weight[b], &cond[b]);
                    if l < best.0 {
                        best = (l, a, b);
                    }
                }
            }
            let (l, a, b) = best;
            // The reference's weights round differently from the core's.
            assert_eq!((m.into, m.from), (a, b));
            assert!((m.loss - l * Base::Bits.per_nat()).abs() <= 1e-12 * (m.loss + 1e-300), "{m:?} vs {l}");
            let s = weight[a] + weight[b];
            cond[a] = cond[a].iter().zip(&cond[b]).map(|(x, y)| (weight[a] * x + weight[b] * y) / s).collect();
            weight[a] = s;
            alive[b] = false;
        }
        assert_eq!(bottleneck_work(rows, cols).1, (rows as u64 + 1) * rows as u64 * (rows as u64 - 1) / 6);
    }
}
