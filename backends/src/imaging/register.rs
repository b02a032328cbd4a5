//! Multiresolution rigid registration by maximising a joint-histogram metric.
//!
//! At each level both images are smoothed by a Gaussian of `σ` pixels at
//! full resolution and shrunk by an integer factor (coarse to fine, ITK's
//! `SetShrinkFactorsPerLevel` / `SetSmoothingSigmasPerLevel` schedule). The
//! metric is evaluated on every fixed pixel of the level whose transformed
//! centre falls inside the moving image (bilinear interpolation); pixels that
//! map outside are left out of the histogram, as in ITK. Powell's method
//! ([`super::powell`]) maximises the metric from the previous level's result.

use itgfx_core::{Base, JointEntropies};

use super::gray::Gray;
use super::joint::{Binning, HistogramKind, JointHistogram, Metric};
use super::powell::{PowellOptions, minimise};
use super::rigid::{Rigid2, centre};

/// One level of the pyramid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Level {
    /// Integer shrink factor.
    pub shrink: usize,
    /// Gaussian smoothing, full-resolution pixels.
    pub sigma: f64,
}

/// What to do; `T` is the transform ([`Rigid2`] for images,
/// [`super::Rigid3`] for volumes).
#[derive(Clone, Debug, PartialEq)]
pub struct RegisterOptions<T = Rigid2> {
    /// Histogram bins per axis (2..=256).
    pub bins: usize,
    /// Binned or Parzen histogram.
    pub kind: HistogramKind,
    /// The metric maximised.
    pub metric: Metric,
    /// Coarse to fine.
    pub levels: Vec<Level>,
    /// Starting transform.
    pub initial: T,
    /// Most Powell iterations per level.
    pub max_iterations: usize,
    /// Least fraction of the fixed pixels that must map inside the moving
    /// image; below it the metric is refused (a penalty), so the optimiser
    /// cannot win by sliding the images apart.
    pub min_overlap: f64,
    /// Farthest a line search may reach, in level pixels (angles: the
    /// rotation that moves the image's rim that far) at the first level;
    /// later levels, which start near the answer, reach half as far.
    pub max_step: f64,
}

impl<T: Default> Default for RegisterOptions<T> {
    fn default() -> Self {
        Self {
            bins: 32,
            kind: HistogramKind::Parzen,
            metric: Metric::Mi,
            levels: vec![
                Level { shrink: 4, sigma: 2.0 },
                Level { shrink: 2, sigma: 1.0 },
                Level { shrink: 1, sigma: 1.0 },
            ],
            initial: T::default(),
            max_iterations: 50,
            min_overlap: 0.25,
            max_step: 8.0,
        }
    }
}

/// The outcome of one level.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelResult {
    /// The level.
    pub level: Level,
    /// Level image size.
    pub size: (usize, usize),
    /// Powell iterations.
    pub iterations: usize,
    /// Metric evaluations.
    pub evaluations: usize,
    /// The transform at the end of the level.
    pub transform: Rigid2,
    /// Metric at the level's start, then after each iteration.
    pub trace: Vec<f64>,
}

/// The outcome of a registration.
#[derive(Clone, Debug, PartialEq)]
pub struct Registration {
    /// Fixed points to moving points.
    pub transform: Rigid2,
    /// The metric at full resolution, unsmoothed, at the final transform.
    pub metric: f64,
    /// The entropies of that joint histogram (bits).
    pub entropies: JointEntropies,
    /// Entropies at the starting transform, same histogram (bits).
    pub initial_entropies: Option<JointEntropies>,
    /// Fraction of fixed pixels inside the moving image at the end.
    pub overlap: f64,
    /// Per level.
    pub levels: Vec<LevelResult>,
}

/// Why a registration cannot run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RegisterError {
    /// The two images differ in size.
    SizeMismatch,
    /// An image has a single intensity: it carries no information to align.
    Constant(&'static str),
    /// An image smaller than 4 × 4.
    TooSmall,
    /// At the end, too few pixels overlap to measure anything.
    NoOverlap,
}

impl core::fmt::Display for RegisterError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::SizeMismatch => f.write_str("the fixed and moving images differ in size"),
            Self::Constant(which) => write!(f, "the {which} image is constant: nothing to register"),
            Self::TooSmall => f.write_str("images must be at least 4 x 4 pixels"),
            Self::NoOverlap => f.write_str("the images do not overlap at the final transform"),
        }
    }
}

