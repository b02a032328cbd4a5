//! Entropy-based supersampling (Part IV §5.1) and the pixel quality and
//! contrast maps it uses as its oracle (Part IV §3–§4, Figs. 1–6).
//!
//! Three phases, as §5.1 describes them:
//!
//! 1. **Oracle**: every pixel takes `n_s = 8` stratified samples (indices
//!    `0..8`); from them, its contrast `C = δ C^c + (1 − δ) C^g` (eq. (23))
//!    with the colour contrast `C^c` of eq. (18) (entropy, or eq. (19)'s
//!    binary form) and the geometry contrast `C^g` of eq. (20) on the
//!    first-hit geometry factors `g = cos θ / r²` (eq. (12)). The result is
//!    the contrast map.
//! 2. **Sampling**: the samples left of the budget are shared among the
//!    pixels in proportion to their contrast (largest remainders; a pixel
//!    above its cap gives its excess to the others), each pixel's samples
//!    taken as one stratified batch from index 8 on.
//! 3. **Reconstruction**: box filter over the pixel's samples.
//!
//! Two forms. **Unbiased** (the default): the oracle's samples only decide;
//! every pixel gets `n_s` fresh samples plus its share of
//! `N_p (N_s − 2 n_s)` (indices `8..16+e`), and its value is their mean. A
//! pixel's count depends on the oracle's samples alone, which are not in
//! its mean, so the mean of its fresh samples is unbiased whatever the
//! count. **Tutorial** (§5.1 as written): the share of `N_p (N_s − n_s)`
//! (indices `8..8+e`) is averaged with the oracle's own 8 samples, which
//! darkens: a pixel whose 8 samples caught a caustic is judged contrasted
//! and its bright samples are diluted by more, one that missed it keeps its
//! dark estimate.
//!
//! Either way the budget is met exactly (no threshold to tune): the mean
//! rays per pixel, oracle included, is `N_s` unless caps leave samples
//! unspent. Contrast weights are
//! Mitchell's (0.4, 0.3, 0.6), as the contrast maps of §4.1; the colour
//! quality map uses equal weights, as Fig. 1.b.

use itgfx_core::Base;
use itgfx_core::pixel::{
    ChannelContrast, MITCHELL_WEIGHTS, log_difference_contrast, mixed_contrast, pixel_colour_contrast,
    pixel_colour_quality, pixel_contrast, pixel_quality,
};

use super::Supersampling;
use super::frame::{Batch, PixelValue, View, moments};
use super::path::PathTracer;
use super::sampler::{self, PilotRays, PixelSampler, Rays};
use crate::tracer::BackendError;

/// Samples per pixel of the oracle, `n_s` (§5.1: "usual values are 2, 4, and 8").
pub const ORACLE_SAMPLES: u32 = 8;

/// The quality and contrast measures of one pixel from its oracle samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelMeasures {
    /// Pixel colour quality `Q^c` with equal channel weights (eq. (11)).
    pub colour_quality: f64,
    /// Pixel geometry quality `Q^g` (eq. (15)).
    pub geometry_quality: f64,
    /// Pixel colour contrast `C^c` (eq. (18), Mitchell weights).
    pub colour_contrast: f64,
    /// Pixel colour binary contrast `C_b^c` (eq. (19), Mitchell weights).
    pub binary_contrast: f64,
    /// Pixel geometry contrast `C^g` (eq. (20)).
    pub geometry_contrast: f64,
    /// Pixel geometry binary contrast `C_b^g` (eq. (21)).
    pub geometry_binary_contrast: f64,
    /// Pixel geometry logarithmic-difference contrast `C_log^g` in bits
    /// (eq. (22)); `+∞` when a sample's ray met nothing and another's did.
    pub geometry_log_contrast: f64,
    /// The oracle's contrast `δ C^c + (1 − δ) C^g` (eq. (23)), `C^c` entropy or binary.
    pub contrast: f64,
}

/// How the oracle's contrast is formed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Oracle {
    /// Colour weight `δ` of eq. (23); 1 is colour only.
    pub delta: f64,
    /// Use the binary colour contrast `C_b^c` (eq. (19)) instead of `C^c` (eq. (18)).
    pub binary: bool,
}

