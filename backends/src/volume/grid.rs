//! The scalar grid: values at voxel centres, `x` fastest, with a spacing
//! per axis, placed so that the box's bounding sphere is the unit sphere
//! around the origin (the viewpoint sphere's frame, as for meshes).

use glam::DVec3;

use super::VolumeError;

/// Largest number of voxels accepted (512³: 0.5 GiB of f32 values).
pub const MAX_VOXELS: usize = 512 * 512 * 512;

/// A scalar volume with optional labels (for objects of a phantom).
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// A name for reports.
    pub name: String,
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// Voxel spacing along x, y, z (any unit; only ratios matter).
    pub spacing: [f64; 3],
    /// Values, `x` fastest: `data[x + nx (y + ny z)]`, all finite.
    pub data: Vec<f32>,
    /// Object label of each voxel (0 = none), if the volume has objects.
    pub labels: Option<Vec<u8>>,
    /// Names of labels `1..`, if any.
    pub label_names: Vec<String>,
    /// Fuzzy object membership `p(o|z)` when the objects' boundaries are
    /// fuzzy (then `labels` is each voxel centre's crisp label); `None`:
    /// the crisp `labels`.
    pub membership: Option<super::objects::Membership>,
}

impl Volume {
    /// A volume from values, checked: positive dims and spacing, matching
    /// length, at most [`MAX_VOXELS`], every value finite.
    ///
    /// # Errors
    /// A one-line reason.
    pub fn new(
        name: impl Into<String>,
        dims: [usize; 3],
        spacing: [f64; 3],
        data: Vec<f32>,
    ) -> Result<Self, VolumeError> {
        let n = checked_voxels(dims)?;
        if spacing.iter().any(|s| !s.is_finite() || *s <= 0.0) {
            return Err(VolumeError::new(format!("spacing {spacing:?}: every spacing must be finite and > 0")));
        }
        if data.len() != n {
            return Err(VolumeError::new(format!(
                "{} values for {}x{}x{} voxels",
                data.len(),
                dims[0],
                dims[1],
                dims[2]
            )));
        }
        if let Some(i) = data.iter().position(|v| !v.is_finite()) {
            let [nx, ny, _] = dims;
            return Err(VolumeError::new(format!(
                "voxel ({}, {}, {}) is not finite ({})",
                i % nx,
                (i / nx) % ny,
                i / (nx * ny),
                data[i]
            )));
        }
        Ok(Self { name: name.into(), dims, spacing, data, labels: None, label_names: Vec::new(), membership: None })
    }

    /// Voxels.
    #[must_use]
    pub fn voxels(&self) -> usize {
        self.data.len()
    }