impl std::error::Error for RegisterError {}

/// Penalty returned (minimised) when the overlap is too small.
const PENALTY: f64 = 1.0e3;

/// One level's pair, ready to measure.
struct Pair {
    fixed: Gray,
    moving: Gray,
    fbin: Binning,
    mbin: Binning,
    shrink: f64,
    centre: (f64, f64),
}

impl Pair {
    fn new(fixed: &Gray, moving: &Gray, level: Level, bins: usize) -> Self {
        let (f, m) =
            (fixed.smoothed(level.sigma).shrunk(level.shrink), moving.smoothed(level.sigma).shrunk(level.shrink));
        let (fl, fh) = f.range();
        let (ml, mh) = m.range();
        Self {
            fbin: Binning::new(f64::from(fl), f64::from(fh), bins),
            mbin: Binning::new(f64::from(ml), f64::from(mh), bins),
            fixed: f,
            moving: m,
            shrink: level.shrink as f64,
            centre: centre(fixed.width, fixed.height),
        }
    }

    /// Fills `h` for transform `t`; returns the overlap fraction.
    fn histogram(&self, t: &Rigid2, kind: HistogramKind, h: &mut JointHistogram) -> f64 {
        h.clear();
        let s = self.shrink;
        let (w, ht) = (self.fixed.width, self.fixed.height);
        let (sn, cs) = t.angle_deg.to_radians().sin_cos();
        let c = self.centre;
        for j in 0..ht {
            let py = (j as f64 + 0.5) * s - 0.5 - c.1;
            for i in 0..w {
                let px = (i as f64 + 0.5) * s - 0.5 - c.0;
                let qx = cs * px - sn * py + c.0 + t.tx;
                let qy = sn * px + cs * py + c.1 + t.ty;
                let (mx, my) = ((qx + 0.5) / s - 0.5, (qy + 0.5) / s - 0.5);
                let f = self.fbin.position(f64::from(self.fixed.data[j * w + i]));
                if kind == HistogramKind::PartialVolume {
                    if let Some(nb) = self.moving.neighbours(mx, my) {
                        for (v, wgt) in nb {
                            h.add_weight(f, self.mbin.position(f64::from(v)), wgt);
                        }
                        h.count_sample();
                    }
                } else if let Some(m) = self.moving.bilinear(mx, my) {
                    h.add(kind, f, self.mbin.position(m));
                }
            }
        }
        h.samples as f64 / (w * ht) as f64
    }
}

/// One pyramid level of a fixed/moving pair in 2 or 3 dimensions, seen by
/// the search as a function of `P` transform parameters.
pub(super) trait LevelPair<const P: usize> {
    /// Fills `h` for parameters `p`; returns the fraction of fixed samples
    /// whose mapped point falls inside the moving image.
    fn fill(&self, p: &[f64; P], kind: HistogramKind, h: &mut JointHistogram) -> f64;
    /// The level's sizes, fixed image.
    fn size(&self) -> Vec<usize>;
}

impl LevelPair<3> for Pair {
    /// Parameters `(t_x, t_y, θ°)`: Powell's directions start as the
    /// translations, then the rotation, the shift usually being the larger
    /// part of a misalignment.
    fn fill(&self, p: &[f64; 3], kind: HistogramKind, h: &mut JointHistogram) -> f64 {
        self.histogram(&Rigid2 { angle_deg: p[2], tx: p[0], ty: p[1] }, kind, h)
    }

    fn size(&self) -> Vec<usize> {
        vec![self.fixed.width, self.fixed.height]
    }
}

/// One level of a search: the parameters it ended at and Powell's record.
pub(super) struct LevelSearch<const P: usize> {
    pub(super) level: Level,
    pub(super) size: Vec<usize>,
    pub(super) iterations: usize,
    pub(super) evaluations: usize,
    pub(super) x: [f64; P],
    /// Metric at the level's start, then after each iteration.
    pub(super) trace: Vec<f64>,
}

