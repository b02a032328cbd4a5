//! Shape descriptors for retrieval (issue 26 §1; syllabus Part 8, "object
//! recognition"): one descriptor built from the viewpoint channel `V → O` of
//! Part V ([`information`]), and two classical shape distributions of Osada
//! et al. (2002), D2 and A3 ([`distributions`]), as baselines.
//!
//! Every descriptor is a list of histograms ("blocks"), each a probability
//! distribution; two descriptors are compared by the mean over blocks of the
//! square root of their Jensen–Shannon divergence (Part II eq. (17), equal
//! weights, bits), [`distance`]: a metric, bounded by 1. Invariance:
//!
//! * translation and uniform scale: every mesh is first put in its own frame,
//!   the area-weighted centroid of its surface at the origin and the largest
//!   distance of a vertex from it as the unit ([`Frame`]); D2 is normalised by
//!   its mean distance, A3 is an angle;
//! * rotation: the information descriptor is a distribution over a fixed
//!   viewpoint sphere (a rotation moves the views, not the histogram), D2 and
//!   A3 are distributions over random surface points;
//! * remeshing: D2 and A3 sample the surface by area; the viewpoint channel's
//!   VMI and VKL do not change when a polygon is split into parts seen alike
//!   (`p(o|v)/p(o)` is the same for each part), see docs/SHAPES.md.
//!
//! [`retrieval`] scores a distance matrix against class labels (leave-one-out
//! nearest neighbour, mean average precision, precision-recall), and
//! [`dataset`] makes the labelled retrieval set the benchmark and the tests use.

pub mod dataset;
pub mod distributions;
pub mod information;
pub mod retrieval;

use glam::DVec3;
use itgfx_core::{Base, jensen_shannon};
use rayon::prelude::*;

use crate::scene::Scene;

/// The descriptors `itgfx shapes --descriptor` selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Histograms of the viewpoint channel's measures ([`information`]).
    Information,
    /// Osada's D2: distances between random surface points.
    D2,
    /// Osada's A3: angles between three random surface points.
    A3,
}

impl Kind {
    /// Every descriptor, in report order.
    pub const ALL: [Self; 3] = [Self::Information, Self::D2, Self::A3];

    /// The command-line name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Information => "it",
            Self::D2 => "d2",
            Self::A3 => "a3",
        }
    }

    /// The descriptor named `s`.
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }
}

/// One histogram of a descriptor: a name and a probability distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// What the histogram counts (`"VMI"`, `"D2"`, …).
    pub name: &'static str,
    /// Bin probabilities (sum 1).
    pub p: Vec<f64>,
}

/// A shape descriptor: its blocks.
#[derive(Clone, Debug, PartialEq)]
pub struct Descriptor {
    /// Which descriptor.
    pub kind: Kind,
    /// Its histograms, compared block by block.
    pub blocks: Vec<Block>,
}

/// Why a descriptor could not be made.
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeError {
    /// The mesh has no triangle of positive area.
    Empty,
    /// The scene is an analytic sphere seen from inside (no triangles).
    Analytic,
    /// Tracing or the channel's measures failed.
    Channel(String),
}

impl std::fmt::Display for ShapeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Empty => f.write_str("no triangle of positive area"),
            Self::Analytic => f.write_str("an analytic sphere seen from inside has no surface to describe"),
            Self::Channel(e) => write!(f, "viewpoint channel: {e}"),
        }
    }
}

impl std::error::Error for ShapeError {}

/// A mesh's own frame: the area-weighted centroid of its surface and the
/// largest distance of a vertex from it. Both are unchanged by rotation and
/// move with translation and scale, so coordinates in this frame are
/// invariant to all three (the bounding box's centre is not: it turns with
/// the axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Area-weighted centroid.
    pub centre: DVec3,
    /// Largest vertex distance from the centre (> 0).
    pub radius: f64,
}

