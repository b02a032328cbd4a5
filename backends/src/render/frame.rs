//! The image plane: pixels sampled in stratified batches, rows in parallel.
//!
//! Sample `i` of pixel `p` draws its random numbers from
//! `LineRng::new(seed, p · 2^24 + i)`, and a pixel's samples are summed in
//! index order: the same seed gives the same image bit for bit on any number
//! of threads. A batch of `n` samples is stratified over the pixel on an
//! `a × b` jittered grid (`a` the largest divisor of `n` not above `√n`), so
//! a uniform run of 64 spp is 8 × 8 jittered and each adaptive batch of 8 is
//! 4 × 2 (alternating with 2 × 4).

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use super::path::{PathTracer, Start, Stratum, strata};
use crate::camera::Camera;
use crate::lines::{LineRng, SeedHash};
use crate::tracer::BackendError;

/// Most samples one pixel may take (the sample index has 23 bits; the 24th
/// marks the pilot samples of unbiased adaptive runs).
pub const MAX_PIXEL_SAMPLES: u32 = 1 << 23;
/// Bit of the sample index set on pilot samples (decisions only).
pub const PILOT: u32 = 1 << 23;
/// Paths traced per call of the seam.
const CHUNK: usize = 8192;
/// Draw of a batch's first sample that keys the batch's stratum
/// permutations (paths use draws `0..2 + 6 · 256`).
const STRATUM_KEY_DRAW: u32 = 0x7fff_ffff;

/// Where and how an image is taken.
#[derive(Clone, Copy, Debug)]
pub struct View {
    /// The camera in the tracer's normalised coordinates.
    pub camera: Camera,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Seed of every random draw.
    pub seed: u64,
    /// The rows `[first, end)` to render (all: `(0, height)`); a shard of a
    /// run renders a range, and the ranges' rows are the whole run's.
    pub rows: (u32, u32),
}

/// A rendered image (or the rows `view.rows` of one): mean radiance per
/// pixel (linear RGB, row-major from the top-left) and the samples each
/// pixel took.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Mean radiance of each pixel.
    pub rgb: Vec<[f64; 3]>,
    /// Samples that went into each pixel's value.
    pub samples: Vec<u32>,
    /// Further samples traced to take decisions only (unbiased adaptive runs).
    pub pilot_samples: Vec<u32>,
    /// Each pixel's sample variance per channel (denominator `n − 1`, 0 below
    /// 2 samples) of the samples in its value; empty when the value is not a
    /// sample mean (the refinement trees' eq. (29) reconstruction) or was not
    /// kept (merged shards).
    pub variance: Vec<[f64; 3]>,
}

impl Frame {
    /// Average samples per pixel in the image values.
    #[must_use]
    pub fn mean_samples(&self) -> f64 {
        self.samples.iter().map(|&s| f64::from(s)).sum::<f64>() / self.samples.len().max(1) as f64
    }

    /// Average samples per pixel traced in all (image and pilot).
    #[must_use]
    pub fn mean_traced(&self) -> f64 {
        let p: f64 = self.pilot_samples.iter().map(|&s| f64::from(s)).sum();
        self.mean_samples() + p / self.samples.len().max(1) as f64
    }
}

/// The radiance samples of one pixel so far, in index order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PixelSamples {
    /// RGB of each sample.
    pub rgb: Vec<[f64; 3]>,
}

/// A pixel a policy rendered its own way ([`Policy::render_own`]): mean
/// RGB, image samples, pilot samples.
pub type OwnPixel = ([f64; 3], u32, u32);