    /// Smallest and largest value.
    #[must_use]
    pub fn range(&self) -> (f32, f32) {
        self.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)))
    }

    /// Half extents of the box in world units (before normalisation).
    fn half_extents(&self) -> DVec3 {
        DVec3::new(
            self.dims[0] as f64 * self.spacing[0],
            self.dims[1] as f64 * self.spacing[1],
            self.dims[2] as f64 * self.spacing[2],
        ) * 0.5
    }

    /// World-to-normalised scale: the box's half diagonal becomes 1.
    #[must_use]
    pub fn scale(&self) -> f64 {
        1.0 / self.half_extents().length()
    }

    /// Half extents of the box in normalised coordinates (length 1).
    #[must_use]
    pub fn box_half(&self) -> DVec3 {
        self.half_extents() * self.scale()
    }

    /// Size of the smallest voxel edge in normalised coordinates.
    #[must_use]
    pub fn voxel_size(&self) -> f64 {
        self.spacing.iter().copied().fold(f64::INFINITY, f64::min) * self.scale()
    }

    /// Continuous voxel coordinates of a normalised point (voxel centres at
    /// integers).
    #[must_use]
    pub fn grid_coords(&self, p: DVec3) -> DVec3 {
        let s = self.scale();
        DVec3::new(
            p.x / (s * self.spacing[0]) + self.dims[0] as f64 * 0.5 - 0.5,
            p.y / (s * self.spacing[1]) + self.dims[1] as f64 * 0.5 - 0.5,
            p.z / (s * self.spacing[2]) + self.dims[2] as f64 * 0.5 - 0.5,
        )
    }

    /// Normalised position of the centre of voxel `(i, j, k)`.
    #[must_use]
    pub fn centre(&self, i: usize, j: usize, k: usize) -> DVec3 {
        let s = self.scale();
        DVec3::new(
            (i as f64 + 0.5 - self.dims[0] as f64 * 0.5) * self.spacing[0] * s,
            (j as f64 + 0.5 - self.dims[1] as f64 * 0.5) * self.spacing[1] * s,
            (k as f64 + 0.5 - self.dims[2] as f64 * 0.5) * self.spacing[2] * s,
        )
    }

    /// Index of voxel `(i, j, k)`.
    #[must_use]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Index of the cell's lowest corner voxel used by [`Volume::corners`]
    /// at grid point `g` (its other corners are one voxel further along
    /// each axis, clamped to the grid).
    #[must_use]
    pub fn cell(&self, g: DVec3) -> usize {
        let mut base = [0usize; 3];
        for (a, b) in base.iter_mut().enumerate() {
            let n = self.dims[a];
            *b = (g[a].clamp(0.0, (n - 1) as f64).floor() as usize).min(n.saturating_sub(2));
        }
        self.index(base[0], base[1], base[2])
    }

    /// The eight voxels around grid point `g` (clamped to the grid) and their
    /// trilinear weights (summing to 1).
    #[must_use]
    pub fn corners(&self, g: DVec3) -> [(usize, f64); 8] {
        let mut base = [0usize; 3];
        let mut frac = [0.0f64; 3];
        for a in 0..3 {
            let n = self.dims[a];
            let x = g[a].clamp(0.0, (n - 1) as f64);
            let i = (x.floor() as usize).min(n.saturating_sub(2));
            base[a] = i;
            frac[a] = if n > 1 { x - i as f64 } else { 0.0 };
        }
        let mut out = [(0usize, 0.0f64); 8];
        for (c, o) in out.iter_mut().enumerate() {
            let (dx, dy, dz) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
            let idx = |a: usize, d: usize| (base[a] + d).min(self.dims[a] - 1);
            let w = [(1.0 - frac[0], frac[0]), (1.0 - frac[1], frac[1]), (1.0 - frac[2], frac[2])];
            let wx = if dx == 0 { w[0].0 } else { w[0].1 };
            let wy = if dy == 0 { w[1].0 } else { w[1].1 };
            let wz = if dz == 0 { w[2].0 } else { w[2].1 };
            *o = (self.index(idx(0, dx), idx(1, dy), idx(2, dz)), wx * wy * wz);
        }
        out
    }

    /// Trilinear value at grid point `g` (clamped to the grid).
    #[must_use]
    pub fn sample(&self, g: DVec3) -> f64 {
        self.corners(g).iter().map(|&(i, w)| w * f64::from(self.data[i])).sum()
    }

    /// Central-difference gradient at grid point `g` (grid units).
    #[must_use]
    pub fn gradient(&self, g: DVec3) -> DVec3 {
        let d = |e: DVec3| self.sample(g + e) - self.sample(g - e);
        DVec3::new(d(DVec3::X), d(DVec3::Y), d(DVec3::Z)) * 0.5
    }
}

/// `nx · ny · nz`, checked against [`MAX_VOXELS`] and for zero sizes.
///
/// # Errors
/// A one-line reason.
pub fn checked_voxels(dims: [usize; 3]) -> Result<usize, VolumeError> {
    if dims.contains(&0) {
        return Err(VolumeError::new(format!("dims {}x{}x{}: every size must be >= 1", dims[0], dims[1], dims[2])));
    }
    let n = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
    match n {
        Some(n) if n <= MAX_VOXELS => Ok(n),
        _ => Err(VolumeError::new(format!(
            "dims {}x{}x{}: more than {MAX_VOXELS} voxels (512^3)",
            dims[0], dims[1], dims[2]
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_interpolate_and_sum_to_one() {
        let data: Vec<f32> = (0..27).map(|i| i as f32).collect();
        let v = Volume::new("t", [3, 3, 3], [1.0; 3], data).unwrap();
        let g = DVec3::new(0.25, 1.5, 1.0);
        let s: f64 = v.corners(g).iter().map(|c| c.1).sum();
        assert!((s - 1.0).abs() < 1e-12);
        // The field is linear, i = x + 3y + 9z: trilinear is exact.
        assert!((v.sample(g) - (0.25 + 4.5 + 9.0)).abs() < 1e-12);
        // Centres map to integer grid coordinates.
        let c = v.grid_coords(v.centre(2, 0, 1));
        assert!((c - DVec3::new(2.0, 0.0, 1.0)).length() < 1e-12);
        assert!((v.box_half().length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_volumes_are_refused() {
        assert!(Volume::new("t", [2, 2, 2], [1.0; 3], vec![0.0; 7]).is_err());
        assert!(Volume::new("t", [0, 2, 2], [1.0; 3], vec![]).is_err());
        assert!(Volume::new("t", [1, 1, 1], [0.0, 1.0, 1.0], vec![0.0]).is_err());
        let e = Volume::new("t", [2, 1, 1], [1.0; 3], vec![0.0, f32::NAN]).unwrap_err();
        assert!(e.0.contains("(1, 0, 0)"), "{e}");
        assert!(checked_voxels([usize::MAX, 2, 1]).is_err());
    }
}
