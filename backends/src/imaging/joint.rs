//! Joint intensity histograms and the similarity metrics computed from them.
//!
//! The histogram is the joint distribution `p(f, m)` of the fixed and moving
//! intensities over the overlap, i.e. the information channel between the two
//! images; every metric is a function of [`itgfx_core::JointEntropies`]:
//! `I(F;M)` (Part II eq. (7)), `I/H(F,M)`, Studholme's
//! `(H(F)+H(M))/H(F,M)` and the entropy correlation coefficient (Part III
//! §3.2.3), all computed by the core.

use itgfx_core::{Base, JointEntropies, joint_entropies};

/// How a pair of intensities lands in the histogram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HistogramKind {
    /// Each pair adds 1 to the bin of each intensity (nearest bin).
    Binned,
    /// Mattes et al.: the fixed intensity in its bin (zero-order), the
    /// moving one spread over 4 bins by a cubic B-spline Parzen window, so
    /// the metric is a smooth function of the transform.
    Parzen,
    /// Maes et al.'s partial-volume interpolation: no new intensity is
    /// made; the pair's unit weight is spread over the bins of the four
    /// moving pixels around the mapped point by their bilinear weights.
    PartialVolume,
}

/// The quantity the registration maximises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// `I(F;M)` (Part II eq. (7)).
    Mi,
    /// Studholme's `(H(F)+H(M))/H(F,M)` ([`JointEntropies::studholme_nmi`]).
    Nmi,
    /// `2I/(H(F)+H(M))` ([`JointEntropies::entropy_correlation`]).
    Ecc,
    /// `I/H(F,M)` ([`JointEntropies::mi_over_joint`]).
    MiOverJoint,
}

impl Metric {
    /// The metric's value from a joint's entropies.
    #[must_use]
    pub fn value(self, e: &JointEntropies) -> f64 {
        match self {
            Self::Mi => e.mutual_information,
            Self::Nmi => e.studholme_nmi(),
            Self::Ecc => e.entropy_correlation(),
            Self::MiOverJoint => e.mi_over_joint(),
        }
    }

    /// The name used on the command line and in reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Mi => "mi",
            Self::Nmi => "nmi",
            Self::Ecc => "ecc",
            Self::MiOverJoint => "mi-over-joint",
        }
    }
}

/// Maps intensities in `[lo, hi]` to continuous bin positions `[0, bins]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Binning {
    lo: f64,
    scale: f64,
    bins: usize,
}

impl Binning {
    /// Bins spanning `[lo, hi]` (a constant range maps everything to bin 0).
    #[must_use]
    pub fn new(lo: f64, hi: f64, bins: usize) -> Self {
        let scale = if hi > lo { bins as f64 / (hi - lo) } else { 0.0 };
        Self { lo, scale, bins }
    }

    /// Continuous position of `v` in `[0, bins]`.
    #[inline]
    #[must_use]
    pub fn position(&self, v: f64) -> f64 {
        ((v - self.lo) * self.scale).clamp(0.0, self.bins as f64)
    }

    /// The bin of `v`.
    #[inline]
    #[must_use]
    pub fn bin(&self, v: f64) -> usize {
        (self.position(v) as usize).min(self.bins - 1)
    }
}

/// A `bins × bins` joint histogram: rows fixed bins, columns moving bins.
#[derive(Clone, Debug, PartialEq)]
pub struct JointHistogram {
    /// Bins per axis.
    pub bins: usize,
    /// Row-major counts (weights).
    pub counts: Vec<f64>,
    /// Pairs added.
    pub samples: u64,
}

/// Cubic B-spline `β³(d)`.
#[inline]
fn bspline3(d: f64) -> f64 {
    let a = d.abs();
    if a < 1.0 {
        (4.0 - 6.0 * a * a + 3.0 * a * a * a) / 6.0
    } else if a < 2.0 {
        let t = 2.0 - a;
        t * t * t / 6.0
    } else {
        0.0
    }
}

impl JointHistogram {
    /// An empty histogram.
    #[must_use]
    pub fn new(bins: usize) -> Self {
        Self { bins, counts: vec![0.0; bins * bins], samples: 0 }
    }

    /// Empties it.
    pub fn clear(&mut self) {
        self.counts.iter_mut().for_each(|c| *c = 0.0);
        self.samples = 0;
    }

    /// Adds one pair given as continuous bin positions (see [`Binning::position`]).
    #[inline]
    pub fn add(&mut self, kind: HistogramKind, f: f64, m: f64) {
        let b = self.bins;
        let row = (f as usize).min(b - 1) * b;
        match kind {
            HistogramKind::Binned | HistogramKind::PartialVolume => self.counts[row + (m as usize).min(b - 1)] += 1.0,
            HistogramKind::Parzen => {
                // Bin k's centre sits at k + ½.
                let x = m - 0.5;
                let k0 = x.floor() as isize;
                for k in k0 - 1..=k0 + 2 {
                    let wgt = bspline3(x - k as f64);
                    self.counts[row + k.clamp(0, b as isize - 1) as usize] += wgt;
                }
            }
        }
        self.samples += 1;
    }

    /// Adds weight `w` to the nearest bins of a pair (partial volume), not
    /// counting a sample: call [`Self::count_sample`] once per point.
    #[inline]
    pub fn add_weight(&mut self, f: f64, m: f64, w: f64) {
        let b = self.bins;
        self.counts[(f as usize).min(b - 1) * b + (m as usize).min(b - 1)] += w;
    }

    /// Counts one sample whose weight was added by [`Self::add_weight`].
    #[inline]
    pub fn count_sample(&mut self) {
        self.samples += 1;
    }

    /// The joint distribution (counts over their total); `None` when empty.
    #[must_use]
    pub fn distribution(&self) -> Option<Vec<f64>> {
        let total: f64 = self.counts.iter().sum();
        (total > 0.0).then(|| self.counts.iter().map(|c| c / total).collect())
    }

    /// Every entropy of the joint, by the core; `None` when empty.
    #[must_use]
    pub fn entropies(&self, base: Base) -> Option<JointEntropies> {
        let p = self.distribution()?;
        joint_entropies(&p, self.bins, self.bins, base).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parzen_weights_sum_to_one() {
        for x in [0.0, 0.3, 0.5, 7.99, 12.0] {
            let mut h = JointHistogram::new(12);
            h.add(HistogramKind::Parzen, 3.2, x);
            assert!((h.counts.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{x}");
        }
    }

    #[test]
    fn identical_images_have_mi_equal_to_entropy() {
        let mut h = JointHistogram::new(4);
        for v in [0.2, 1.5, 2.5, 3.9, 0.1, 1.1] {
            h.add(HistogramKind::Binned, v, v);
        }
        let e = h.entropies(Base::Bits).unwrap();
        assert!((e.mutual_information - e.h_x).abs() < 1e-12);
        assert!((Metric::Nmi.value(&e) - 2.0).abs() < 1e-12);
        assert!((Metric::Ecc.value(&e) - 1.0).abs() < 1e-12);
        assert!(JointHistogram::new(3).entropies(Base::Bits).is_none());
    }
}
