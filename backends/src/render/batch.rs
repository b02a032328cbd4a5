//! The batch sampler: every pixel takes a first stratified batch, then
//! more while a stop rule ([`Policy`]) asks for them — `uniform` (one
//! batch) and the tutorial's batch criteria ([`super::criteria`]).
//!
//! Rounds: every pixel still asking traces its next batch (indices
//! following its samples so far, the grid turned on odd batches). In the
//! unbiased form the batches only decide (their indices carry the
//! [`PILOT`](super::frame::PILOT) bit), and a last round traces as many
//! fresh samples as the decisions took, in one stratified batch; the
//! pixel's value is their mean. In the tutorial's form the value is the
//! mean of the deciding samples themselves.

use super::frame::{Batch, MAX_PIXEL_SAMPLES, PixelValue, View};
use super::sampler::{PixelSampler, Rays};

/// The radiance samples of one pixel so far, in index order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PixelSamples {
    /// RGB of each sample.
    pub rgb: Vec<[f64; 3]>,
}

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

/// The batch sampler of a stop rule.
#[derive(Clone, Copy, Debug)]
pub struct Batches<P>(pub P);

/// One pixel of a set in the batch sampler.
struct Pixel {
    samples: PixelSamples,
    batches: u32,
    next: u32,
}

/// The state of a set of pixels in the batch sampler.
pub struct BatchPixels {
    ids: Vec<u32>,
    pixels: Vec<Pixel>,
    /// The fresh samples of the unbiased form's last round, once traced.
    fresh: Option<Vec<[f64; 3]>>,
    /// The rounds that decide are over.
    decided: bool,
}

impl<P: Policy> PixelSampler for Batches<P> {
    type Pilot = ();
    type Plan = ();
    type Pixels = BatchPixels;

    fn pilot(&self, _: &[[f64; 3]], _: &[f64]) {}

    fn counts(&self, _: &View, _: Vec<()>) {}

    fn start(&self, (): &(), _: &View, ids: &[u32]) -> BatchPixels {
        let first = self.0.first().clamp(1, MAX_PIXEL_SAMPLES);
        let pixels = ids.iter().map(|_| Pixel { samples: PixelSamples::default(), batches: 0, next: first }).collect();
        BatchPixels { ids: ids.to_vec(), pixels, fresh: None, decided: false }
    }

    fn round(&self, (): &(), _: &View, px: &mut BatchPixels, estimate: bool) -> Option<Rays> {
        let unbiased = self.0.unbiased();
        if !px.decided {
            // Decision rounds: every pixel still asking gets its next batch.
            let batches: Vec<Batch> = px
                .pixels
                .iter()
                .enumerate()
                .filter(|(_, p)| p.next > 0)
                .map(|(k, p)| Batch {
                    pixel: px.ids[k],
                    slot: k as u32,
                    first: p.samples.rgb.len() as u32,
                    n: p.next,
                    odd: p.batches % 2 == 1,
                    pilot: unbiased,
                })
                .collect();
            if !batches.is_empty() {
                return Some(Rays::Batches { batches, geometry: false });
            }
            px.decided = true;
            if unbiased && estimate {
                // Unbiased: as many fresh samples as the pilot took, in one stratified batch.
                let batches = px
                    .pixels
                    .iter()
                    .enumerate()
                    .map(|(k, p)| Batch {
                        pixel: px.ids[k],
                        slot: k as u32,
                        first: 0,
                        n: p.samples.rgb.len() as u32,
                        odd: false,
                        pilot: false,
                    })
                    .collect();
                return Some(Rays::Batches { batches, geometry: false });
            }
        }
        None
    }

    fn absorb(&self, (): &(), px: &mut BatchPixels, rays: Rays, rgb: &[[f64; 3]], _: &[f64]) {
        if px.decided {
            px.fresh = Some(rgb.to_vec());
            return;
        }
        let Rays::Batches { batches, .. } = rays else { return };
        let mut k = 0;
        for b in &batches {
            let p = &mut px.pixels[b.slot as usize];
            p.samples.rgb.extend_from_slice(&rgb[k..k + b.n as usize]);
            k += b.n as usize;
            p.batches += 1;
            let room = MAX_PIXEL_SAMPLES - p.samples.rgb.len() as u32;
            p.next = self.0.more(&p.samples).min(room);
        }
    }

    fn estimate(&self, (): &(), px: BatchPixels) -> Vec<PixelValue> {
        if !self.0.unbiased() {
            return px.pixels.iter().map(|p| PixelValue::of(&p.samples.rgb, 0)).collect();
        }
        let Some(fresh) = px.fresh else {
            // Only decided (a tuning run): the image samples are counted, not traced.
            return px
                .pixels
                .iter()
                .map(|p| PixelValue { pilot: p.samples.rgb.len() as u32, ..PixelValue::of(&p.samples.rgb, 0) })
                .collect();
        };
        let mut k = 0;
        px.pixels
            .iter()
            .map(|p| {
                let n = p.samples.rgb.len();
                let v = PixelValue::of(&fresh[k..k + n], n as u32);
                k += n;
                v
            })
            .collect()
    }
}
