//! Front-to-back ray casting of a volume from a viewpoint on the sphere.
//!
//! The camera sits at `distance` (in bounding-sphere radii) along a
//! direction, looks at the centre and its square image just covers the
//! bounding sphere (a half angle of `asin(1/distance)` to the sphere's
//! tangents). A ray samples the volume every `step` voxels from where it
//! enters the box; each sample's transfer-function opacity, given per world
//! unit of length (a voxel of spacing 1, as in VTK), is corrected for the
//! step, `α = 1 − (1 − α_tf)^Δ` with `Δ` the step in world units, and the
//! sample adds `T · α` to the image,
//! `T` the transmittance in front of it. That contribution is the sample's
//! visibility (Part VI §2.2); it is shared among the eight voxels around the
//! sample by their trilinear weights, so `Σ_z vis(z|v) = Σ_rays (1 − T_end)`.
//! Rays stop when `T` falls below [`EARLY_TERMINATION`].

use glam::DVec3;

use super::{TransferFunction, Volume};
use crate::camera::Camera;
use crate::shards::Fnv;

/// Transmittance below which a ray stops (early ray termination).
pub const EARLY_TERMINATION: f64 = 1e-4;

/// Entries of the transfer-function table over the normalised scalar.
const TABLE: usize = 4096;

/// The camera of the viewpoint along `direction` at `distance` (> 1)
/// bounding-sphere radii: [`Camera::look_at`] the centre, with the z axis
/// as up (the y axis for directions within 8° of the poles), and a square
/// image that just covers the sphere of `radius` (≤ 1) about the centre, a
/// half angle of `asin(radius/distance)` to its tangents: 1 for the
/// channel's rays, less for pictures framed on what the transfer function
/// shows. Pixel `(x, y)` is the ray `Camera::direction(x + 0.5, y + 0.5)`.
///
/// # Panics
/// Never for a finite, non-zero `direction` and a finite `distance > 1`
/// (the CLI's viewpoints and `--distance`): the camera is then valid.
#[must_use]
pub fn viewpoint_camera(direction: DVec3, distance: f64, radius: f64) -> Camera {
    let d = direction.normalize();
    let up = if d.z.abs() > 0.99 { DVec3::Y } else { DVec3::Z };
    let half = (radius.clamp(1e-3, 1.0) / distance).min(1.0).asin();
    Camera::look_at(d * distance, DVec3::ZERO, up, 2.0 * half.to_degrees())
        .expect("a viewpoint outside the bounding sphere has a valid camera")
}

/// The ray through the centre of pixel `(x, y)` of a `size × size` image.
pub(crate) fn pixel_ray(camera: &Camera, x: u32, y: u32, size: u32) -> DVec3 {
    camera.direction(f64::from(x) + 0.5, f64::from(y) + 0.5, size, size)
}

/// A volume and a transfer function ready to cast: the opacity (corrected
/// for the step) and colour tabulated over the normalised scalar.
pub struct Caster<'a> {
    /// The volume.
    pub volume: &'a Volume,
    lo: f64,
    inv_range: f64,
    step: f64,
    step_voxels: f64,
    skip_below: f64,
    table: Vec<(f64, [f64; 3])>,
    /// Opacity of each voxel's own value under the transfer function
    /// (uncorrected), its importance for EVMI.
    pub voxel_opacity: Vec<f64>,
    /// Per cell (by its lowest corner, [`Volume::cell`]): whether any corner's
    /// normalised value is above the transparent range, so that a sample in
    /// it can be seen. Samples in other cells are skipped without changing
    /// any result: their trilinear value is at most their largest corner's.
    cell_active: Vec<bool>,
}

impl<'a> Caster<'a> {
    /// A caster sampling every `step_voxels` voxels (0 < step ≤ 2).
    #[must_use]
    pub fn new(volume: &'a Volume, tf: &TransferFunction, step_voxels: f64) -> Self {
        let (lo, hi) = volume.range();
        Self::with_range(volume, tf, step_voxels, (f64::from(lo), f64::from(hi)))
    }

