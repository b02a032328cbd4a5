//! The shape distributions of Osada, Funkhouser, Chazelle and Dobkin, "Shape
//! distributions", ACM TOG 21(4), 2002: D2 (the distance between two random
//! points of the surface) and A3 (the angle formed by three), the classical
//! baselines of `itgfx shapes`. Points are drawn uniformly by area, sample
//! `i` a pure function of `(seed, i)` ([`crate::lines::LineRng`]), so the
//! histograms are the same for any thread count.

use glam::DVec3;
use rayon::prelude::*;

use super::{Block, Frame, ShapeError, soft_histogram};
use crate::lines::{LineRng, SeedHash};
use crate::scene::Scene;

/// Bins of both histograms.
pub const BINS: usize = 64;
/// D2 is histogrammed over `[0, D2_RANGE]` mean distances (Osada et al.
/// normalise by the mean distance).
pub const D2_RANGE: f64 = 3.0;

/// Triangles in the frame and their cumulative areas, for area sampling.
struct Surface {
    triangles: Vec<[DVec3; 3]>,
    cumulative: Vec<f64>,
}

impl Surface {
    fn new(scene: &Scene, frame: &Frame) -> Result<Self, ShapeError> {
        let triangles: Vec<[DVec3; 3]> =
            scene.triangles.iter().map(|t| [frame.map(t[0]), frame.map(t[1]), frame.map(t[2])]).collect();
        let mut total = 0.0;
        let cumulative: Vec<f64> = triangles
            .iter()
            .map(|t| {
                total += (t[1] - t[0]).cross(t[2] - t[0]).length() * 0.5;
                total
            })
            .collect();
        if !(total > 0.0) {
            return Err(ShapeError::Empty);
        }
        Ok(Self { triangles, cumulative })
    }

    /// A point uniform by area from draws `k, k+1, k+2` of `rng`.
    fn point(&self, rng: &LineRng, k: u32) -> DVec3 {
        let total = self.cumulative[self.cumulative.len() - 1];
        let target = rng.uniform(k) * total;
        let i = self.cumulative.partition_point(|&c| c <= target).min(self.triangles.len() - 1);
        let [a, b, c] = self.triangles[i];
        let s = rng.uniform(k + 1).sqrt();
        let t = rng.uniform(k + 2);
        a * (1.0 - s) + b * (s * (1.0 - t)) + c * (s * t)
    }
}

/// D2: `samples` distances between two random surface points, divided by
/// their mean, histogrammed over `[0, D2_RANGE]`.
///
/// # Errors
/// [`ShapeError::Empty`].
pub fn d2(scene: &Scene, frame: &Frame, seed: u64, samples: u64) -> Result<Block, ShapeError> {
    let s = Surface::new(scene, frame)?;
    let h = SeedHash::new(seed);
    let d: Vec<f64> = (0..samples.max(1))
        .into_par_iter()
        .map(|i| {
            let r = LineRng::of(h, i);
            (s.point(&r, 0) - s.point(&r, 3)).length()
        })
        .collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    if !(mean > 0.0) {
        return Err(ShapeError::Empty);
    }
    let scaled: Vec<f64> = d.iter().map(|x| x / mean).collect();
    Ok(Block { name: "D2", p: soft_histogram(&scaled, None, 0.0, D2_RANGE, BINS) })
}

/// A3: `samples` angles (radians, `[0, π]`) at the middle one of three
/// random surface points, histogrammed.
///
/// # Errors
/// [`ShapeError::Empty`].
pub fn a3(scene: &Scene, frame: &Frame, seed: u64, samples: u64) -> Result<Block, ShapeError> {
    let s = Surface::new(scene, frame)?;
    let h = SeedHash::new(seed ^ 0xA3A3_A3A3);
    let a: Vec<f64> = (0..samples.max(1))
        .into_par_iter()
        .map(|i| {
            let r = LineRng::of(h, i);
            let (p, q, o) = (s.point(&r, 0), s.point(&r, 3), s.point(&r, 6));
            let (u, v) = (p - q, o - q);
            let l = u.length() * v.length();
            // Coincident points have no angle: NaN, skipped by the histogram.
            if l > 0.0 { (u.dot(v) / l).clamp(-1.0, 1.0).acos() } else { f64::NAN }
        })
        .collect();
    Ok(Block { name: "A3", p: soft_histogram(&a, None, 0.0, std::f64::consts::PI, BINS) })
}
