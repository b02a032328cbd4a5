//! Adaptive sampling with the refinement tree of Part IV §6.
//!
//! Every pixel is a 1-node; an `n`-node takes `N_s^r` stratified samples
//! (`N_s^r / N_r` in each of its `N_r = 4` quadrants; `N_s^r` a multiple of
//! `N_r`, Part IV §6.1's notation table; default 8, `--node-samples`). While its contrast is `≥ ε` and
//! `n` is below the deepest level (4, as the tutorial's trees), the node
//! splits into its quadrants, each sampled anew. The node contrast is one
//! of the three compared in §6.4 ([`TreeContrast`]):
//!
//! * `ec`: eq. (27), `C_n = Σ_c w^c C_n^c q_n^c`, the entropy contrast
//!   `C^c = 1 − H(p^c)/log N` of each channel (eq. (16)) weighted by the
//!   sRGB weights and the node's importance `q_n^c = c̄_n^c / N_r^{n−1}`
//!   (Proposition 1, eq. (26));
//! * `ic`: the same with Mitchell's classic contrast (eq. (1)) per channel
//!   and Mitchell's channel weights (0.4, 0.3, 0.6), as `cc-tree` — the
//!   importance-weighted contrast `IC`;
//! * `cc-tree`: Simmons' priority `p_c = Σ_c k_c C^c c̄^c` (eq. (2)), the
//!   classic contrast weighted by the channel mean, recursive to level 4 —
//!   the tutorial's `CC` of Table 2.
//!
//! With `δ < 1` the colour contrast is mixed with the pixel geometry
//! contrast `C^g = 1 − H(g)/log N` of the samples' first-hit geometry
//! factors `g = cos θ / r²` (eqs. (12), (20), (28)): a node whose rays hit
//! different surfaces, or one surface at very different distances, splits.
//! A leaf's colour is the mean of its samples; a split node's is the mean of
//! its children's (eq. (29), the children covering equal areas). The
//! pixel's value is its 1-node's colour.
//!
//! The tree is built level by level for all pixels of a row at once (one
//! wavefront per level through the tracing seam). Node `k` (breadth-first
//! within its pixel) uses sample indices `k N_s^r..(k + 1) N_s^r`, so the
//! image does not depend on the thread count.

use itgfx_core::pixel::{
    ChannelContrast, MITCHELL_WEIGHTS, SRGB_LUMINANCE_WEIGHTS, binary_contrast, importance_weighted_contrast,
    mixed_contrast, pixel_contrast, priority_colour,
};

use super::frame::{PILOT, PixelValue, View};
use super::path::{Start, strata};
use super::sampler::{PixelSampler, Rays};
use crate::lines::LineRng;

/// Samples per node `N_s^r` by default (the tutorial's Table 2; Fig. 13 used 4).
pub const NODE_SAMPLES: u32 = 8;
/// Most samples per node `--node-samples` takes (a pixel's 85 nodes of 4
/// levels then trace at most 87,040 pilot samples, far below the 2^23
/// sample indices).
pub const MAX_NODE_SAMPLES: u32 = 1024;
/// Regions per node, `N_r` (quadrants).
pub const REGIONS: u32 = 4;
/// Deepest level of the tree (the pixel is level 1).
pub const MAX_LEVEL: u32 = 4;

/// Whether `n` can be `N_s^r`: a multiple of `N_r` (at least `N_r`, so
/// every quadrant holds a sample; Part IV §6.1), at most [`MAX_NODE_SAMPLES`].
#[must_use]
pub fn valid_node_samples(n: u32) -> bool {
    (REGIONS..=MAX_NODE_SAMPLES).contains(&n) && n.is_multiple_of(REGIONS)
}

/// The colour contrast a tree node is judged by (Part IV §6.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeContrast {
    /// Entropy contrast weighted by importance, eq. (27) (`ec`).
    Entropy,
    /// Classic contrast weighted by importance, eqs. (1), (26) (`ic`).
    Importance,
    /// Classic contrast weighted by the channel mean, eq. (2) (`cc-tree`).
    Classic,
    /// Binary contrasts weighted by importance as eq. (27): colour `C_b^c`
    /// (eqs. (17), (19)) and geometry `C_b^g` (eq. (21)) (`ec-binary`;
    /// §6.4's test of Fig. 13.b).
    EntropyBinary,
}