    /// [`Caster::new`] with the scalar normalised by `range` instead of the
    /// volume's own: the frames of a time series share their range, so one
    /// transfer function means the same values in every frame.
    #[must_use]
    pub fn with_range(volume: &'a Volume, tf: &TransferFunction, step_voxels: f64, range: (f64, f64)) -> Self {
        let (lo, hi) = range;
        let inv_range = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
        let world_step = step_voxels * volume.spacing.iter().copied().fold(f64::INFINITY, f64::min);
        let table = (0..TABLE)
            .map(|k| {
                let (a, c) = tf.eval(k as f64 / (TABLE - 1) as f64);
                (1.0 - (1.0 - a.min(1.0)).powf(world_step), c)
            })
            .collect();
        let voxel_opacity = volume.data.iter().map(|&v| tf.eval((f64::from(v) - lo) * inv_range).0).collect();
        let skip_below = tf.transparent_below();
        let cell_active = active_cells(volume, |v| ((f64::from(v) - lo) * inv_range).clamp(0.0, 1.0) > skip_below);
        Self {
            cell_active,
            volume,
            lo,
            inv_range,
            step: step_voxels * volume.voxel_size(),
            step_voxels,
            skip_below,
            table,
            voxel_opacity,
        }
    }

    /// Radius of the smallest sphere about the centre holding every voxel of
    /// positive opacity (plus one voxel), at most 1.
    #[must_use]
    pub fn content_radius(&self) -> f64 {
        let v = self.volume;
        let [nx, ny, _] = v.dims;
        let r = self
            .voxel_opacity
            .iter()
            .enumerate()
            .filter(|(_, a)| **a > 0.0)
            .map(|(i, _)| v.centre(i % nx, (i / nx) % ny, i / (nx * ny)).length())
            .fold(0.0, f64::max);
        (r + 2.0 * v.voxel_size()).min(1.0)
    }

    /// Hashes in everything a channel row depends on besides the viewpoint
    /// and the image: the grid (dims, spacing, every value's bits), the
    /// scalar normalisation, the sample step and the step-corrected opacity
    /// table of the transfer function. Shards of one run agree on it.
    pub fn fingerprint(&self, h: &mut Fnv) {
        let v = self.volume;
        for d in v.dims {
            h.eat(&(d as u64).to_le_bytes());
        }
        for x in v.spacing.iter().chain([&self.lo, &self.inv_range, &self.step, &self.skip_below]) {
            h.eat(&x.to_bits().to_le_bytes());
        }
        for x in &v.data {
            h.eat(&x.to_bits().to_le_bytes());
        }
        for (a, _) in &self.table {
            h.eat(&a.to_bits().to_le_bytes());
        }
    }

    /// Sample step in voxels.
    #[must_use]
    pub fn step_voxels(&self) -> f64 {
        self.step_voxels
    }

    fn lookup(&self, value: f64) -> Option<(f64, [f64; 3])> {
        let s = ((value - self.lo) * self.inv_range).clamp(0.0, 1.0);
        if s <= self.skip_below {
            return None;
        }
        let k = (s * (TABLE - 1) as f64).round() as usize;
        Some(self.table[k])
    }

