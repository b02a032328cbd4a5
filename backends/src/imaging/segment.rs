//! Segmentation by the information channel `R → X` between regions and
//! intensity bins (Rigau, Feixas & Sbert's split-and-merge).
//!
//! *Split*: a binary space partition grows greedily. Splitting a region `r`
//! into `r₁, r₂` raises `I(R;X)` by `p(r)·JS_{π}(p(X|r₁), p(X|r₂))` with
//! `π = (p(r₁), p(r₂))/p(r)` (the Jensen–Shannon grouping identity of
//! Part II §5, computed by [`itgfx_core::jensen_shannon`]); every leaf keeps
//! its best horizontal or vertical cut and the leaf with the largest gain is
//! split, until the leaves capture a fraction of `H(X)`, a leaf count is
//! reached, or no cut gains anything. `I(R;X)` after each split is measured
//! by [`itgfx_core::mutual_information`] on the leaves' joint.
//!
//! *Merge*: the leaves are clustered by the core's agglomerative information
//! bottleneck ([`itgfx_core::agglomerative_bottleneck`]), which merges at
//! each step the two clusters that lose the least `I(T;X)`; a cluster need
//! not be connected.

use itgfx_core::{Base, agglomerative_bottleneck, entropy_of_weights, jensen_shannon, mutual_information};

use super::gray::Gray;

/// What to do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentOptions {
    /// Intensity bins `|X|` (2..=256), spanning the image's range.
    pub bins: usize,
    /// Most leaves of the split (the bottleneck is `O(leaves³·bins)`).
    pub max_leaves: usize,
    /// Stop splitting once `I(R;X) ≥ split_ratio · H(X)`.
    pub split_ratio: f64,
    /// Regions wanted after merging; `None`: chosen by `ratio`.
    pub regions: Option<usize>,
    /// Without `regions`: the fewest clusters keeping
    /// `I(T;X) ≥ ratio · I(R;X)` of the split.
    pub ratio: f64,
}

impl Default for SegmentOptions {
    fn default() -> Self {
        Self { bins: 32, max_leaves: 128, split_ratio: 1.0, regions: None, ratio: 0.9 }
    }
}

/// An axis-aligned leaf of the partition, in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    /// Left column.
    pub x: usize,
    /// Top row.
    pub y: usize,
    /// Columns.
    pub w: usize,
    /// Rows.
    pub h: usize,
}

/// The outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct Segmentation {
    /// `H(X)` of the binned intensities, bits.
    pub h_x: f64,
    /// `I(R;X)` with `n + 1` leaves at index `n` (bits): non-decreasing.
    pub split_curve: Vec<f64>,
    /// The leaves of the split.
    pub leaves: Vec<Rect>,
    /// `I(T;X)` with `k` clusters at index `k − 1`, `k = 1..=leaves` (bits):
    /// the bottleneck's merge sequence read backwards.
    pub merge_curve: Vec<f64>,
    /// Clusters kept.
    pub regions: usize,
    /// `I(T;X)` with them, bits.
    pub information: f64,
    /// Cluster of each pixel, row-major, `0..regions`.
    pub labels: Vec<usize>,
    /// Mean intensity of each cluster.
    pub means: Vec<f64>,
}

/// Why a segmentation cannot run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SegmentError {
    /// One intensity everywhere: `H(X) = 0`, nothing to capture.
    Constant,
    /// An empty image.
    Empty,
}

impl core::fmt::Display for SegmentError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Constant => f.write_str("the image is constant (H(X) = 0): nothing to segment"),
            Self::Empty => f.write_str("the image is empty"),
        }
    }
}

impl std::error::Error for SegmentError {}

struct Cut {
    gain: f64,
    vertical: bool,
    at: usize,
}

