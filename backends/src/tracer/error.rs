//! The errors a backend reports, below every backend so that each can name
//! them ([`crate::backend`] chooses among the backends and re-exports it).

use std::fmt;

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