/// How many samples a pixel takes: a first batch, then more while the
/// policy asks for them.
pub trait Policy: Sync {
    /// Samples of the first batch.
    fn first(&self) -> u32;
    /// Samples of the next batch given those so far; 0 to stop.
    fn more(&self, so_far: &PixelSamples) -> u32;
    /// Whether decisions are taken on a separate pilot set: the pixel's value
    /// is then the mean of as many fresh samples as the pilot run took.
    fn unbiased(&self) -> bool {
        false
    }
    /// A policy that renders its pixels its own way (the refinement tree of
    /// Part IV §6) instead of in batches: (mean, image samples, pilot
    /// samples) per pixel of `ids`. The hook keeps this file below the
    /// policies that use its types.
    fn render_own(
        &self,
        _pt: &PathTracer,
        _view: &View,
        _ids: &[u32],
        _estimate: bool,
    ) -> Option<Result<Vec<OwnPixel>, BackendError>> {
        None
    }
}

/// Image-plane position of sample `i` of pixel `(x, y)`, which is sample
/// `i - first` of a batch of `n` starting at `first`.
fn position(x: u32, y: u32, i: u32, first: u32, n: u32, rng: &LineRng, odd: bool) -> (f64, f64) {
    let (mut a, mut b) = strata(n);
    if odd {
        std::mem::swap(&mut a, &mut b);
    }
    let c = i - first;
    let (cx, cy) = (c % a, c / a);
    let sx = f64::from(x) + (f64::from(cx) + rng.uniform(0)) / f64::from(a);
    let sy = f64::from(y) + (f64::from(cy) + rng.uniform(1)) / f64::from(b);
    (sx, sy)
}

/// One pending batch: pixel, first sample index, batch size, parity.
#[derive(Clone, Copy)]
pub(crate) struct Batch {
    pub(crate) pixel: u32,
    pub(crate) slot: u32,
    pub(crate) first: u32,
    pub(crate) n: u32,
    pub(crate) odd: bool,
    pub(crate) pilot: bool,
}

/// Traces the batches of a row; returns the RGB of every sample in order.
fn trace(pt: &PathTracer, view: &View, batches: &[Batch]) -> Result<Vec<[f64; 3]>, BackendError> {
    trace_geometry(pt, view, batches, None)
}

/// As [`trace`]; with `geometry`, also each sample's first-hit geometry
/// factor (Part IV eq. (12)), in order. Each sample carries its place in
/// its batch ([`Stratum`]): the path tracer stratifies its first diffuse
/// vertex over the batch as the batch is stratified over the pixel.
pub(crate) fn trace_geometry(
    pt: &PathTracer,
    view: &View,
    batches: &[Batch],
    mut geometry: Option<&mut Vec<f64>>,
) -> Result<Vec<[f64; 3]>, BackendError> {
    let mut starts = Vec::with_capacity(CHUNK);
    let mut strata = Vec::with_capacity(CHUNK);
    let mut out = Vec::new();
    let mut g = Vec::new();
    let mut flush =
        |starts: &mut Vec<Start>, strata: &mut Vec<Stratum>, out: &mut Vec<[f64; 3]>| -> Result<(), BackendError> {
            let want = geometry.is_some();
            out.extend(pt.radiance_strata(starts, Some(strata), want.then_some(&mut g))?);
            if let Some(all) = geometry.as_deref_mut() {
                all.extend_from_slice(&g);
            }
            starts.clear();
            strata.clear();
            Ok(())
        };
    let seed = SeedHash::new(view.seed);
    for b in batches {
        let (x, y) = (b.pixel % view.width, b.pixel / view.width);
        let pilot = if b.pilot { PILOT } else { 0 };
        // The batch's permutation key: a draw no path uses, of its first sample.
        let key = LineRng::of(seed, (u64::from(b.pixel) << 24) | u64::from(b.first | pilot)).u32(STRATUM_KEY_DRAW);
        for i in b.first..b.first + b.n {
            let rng = LineRng::of(seed, (u64::from(b.pixel) << 24) | u64::from(i | pilot));
            let (sx, sy) = position(x, y, i, b.first, b.n, &rng, b.odd);
            let direction = view.camera.direction(sx, sy, view.width, view.height);
            starts.push(Start { origin: view.camera.eye, direction, rng });
            strata.push(Stratum { index: i - b.first, count: b.n, key });
            if starts.len() >= CHUNK {
                flush(&mut starts, &mut strata, &mut out)?;
            }
        }
    }
    flush(&mut starts, &mut strata, &mut out)?;
    Ok(out)
}