impl TreeContrast {
    /// The tree sampler called `name`: `ec`, `ic` or `cc-tree`.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "ec" => Some(Self::Entropy),
            "ic" => Some(Self::Importance),
            "cc-tree" => Some(Self::Classic),
            "ec-binary" => Some(Self::EntropyBinary),
            _ => None,
        }
    }
}

/// Command-line names of the tree samplers.
pub const NAMES: &[&str] = &["ec", "ic", "cc-tree", "ec-binary"];

/// The refinement-tree sampler with threshold `ε`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tree {
    /// Threshold `ε` on the node contrast.
    pub threshold: f64,
    /// Build the tree on pilot samples, then sample every leaf afresh for
    /// its colour (the deciding samples never enter the image).
    pub unbiased: bool,
    /// The colour contrast of a node.
    pub contrast: TreeContrast,
    /// Weight `δ` of colour against geometry in eq. (28); 1 is colour only.
    pub delta: f64,
    /// Samples per node `N_s^r` ([`valid_node_samples`]).
    pub node_samples: u32,
}

/// The contrast of an `n`-node's samples (eq. (28)): `δ` times the colour
/// contrast of `kind` plus `1 − δ` times the geometry contrast (eq. (20)) of
/// the first-hit geometry factors `g`; infinite when the core refuses the
/// samples (non-finite radiance), so the node splits.
#[must_use]
pub fn node_contrast(rgb: &[[f64; 3]], g: &[f64], level: u32, kind: TreeContrast, delta: f64) -> f64 {
    let value = || -> Result<f64, itgfx_core::Error> {
        let ch: [Vec<f64>; 3] = std::array::from_fn(|c| rgb.iter().map(|s| s[c]).collect());
        let channels = [ch[0].as_slice(), ch[1].as_slice(), ch[2].as_slice()];
        let colour = match kind {
            TreeContrast::Entropy => importance_weighted_contrast(
                &channels,
                &SRGB_LUMINANCE_WEIGHTS,
                ChannelContrast::Entropy,
                REGIONS,
                level,
            )?,
            TreeContrast::Importance => {
                importance_weighted_contrast(&channels, &MITCHELL_WEIGHTS, ChannelContrast::Classic, REGIONS, level)?
            }
            TreeContrast::Classic => priority_colour(&ch[0], &ch[1], &ch[2])?,
            TreeContrast::EntropyBinary => importance_weighted_contrast(
                &channels,
                &SRGB_LUMINANCE_WEIGHTS,
                ChannelContrast::Binary,
                REGIONS,
                level,
            )?,
        };
        if delta >= 1.0 {
            return Ok(colour);
        }
        let geometry = if kind == TreeContrast::EntropyBinary { binary_contrast(g)? } else { pixel_contrast(g)? };
        mixed_contrast(delta, colour, geometry)
    };
    value().unwrap_or(f64::INFINITY)
}

/// Colour of a node from its children (eq. (29)): the mean over the equal-area regions.
#[must_use]
pub fn reconstruct(children: &[[f64; 3]]) -> [f64; 3] {
    let mut acc = [0.0; 3];
    for c in children {
        for k in 0..3 {
            acc[k] += c[k];
        }
    }
    acc.map(|v| v / children.len().max(1) as f64)
}

struct Node {
    slot: usize,
    pixel: u32,
    serial: u32,
    level: u32,
    x: f64,
    y: f64,
    size: f64,
    colour: [f64; 3],
    children: Option<usize>,
}

/// The refinement trees of a set of pixels being built.
pub struct TreePixels {
    nodes: Vec<Node>,
    /// Each pixel's next node serial.
    serials: Vec<u32>,
    /// Each pixel's image samples.
    counts: Vec<u32>,
    /// Each pixel's decision samples (the unbiased form's tree).
    pilot: Vec<u32>,
    /// The level being traced: nodes `[start, end)`.
    level: (usize, usize),
    /// The unbiased form's leaves, once the tree is built.
    leaves: Option<Vec<usize>>,
}

