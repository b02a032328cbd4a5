//! View selection for volume data (Part VI): the viewpoint channel of Part V
//! carried from polygons to voxels.
//!
//! A ray caster ([`raycast`]) composites a scalar grid ([`Volume`]) front to
//! back through a transfer function ([`transfer`]); the opacity each sample
//! adds to the image, `T · α` (its *visibility*, Part VI §2.2 after Bordoloi and Shen 2005),
//! is shared among the eight voxels around it by their trilinear weights.
//! Summed over the rays of viewpoint `v`, these give the row `vis(z|v)` of
//! the channel `V → Z` over voxels ([`channel`]), stored in the sparse
//! [`crate::viewpoint::ViewpointChannel`] with voxels in place of polygons,
//! so every measure is the viewpoint code's and the core's:
//! `p(z|v) = vis(z|v)/Σ_z vis(z|v)`, `p(v)` from the visibility a viewpoint
//! gathers (or uniform), `H(Z|v)` (Part V eq. (2)), `I(V;Z)` (eq. (6)), VMI
//! `I(v;Z)` (eq. (7)), the voxel mutual information `I(z;V)` (VoMI, the
//! volume analogue of polygonal mutual information), its colour form and the
//! importance-weighted VMI (EVMI).
//!
//! * [`grid`]: the scalar grid and its trilinear sampling;
//! * [`builtin`]: analytic volumes (hydrogen orbitals, a labelled phantom,
//!   a solid cube);
//! * [`raw`]: raw volumes (u8/u16/f32, little-endian) with size checks
//!   before any allocation; [`nrrd`]: the single-file raw NRRD subset;
//! * [`transfer`]: piecewise-linear opacity and colour over the scalar;
//! * [`raycast`]: cameras on the viewpoint sphere, visibility and pictures;
//! * [`iso`]: iso-surfaces by marching tetrahedra, for the polygonal route;
//! * [`channel`]: the channel and its measures; [`objects`]: the object
//!   channel of a labelled volume (crisp or fuzzy membership);
//! * [`series`]: time-varying volumes; [`paths`]: the best static view of a
//!   series, its dynamic view path, and the geodesic camera path between
//!   two views;
//! * [`shard_job`]: the memory a run needs, a shard's rows saved, shards
//!   merged.

pub mod builtin;
pub mod cast;
pub mod channel;
pub mod grid;
pub mod iso;
pub mod nrrd;
pub mod objects;
pub mod paths;
pub mod raw;
pub mod raycast;
pub mod series;
pub mod shard_job;
pub mod transfer;

pub use channel::{VolumeChannelOptions, VolumeMeasures, volume_channel, volume_measures};
pub use grid::Volume;
pub use transfer::TransferFunction;

use std::fmt;

/// A volume failure: a bad specification, file or size. One line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VolumeError(pub String);

impl fmt::Display for VolumeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for VolumeError {}

impl VolumeError {
    /// An error with a message.
    pub fn new(m: impl Into<String>) -> Self {
        Self(m.into())
    }
}
