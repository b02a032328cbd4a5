//! One pixel loop for every sampler: the [`PixelSampler`] trait and the
//! loop that drives any implementation of it over the image.
//!
//! The split is pbrt-v4's Sampler and Film (Mitsuba 3's sampler and
//! `ImageBlock`): a sampler says which rays each pixel takes and how its
//! samples make its value; the loop owns the rest — rows in parallel, the
//! rays sent through the tracing seam in the sampler's rounds, a shard's
//! rows, progress, and the [`Frame`] the values land in. A sampler runs in
//! three steps:
//!
//! 1. **pilot** (optional, [`PixelSampler::pilot_rays`]): one stratified
//!    batch in every pixel of the whole image (indices `0..n`), each pixel's
//!    samples kept as the sampler's [`PixelSampler::Pilot`] (es's contrast
//!    measures, `adaptive`'s sums). A shard traces the whole pilot, since a
//!    pixel's count may depend on every other pixel's pilot.
//! 2. **counts** ([`PixelSampler::counts`]): the decisions taken on all
//!    the pilots (es's and `adaptive`'s shares of the budget).
//! 3. **estimate**: for each set of pixels (a row; a chunk of the tuning
//!    grid), rounds of rays ([`PixelSampler::round`],
//!    [`PixelSampler::absorb`]) until the sampler asks for none, then each
//!    pixel's value ([`PixelSampler::estimate`]).
//!
//! The implementations: the batch criteria and `uniform`
//! ([`super::batch::Batches`]), the refinement tree ([`super::tree::Tree`]),
//! entropy-based supersampling ([`super::Supersampling`]) and `adaptive`
//! ([`super::AdaptiveSampling`]). Every sample's random numbers come from
//! its pixel and index, and a pixel's samples are summed in index order by
//! its sampler, so the image does not depend on the thread count.

use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

use super::frame::{Batch, Frame, PixelValue, View, trace_geometry};
use super::path::{PathTracer, Start};
use crate::tracer::BackendError;

/// The pilot a sampler takes in every pixel before deciding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PilotRays {
    /// Stratified samples a pixel (one batch, indices `0..spp`).
    pub spp: u32,
    /// Whether each sample's first-hit geometry factor is kept (Part IV eq. (12)).
    pub geometry: bool,
}

/// The rays of one round of a set of pixels.
#[derive(Clone, Debug)]
pub enum Rays {
    /// Stratified batches of pixel samples ([`trace_geometry`]).
    Batches {
        /// The batches, in the order their samples come back.
        batches: Vec<Batch>,
        /// Keep each sample's first-hit geometry factor.
        geometry: bool,
    },
    /// Camera rays the sampler placed itself (the refinement tree's nodes),
    /// traced as given.
    Starts {
        /// The rays, in the order their samples come back.
        starts: Vec<Start>,
        /// Keep each sample's first-hit geometry factor.
        geometry: bool,
    },
}

/// A pixel sampler: which rays each pixel takes and how its samples make
/// its value (module notes).
pub trait PixelSampler: Sync {
    /// What one pixel's pilot leaves for the decision (`()` without a pilot).
    type Pilot: Send + Sync;
    /// The decisions taken on the whole image's pilots (`()` without).
    type Plan: Sync;
    /// The state of a set of pixels between rounds.
    type Pixels: Send;

    /// The pilot every pixel takes before [`counts`](Self::counts); `None`:
    /// no pilot.
    fn pilot_rays(&self) -> Option<PilotRays> {
        None
    }
    /// One pixel's pilot from its samples `rgb` and their geometry factors
    /// `g` (empty unless asked for).
    fn pilot(&self, rgb: &[[f64; 3]], g: &[f64]) -> Self::Pilot;
    /// The decisions from every pixel's pilot (row-major; empty without a pilot).
    fn counts(&self, view: &View, pilots: Vec<Self::Pilot>) -> Self::Plan;
    /// The state of the pixels `ids` (indices `y · width + x`) before their first round.
    fn start(&self, plan: &Self::Plan, view: &View, ids: &[u32]) -> Self::Pixels;
    /// The rays of the next round, `None` when the pixels are done. With
    /// `estimate` false only the rays that decide are asked for: the
    /// image's samples are counted, not traced (a tuning run).
    fn round(&self, plan: &Self::Plan, view: &View, pixels: &mut Self::Pixels, estimate: bool) -> Option<Rays>;
    /// A round's radiance (and geometry factors, when asked), in the order of `rays`.
    fn absorb(&self, plan: &Self::Plan, pixels: &mut Self::Pixels, rays: Rays, rgb: &[[f64; 3]], g: &[f64]);
    /// Each pixel's value, in the order of `ids`.
    fn estimate(&self, plan: &Self::Plan, pixels: Self::Pixels) -> Vec<PixelValue>;
}