/// The measures of a pixel with samples `rgb` and geometry factors `g`
/// (the same length, at least 2). A sample set the core refuses (non-finite
/// radiance) gets contrast 1 and quality 0: the worst pixel.
#[must_use]
pub fn measures(rgb: &[[f64; 3]], g: &[f64], oracle: Oracle) -> PixelMeasures {
    let value = || -> Result<PixelMeasures, itgfx_core::Error> {
        let ch: [Vec<f64>; 3] = std::array::from_fn(|c| rgb.iter().map(|s| s[c]).collect());
        let channels = [ch[0].as_slice(), ch[1].as_slice(), ch[2].as_slice()];
        let colour_contrast = pixel_colour_contrast(&channels, &MITCHELL_WEIGHTS, ChannelContrast::Entropy)?;
        let binary_contrast = pixel_colour_contrast(&channels, &MITCHELL_WEIGHTS, ChannelContrast::Binary)?;
        let geometry_contrast = pixel_contrast(g)?;
        let colour = if oracle.binary { binary_contrast } else { colour_contrast };
        Ok(PixelMeasures {
            colour_quality: pixel_colour_quality(&channels, &[1.0; 3])?,
            geometry_quality: pixel_quality(g)?,
            colour_contrast,
            binary_contrast,
            geometry_contrast,
            geometry_binary_contrast: itgfx_core::pixel::binary_contrast(g)?,
            geometry_log_contrast: log_difference_contrast(g, Base::Bits)?,
            contrast: mixed_contrast(oracle.delta, colour, geometry_contrast)?,
        })
    };
    value().unwrap_or(PixelMeasures {
        colour_contrast: 1.0,
        binary_contrast: 1.0,
        geometry_contrast: 1.0,
        geometry_binary_contrast: 1.0,
        geometry_log_contrast: f64::INFINITY,
        contrast: 1.0,
        ..PixelMeasures::default()
    })
}

/// The oracle pass: `n_s` stratified samples in every pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct ContrastMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Sum of each pixel's oracle samples (RGB).
    pub sums: Vec<[f64; 3]>,
    /// Each pixel's measures.
    pub measures: Vec<PixelMeasures>,
}