/// The multiresolution search shared by 2D and 3D: at each level, Powell
/// maximises `o.metric` of the pair `make(level)` from the previous level's
/// parameters, starting along `scales(level)` (one unit of each moves the
/// image's rim by about one level pixel or voxel). Returns the levels and,
/// at full resolution unsmoothed, the entropies at `x0` (`None` without
/// overlap), at the answer, and the answer's overlap.
pub(super) fn search<const P: usize, T, L: LevelPair<P>>(
    o: &RegisterOptions<T>,
    x0: [f64; P],
    make: impl Fn(Level) -> L,
    scales: impl Fn(Level) -> [f64; P],
    mut progress: impl FnMut(usize, usize),
) -> Result<(Vec<LevelSearch<P>>, Option<JointEntropies>, JointEntropies, f64), RegisterError> {
    let mut x = x0;
    let mut h = JointHistogram::new(o.bins);
    let mut levels = Vec::with_capacity(o.levels.len());
    for (k, &level) in o.levels.iter().enumerate() {
        progress(k, o.levels.len());
        let pair = make(level);
        let objective = |p: &[f64; P]| {
            let overlap = pair.fill(p, o.kind, &mut h);
            if overlap < o.min_overlap {
                return PENALTY;
            }
            h.entropies(Base::Bits).map_or(PENALTY, |e| -o.metric.value(&e))
        };
        let popt = PowellOptions {
            ftol: 1e-7,
            xtol: if level.shrink == 1 { 0.002 } else { 0.01 },
            max_iterations: o.max_iterations,
            max_step: if k == 0 { o.max_step } else { o.max_step / 2.0 },
        };
        let r = minimise(objective, x, scales(level), &popt);
        x = r.x;
        levels.push(LevelSearch {
            level,
            size: pair.size(),
            iterations: r.iterations,
            evaluations: r.evaluations,
            x,
            trace: r.trace.iter().map(|v| -v).collect(),
        });
    }
    let full = make(Level { shrink: 1, sigma: 0.0 });
    let initial = {
        let ov = full.fill(&x0, o.kind, &mut h);
        if ov > 0.0 { h.entropies(Base::Bits) } else { None }
    };
    let overlap = full.fill(&x, o.kind, &mut h);
    let entropies = h.entropies(Base::Bits).ok_or(RegisterError::NoOverlap)?;
    Ok((levels, initial, entropies, overlap))
}

/// Registers `moving` onto `fixed`; `progress(level, levels)` is called as
/// each level starts.
///
/// # Errors
/// [`RegisterError`] for mismatched, tiny or constant images, or no overlap.
pub fn register(
    fixed: &Gray,
    moving: &Gray,
    o: &RegisterOptions,
    progress: impl FnMut(usize, usize),
) -> Result<Registration, RegisterError> {
    if (fixed.width, fixed.height) != (moving.width, moving.height) {
        return Err(RegisterError::SizeMismatch);
    }
    if fixed.width < 4 || fixed.height < 4 {
        return Err(RegisterError::TooSmall);
    }
    for (img, which) in [(fixed, "fixed"), (moving, "moving")] {
        let (lo, hi) = img.range();
        if lo >= hi {
            return Err(RegisterError::Constant(which));
        }
    }
    let radius = fixed.width.max(fixed.height) as f64 / 2.0;
    let to = |p: [f64; 3]| Rigid2 { angle_deg: p[2], tx: p[0], ty: p[1] };
    let (found, initial_entropies, entropies, overlap) = search(
        o,
        [o.initial.tx, o.initial.ty, o.initial.angle_deg],
        |level| Pair::new(fixed, moving, level, o.bins),
        |level| {
            let s = level.shrink as f64;
            [s, s, s * radius.recip().to_degrees()]
        },
        progress,
    )?;
    let levels: Vec<LevelResult> = found
        .into_iter()
        .map(|l| LevelResult {
            level: l.level,
            size: (l.size[0], l.size[1]),
            iterations: l.iterations,
            evaluations: l.evaluations,
            transform: to(l.x),
            trace: l.trace,
        })
        .collect();
    let t = levels.last().map_or(o.initial, |l| l.transform);
    Ok(Registration { transform: t, metric: o.metric.value(&entropies), entropies, initial_entropies, overlap, levels })
}

/// `moving(T(x))` on the fixed grid (bilinear; `outside` where `T(x)` leaves the image).
#[must_use]
pub fn resample(moving: &Gray, t: &Rigid2, outside: f32) -> Gray {
    let c = centre(moving.width, moving.height);
    let mut out = Gray::new(moving.width, moving.height);
    for y in 0..moving.height {
        for x in 0..moving.width {
            let (qx, qy) = t.apply(c, x as f64, y as f64);
            out.data[y * moving.width + x] = moving.bilinear(qx, qy).map_or(outside, |v| v as f32);
        }
    }
    out
}