/// Sampled state of one pixel of the row being rendered.
struct Pixel {
    samples: PixelSamples,
    batches: u32,
    next: u32,
    image: u32,
}

/// Renders `view` with `policy` deciding each pixel's samples; `progress`
/// is called with (rows done, rows).
///
/// # Errors
/// Backend failures only.
pub fn render(
    pt: &PathTracer,
    view: &View,
    policy: &dyn Policy,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Frame, BackendError> {
    let w = view.width;
    let (first, end) = view.rows;
    let h = end - first;
    let done = AtomicU64::new(0);
    let rows: Vec<Vec<PixelValue>> = (first..end)
        .into_par_iter()
        .map(|y| {
            let pixels: Vec<u32> = (y * w..(y + 1) * w).collect();
            let row = render_pixels(pt, view, policy, &pixels, true);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, u64::from(h));
            row
        })
        .collect::<Result<_, _>>()?;
    let mut frame = Frame {
        width: w,
        height: h,
        rgb: Vec::with_capacity((w * h) as usize),
        samples: Vec::with_capacity((w * h) as usize),
        pilot_samples: Vec::with_capacity((w * h) as usize),
        variance: Vec::with_capacity((w * h) as usize),
    };
    let mut all_means = true;
    for p in rows.into_iter().flatten() {
        frame.rgb.push(p.rgb);
        frame.samples.push(p.samples);
        frame.pilot_samples.push(p.pilot);
        match p.variance {
            Some(v) => frame.variance.push(v),
            None => all_means = false,
        }
    }
    if !all_means {
        frame.variance.clear();
    }
    Ok(frame)
}

/// Rays traced for each of `pixels` (indices `y · width + x`) under
/// `policy`, decision samples and image samples together: what [`render`]
/// would spend there (the pixels of a pilot run). Only the decisions are
/// traced: an unbiased policy's image samples are counted, not traced (as
/// many as its pilot took, or 8 a leaf of the tree).
///
/// # Errors
/// Backend failures only.
pub fn sample_counts(
    pt: &PathTracer,
    view: &View,
    policy: &dyn Policy,
    pixels: &[u32],
) -> Result<Vec<u32>, BackendError> {
    let parts: Vec<Vec<PixelValue>> =
        pixels.par_chunks(64).map(|c| render_pixels(pt, view, policy, c, false)).collect::<Result<_, _>>()?;
    Ok(parts.into_iter().flatten().map(|p| p.samples + p.pilot).collect())
}

/// One rendered pixel: its value, the variance of the samples averaged into
/// it (`None` when the value is not their mean), and the samples spent.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PixelValue {
    pub(crate) rgb: [f64; 3],
    pub(crate) variance: Option<[f64; 3]>,
    pub(crate) samples: u32,
    pub(crate) pilot: u32,
}

impl PixelValue {
    /// The mean and variance of `s`, with `pilot` decision samples besides.
    fn of(s: &[[f64; 3]], pilot: u32) -> Self {
        let (rgb, variance) = moments(s);
        Self { rgb, variance: Some(variance), samples: s.len() as u32, pilot }
    }
}