/// The best cut of `r`: gain in bits of `I(R;X)`.
fn best_cut(q: &[u16], width: usize, r: Rect, bins: usize, total: f64) -> Option<Cut> {
    let n = (r.w * r.h) as f64;
    let mut best: Option<Cut> = None;
    let mut dists = vec![0.0f64; 2 * bins];
    for vertical in [true, false] {
        let lines = if vertical { r.w } else { r.h };
        if lines < 2 {
            continue;
        }
        // Histogram of each column (vertical cuts) or row.
        let mut per = vec![0u32; lines * bins];
        for y in r.y..r.y + r.h {
            for x in r.x..r.x + r.w {
                let l = if vertical { x - r.x } else { y - r.y };
                per[l * bins + q[y * width + x] as usize] += 1;
            }
        }
        let mut all = vec![0u32; bins];
        for l in 0..lines {
            for b in 0..bins {
                all[b] += per[l * bins + b];
            }
        }
        let mut left = vec![0u32; bins];
        let mut nl = 0u32;
        for at in 1..lines {
            for b in 0..bins {
                left[b] += per[(at - 1) * bins + b];
                nl += per[(at - 1) * bins + b];
            }
            let nr = n as u32 - nl;
            for b in 0..bins {
                dists[b] = f64::from(left[b]) / f64::from(nl);
                dists[bins + b] = f64::from(all[b] - left[b]) / f64::from(nr);
            }
            let pi = [f64::from(nl) / n, f64::from(nr) / n];
            let js = jensen_shannon(&pi, &dists, bins, Base::Bits).unwrap_or(0.0);
            let gain = n / total * js;
            if best.as_ref().is_none_or(|c| gain > c.gain) {
                best = Some(Cut { gain, vertical, at });
            }
        }
    }
    best
}

/// The leaves' joint `p(r, x)`, row-major `leaves × bins`.
fn leaf_joint(q: &[u16], width: usize, leaves: &[Rect], bins: usize, total: f64) -> Vec<f64> {
    let mut j = vec![0.0; leaves.len() * bins];
    for (k, r) in leaves.iter().enumerate() {
        for y in r.y..r.y + r.h {
            for x in r.x..r.x + r.w {
                j[k * bins + q[y * width + x] as usize] += 1.0;
            }
        }
    }
    j.iter_mut().for_each(|v| *v /= total);
    j
}