    /// Where a ray from `o` along `d` is inside the box: `(t0, t1)`.
    pub(crate) fn clip(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let h = self.volume.box_half();
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            if d[a].abs() < 1e-300 {
                if o[a].abs() > h[a] {
                    return None;
                }
                continue;
            }
            let (x, y) = ((-h[a] - o[a]) / d[a], (h[a] - o[a]) / d[a]);
            t0 = t0.max(x.min(y));
            t1 = t1.min(x.max(y));
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// Marches one ray, calling `visit(corners, contribution, colour, grid
    /// point)` for every sample with positive opacity; returns the
    /// transmittance left.
    fn march(&self, o: DVec3, d: DVec3, visit: impl FnMut(&[(usize, f64); 8], f64, [f64; 3], DVec3)) -> f64 {
        let Some((t0, t1)) = self.clip(o, d) else { return 1.0 };
        self.march_from(o, d, self.first_sample(t0), t1, 1.0, visit)
    }

    /// The first sample's `t` of a ray whose box span is `(t0, _)`.
    pub(crate) fn first_sample(&self, t0: f64) -> f64 {
        t0 + 0.5 * self.step
    }

    /// Sample step in normalised units.
    pub(crate) fn step(&self) -> f64 {
        self.step
    }

    /// [`Caster::march`] from the sample at `t` (before `t1`) with
    /// `transmittance` in front of it: where a device that ran out of room
    /// for a ray's samples hands the rest of the ray back.
    pub(crate) fn march_from(
        &self,
        o: DVec3,
        d: DVec3,
        mut t: f64,
        t1: f64,
        mut transmittance: f64,
        mut visit: impl FnMut(&[(usize, f64); 8], f64, [f64; 3], DVec3),
    ) -> f64 {
        while t < t1 {
            let g = self.volume.grid_coords(o + d * t);
            if !self.cell_active[self.volume.cell(g)] {
                t += self.step;
                continue;
            }
            let corners = self.volume.corners(g);
            let value: f64 = corners.iter().map(|&(i, w)| w * f64::from(self.volume.data[i])).sum();
            if let Some((alpha, colour)) = self.lookup(value)
                && alpha > 0.0
            {
                visit(&corners, transmittance * alpha, colour, g);
                transmittance *= 1.0 - alpha;
                if transmittance < EARLY_TERMINATION {
                    break;
                }
            }
            t += self.step;
        }
        transmittance
    }

    /// Shares a sample's contribution `c` at grid point `g` among its eight
    /// voxels, in [`Volume::corners`] order, as [`Caster::visibility_with`]
    /// does: `add(voxel, c · w)`.
    pub(crate) fn deposit(&self, g: DVec3, c: f64, mut add: impl FnMut(usize, f64)) {
        for (i, w) in self.volume.corners(g) {
            add(i, c * w);
        }
    }

    /// The transfer function's step-corrected opacity table over the
    /// normalised scalar, and the scalar's normalisation `(lo, 1/range)`
    /// and transparent range (`s ≤ skip_below` is skipped).
    pub(crate) fn opacity_table(&self) -> (Vec<f64>, f64, f64, f64) {
        (self.table.iter().map(|e| e.0).collect(), self.lo, self.inv_range, self.skip_below)
    }

    /// Whether each cell (by lowest corner) can be seen.
    pub(crate) fn active_cells(&self) -> &[bool] {
        &self.cell_active
    }

    /// Adds every voxel's visibility from `view` over a `size × size` image
    /// to `vis` (one entry per voxel); returns the rays' total transmittance
    /// left (the background's share).
    pub fn visibility(&self, view: &Camera, size: u32, vis: &mut [f64]) -> f64 {
        self.visibility_with(view, size, |i, x| vis[i] += x)
    }

    /// [`Caster::visibility`] through `add(voxel, contribution)`, called for
    /// the eight corners of every sample in ray order (pixels row by row), so
    /// a caller may keep the sums wherever it likes (the channel keeps them
    /// over [`Caster::receiving_voxels`] only); returns the background's share.
    pub fn visibility_with(&self, view: &Camera, size: u32, mut add: impl FnMut(usize, f64)) -> f64 {
        let mut background = 0.0;
        for y in 0..size {
            for x in 0..size {
                let d = pixel_ray(view, x, y, size);
                background += self.march(view.eye, d, |corners, c, _, _| {
                    for &(i, w) in corners {
                        add(i, c * w);
                    }
                });
            }
        }
        background
    }

    /// The voxels that can receive visibility, in increasing index: the
    /// corners of the cells a ray samples ([`Volume::corners`] of a point in
    /// an active cell). Any other voxel's `vis(z|v)` is 0 from every
    /// viewpoint, by construction of [`Caster::visibility`].
    #[must_use]
    pub fn receiving_voxels(&self) -> Vec<u32> {
        let [nx, ny, nz] = self.volume.dims;
        let mut m = self.cell_active.clone();
        // Dilate towards higher indices, one voxel per axis (a cell's far
        // corners); descending order reads m[i - stride] before it is updated.
        for (stride, n) in [(1, nx), (nx, ny), (nx * ny, nz)] {
            for i in (0..m.len()).rev() {
                if (i / stride) % n > 0 && m[i - stride] {
                    m[i] = true;
                }
            }
        }
        m.iter().enumerate().filter(|&(_, &x)| x).map(|(i, _)| i as u32).collect()
    }

    /// An RGB picture from `view`, `size × size`, with headlight shading from
    /// the gradient; `tint`, when given, replaces the transfer function's
    /// colour by a per-voxel colour (sampled trilinearly). Background
    /// `[24, 24, 28]`.
    #[must_use]
    pub fn render(&self, view: &Camera, size: u32, tint: Option<&[[f32; 3]]>) -> Vec<[u8; 3]> {
        use rayon::prelude::*;
        (0..size * size)
            .into_par_iter()
            .map(|k| {
                let d = pixel_ray(view, k % size, k / size, size);
                let mut acc = [0.0f64; 3];
                let t = self.march(view.eye, d, |corners, c, colour, g| {
                    let colour = match tint {
                        Some(t) => {
                            let mut m = [0.0; 3];
                            for &(i, w) in corners {
                                for (a, mc) in m.iter_mut().enumerate() {
                                    *mc += w * f64::from(t[i][a]);
                                }
                            }
                            m
                        }
                        None => colour,
                    };
                    let grad = self.volume.gradient(g);
                    let shade = if grad.length() > 1e-9 { 0.35 + 0.65 * grad.normalize().dot(d).abs() } else { 1.0 };
                    for a in 0..3 {
                        acc[a] += c * colour[a] * shade;
                    }
                });
                let bg = [24.0f64, 24.0, 28.0].map(|c| (c / 255.0).powf(2.2));
                // A field shown as a tint: the ray's mean tint, with opacity
                // boosted threefold so faint volumes still show their colours.
                let (cover, t) = if tint.is_some() && t < 1.0 {
                    let a = (3.0 * (1.0 - t)).min(1.0);
                    (a / (1.0 - t), 1.0 - a)
                } else {
                    (1.0, t)
                };
                let px =
                    |a: usize| ((acc[a] * cover + t * bg[a]).clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8;
                [px(0), px(1), px(2)]
            })
            .collect()
    }
}

/// Cells (by lowest corner) with a corner where `active` holds: a
/// separable dilation of the active voxels towards lower indices, one voxel
/// per axis (the corners of [`Volume::corners`], clamped at the far faces).
fn active_cells(v: &Volume, active: impl Fn(f32) -> bool) -> Vec<bool> {
    let [nx, ny, nz] = v.dims;
    let mut m: Vec<bool> = v.data.iter().map(|&x| active(x)).collect();
    for (stride, n) in [(1, nx), (nx, ny), (nx * ny, nz)] {
        for i in 0..m.len() {
            // Ascending order reads m[i + stride] before it is updated.
            if (i / stride) % n + 1 < n && m[i + stride] {
                m[i] = true;
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::builtin::built_in;

    #[test]
    fn opaque_cube_visibility_is_the_covered_image() {
        let v = built_in("cube:16").unwrap();
        let tf = TransferFunction::preset("step").unwrap();
        let c = Caster::new(&v, &tf, 0.5);
        let view = viewpoint_camera(DVec3::new(0.3, 0.5, 0.8), 3.0, 1.0);
        let mut vis = vec![0.0; v.voxels()];
        let size = 32;
        let bg = c.visibility(&view, size, &mut vis);
        let total: f64 = vis.iter().sum();
        // Every ray either hits the opaque cube (visibility ~1) or not.
        assert!((total + bg - f64::from(size * size)).abs() < 1e-6 * f64::from(size * size));
        assert!(total > 10.0 && bg > 10.0);
        // Only voxels at the cube's surface (value-1 cells near the faces) are seen.
        let inner = v.index(8, 8, 8);
        assert_eq!(vis[inner], 0.0);
    }

    #[test]
    fn skipping_empty_cells_changes_nothing() {
        for spec in ["phantom:12", "hydrogen:3,2,0,12"] {
            let v = built_in(spec).unwrap();
            let tf = TransferFunction::preset("ramp").unwrap();
            let fast = Caster::new(&v, &tf, 0.5);
            let mut every = Caster::new(&v, &tf, 0.5);
            every.cell_active.iter_mut().for_each(|c| *c = true);
            assert!(fast.cell_active.iter().any(|c| !c), "{spec}: nothing to skip");
            for d in [DVec3::new(0.3, 0.5, 0.8), DVec3::X, DVec3::new(-1.0, 2.0, -0.5)] {
                let view = viewpoint_camera(d, 3.0, 1.0);
                let (mut a, mut b) = (vec![0.0; v.voxels()], vec![0.0; v.voxels()]);
                let ba = fast.visibility(&view, 24, &mut a);
                let bb = every.visibility(&view, 24, &mut b);
                assert_eq!((a, ba), (b, bb), "{spec} {d}");
            }
        }
    }

    #[test]
    fn view_frames_are_orthonormal() {
        for d in [DVec3::Z, DVec3::new(1.0, 2.0, 3.0), -DVec3::Z, DVec3::X] {
            let v = viewpoint_camera(d, 3.0, 1.0);
            assert!(v.forward.dot(v.right).abs() < 1e-12 && v.up.dot(v.forward).abs() < 1e-12);
            assert!((pixel_ray(&v, 16, 16, 33) - v.forward).length() < 1e-12);
            // The image's edge rays graze the bounding sphere.
            let edge = pixel_ray(&v, 0, 16, 33).angle_between(v.forward);
            let half = (1.0f64 / 3.0).asin();
            assert!((edge - half).abs() < half / 33.0 + 1e-9, "{edge} {half}");
        }
    }
}