/// Traces one round: radiance of every sample in order, and the geometry
/// factors when asked for (else empty).
fn trace(pt: &PathTracer, view: &View, rays: &Rays) -> Result<(Vec<[f64; 3]>, Vec<f64>), BackendError> {
    let mut g = Vec::new();
    let rgb = match rays {
        Rays::Batches { batches, geometry } => trace_geometry(pt, view, batches, geometry.then_some(&mut g))?,
        Rays::Starts { starts, geometry } => pt.radiance_geometry(starts, geometry.then_some(&mut g))?,
    };
    Ok((rgb, g))
}

/// Runs the rounds of the pixels `ids` and returns their values.
fn pixels<S: PixelSampler>(
    pt: &PathTracer,
    view: &View,
    sampler: &S,
    plan: &S::Plan,
    ids: &[u32],
    estimate: bool,
) -> Result<Vec<PixelValue>, BackendError> {
    let mut state = sampler.start(plan, view, ids);
    while let Some(rays) = sampler.round(plan, view, &mut state, estimate) {
        let (rgb, g) = trace(pt, view, &rays)?;
        sampler.absorb(plan, &mut state, rays, &rgb, &g);
    }
    Ok(sampler.estimate(plan, state))
}

/// The sampler's pilot in every pixel of the whole image (rows in
/// parallel); `progress` gets the rows done. Empty without a pilot.
///
/// # Errors
/// Backend failures only.
pub fn pilot<S: PixelSampler>(
    pt: &PathTracer,
    view: &View,
    sampler: &S,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<S::Pilot>, BackendError> {
    let Some(PilotRays { spp, geometry }) = sampler.pilot_rays() else { return Ok(Vec::new()) };
    let (w, n) = (view.width, spp as usize);
    let done = AtomicU64::new(0);
    let rows: Vec<Vec<S::Pilot>> = (0..view.height)
        .into_par_iter()
        .map(|y| {
            let batches: Vec<Batch> = (0..w)
                .map(|x| Batch { pixel: y * w + x, slot: x, first: 0, n: spp, odd: false, pilot: false })
                .collect();
            let (rgb, g) = trace(pt, view, &Rays::Batches { batches, geometry })?;
            let row = (0..w as usize)
                .map(|x| sampler.pilot(&rgb[x * n..(x + 1) * n], g.get(x * n..(x + 1) * n).unwrap_or(&[])))
                .collect();
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            Ok(row)
        })
        .collect::<Result<_, BackendError>>()?;
    Ok(rows.into_iter().flatten().collect())
}

/// Renders the rows `view.rows` with `sampler`: its pilot over the whole
/// image and its counts, then every row's rounds (rows in parallel), the
/// values gathered into the frame. Returns the frame and the sampler's
/// plan. `progress` gets (rows done, rows) of both passes.
///
/// # Errors
/// Backend failures only.
pub fn render<S: PixelSampler>(
    pt: &PathTracer,
    view: &View,
    sampler: &S,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(Frame, S::Plan), BackendError> {
    let (w, (first, end)) = (view.width, view.rows);
    let mine = u64::from(end - first);
    // With a pilot the progress counts the whole image's pilot rows, then the shard's rows as as many again.
    let (base, scale, total) = match sampler.pilot_rays() {
        Some(_) => (u64::from(view.height), u64::from(view.height), 2 * u64::from(view.height)),
        None => (0, mine, mine),
    };
    let pilots = pilot(pt, view, sampler, &|d| progress(d, total))?;
    let plan = sampler.counts(view, pilots);
    let done = AtomicU64::new(0);
    let rows: Vec<Vec<PixelValue>> = (first..end)
        .into_par_iter()
        .map(|y| {
            let ids: Vec<u32> = (y * w..(y + 1) * w).collect();
            let row = pixels(pt, view, sampler, &plan, &ids, true);
            progress(base + (done.fetch_add(1, Ordering::Relaxed) + 1) * scale / mine.max(1), total);
            row
        })
        .collect::<Result<_, _>>()?;
    Ok((Frame::of_values(w, end - first, rows.into_iter().flatten()), plan))
}

/// Rays traced for each of `ids` (indices `y · width + x`) by `sampler`,
/// decision samples and image samples together: what [`render`] would spend
/// there (a tuning run). Only the decisions are traced: an unbiased
/// sampler's image samples are counted, not traced.
///
/// # Errors
/// Backend failures only.
pub fn counts<S: PixelSampler>(
    pt: &PathTracer,
    view: &View,
    sampler: &S,
    ids: &[u32],
) -> Result<Vec<u32>, BackendError> {
    let plan = sampler.counts(view, pilot(pt, view, sampler, &|_| {})?);
    let parts: Vec<Vec<PixelValue>> =
        ids.par_chunks(64).map(|c| pixels(pt, view, sampler, &plan, c, false)).collect::<Result<_, _>>()?;
    Ok(parts.into_iter().flatten().map(|p| p.samples + p.pilot).collect())
}