/// Segments `img`; `progress(leaves, max_leaves)` reports the split as it
/// grows, then `progress(n, n)` once, with the final leaf count, as the
/// merge starts.
///
/// # Errors
/// [`SegmentError`] for an empty or constant image.
pub fn segment(
    img: &Gray,
    o: &SegmentOptions,
    mut progress: impl FnMut(u64, u64),
) -> Result<Segmentation, SegmentError> {
    let (w, h) = (img.width, img.height);
    if w == 0 || h == 0 {
        return Err(SegmentError::Empty);
    }
    let (lo, hi) = img.range();
    if lo >= hi {
        return Err(SegmentError::Constant);
    }
    let bins = o.bins;
    let scale = bins as f64 / f64::from(hi - lo);
    let q: Vec<u16> = img.data.iter().map(|&v| ((f64::from(v - lo) * scale) as usize).min(bins - 1) as u16).collect();
    let total = (w * h) as f64;
    let mut hist = vec![0.0; bins];
    q.iter().for_each(|&b| hist[b as usize] += 1.0);
    let h_x = entropy_of_weights(&hist, Base::Bits).map_err(|_| SegmentError::Constant)?;
    let mut leaves = vec![Rect { x: 0, y: 0, w, h }];
    let mut cuts = vec![best_cut(&q, w, leaves[0], bins, total)];
    let mut split_curve = vec![0.0];
    let tiny = 1e-12;
    while leaves.len() < o.max_leaves && *split_curve.last().unwrap_or(&0.0) < o.split_ratio * h_x - 1e-9 {
        progress(leaves.len() as u64, o.max_leaves as u64);
        let Some((k, _)) = cuts
            .iter()
            .enumerate()
            .filter_map(|(k, c)| c.as_ref().map(|c| (k, c.gain)))
            .filter(|&(_, g)| g > tiny)
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
        else {
            break;
        };
        let r = leaves[k];
        let c = cuts[k].take().unwrap_or(Cut { gain: 0.0, vertical: true, at: 1 });
        let (a, b) = if c.vertical {
            (Rect { w: c.at, ..r }, Rect { x: r.x + c.at, w: r.w - c.at, ..r })
        } else {
            (Rect { h: c.at, ..r }, Rect { y: r.y + c.at, h: r.h - c.at, ..r })
        };
        leaves[k] = a;
        cuts[k] = best_cut(&q, w, a, bins, total);
        leaves.push(b);
        cuts.push(best_cut(&q, w, b, bins, total));
        let j = leaf_joint(&q, w, &leaves, bins, total);
        let i = mutual_information(&j, leaves.len(), bins, Base::Bits).unwrap_or(0.0);
        split_curve.push(i);
    }
    progress(leaves.len() as u64, leaves.len() as u64);
    let j = leaf_joint(&q, w, &leaves, bins, total);
    let ib = agglomerative_bottleneck(&j, leaves.len(), bins, Base::Bits).map_err(|_| SegmentError::Constant)?;
    let n = leaves.len();
    let mut merge_curve = vec![0.0; n];
    merge_curve[n - 1] = ib.initial_information;
    for m in &ib.merges {
        merge_curve[m.clusters - 1] = m.information;
    }
    let regions = match o.regions {
        Some(k) => k.clamp(1, n),
        None => {
            let target = o.ratio * ib.initial_information - 1e-9 * ib.initial_information.max(1.0);
            (1..=n).find(|&k| merge_curve[k - 1] >= target).unwrap_or(n)
        }
    };
    let assign = ib.assignment(regions).map_err(|_| SegmentError::Constant)?;
    let mut labels = vec![0usize; w * h];
    let (mut sum, mut count) = (vec![0.0; regions], vec![0.0; regions]);
    for (k, r) in leaves.iter().enumerate() {
        for y in r.y..r.y + r.h {
            for x in r.x..r.x + r.w {
                labels[y * w + x] = assign[k];
                sum[assign[k]] += f64::from(img.data[y * w + x]);
                count[assign[k]] += 1.0;
            }
        }
    }
    let means = sum.iter().zip(&count).map(|(s, c)| if *c > 0.0 { s / c } else { 0.0 }).collect();
    Ok(Segmentation {
        h_x,
        information: merge_curve[regions - 1],
        split_curve,
        leaves,
        merge_curve,
        regions,
        labels,
        means,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three grey levels on rectangles: three clusters keep all of `I(R;X) = H(X)`.
    #[test]
    fn piecewise_constant_is_recovered() {
        let (w, h) = (24, 16);
        let mut g = Gray::new(w, h);
        for y in 0..h {
            for x in 0..w {
                g.data[y * w + x] = if x < 10 {
                    0.1
                } else if y < 5 {
                    0.9
                } else if x > 18 {
                    0.1
                } else {
                    0.5
                };
            }
        }
        let s = segment(&g, &SegmentOptions { ratio: 1.0, ..SegmentOptions::default() }, |_, _| {}).unwrap();
        assert!((s.split_curve.last().unwrap() - s.h_x).abs() < 1e-9);
        assert_eq!(s.regions, 3);
        assert!((s.information - s.h_x).abs() < 1e-9);
        assert!(s.merge_curve[1] < s.h_x - 1e-3);
        assert!(s.split_curve.windows(2).all(|p| p[1] >= p[0] - 1e-12));
        assert!(s.merge_curve.windows(2).all(|p| p[1] >= p[0] - 1e-12));
        assert_eq!(segment(&Gray::new(3, 3), &SegmentOptions::default(), |_, _| {}), Err(SegmentError::Constant));
    }
}