impl Frame {
    /// The frame of `scene`'s triangles.
    ///
    /// # Errors
    /// [`ShapeError::Analytic`] for the analytic sphere, [`ShapeError::Empty`]
    /// when the total area is 0.
    pub fn of(scene: &Scene) -> Result<Self, ShapeError> {
        if scene.sphere.is_some() {
            return Err(ShapeError::Analytic);
        }
        let (mut area, mut sum) = (0.0, DVec3::ZERO);
        for t in &scene.triangles {
            let a = (t[1] - t[0]).cross(t[2] - t[0]).length() * 0.5;
            area += a;
            sum += (t[0] + t[1] + t[2]) * (a / 3.0);
        }
        if !(area > 0.0 && area.is_finite()) {
            return Err(ShapeError::Empty);
        }
        let centre = sum / area;
        let radius = scene.triangles.iter().flatten().map(|v| (*v - centre).length()).fold(0.0, f64::max);
        if !(radius > 0.0) {
            return Err(ShapeError::Empty);
        }
        Ok(Self { centre, radius })
    }

    /// A point in the frame: `(p − centre) / radius`, inside the unit ball.
    #[must_use]
    pub fn map(&self, p: DVec3) -> DVec3 {
        (p - self.centre) / self.radius
    }
}

/// Settings shared by the descriptors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Seed of the surface samples (D2, A3).
    pub seed: u64,
    /// Point pairs (D2) and triples (A3) sampled.
    pub samples: u64,
    /// The information descriptor's settings.
    pub information: information::Settings,
}

impl Default for Settings {
    fn default() -> Self {
        Self { seed: 1, samples: 1 << 18, information: information::Settings::default() }
    }
}

/// The descriptor `kind` of `scene`.
///
/// # Errors
/// [`ShapeError`].
pub fn describe(
    scene: &Scene,
    kind: Kind,
    settings: &Settings,
    backend: crate::BackendChoice,
) -> Result<Descriptor, ShapeError> {
    let frame = Frame::of(scene)?;
    let blocks = match kind {
        Kind::Information => information::blocks(scene, &frame, &settings.information, backend)?,
        Kind::D2 => vec![distributions::d2(scene, &frame, settings.seed, settings.samples)?],
        Kind::A3 => vec![distributions::a3(scene, &frame, settings.seed, settings.samples)?],
    };
    Ok(Descriptor { kind, blocks })
}

/// A histogram of `values` over `bins` equal bins of `[lo, hi]` (values
/// outside are clamped to the end bins), each value's `weight` shared
/// between the two nearest bin centres in proportion to its distance from
/// them (linear binning), so the histogram moves continuously with the
/// values; normalised to sum 1 (all zeros if the weights sum to 0).
#[must_use]
pub fn soft_histogram(values: &[f64], weights: Option<&[f64]>, lo: f64, hi: f64, bins: usize) -> Vec<f64> {
    let mut h = vec![0.0; bins];
    let width = (hi - lo) / bins as f64;
    for (i, &v) in values.iter().enumerate() {
        let w = weights.map_or(1.0, |w| w[i]);
        if !v.is_finite() || !(w > 0.0) {
            continue;
        }
        let x = ((v - lo) / width - 0.5).clamp(0.0, (bins - 1) as f64);
        let k = (x.floor() as usize).min(bins - 1);
        let f = x - k as f64;
        h[k] += w * (1.0 - f);
        if k + 1 < bins {
            h[k + 1] += w * f;
        }
    }
    normalise(&mut h);
    h
}

/// Scales `h` to sum 1 (left as is when its sum is 0).
pub fn normalise(h: &mut [f64]) {
    let s: f64 = h.iter().sum();
    if s > 0.0 {
        h.iter_mut().for_each(|x| *x /= s);
    }
}

/// `√JS(p, q)` in bits with equal weights (Part II eq. (17)): the
/// Jensen–Shannon distance, a metric in `[0, 1]`; 0 for two empty blocks.
///
/// # Errors
/// Core errors (lengths differ, not distributions).
pub fn block_distance(p: &[f64], q: &[f64]) -> Result<f64, itgfx_core::Error> {
    if p.len() != q.len() {
        return Err(itgfx_core::Error::LengthMismatch { expected: p.len(), found: q.len() });
    }
    if p.iter().all(|&x| x == 0.0) && q.iter().all(|&x| x == 0.0) {
        return Ok(0.0);
    }
    let dists: Vec<f64> = p.iter().chain(q).copied().collect();
    let js = jensen_shannon(&[0.5, 0.5], &dists, p.len(), Base::Bits)?;
    Ok(js.max(0.0).sqrt())
}

