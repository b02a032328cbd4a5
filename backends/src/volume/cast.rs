//! The volume-casting seam: what the channel over voxels asks of a ray
//! caster. [`crate::backend::open_volume`] maps a backend choice to an
//! implementation, in the one registry that opens the tracing seam too.
//!
//! * `cpu`: [`Caster`] itself, rayon over viewpoints in the caller;
//! * `vulkan`: [`crate::vulkan::volume::VulkanVolumeCaster`], a compute
//!   kernel that marches the rays on the device and hands each ray's samples
//!   back, which the host shares among voxels in ray order, so the rows are
//!   the CPU's bit for bit.
//!
//! The pictures are always cast on the CPU: they are a few rays next to the
//! channel's `N_v · size²`.

use crate::backend::BackendError;
use crate::camera::Camera;

use super::raycast::Caster;

/// A volume ray caster the channel over voxels (Part VI §2.2) can use.
pub trait VolumeCaster: Sync {
    /// The backend's name, as `--backend` takes it.
    fn name(&self) -> &'static str;

    /// The caster whose volume, transfer function and step are cast.
    fn caster(&self) -> &Caster<'_>;

    /// Adds the visibility `vis(z|v)` of every voxel from `view` over a
    /// `size × size` image to `row[slot[z]]` (`slot` maps each voxel to a
    /// place in `row`: every voxel that can receive visibility,
    /// [`Caster::receiving_voxels`], has one), in ray order (pixels row by
    /// row, samples front to back, a sample's eight voxels in
    /// [`crate::volume::Volume::corners`] order), as [`Caster::visibility`]
    /// adds them; returns the rays' total transmittance left.
    ///
    /// # Errors
    /// Device failures.
    fn visibility_row(&self, view: &Camera, size: u32, slot: &[u32], row: &mut [f64]) -> Result<f64, BackendError>;

    /// Rays a device handed back to the host to finish (more samples than
    /// it keeps per ray); 0 on the CPU.
    fn rays_finished_on_host(&self) -> u64 {
        0
    }
}

impl VolumeCaster for Caster<'_> {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn caster(&self) -> &Caster<'_> {
        self
    }

    fn visibility_row(&self, view: &Camera, size: u32, slot: &[u32], row: &mut [f64]) -> Result<f64, BackendError> {
        Ok(self.visibility_with(view, size, |z, x| row[slot[z] as usize] += x))
    }
}

impl<T: VolumeCaster + ?Sized> VolumeCaster for &T {
    fn name(&self) -> &'static str {
        (**self).name()
    }

    fn caster(&self) -> &Caster<'_> {
        (**self).caster()
    }

    fn visibility_row(&self, view: &Camera, size: u32, slot: &[u32], row: &mut [f64]) -> Result<f64, BackendError> {
        (**self).visibility_row(view, size, slot, row)
    }

    fn rays_finished_on_host(&self) -> u64 {
        (**self).rays_finished_on_host()
    }
}
