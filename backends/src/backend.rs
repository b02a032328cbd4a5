//! Choosing and opening a backend: the names a backend goes by, the errors
//! a backend reports, [`open`], which builds the chosen [`Tracer`] over a
//! prepared scene, and [`open_volume`], the chosen [`VolumeCaster`] over a
//! volume: the one registry of backends, above the CPU and Vulkan ones.
//!
//! Every engine (scene visibility, viewpoints, rendering, radiosity) is
//! written against the [`Tracer`] seam and never names a backend; this
//! module is the one place that maps a name to an implementation.

use std::fmt;
use std::str::FromStr;

pub use crate::tracer::BackendError;
use crate::tracer::{CpuTracer, Prepared, ReferenceTracer, Tracer};
use crate::volume::cast::VolumeCaster;
use crate::volume::raycast::Caster;

/// Which backend to open.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BackendChoice {
    /// rayon + obvhs on the CPU.
    Cpu,
    /// The brute-force reference tracer (test oracle; O(lines × triangles)).
    Reference,
    /// Vulkan compute (ash + naga kernels), on any Vulkan 1.2 device with f64 shaders.
    Vulkan,
}

impl BackendChoice {
    /// Every choice, in the order help texts list them.
    pub const ALL: [BackendChoice; 3] = [BackendChoice::Cpu, BackendChoice::Vulkan, BackendChoice::Reference];

    /// The name `--backend` takes and JSON reports.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            BackendChoice::Cpu => "cpu",
            BackendChoice::Reference => "reference",
            BackendChoice::Vulkan => "vulkan",
        }
    }
}

impl fmt::Display for BackendChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown backend name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownBackend(pub String);

impl fmt::Display for UnknownBackend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown backend {:?}: expected cpu, vulkan or reference", self.0)
    }
}

impl std::error::Error for UnknownBackend {}

impl FromStr for BackendChoice {
    type Err = UnknownBackend;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        BackendChoice::ALL.into_iter().find(|c| c.name() == s).ok_or_else(|| UnknownBackend(s.to_string()))
    }
}

/// Opens a backend on a prepared scene.
///
/// # Errors
/// [`BackendError::Unavailable`] when Vulkan has no loader, driver or device;
/// [`BackendError::TooLarge`] when the address space for the BVH build
/// cannot be reserved ([`crate::memory::probe`]).
pub fn open(choice: BackendChoice, scene: &Prepared) -> Result<Box<dyn Tracer>, BackendError> {
    if choice != BackendChoice::Reference {
        // Both build an obvhs BVH, which panics if an allocation fails: its
        // peak address space is claimed (and given back) first.
        let n = scene.triangles.len() as u64;
        crate::memory::probe(
            || format!("the BVH over {n} triangles"),
            n.saturating_mul(crate::memory::BVH_BUILD_BYTES_PER_TRIANGLE),
        )
        .map_err(|e| BackendError::TooLarge { backend: choice.name(), reason: e.to_string() })?;
    }
    match choice {
        BackendChoice::Cpu => Ok(Box::new(CpuTracer::new(scene))),
        BackendChoice::Reference => Ok(Box::new(ReferenceTracer::new(scene))),
        BackendChoice::Vulkan => Ok(Box::new(crate::vulkan::tracer::VulkanTracer::new(scene)?)),
    }
}

/// Bytes a backend allocates besides the channel for views of `rays` rays,
/// before it allocates them: 0 on the CPU; the device's buffers on Vulkan
/// ([`crate::vulkan::volume::device_memory`], host memory too on lavapipe).
#[must_use]
pub fn volume_memory(choice: BackendChoice, caster: &Caster<'_>, rays: u64) -> u64 {
    match choice {
        BackendChoice::Vulkan => crate::vulkan::volume::device_memory(caster, rayon::current_num_threads(), rays),
        BackendChoice::Cpu | BackendChoice::Reference => 0,
    }
}

/// Opens a volume caster ([`VolumeCaster`]) over `caster`.
///
/// # Errors
/// [`BackendError::Unavailable`] when Vulkan has no loader, driver or
/// device, or for `reference` (a triangle tracer: volumes have none);
/// [`BackendError::TooLarge`] when the volume exceeds the device's buffers.
pub fn open_volume<'a>(
    choice: BackendChoice,
    caster: &'a Caster<'a>,
) -> Result<Box<dyn VolumeCaster + 'a>, BackendError> {
    match choice {
        BackendChoice::Cpu => Ok(Box::new(caster)),
        BackendChoice::Vulkan => Ok(Box::new(crate::vulkan::volume::VulkanVolumeCaster::new(caster)?)),
        BackendChoice::Reference => Err(BackendError::Unavailable {
            backend: "reference",
            reason: "it traces triangles; volumes are cast by the cpu or vulkan backend".into(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for c in BackendChoice::ALL {
            assert_eq!(c.name().parse::<BackendChoice>(), Ok(c));
        }
        let e = "gpu".parse::<BackendChoice>().unwrap_err();
        assert_eq!(e.to_string(), "unknown backend \"gpu\": expected cpu, vulkan or reference");
    }
}