impl PixelSampler for Tree {
    type Pilot = ();
    type Plan = ();
    type Pixels = TreePixels;

    fn pilot(&self, _: &[[f64; 3]], _: &[f64]) {}

    fn counts(&self, _: &View, _: Vec<()>) {}

    /// Every pixel is a 1-node.
    fn start(&self, (): &(), view: &View, ids: &[u32]) -> TreePixels {
        let nodes = ids
            .iter()
            .enumerate()
            .map(|(slot, &pixel)| Node {
                slot,
                pixel,
                serial: 0,
                level: 1,
                x: f64::from(pixel % view.width),
                y: f64::from(pixel / view.width),
                size: 1.0,
                colour: [0.0; 3],
                children: None,
            })
            .collect();
        let n = ids.len();
        TreePixels { nodes, serials: vec![1; n], counts: vec![0; n], pilot: vec![0; n], level: (0, 0), leaves: None }
    }

    /// The tree is built level by level (one round a level); in the
    /// unbiased form a last round samples every leaf afresh.
    fn round(&self, (): &(), view: &View, t: &mut TreePixels, estimate: bool) -> Option<Rays> {
        if t.leaves.is_some() {
            return None;
        }
        let start = t.level.1;
        if start < t.nodes.len() {
            t.level = (start, t.nodes.len());
            let starts = node_starts(view, &t.nodes[start..], self.unbiased, self.node_samples);
            return Some(Rays::Starts { starts, geometry: self.delta < 1.0 });
        }
        if !self.unbiased {
            return None;
        }
        // The tree's samples only decided: every leaf is sampled afresh.
        t.pilot = std::mem::replace(&mut t.counts, vec![0; t.pilot.len()]);
        let leaves: Vec<usize> = (0..t.nodes.len()).filter(|&k| t.nodes[k].children.is_none()).collect();
        for &k in &leaves {
            t.counts[t.nodes[k].slot] += self.node_samples;
        }
        let starts = leaves
            .iter()
            .flat_map(|&k| node_starts(view, std::slice::from_ref(&t.nodes[k]), false, self.node_samples))
            .collect();
        t.leaves = Some(leaves);
        estimate.then_some(Rays::Starts { starts, geometry: false })
    }

    fn absorb(&self, (): &(), t: &mut TreePixels, _: Rays, rgb: &[[f64; 3]], g: &[f64]) {
        let ns = self.node_samples as usize;
        if let Some(leaves) = &t.leaves {
            for (j, &k) in leaves.iter().enumerate() {
                t.nodes[k].colour = reconstruct(&rgb[j * ns..(j + 1) * ns]);
            }
            return;
        }
        let (start, end) = t.level;
        for k in start..end {
            let span = (k - start) * ns..(k - start + 1) * ns;
            let s = &rgb[span.clone()];
            let gs = g.get(span).unwrap_or(&[]);
            let (slot, level) = (t.nodes[k].slot, t.nodes[k].level);
            t.counts[slot] += self.node_samples;
            t.nodes[k].colour = reconstruct(s);
            if level < MAX_LEVEL && node_contrast(s, gs, level, self.contrast, self.delta) >= self.threshold {
                t.nodes[k].children = Some(t.nodes.len());
                let (x, y, half) = (t.nodes[k].x, t.nodes[k].y, t.nodes[k].size * 0.5);
                let pixel = t.nodes[k].pixel;
                for q in 0..REGIONS {
                    let serial = t.serials[slot];
                    t.serials[slot] += 1;
                    t.nodes.push(Node {
                        slot,
                        pixel,
                        serial,
                        level: level + 1,
                        x: x + f64::from(q % 2) * half,
                        y: y + f64::from(q / 2) * half,
                        size: half,
                        colour: [0.0; 3],
                        children: None,
                    });
                }
            }
        }
    }

