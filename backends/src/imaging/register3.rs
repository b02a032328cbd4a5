//! Rigid registration of volumes (6 parameters): the search of
//! [`super::register()`] (pyramid, joint histogram, metric by the core,
//! Powell) over a 3D level pair.
//!
//! Fixed voxel `i` sits at physical `i·spacing`; `T` ([`Rigid3`]) maps it
//! about the volume centre into the moving volume, sampled trilinearly (or
//! spread over its eight neighbours for partial volume). Voxels that map
//! outside the moving volume's extent (`[−½, n − ½)` voxels on each axis, as
//! ITK; see [`Gray3::neighbours`]) are left out of the histogram.

use itgfx_core::JointEntropies;

use super::gray3::Gray3;
use super::joint::{Binning, HistogramKind, JointHistogram};
use super::register::{Level, LevelPair, RegisterError, RegisterOptions, search};
use super::rigid3::{Rigid3, apply_mat};

/// The outcome of one level.
#[derive(Clone, Debug, PartialEq)]
pub struct Level3 {
    /// The level.
    pub level: Level,
    /// Level volume size.
    pub size: [usize; 3],
    /// Powell iterations.
    pub iterations: usize,
    /// Metric evaluations.
    pub evaluations: usize,
    /// The transform at the end of the level.
    pub transform: Rigid3,
    /// Metric at the level's start, then after each iteration.
    pub trace: Vec<f64>,
}

/// The outcome of a volume registration.
#[derive(Clone, Debug, PartialEq)]
pub struct Registration3 {
    /// Fixed points to moving points.
    pub transform: Rigid3,
    /// The metric at full resolution, unsmoothed, at the final transform.
    pub metric: f64,
    /// The entropies of that joint histogram (bits).
    pub entropies: JointEntropies,
    /// Entropies at the starting transform, same histogram (bits).
    pub initial_entropies: Option<JointEntropies>,
    /// Fraction of fixed voxels inside the moving volume at the end.
    pub overlap: f64,
    /// Per level.
    pub levels: Vec<Level3>,
}

/// One level's pair of volumes, ready to measure.
struct Pair3 {
    /// Fixed intensity bin of each level voxel.
    fbins: Vec<u8>,
    dims: [usize; 3],
    moving: Gray3,
    mbin: Binning,
    shrink: f64,
    spacing: [f64; 3],
    centre: [f64; 3],
}

impl Pair3 {
    fn new(fixed: &Gray3, moving: &Gray3, level: Level, bins: usize) -> Self {
        let f = fixed.smoothed(level.sigma).shrunk(level.shrink);
        let m = moving.smoothed(level.sigma).shrunk(level.shrink);
        let (fl, fh) = f.range();
        let (ml, mh) = m.range();
        let fbin = Binning::new(f64::from(fl), f64::from(fh), bins);
        Self {
            fbins: f.data.iter().map(|&v| fbin.bin(f64::from(v)) as u8).collect(),
            dims: f.dims,
            mbin: Binning::new(f64::from(ml), f64::from(mh), bins),
            moving: m,
            shrink: level.shrink as f64,
            spacing: fixed.spacing,
            centre: fixed.centre(),
        }
    }

    /// The moving level's continuous voxel coordinates of fixed level voxel
    /// `i`: `i ↦ ((i + ½)s − ½)·spacing ↦ T ↦ (q/spacing + ½)/s − ½`.
    fn map(&self, t: &Rigid3, r: &[[f64; 3]; 3], i: [f64; 3]) -> [f64; 3] {
        let (s, c) = (self.shrink, self.centre);
        let d: [f64; 3] = core::array::from_fn(|a| ((i[a] + 0.5) * s - 0.5) * self.spacing[a] - c[a]);
        let q = apply_mat(r, d);
        core::array::from_fn(|a| ((q[a] + c[a] + t.t[a]) / self.spacing[a] + 0.5) / s - 0.5)
    }

