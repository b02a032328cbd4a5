//! Scalar volumes for 3D registration: storage, Gaussian smoothing (the
//! same separable passes as [`super::Gray`]), shrinking and trilinear samples.

use super::gray::{range_of, smooth_grid};

/// A scalar volume, `x` fastest: `data[(z·ny + y)·nx + x]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Gray3 {
    /// Voxels along `x`, `y`, `z`.
    pub dims: [usize; 3],
    /// Voxel edge lengths along `x`, `y`, `z` (physical units, e.g. mm).
    pub spacing: [f64; 3],
    /// Samples.
    pub data: Vec<f32>,
}

impl Gray3 {
    /// A volume of zeros.
    #[must_use]
    pub fn new(dims: [usize; 3], spacing: [f64; 3]) -> Self {
        Self { dims, spacing, data: vec![0.0; dims[0] * dims[1] * dims[2]] }
    }

    /// The sample at voxel `(x, y, z)`.
    #[inline]
    #[must_use]
    pub fn at(&self, x: usize, y: usize, z: usize) -> f32 {
        self.data[(z * self.dims[1] + y) * self.dims[0] + x]
    }

    /// Smallest and largest sample (`(0, 0)` when empty).
    #[must_use]
    pub fn range(&self) -> (f32, f32) {
        range_of(&self.data)
    }

    /// The volume's centre in physical coordinates (voxel `i` at `i·spacing`).
    #[must_use]
    pub fn centre(&self) -> [f64; 3] {
        core::array::from_fn(|a| (self.dims[a] as f64 - 1.0) / 2.0 * self.spacing[a])
    }

    /// The eight voxels around continuous voxel coordinates `p` with their
    /// trilinear weights (summing to 1); `None` outside the volume's extent
    /// `[−½, n − ½)` on any axis (ITK's `IsInsideBuffer`: a voxel is a cube
    /// around its centre), within which `p` is clamped to the centres
    /// `[0, n − 1]`. With the centres as the limit, the smallest rotation put
    /// half of every face outside, and MI, which rises as background leaves
    /// the overlap, drew a volume registered onto itself off the identity.
    #[inline]
    #[must_use]
    pub fn neighbours(&self, p: [f64; 3]) -> Option<[(f32, f64); 8]> {
        let d = self.dims;
        if !(0..3).all(|a| p[a] >= -0.5 && p[a] < d[a] as f64 - 0.5) {
            return None;
        }
        let p: [f64; 3] = core::array::from_fn(|a| p[a].clamp(0.0, (d[a] - 1) as f64));
        let i0: [usize; 3] = core::array::from_fn(|a| p[a].floor() as usize);
        let i1: [usize; 3] = core::array::from_fn(|a| (i0[a] + 1).min(d[a] - 1));
        let f: [f64; 3] = core::array::from_fn(|a| p[a] - i0[a] as f64);
        let (sx, sxy) = (d[0], d[0] * d[1]);
        let idx = |x: usize, y: usize, z: usize| self.data[z * sxy + y * sx + x];
        let (gx, gy, gz) = (1.0 - f[0], 1.0 - f[1], 1.0 - f[2]);
        Some([
            (idx(i0[0], i0[1], i0[2]), gx * gy * gz),
            (idx(i1[0], i0[1], i0[2]), f[0] * gy * gz),
            (idx(i0[0], i1[1], i0[2]), gx * f[1] * gz),
            (idx(i1[0], i1[1], i0[2]), f[0] * f[1] * gz),
            (idx(i0[0], i0[1], i1[2]), gx * gy * f[2]),
            (idx(i1[0], i0[1], i1[2]), f[0] * gy * f[2]),
            (idx(i0[0], i1[1], i1[2]), gx * f[1] * f[2]),
            (idx(i1[0], i1[1], i1[2]), f[0] * f[1] * f[2]),
        ])
    }

    /// Trilinear sample at continuous voxel coordinates (voxel centres at
    /// integers); `None` outside the volume's extent, as [`Self::neighbours`].
    #[inline]
    #[must_use]
    pub fn trilinear(&self, p: [f64; 3]) -> Option<f64> {
        self.neighbours(p).map(|nb| nb.iter().map(|&(v, w)| f64::from(v) * w).sum())
    }

    /// Separable Gaussian smoothing with standard deviation `sigma` voxels
    /// on every axis (kernel radius `⌈3σ⌉`, edges clamped); `sigma ≤ 0` copies.
    #[must_use]
    pub fn smoothed(&self, sigma: f64) -> Self {
        Self { dims: self.dims, spacing: self.spacing, data: smooth_grid(&self.data, &self.dims, sigma) }
    }

    /// Shrinks every axis by an integer `factor` (at least one voxel each):
    /// output voxel `i` is the trilinear sample at `(i + ½)·f − ½`, the
    /// pyramid's convention of [`super::Gray::shrunk`]; the spacing grows by `f`.
    #[must_use]
    pub fn shrunk(&self, factor: usize) -> Self {
        if factor <= 1 {
            return self.clone();
        }
        let f = factor as f64;
        let dims: [usize; 3] = core::array::from_fn(|a| (self.dims[a] / factor).max(1));
        let mut out = Self::new(dims, core::array::from_fn(|a| self.spacing[a] * f));
        let mut k = 0;
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let p: [f64; 3] = core::array::from_fn(|a| {
                        let i = [x, y, z][a] as f64;
                        ((i + 0.5) * f - 0.5).min((self.dims[a] - 1) as f64)
                    });
                    out.data[k] = self.trilinear(p).unwrap_or(0.0) as f32;
                    k += 1;
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trilinear_is_exact_on_ramps_and_smoothing_keeps_constants() {
        let mut g = Gray3::new([5, 4, 3], [1.0, 2.0, 0.5]);
        for z in 0..3 {
            for y in 0..4 {
                for x in 0..5 {
                    g.data[(z * 4 + y) * 5 + x] = (2 * x + 3 * y + 5 * z) as f32;
                }
            }
        }
        assert!((g.trilinear([1.25, 2.5, 0.5]).unwrap() - (2.5 + 7.5 + 2.5)).abs() < 1e-9);
        assert!(g.trilinear([0.0, 0.0, 2.5]).is_none() && g.trilinear([-0.51, 0.0, 0.0]).is_none());
        assert_eq!(g.trilinear([4.3, -0.2, 2.0]), g.trilinear([4.0, 0.0, 2.0]));
        let nb = g.neighbours([3.3, 0.2, 1.7]).unwrap();
        assert!((nb.iter().map(|v| v.1).sum::<f64>() - 1.0).abs() < 1e-12);
        let s = g.shrunk(2);
        assert_eq!((s.dims, s.spacing), ([2, 2, 1], [2.0, 4.0, 1.0]));
        let mut c = Gray3::new([6, 5, 4], [1.0; 3]);
        c.data.iter_mut().for_each(|v| *v = 0.25);
        assert!(c.smoothed(1.5).data.iter().all(|v| (v - 0.25).abs() < 1e-6));
        let mut d = Gray3::new([15, 15, 15], [1.0; 3]);
        d.data[(7 * 15 + 7) * 15 + 7] = 1.0;
        assert!((d.smoothed(1.5).data.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    }
}