/// Renders the given pixels (indices `y · width + x`): (mean, image samples,
/// pilot samples). With `estimate` false an unbiased policy only decides:
/// the image samples are counted but not traced (the mean is the pilot's).
fn render_pixels(
    pt: &PathTracer,
    view: &View,
    policy: &dyn Policy,
    ids: &[u32],
    estimate: bool,
) -> Result<Vec<PixelValue>, BackendError> {
    if let Some(values) = policy.render_own(pt, view, ids, estimate) {
        let values = values?;
        return Ok(values
            .into_iter()
            .map(|(rgb, samples, pilot)| PixelValue { rgb, variance: None, samples, pilot })
            .collect());
    }
    let unbiased = policy.unbiased();
    let first = policy.first().clamp(1, MAX_PIXEL_SAMPLES);
    let mut pixels: Vec<Pixel> =
        ids.iter().map(|_| Pixel { samples: PixelSamples::default(), batches: 0, next: first, image: 0 }).collect();
    // Decision rounds: every pixel still asking gets its next batch.
    loop {
        let batches: Vec<Batch> = pixels
            .iter()
            .enumerate()
            .filter(|(_, p)| p.next > 0)
            .map(|(k, p)| Batch {
                pixel: ids[k],
                slot: k as u32,
                first: p.samples.rgb.len() as u32,
                n: p.next,
                odd: p.batches % 2 == 1,
                pilot: unbiased,
            })
            .collect();
        if batches.is_empty() {
            break;
        }
        let rgb = trace(pt, view, &batches)?;
        let mut k = 0;
        for b in &batches {
            let p = &mut pixels[b.slot as usize];
            p.samples.rgb.extend_from_slice(&rgb[k..k + b.n as usize]);
            k += b.n as usize;
            p.batches += 1;
            let room = MAX_PIXEL_SAMPLES - p.samples.rgb.len() as u32;
            p.next = policy.more(&p.samples).min(room);
        }
    }
    if !unbiased {
        return Ok(pixels.into_iter().map(|p| PixelValue::of(&p.samples.rgb, 0)).collect());
    }
    if !estimate {
        return Ok(pixels
            .into_iter()
            .map(|p| {
                let n = p.samples.rgb.len() as u32;
                PixelValue { pilot: n, ..PixelValue::of(&p.samples.rgb, 0) }
            })
            .collect());
    }
    // Unbiased: as many fresh samples as the pilot took, in one stratified batch.
    let batches: Vec<Batch> = pixels
        .iter_mut()
        .enumerate()
        .map(|(k, p)| {
            p.image = p.samples.rgb.len() as u32;
            Batch { pixel: ids[k], slot: k as u32, first: 0, n: p.image, odd: false, pilot: false }
        })
        .collect();
    let rgb = trace(pt, view, &batches)?;
    let mut k = 0;
    Ok(pixels
        .into_iter()
        .map(|p| {
            let n = p.image as usize;
            let v = PixelValue::of(&rgb[k..k + n], p.samples.rgb.len() as u32);
            k += n;
            v
        })
        .collect())
}

/// Mean and sample variance (denominator `n − 1`; 0 below 2 samples) of
/// each channel of `s`.
pub(crate) fn moments(s: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let m = mean(s);
    let mut ss = [0.0; 3];
    for c in s {
        for k in 0..3 {
            ss[k] += (c[k] - m[k]) * (c[k] - m[k]);
        }
    }
    let d = s.len().saturating_sub(1).max(1) as f64;
    (m, if s.len() < 2 { [0.0; 3] } else { ss.map(|v| v / d) })
}

pub(crate) fn mean(s: &[[f64; 3]]) -> [f64; 3] {
    let mut acc = DVec3::ZERO;
    for c in s {
        acc += DVec3::from_array(*c);
    }
    (acc / s.len().max(1) as f64).to_array()
}

/// A fixed number of samples per pixel in one stratified batch.
#[derive(Clone, Copy, Debug)]
pub struct Uniform(pub u32);

impl Policy for Uniform {
    fn first(&self) -> u32 {
        self.0
    }
    fn more(&self, _: &PixelSamples) -> u32 {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_are_near_square() {
        assert_eq!(strata(64), (8, 8));
        assert_eq!(strata(8), (2, 4));
        assert_eq!(strata(60), (6, 10));
        assert_eq!(strata(7), (1, 7));
        assert_eq!(strata(1), (1, 1));
    }
}
