//! Choosing and opening a backend: the names `--backend` accepts, the
//! errors a backend reports, and [`open`], which builds the chosen
//! [`Tracer`] over a prepared scene.
//!
//! Every engine (scene visibility, viewpoints, rendering, radiosity) is
//! written against the [`Tracer`] seam and never names a backend; this
//! module is the one place that maps a name to an implementation.

use std::fmt;
use std::str::FromStr;

use crate::tracer::{CpuTracer, Prepared, ReferenceTracer, Tracer};

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

/// Why a backend could not trace.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BackendError {
    /// The backend is not available here (no device, no loader, no driver).
    Unavailable {
        /// Backend name.
        backend: &'static str,
        /// Why, with the fix where there is one.
        reason: String,
    },
    /// The scene or batch does not fit the backend's limits (buffer sizes).
    TooLarge {
        /// Backend name.
        backend: &'static str,
        /// What did not fit, with the limit and the way out.
        reason: String,
    },
    /// Device memory ran out.
    OutOfMemory,
    /// The device was lost.
    DeviceLost,
}

impl fmt::Display for BackendError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BackendError::Unavailable { backend, reason } => {
                write!(f, "the {backend} backend is unavailable: {reason}")
            }
            BackendError::TooLarge { backend, reason } => write!(f, "too large for the {backend} backend: {reason}"),
            BackendError::OutOfMemory => write!(f, "out of device memory"),
            BackendError::DeviceLost => write!(f, "device lost"),
        }
    }
}

impl std::error::Error for BackendError {}

/// Opens a backend on a prepared scene.
///
/// # Errors
/// [`BackendError::Unavailable`] when Vulkan has no loader, driver or device.
pub fn open(choice: BackendChoice, scene: &Prepared) -> Result<Box<dyn Tracer>, BackendError> {
    match choice {
        BackendChoice::Cpu => Ok(Box::new(CpuTracer::new(scene))),
        BackendChoice::Reference => Ok(Box::new(ReferenceTracer::new(scene))),
        BackendChoice::Vulkan => Ok(Box::new(crate::vulkan::tracer::VulkanTracer::new(scene)?)),
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
