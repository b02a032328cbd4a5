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
/// `O(|X|³ |Y|)`: meant for up to a few hundred rows.
///
/// # Errors
/// As [`crate::joint_entropies`].
pub fn agglomerative_bottleneck<T: Real>(
    joint: &[T],
    rows: usize,
    cols: usize,
    base: Base,
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
    for step in 1..rows {
        let mut best = (f64::INFINITY, 0, 0);
        for a in 0..rows {
            if !alive[a] {
                continue;
            }
            for b in a + 1..rows {
                if alive[b] {
                    let l = merge_loss(weight[a], &cond[a], weight[b], &cond[b]);
                    if l < best.0 {
                        best = (l, a, b);
                    }
                }
            }
        }
        let (loss, a, b) = best;
        let s = weight[a] + weight[b];
        if s > 0.0 {
            let merged: Vec<f64> =
                cond[a].iter().zip(&cond[b]).map(|(x, y)| (weight[a] * x + weight[b] * y) / s).collect();
            cond[a] = merged;
        }
        weight[a] = s;
        alive[b] = false;
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
