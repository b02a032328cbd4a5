//! The image plane and the film: pixels sampled in stratified batches,
//! their values gathered into a [`Frame`] (pooled across passes by
//! [`Frame::pool`]); the loop that drives the samplers is [`super::sampler`].
//!
//! Sample `i` of pixel `p` draws its random numbers from
//! `LineRng::new(seed, p · 2^24 + i)`, and a pixel's samples are summed in
//! index order: the same seed gives the same image bit for bit on any number
//! of threads. A batch of `n` samples is stratified over the pixel on an
//! `a × b` jittered grid (`a` the largest divisor of `n` not above `√n`), so
//! a uniform run of 64 spp is 8 × 8 jittered and each adaptive batch of 8 is
//! 4 × 2 (alternating with 2 × 4).

use glam::DVec3;

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
    /// The frame of `width × height` pixels with these values (row-major);
    /// its variance is kept only if every value has one.
    pub(crate) fn of_values(width: u32, height: u32, values: impl Iterator<Item = PixelValue>) -> Self {
        let n = (width * height) as usize;
        let mut frame = Frame {
            width,
            height,
            rgb: Vec::with_capacity(n),
            samples: Vec::with_capacity(n),
            pilot_samples: Vec::with_capacity(n),
            variance: Vec::with_capacity(n),
        };
        let mut all_means = true;
        for p in values {
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
        frame
    }

    /// Pools the samples of another pass `b` of the same pixels into this
    /// frame: counts add, means are weighted by count, variances are those
    /// of the pooled samples (kept only if both passes kept them).
    pub fn pool(&mut self, b: &Frame) {
        let a = self;
        let keep_var = a.variance.len() == a.rgb.len() && b.variance.len() == b.rgb.len();
        for i in 0..a.rgb.len() {
            let (na, nb) = (f64::from(a.samples[i]), f64::from(b.samples[i]));
            let n = na + nb;
            if n == 0.0 {
                continue;
            }
            let (ma, mb) = (a.rgb[i], b.rgb[i]);
            let m: [f64; 3] = std::array::from_fn(|k| (na * ma[k] + nb * mb[k]) / n);
            if keep_var {
                let (va, vb) = (a.variance[i], b.variance[i]);
                a.variance[i] = std::array::from_fn(|k| {
                    // Sums of squared deviations about each pass's mean, then about the pooled mean.
                    let ss = (na - 1.0).max(0.0) * va[k]
                        + (nb - 1.0).max(0.0) * vb[k]
                        + na * (ma[k] - m[k]).powi(2)
                        + nb * (mb[k] - m[k]).powi(2);
                    if n < 2.0 { 0.0 } else { ss / (n - 1.0) }
                });
            }
            a.rgb[i] = m;
            a.samples[i] += b.samples[i];
            a.pilot_samples[i] += b.pilot_samples[i];
        }
        if !keep_var {
            a.variance.clear();
        }
    }

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

/// One stratified batch of a pixel's samples: indices `first..first + n`
/// on an `a × b` jittered grid ([`strata`]).
#[derive(Clone, Copy, Debug)]
pub struct Batch {
    /// The pixel, `y · width + x`.
    pub pixel: u32,
    /// Where the sampler keeps the pixel (its place in the set of pixels).
    pub slot: u32,
    /// Index of the batch's first sample.
    pub first: u32,
    /// Samples in the batch.
    pub n: u32,
    /// The grid turned, `b × a` (alternate batches of one pixel).
    pub odd: bool,
    /// Decision samples: their indices take the [`PILOT`] bit.
    pub pilot: bool,
}

/// Traces `batches`: the RGB of every sample in order; with `geometry`, also each sample's first-hit geometry
/// factor (Part IV eq. (12)), in order. Each sample carries its place in
/// its batch ([`Stratum`]): the path tracer stratifies its first diffuse
/// vertex over the batch as the batch is stratified over the pixel.
pub fn trace_geometry(
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
    let tan = view.camera.tan_half_fov();
    for b in batches {
        let (x, y) = (b.pixel % view.width, b.pixel / view.width);
        let pilot = if b.pilot { PILOT } else { 0 };
        // The batch's permutation key: a draw no path uses, of its first sample.
        let key = LineRng::of(seed, (u64::from(b.pixel) << 24) | u64::from(b.first | pilot)).u32(STRATUM_KEY_DRAW);
        for i in b.first..b.first + b.n {
            let rng = LineRng::of(seed, (u64::from(b.pixel) << 24) | u64::from(i | pilot));
            let (sx, sy) = position(x, y, i, b.first, b.n, &rng, b.odd);
            let direction = view.camera.direction_tan(tan, sx, sy, view.width, view.height);
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

/// One rendered pixel: its value, the variance of the samples averaged into
/// it (`None` when the value is not their mean), and the samples spent.
#[derive(Clone, Copy, Debug)]
pub struct PixelValue {
    /// The value, linear RGB.
    pub rgb: [f64; 3],
    /// The sample variance per channel of the samples averaged into it.
    pub variance: Option<[f64; 3]>,
    /// Samples in the value.
    pub samples: u32,
    /// Samples traced to decide only.
    pub pilot: u32,
}

impl PixelValue {
    /// The mean and variance of `s`, with `pilot` decision samples besides.
    pub(crate) fn of(s: &[[f64; 3]], pilot: u32) -> Self {
        let (rgb, variance) = moments(s);
        Self { rgb, variance: Some(variance), samples: s.len() as u32, pilot }
    }
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
