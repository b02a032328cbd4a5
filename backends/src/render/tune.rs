//! Thresholds for an equal budget: the tutorial compares criteria at the
//! same average number of rays per pixel (Part IV Table 2, III-IV Table 3:
//! 60). The threshold is found by bisection on `log ε` over a pilot: a
//! regular grid of at most 2,048 pixels of the same view, rendered with a
//! different seed, so the final image's own samples never tune it and no
//! reference image is looked at. A pixel's spend is heavy-tailed (a few
//! caustic pixels run to the cap), so a small grid misses the budget: on
//! `mirror-room` 128² at 60 rays, 441 pilot pixels gave images tracing
//! 40.9–55.6 rays for `ct`, `kl`, `hl-sqrt`, `cc` in the unbiased form;
//! 1,849 give 58.7–60.3.

use super::frame::View;
use super::path::PathTracer;
use super::sampler::{PixelSampler, counts};
use crate::tracer::BackendError;

/// Pixels of the pilot grid, at most.
const PILOT_PIXELS: u32 = 2048;
/// Bisection steps on `log ε`.
const STEPS: u32 = 14;

/// Result of tuning.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tuned {
    /// The threshold found.
    pub threshold: f64,
    /// Average rays per pixel it traces on the pilot (decision and image
    /// samples together).
    pub pilot_mean: f64,
    /// Pilot pixels.
    pub pilot_pixels: u32,
}

/// The pilot pixels: a regular grid over the image.
#[must_use]
pub fn pilot_pixels(width: u32, height: u32) -> Vec<u32> {
    let total = u64::from(width) * u64::from(height);
    let stride = ((total as f64 / f64::from(PILOT_PIXELS)).sqrt().ceil() as u32).max(1);
    let mut out = Vec::new();
    for y in (stride / 2..height).step_by(stride as usize) {
        for x in (stride / 2..width).step_by(stride as usize) {
            out.push(y * width + x);
        }
    }
    out
}

/// The threshold at which the sampler `make(ε)` traces on average `target`
/// rays per pixel on the pilot grid, decision samples included (spend must
/// fall as `ε` grows). In the unbiased form every decision sample is
/// counted with the image's (a pixel that decides on `n` samples traces
/// `2n`), so `target` is the whole cost in either form.
///
/// # Errors
/// Backend failures only.
pub fn tune<S: PixelSampler>(
    pt: &PathTracer,
    view: &View,
    target: f64,
    make: impl Fn(f64) -> S,
) -> Result<Tuned, BackendError> {
    let pilot = View { seed: view.seed ^ 0x005E_ED0F_7E57, ..*view };
    let pixels = pilot_pixels(view.width, view.height);
    let mean = |eps: f64| -> Result<f64, BackendError> {
        let n = counts(pt, &pilot, &make(eps), &pixels)?;
        Ok(n.iter().map(|&v| f64::from(v)).sum::<f64>() / n.len().max(1) as f64)
    };
    // Spend falls as ε grows: bracket in log space, then bisect.
    let (mut lo, mut hi) = (-32.0f64, 6.0f64);
    let (mut best, mut best_mean) = (hi.exp(), f64::NAN);
    for _ in 0..STEPS {
        let mid = 0.5 * (lo + hi);
        let m = mean(mid.exp())?;
        if best_mean.is_nan() || (m - target).abs() < (best_mean - target).abs() {
            (best, best_mean) = (mid.exp(), m);
        }
        if m > target { lo = mid } else { hi = mid }
    }
    Ok(Tuned { threshold: best, pilot_mean: best_mean, pilot_pixels: pixels.len() as u32 })
}