    fn histogram(&self, t: &Rigid3, kind: HistogramKind, h: &mut JointHistogram) -> f64 {
        h.clear();
        let r = t.matrix();
        // The map is affine in the level index: origin and one step per axis.
        let o = self.map(t, &r, [0.0; 3]);
        let step: [[f64; 3]; 3] = core::array::from_fn(|a| {
            let e = self.map(t, &r, core::array::from_fn(|b| if a == b { 1.0 } else { 0.0 }));
            core::array::from_fn(|k| e[k] - o[k])
        });
        let [nx, ny, nz] = self.dims;
        let mut k = 0;
        for z in 0..nz {
            for y in 0..ny {
                let row: [f64; 3] = core::array::from_fn(|a| o[a] + y as f64 * step[1][a] + z as f64 * step[2][a]);
                for x in 0..nx {
                    let p: [f64; 3] = core::array::from_fn(|a| row[a] + x as f64 * step[0][a]);
                    let f = f64::from(self.fbins[k]);
                    k += 1;
                    if kind == HistogramKind::PartialVolume {
                        if let Some(nb) = self.moving.neighbours(p) {
                            for (v, wgt) in nb {
                                h.add_weight(f, self.mbin.position(f64::from(v)), wgt);
                            }
                            h.count_sample();
                        }
                    } else if let Some(m) = self.moving.trilinear(p) {
                        h.add(kind, f, self.mbin.position(m));
                    }
                }
            }
        }
        h.samples as f64 / (nx * ny * nz) as f64
    }
}

impl LevelPair<6> for Pair3 {
    /// Parameters `(t_x, t_y, t_z, α°, β°, γ°)` ([`Rigid3::params`]).
    fn fill(&self, p: &[f64; 6], kind: HistogramKind, h: &mut JointHistogram) -> f64 {
        self.histogram(&Rigid3::from_params(*p), kind, h)
    }

    fn size(&self) -> Vec<usize> {
        self.dims.to_vec()
    }
}

/// Bytes a registration of two volumes of `voxels` voxels holds at its
/// peak beyond the two inputs: at the finest level the smoothed copy being
/// made, its pass buffer and the shrunk copy of one volume (`3 × 4` bytes a
/// voxel), the level's moving volume (4) and fixed bins (1), and the
/// resampled output (4).
#[must_use]
pub fn working_bytes(voxels: usize) -> u64 {
    voxels as u64 * 21 + (1 << 20)
}

/// Registers volume `moving` onto `fixed` (same dims and spacing);
/// `progress(level, levels)` is called as each level starts.
///
/// # Errors
/// [`RegisterError`] for mismatched, tiny or constant volumes, or no overlap.
pub fn register3(
    fixed: &Gray3,
    moving: &Gray3,
    o: &RegisterOptions<Rigid3>,
    progress: impl FnMut(usize, usize),
) -> Result<Registration3, RegisterError> {
    if fixed.dims != moving.dims || fixed.spacing != moving.spacing {
        return Err(RegisterError::SizeMismatch);
    }
    if fixed.dims.iter().any(|&n| n < 4) {
        return Err(RegisterError::TooSmall);
    }
    for (img, which) in [(fixed, "fixed"), (moving, "moving")] {
        let (lo, hi) = img.range();
        if lo >= hi {
            return Err(RegisterError::Constant(which));
        }
    }
    let sp = fixed.spacing;
    let mean_spacing = (sp[0] + sp[1] + sp[2]) / 3.0;
    let radius = (0..3).map(|a| fixed.dims[a] as f64 * sp[a]).fold(0.0, f64::max) / 2.0;
    let (found, initial_entropies, entropies, overlap) = search(
        o,
        o.initial.params(),
        |level| Pair3::new(fixed, moving, level, o.bins),
        |level| {
            let s = level.shrink as f64 * mean_spacing;
            let a = (s / radius).to_degrees();
            [s, s, s, a, a, a]
        },
        progress,
    )?;
    let levels: Vec<Level3> = found
        .into_iter()
        .map(|l| Level3 {
            level: l.level,
            size: [l.size[0], l.size[1], l.size[2]],
            iterations: l.iterations,
            evaluations: l.evaluations,
            transform: Rigid3::from_params(l.x),
            trace: l.trace,
        })
        .collect();
    let t = levels.last().map_or(o.initial, |l| l.transform);
    Ok(Registration3 {
        transform: t,
        metric: o.metric.value(&entropies),
        entropies,
        initial_entropies,
        overlap,
        levels,
    })
}