/// The distance between two descriptors of the same kind: the mean over
/// blocks of [`block_distance`].
///
/// # Errors
/// Core errors; [`itgfx_core::Error::LengthMismatch`] when the block counts differ.
pub fn distance(a: &Descriptor, b: &Descriptor) -> Result<f64, itgfx_core::Error> {
    if a.blocks.len() != b.blocks.len() || a.blocks.is_empty() {
        return Err(itgfx_core::Error::LengthMismatch { expected: a.blocks.len(), found: b.blocks.len() });
    }
    let mut sum = 0.0;
    for (x, y) in a.blocks.iter().zip(&b.blocks) {
        sum += block_distance(&x.p, &y.p)?;
    }
    Ok(sum / a.blocks.len() as f64)
}

/// The symmetric `n × n` distance matrix of `descriptors` (zero diagonal),
/// row-major; each pair computed once, in parallel.
///
/// # Errors
/// As [`distance`].
pub fn distance_matrix(descriptors: &[Descriptor]) -> Result<Vec<f64>, itgfx_core::Error> {
    let n = descriptors.len();
    let pairs: Vec<(usize, usize)> = (0..n).flat_map(|i| (i + 1..n).map(move |j| (i, j))).collect();
    let d: Vec<Result<f64, itgfx_core::Error>> =
        pairs.par_iter().map(|&(i, j)| distance(&descriptors[i], &descriptors[j])).collect();
    let mut m = vec![0.0; n * n];
    for (&(i, j), x) in pairs.iter().zip(d) {
        let x = x?;
        m[i * n + j] = x;
        m[j * n + i] = x;
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn soft_histogram_sums_to_one_and_splits_between_centres() {
        let h = soft_histogram(&[0.5], None, 0.0, 2.0, 2);
        // 0.5 is bin 0's centre: all in bin 0.
        assert!((h[0] - 1.0).abs() < 1e-12, "{h:?}");
        let h = soft_histogram(&[1.0], None, 0.0, 2.0, 2);
        assert!((h[0] - 0.5).abs() < 1e-12 && (h[1] - 0.5).abs() < 1e-12, "{h:?}");
        let h = soft_histogram(&[-5.0, 9.0, 0.7], Some(&[1.0, 2.0, 1.0]), 0.0, 2.0, 4);
        assert!((h.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(h[3] >= 0.5, "clamped to the end bin: {h:?}");
    }

    #[test]
    fn block_distance_is_a_bounded_symmetric_js_distance() {
        let p = [0.5, 0.5, 0.0];
        let q = [0.0, 0.0, 1.0];
        assert!((block_distance(&p, &q).unwrap() - 1.0).abs() < 1e-12, "disjoint: 1 bit");
        assert_eq!(block_distance(&p, &p).unwrap(), 0.0);
        let r = [0.2, 0.3, 0.5];
        assert_eq!(block_distance(&p, &r).unwrap(), block_distance(&r, &p).unwrap());
        assert!(block_distance(&p, &[1.0]).is_err());
    }

    #[test]
    fn frame_is_invariant_to_translation_and_scale() {
        let s = crate::meshes::torus("t", 1.0, 0.3, 24, 12);
        let f = Frame::of(&s).unwrap();
        let mut moved = s.clone();
        for t in &mut moved.triangles {
            for v in t.iter_mut() {
                *v = *v * 2.5 + DVec3::new(3.0, -1.0, 7.0);
            }
        }
        let g = Frame::of(&moved).unwrap();
        let p = s.triangles[5][1];
        assert!((f.map(p) - g.map(p * 2.5 + DVec3::new(3.0, -1.0, 7.0))).length() < 1e-12);
        assert!(Frame::of(&Scene::named("empty")).is_err());
    }
}