/// The joint histogram of `fixed` and `moving(T(·))` at full resolution.
#[must_use]
pub fn joint_histogram(fixed: &Gray, moving: &Gray, t: &Rigid2, bins: usize, kind: HistogramKind) -> JointHistogram {
    let pair = Pair::new(fixed, moving, Level { shrink: 1, sigma: 0.0 }, bins);
    let mut h = JointHistogram::new(bins);
    pair.histogram(t, kind, &mut h);
    h
}

#[cfg(test)]
mod tests {
    use super::super::phantom::{PhantomOptions, render};
    use super::*;

    #[test]
    fn recovers_a_known_transform() {
        let truth = Rigid2 { angle_deg: 4.0, tx: 3.5, ty: -2.25 };
        let (f, m) = render(&PhantomOptions { width: 64, height: 64, truth, noise: 0.02, bias: 0.1, seed: 3 });
        let r = register(&f, &m, &RegisterOptions::default(), |_, _| {}).unwrap();
        assert!(r.transform.corner_distance(&truth, 64, 64) < 0.5, "{:?}", r.transform);
        assert!(r.entropies.mutual_information > r.initial_entropies.unwrap().mutual_information);
    }

    /// A smooth mono-modal image and its exactly shifted copy (no noise,
    /// no resampling error): the shift comes back to a hundredth of a pixel.
    #[test]
    fn subpixel_shift_of_a_monomodal_pair() {
        let blobs = |x: f64, y: f64| {
            let g = |cx: f64, cy: f64, s: f64| (-((x - cx).powi(2) + (y - cy).powi(2)) / (2.0 * s * s)).exp();
            (0.6 * g(20.0, 25.0, 6.0) + 0.4 * g(40.0, 18.0, 4.0) + 0.5 * g(30.0, 42.0, 8.0)) as f32
        };
        let (w, h) = (64, 60);
        let truth = Rigid2 { angle_deg: 0.0, tx: 2.3, ty: -1.7 };
        let mut f = Gray::new(w, h);
        let mut m = Gray::new(w, h);
        for y in 0..h {
            for x in 0..w {
                f.data[y * w + x] = blobs(x as f64, y as f64);
                m.data[y * w + x] = blobs(x as f64 - truth.tx, y as f64 - truth.ty);
            }
        }
        let r = register(&f, &m, &RegisterOptions::default(), |_, _| {}).unwrap();
        assert!((r.transform.tx - 2.3).abs() < 0.01 && (r.transform.ty + 1.7).abs() < 0.01, "{:?}", r.transform);
        assert!(r.transform.angle_deg.abs() < 0.05);
    }

    /// Registering B onto A gives (nearly) the inverse of A onto B.
    #[test]
    fn symmetric() {
        let truth = Rigid2 { angle_deg: -3.0, tx: -2.0, ty: 1.5 };
        let (f, m) = render(&PhantomOptions { width: 64, height: 64, truth, noise: 0.0, bias: 0.0, seed: 1 });
        let o = RegisterOptions::default();
        let ab = register(&f, &m, &o, |_, _| {}).unwrap().transform;
        let ba = register(&m, &f, &o, |_, _| {}).unwrap().transform;
        assert!(ab.corner_distance(&ba.inverse(), 64, 64) < 0.25, "{ab:?} vs {:?}", ba.inverse());
    }

    /// Every kind of histogram holds one unit of weight per overlapping pixel.
    #[test]
    fn histograms_hold_one_unit_per_sample() {
        let truth = Rigid2 { angle_deg: 2.0, tx: 1.5, ty: -0.5 };
        let (f, m) = render(&PhantomOptions { width: 40, height: 36, truth, noise: 0.01, bias: 0.0, seed: 2 });
        for kind in [HistogramKind::Binned, HistogramKind::Parzen, HistogramKind::PartialVolume] {
            let h = joint_histogram(&f, &m, &truth, 16, kind);
            assert!(h.samples > 1000);
            assert!((h.counts.iter().sum::<f64>() - h.samples as f64).abs() < 1e-9, "{kind:?}");
        }
    }

    #[test]
    fn refuses_bad_pairs() {
        let f = Gray::new(8, 8);
        assert_eq!(
            register(&f, &Gray::new(8, 9), &RegisterOptions::default(), |_, _| {}),
            Err(RegisterError::SizeMismatch)
        );
        assert_eq!(register(&f, &f, &RegisterOptions::default(), |_, _| {}), Err(RegisterError::Constant("fixed")));
    }
}