/// `moving(T(p))` on the fixed grid (trilinear; `outside` where `T(p)`
/// leaves the volume).
#[must_use]
pub fn resample3(moving: &Gray3, t: &Rigid3, outside: f32) -> Gray3 {
    let (c, sp, d) = (moving.centre(), moving.spacing, moving.dims);
    let mut out = Gray3::new(d, sp);
    let mut k = 0;
    for z in 0..d[2] {
        for y in 0..d[1] {
            for x in 0..d[0] {
                let p = [x as f64 * sp[0], y as f64 * sp[1], z as f64 * sp[2]];
                let q = t.apply(c, p);
                out.data[k] = moving.trilinear(core::array::from_fn(|a| q[a] / sp[a])).map_or(outside, |v| v as f32);
                k += 1;
            }
        }
    }
    out
}

/// The joint histogram of `fixed` and `moving(T(·))` at full resolution.
#[must_use]
pub fn joint_histogram3(fixed: &Gray3, moving: &Gray3, t: &Rigid3, bins: usize, kind: HistogramKind) -> JointHistogram {
    let pair = Pair3::new(fixed, moving, Level { shrink: 1, sigma: 0.0 }, bins);
    let mut h = JointHistogram::new(bins);
    pair.histogram(t, kind, &mut h);
    h
}

#[cfg(test)]
mod tests {
    use super::super::joint::Metric;
    use super::super::phantom::{Phantom3Options, render3};
    use super::*;

    fn pair(truth: Rigid3) -> (Gray3, Gray3) {
        render3(&Phantom3Options { dims: [40, 36, 32], spacing: [1.0; 3], truth, noise: 0.02, bias: 0.0, seed: 5 })
    }

    /// A known 6-parameter transform between the two modalities comes back
    /// within 1° and half a voxel (NMI: on so small a volume MI's maximum
    /// moves by over a degree with the overlap, see docs/IMAGING.md); the
    /// starting point (the identity) is outside that tolerance, so the check
    /// can fail.
    #[test]
    fn recovers_a_known_transform() {
        let truth = Rigid3 { angles_deg: [4.0, -3.0, 6.0], t: [2.5, -1.75, 1.5] };
        let (f, m) = pair(truth);
        let o = RegisterOptions::<Rigid3> {
            metric: Metric::Nmi,
            levels: vec![Level { shrink: 2, sigma: 1.0 }, Level { shrink: 1, sigma: 1.0 }],
            ..RegisterOptions::default()
        };
        let r = register3(&f, &m, &o, |_, _| {}).unwrap();
        let err = |t: &Rigid3| {
            let d: f64 = (0..3).map(|a| (t.t[a] - truth.t[a]).powi(2)).sum::<f64>().sqrt();
            (t.rotation_distance_deg(&truth), d)
        };
        let (rot, tr) = err(&r.transform);
        assert!(rot < 1.0 && tr < 0.5, "{:?}: {rot}° {tr}", r.transform);
        let (rot0, tr0) = err(&Rigid3::default());
        assert!(rot0 > 1.0 && tr0 > 0.5);
        assert!(r.entropies.mutual_information > r.initial_entropies.unwrap().mutual_information);
        assert!(r.transform.corner_distance(&truth, f.dims, f.spacing) < 1.0);
    }

    /// A volume against itself stays at the identity, `I(F;F) = H(F)`, and
    /// every histogram kind holds one unit of weight per overlapping voxel.
    #[test]
    fn identity_and_histograms() {
        let (f, _) = pair(Rigid3::default());
        let o = RegisterOptions::<Rigid3> {
            kind: HistogramKind::Binned,
            metric: Metric::Nmi,
            levels: vec![Level { shrink: 2, sigma: 1.0 }, Level { shrink: 1, sigma: 0.0 }],
            ..RegisterOptions::default()
        };
        let r = register3(&f, &f, &o, |_, _| {}).unwrap();
        assert!(r.transform.params().iter().all(|v| v.abs() < 0.05), "{:?}", r.transform);
        assert!((r.entropies.mutual_information - r.entropies.h_x).abs() < 1e-9);
        let t = Rigid3 { angles_deg: [1.0, 2.0, -3.0], t: [0.5, 1.25, -0.75] };
        for kind in [HistogramKind::Binned, HistogramKind::Parzen, HistogramKind::PartialVolume] {
            let h = joint_histogram3(&f, &f, &t, 16, kind);
            assert!(h.samples > 20_000);
            assert!((h.counts.iter().sum::<f64>() - h.samples as f64).abs() < 1e-6, "{kind:?}");
        }
        assert_eq!(register3(&f, &Gray3::new([40, 36, 31], [1.0; 3]), &o, |_, _| {}), Err(RegisterError::SizeMismatch));
    }
}