/// Traces `ORACLE_SAMPLES` samples in every pixel of `view` (rows in
/// parallel: the supersampler's pilot, [`sampler::pilot`]) and measures
/// each pixel; `progress` gets (rows done, rows).
///
/// # Errors
/// Backend failures only.
pub fn contrast_map(
    pt: &PathTracer,
    view: &View,
    oracle: Oracle,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<ContrastMap, BackendError> {
    let es = Supersampling { oracle, spp: ORACLE_SAMPLES, max: ORACLE_SAMPLES, unbiased: true };
    let h = u64::from(view.height);
    let pilots = sampler::pilot(pt, view, &es, &|d| progress(d, h))?;
    Ok(map_of(view, pilots))
}

/// The contrast map of the oracle's pixels (row-major).
fn map_of(view: &View, pilots: Vec<([f64; 3], PixelMeasures)>) -> ContrastMap {
    let (sums, measures) = pilots.into_iter().unzip();
    ContrastMap { width: view.width, height: view.height, sums, measures }
}

fn sum(s: &[[f64; 3]], mut acc: [f64; 3]) -> [f64; 3] {
    for c in s {
        for k in 0..3 {
            acc[k] += c[k];
        }
    }
    acc
}

/// Shares `total` samples among pixels in proportion to `weights` (all
/// finite, non-negative), no pixel above `cap`: a pixel whose share passes
/// the cap gets the cap and the rest is shared again among the others;
/// fractions go to the largest remainders (ties to the lower index). With
/// all weights 0 the share is uniform. The result sums to
/// `min(total, cap · pixels)`.
#[must_use]
pub fn allocate(weights: &[f64], total: u64, cap: u32) -> Vec<u32> {
    let n = weights.len();
    let mut out = vec![0u32; n];
    if n == 0 || cap == 0 {
        return out;
    }
    let all_zero = weights.iter().all(|&w| !(w > 0.0));
    let weight = |i: usize| if all_zero { 1.0 } else { weights[i].max(0.0) };
    let mut active: Vec<usize> = (0..n).filter(|&i| weight(i) > 0.0).collect();
    let mut remaining = total.min(u64::from(cap) * n as u64) as f64;
    // Water filling: pixels whose share passes the cap are capped, then shares are recomputed.
    loop {
        let sw: f64 = active.iter().map(|&i| weight(i)).sum();
        if sw <= 0.0 {
            break;
        }
        let before = active.len();
        active.retain(|&i| {
            if remaining * weight(i) / sw >= f64::from(cap) {
                out[i] = cap;
                false
            } else {
                true
            }
        });
        remaining -= f64::from(cap) * (before - active.len()) as f64;
        if active.len() == before {
            break;
        }
    }
    let sw: f64 = active.iter().map(|&i| weight(i)).sum();
    if sw <= 0.0 || remaining <= 0.0 {
        return out;
    }
    let mut fractions = Vec::with_capacity(active.len());
    let mut given = 0u64;
    for &i in &active {
        let share = remaining * weight(i) / sw;
        let whole = share.floor();
        out[i] = whole as u32;
        given += whole as u64;
        fractions.push((share - whole, i));
    }
    let left = (remaining.round() as u64).saturating_sub(given);
    fractions.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    // Every active share is below the cap, so its floor plus one is within it.
    for &(_, i) in fractions.iter().take(left as usize) {
        out[i] += 1;
    }
    out
}

/// The supersampler's decisions: the oracle's contrast map and each
/// pixel's share of the rest of the budget.
pub struct SharePlan {
    /// The oracle's contrast map (of the whole image).
    pub map: ContrastMap,
    /// Each pixel's samples beyond the oracle's `n_s`.
    pub extra: Vec<u32>,
}

/// A set of pixels being supersampled: each pixel's running sum (the
/// oracle's own in the tutorial form) and the variance of its fresh samples.
pub struct SharePixels {
    ids: Vec<u32>,
    sums: Vec<[f64; 3]>,
    variance: Vec<[f64; 3]>,
    traced: bool,
}

impl Supersampling {
    /// Fresh samples pixel `p` traces: its share, and as many as the
    /// oracle's in the unbiased form.
    fn fresh(&self, plan: &SharePlan, p: u32) -> u32 {
        let e = plan.extra[p as usize];
        if self.unbiased { ORACLE_SAMPLES + e } else { e }
    }
}

/// Entropy-based supersampling with an average of `spp` rays per pixel
/// (the oracle's included), at most `max` in a pixel's estimate: the
/// oracle's contrast map (the pilot, over the whole image: the share of
/// every row depends on every pixel's contrast), then the rest of the
/// budget shared by contrast, then the box filter (over the fresh samples
/// in the unbiased form, over the oracle's and the share in the tutorial
/// form).
impl PixelSampler for Supersampling {
    type Pilot = ([f64; 3], PixelMeasures);
    type Plan = SharePlan;
    type Pixels = SharePixels;

    fn pilot_rays(&self) -> Option<PilotRays> {
        Some(PilotRays { spp: ORACLE_SAMPLES, geometry: true })
    }

    fn pilot(&self, rgb: &[[f64; 3]], g: &[f64]) -> Self::Pilot {
        (sum(rgb, [0.0; 3]), measures(rgb, g, self.oracle))
    }

    fn counts(&self, view: &View, pilots: Vec<Self::Pilot>) -> SharePlan {
        let map = map_of(view, pilots);
        let pixels = map.measures.len() as u64;
        // Samples spent before the shares: the oracle's (its samples are also
        // the estimate's first in the tutorial form; in the unbiased form as
        // many fresh ones follow).
        let spent = if self.unbiased { 2 * ORACLE_SAMPLES } else { ORACLE_SAMPLES };
        let extra_total = pixels * u64::from(self.spp.saturating_sub(spent));
        let contrast: Vec<f64> = map.measures.iter().map(|m| m.contrast).collect();
        let extra = allocate(&contrast, extra_total, self.max.saturating_sub(ORACLE_SAMPLES));
        SharePlan { map, extra }
    }

    fn start(&self, plan: &SharePlan, _: &View, ids: &[u32]) -> SharePixels {
        let kept = |p: u32| if self.unbiased { [0.0; 3] } else { plan.map.sums[p as usize] };
        SharePixels {
            ids: ids.to_vec(),
            sums: ids.iter().map(|&p| kept(p)).collect(),
            variance: vec![[0.0; 3]; ids.len()],
            traced: false,
        }
    }

    /// One round: each pixel's fresh samples as one stratified batch from index 8.
    fn round(&self, plan: &SharePlan, _: &View, px: &mut SharePixels, estimate: bool) -> Option<Rays> {
        if px.traced || !estimate {
            return None;
        }
        px.traced = true;
        let batches = (px.ids.iter().enumerate())
            .filter(|&(_, &p)| self.fresh(plan, p) > 0)
            .map(|(k, &p)| Batch {
                pixel: p,
                slot: k as u32,
                first: ORACLE_SAMPLES,
                n: self.fresh(plan, p),
                odd: false,
                pilot: false,
            })
            .collect();
        Some(Rays::Batches { batches, geometry: false })
    }

    fn absorb(&self, _: &SharePlan, px: &mut SharePixels, rays: Rays, rgb: &[[f64; 3]], _: &[f64]) {
        let Rays::Batches { batches, .. } = rays else { return };
        let mut k = 0;
        for b in &batches {
            let (n, slot) = (b.n as usize, b.slot as usize);
            px.sums[slot] = sum(&rgb[k..k + n], px.sums[slot]);
            // The unbiased form's value is the mean of these fresh samples alone.
            px.variance[slot] = moments(&rgb[k..k + n]).1;
            k += n;
        }
    }

    fn estimate(&self, plan: &SharePlan, px: SharePixels) -> Vec<PixelValue> {
        let decided = if self.unbiased { ORACLE_SAMPLES } else { 0 };
        (px.ids.iter().zip(px.sums).zip(px.variance))
            .map(|((&p, s), v)| {
                let samples = ORACLE_SAMPLES + plan.extra[p as usize];
                let n = f64::from(samples);
                PixelValue {
                    rgb: s.map(|v| v / n),
                    // The tutorial form's value also holds the oracle's samples, whose squares are not kept.
                    variance: self.unbiased.then_some(v),
                    samples,
                    pilot: decided,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const COLOUR: Oracle = Oracle { delta: 1.0, binary: false };

    #[test]
    fn allocation_is_proportional_exact_and_capped() {
        let a = allocate(&[1.0, 3.0, 0.0, 4.0], 16, 100);
        assert_eq!(a, vec![2, 6, 0, 8]);
        // 10 samples by weights 1:1:1 -> 3.33 each; one remainder to the lowest index.
        assert_eq!(allocate(&[1.0, 1.0, 1.0], 10, 100), vec![4, 3, 3]);
        // The cap passes the excess on: 12 by 10:1:1 with cap 6 -> 6, 3, 3.
        assert_eq!(allocate(&[10.0, 1.0, 1.0], 12, 6), vec![6, 3, 3]);
        // All flat: uniform.
        assert_eq!(allocate(&[0.0; 4], 8, 100), vec![2; 4]);
        // More than the caps hold: every pixel at its cap.
        assert_eq!(allocate(&[1.0, 2.0], 100, 5), vec![5, 5]);
        let big: Vec<f64> = (0..1000).map(|i| f64::from(i % 7) * 0.1).collect();
        assert_eq!(allocate(&big, 52_000, 1000).iter().map(|&v| u64::from(v)).sum::<u64>(), 52_000);
    }

    #[test]
    fn a_flat_pixel_gets_no_more_samples_and_a_split_pixel_does() {
        // Synthetic oracle sample sets: flat pixels have contrast 0 (no share),
        // an edge pixel (half light, half dark; or two surfaces with δ < 1) takes it all.
        let flat = [[0.3, 0.4, 0.5]; 8];
        let split: Vec<[f64; 3]> = (0..8).map(|i| if i % 2 == 0 { [2.0, 1.0, 0.5] } else { [0.0; 3] }).collect();
        let g = [1.0; 8];
        let two: Vec<f64> = (0..8).map(|i| if i < 4 { 1.0 } else { 0.01 }).collect();
        let mixed = Oracle { delta: 0.5, binary: true };
        for oracle in [COLOUR, Oracle { delta: 1.0, binary: true }, mixed] {
            let c = [measures(&flat, &g, oracle).contrast, measures(&split, &g, oracle).contrast];
            assert!(c[0] < 1e-12 && c[1] > 0.1, "{oracle:?}: {c:?}");
            assert_eq!(allocate(&[c[0], c[1], c[0]], 52, 1000), vec![0, 52, 0]);
        }
        assert!(measures(&flat, &two, mixed).contrast > 0.1, "geometry contrast (eq. (20)) splits");
        assert!(measures(&flat, &two, COLOUR).contrast < 1e-12, "δ = 1 is colour only");
    }

    #[test]
    fn measures_are_the_core_definitions() {
        let flat = measures(&[[0.5; 3]; 8], &[2.0; 8], COLOUR);
        assert!((flat.colour_quality - 1.0).abs() < 1e-12 && (flat.geometry_quality - 1.0).abs() < 1e-12);
        // One bright sample of 8 in every channel: H = 0, quality 0, contrasts 1.
        let one: Vec<[f64; 3]> = (0..8).map(|i| if i == 0 { [1.0; 3] } else { [0.0; 3] }).collect();
        let m = measures(&one, &[1.0; 8], COLOUR);
        assert_eq!((m.colour_quality, m.colour_contrast, m.binary_contrast, m.contrast), (0.0, 1.0, 1.0, 1.0));
        let bad = measures(&[[f64::NAN; 3]; 8], &[1.0; 8], COLOUR);
        assert_eq!(bad.contrast, 1.0, "refused samples count as the worst pixel");
    }
}