    /// A pixel's value is its 1-node's colour, each split node the mean of
    /// its quadrants (eq. (29)): not a sample mean, so no variance.
    fn estimate(&self, (): &(), mut t: TreePixels) -> Vec<PixelValue> {
        // Ascent: children were pushed after their parents, so go backwards.
        for k in (0..t.nodes.len()).rev() {
            if let Some(c) = t.nodes[k].children {
                let kids: Vec<[f64; 3]> = t.nodes[c..c + REGIONS as usize].iter().map(|n| n.colour).collect();
                t.nodes[k].colour = reconstruct(&kids);
            }
        }
        (0..t.counts.len())
            .map(|slot| PixelValue {
                rgb: t.nodes[slot].colour,
                variance: None,
                samples: t.counts[slot],
                pilot: t.pilot[slot],
            })
            .collect()
    }
}

/// The camera rays of `nodes`: `ns` each on a jittered grid of the node's
/// square, `ns / 4` in each quadrant: each quadrant is `b × a` cells
/// (`(a, b)` = [`strata`]`(ns / 4)`), so 8 a node is a 4 × 2 grid with 2 a
/// quadrant. Pilot samples take the [`PILOT`] bit in their index.
fn node_starts(view: &View, nodes: &[Node], pilot: bool, ns: u32) -> Vec<Start> {
    let (a, b) = strata(ns / REGIONS);
    let (columns, rows) = (2 * b, 2 * a);
    let mut starts = Vec::with_capacity(nodes.len() * ns as usize);
    let tan = view.camera.tan_half_fov();
    for n in nodes {
        for i in 0..ns {
            let index = (n.serial * ns + i) | if pilot { PILOT } else { 0 };
            let rng = LineRng::new(view.seed, (u64::from(n.pixel) << 24) | u64::from(index));
            let (cx, cy) = (f64::from(i % columns), f64::from(i / columns));
            let sx = n.x + (cx + rng.uniform(0)) / f64::from(columns) * n.size;
            let sy = n.y + (cy + rng.uniform(1)) / f64::from(rows) * n.size;
            let direction = view.camera.direction_tan(tan, sx, sy, view.width, view.height);
            starts.push(Start { origin: view.camera.eye, direction, rng });
        }
    }
    starts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reconstruction_of_a_hand_made_tree() {
        // A pixel split once, its first quadrant split again (Fig. 10's shape):
        // c_1 = mean(c_{2,0..3}), c_{2,0} = mean(c_{3,0..3}).
        let deep = [[4.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0; 3]];
        let c20 = reconstruct(&deep);
        assert_eq!(c20, [1.0, 0.0, 0.0]);
        let c1 = reconstruct(&[c20, [1.0, 1.0, 1.0], [0.0; 3], [2.0, 3.0, 3.0]]);
        assert_eq!(c1, [1.0, 1.0, 1.0]);
    }

    const KINDS: [TreeContrast; 3] = [TreeContrast::Entropy, TreeContrast::Importance, TreeContrast::Classic];

    /// `ec-binary` by hand: geometry factors 1 and 3 give `C_b^g = 1 − H_b(1/4)`
    /// (eq. (21)); two colours 1 and 0 give `C_b = 1 − H_b(0) = 1` per channel,
    /// weighted by the mean 1/2 and the importance `1/N_r^(n−1)` (eq. (27)).
    #[test]
    fn binary_tree_contrast_by_hand() {
        let hb = 0.25 * 2.0 + 0.75 * (4.0f64 / 3.0).log2();
        let grey = [[0.5; 3]; 2];
        let g = node_contrast(&grey, &[1.0, 3.0], 1, TreeContrast::EntropyBinary, 0.0);
        assert!((g - (1.0 - hb)).abs() < 1e-12, "{g}");
        let edge = [[1.0; 3], [0.0; 3]];
        let c1 = node_contrast(&edge, &[1.0, 1.0], 1, TreeContrast::EntropyBinary, 1.0);
        assert!((c1 - 0.5).abs() < 1e-12, "{c1}");
        let c2 = node_contrast(&edge, &[1.0, 1.0], 2, TreeContrast::EntropyBinary, 1.0);
        assert!((c2 - 0.5 / 4.0).abs() < 1e-12, "{c2}");
        assert_eq!(TreeContrast::from_name("ec-binary"), Some(TreeContrast::EntropyBinary));
    }

    #[test]
    fn node_contrast_is_eq_27_and_falls_with_depth() {
        let flat = [[0.5; 3]; 8];
        assert_eq!(node_contrast(&flat, &[], 1, TreeContrast::Entropy, 1.0), 0.0, "a flat node never splits");
        let edge: Vec<[f64; 3]> = (0..8).map(|i| if i < 4 { [1.0; 3] } else { [0.0; 3] }).collect();
        // Each channel: 4 of 8 samples equal, H = log 4, quality 2/3, contrast 1/3; mean 1/2.
        let c1 = node_contrast(&edge, &[], 1, TreeContrast::Entropy, 1.0);
        assert!((c1 - (1.0 / 3.0) * 0.5).abs() < 1e-12, "{c1}");
        let c2 = node_contrast(&edge, &[], 2, TreeContrast::Entropy, 1.0);
        assert!((c2 - c1 / 4.0).abs() < 1e-12, "importance falls by N_r a level");
    }

    #[test]
    fn importance_weighted_classic_contrast_by_hand() {
        // Classic contrast 1 in every channel, means 1/2: IC = Σ k_c · 1 · (1/2) / 4^{n-1};
        // CC (eq. (2)) = Σ k_c · 1 · 1/2 at every level.
        let edge: Vec<[f64; 3]> = (0..8).map(|i| if i < 4 { [1.0; 3] } else { [0.0; 3] }).collect();
        let k: f64 = MITCHELL_WEIGHTS.iter().sum();
        for level in 1..=3 {
            let ic = node_contrast(&edge, &[], level, TreeContrast::Importance, 1.0);
            assert!((ic - k * 0.5 / 4f64.powi(level as i32 - 1)).abs() < 1e-12, "{ic}");
            let cc = node_contrast(&edge, &[], level, TreeContrast::Classic, 1.0);
            assert!((cc - k * 0.5).abs() < 1e-12, "{cc}");
        }
    }

    #[test]
    fn flat_nodes_never_split_and_split_nodes_always_do() {
        // Synthetic sample sets: a flat node stays, an edge node splits, for
        // every tree contrast, at any small threshold and any level above the last.
        let flat = [[0.3, 0.4, 0.5]; 8];
        let split: Vec<[f64; 3]> = (0..8).map(|i| if i % 2 == 0 { [2.0, 1.0, 0.5] } else { [0.0; 3] }).collect();
        let g = [1.0; 8];
        for kind in KINDS {
            for level in 1..MAX_LEVEL {
                assert!(node_contrast(&flat, &g, level, kind, 0.9) < 1e-9, "{kind:?}: a flat node splits");
                assert!(node_contrast(&split, &g, level, kind, 0.9) >= 1e-3, "{kind:?}: an edge does not split");
            }
        }
    }

    #[test]
    fn geometry_contrast_splits_a_node_over_two_surfaces() {
        // Same colour everywhere, but half the rays hit a near wall and half a far one:
        // colour alone (δ = 1) never splits, δ < 1 (eq. (28)) does.
        let rgb = [[0.5; 3]; 8];
        let g: Vec<f64> = (0..8).map(|i| if i < 4 { 1.0 } else { 0.01 }).collect();
        assert_eq!(node_contrast(&rgb, &g, 1, TreeContrast::Entropy, 1.0), 0.0);
        let c = node_contrast(&rgb, &g, 1, TreeContrast::Entropy, 0.9);
        let want = 0.1 * itgfx_core::pixel::pixel_contrast(&g).unwrap();
        assert!(c > 0.01 && (c - want).abs() < 1e-12, "{c}");
        assert!(node_contrast(&rgb, &[1.0; 8], 1, TreeContrast::Entropy, 0.9) < 1e-12, "one surface: no split");
    }
}
