//! Information theory on images (syllabus Part 8): rigid registration by
//! maximising mutual information, and segmentation by the information
//! channel between regions and intensities.
//!
//! * [`gray`]: scalar images, Gaussian smoothing, shrinking, bilinear samples.
//! * [`gray3`]: scalar volumes, with the same smoothing, shrinking and trilinear samples.
//! * [`rigid`]: the 2D rigid transform (rotation about the centre, translation).
//! * [`rigid3`]: the 3D rigid transform (ZYX Euler angles about the centre, translation).
//! * [`phantom`]: a labelled phantom in two "modalities" with a known transform.
//! * [`joint`]: joint intensity histograms (binned or Parzen) and the
//!   similarity metrics, every one computed by `itgfx-core`'s
//!   [`itgfx_core::joint_entropies`] (Part II eq. (7); Part III §3.2.3).
//! * [`powell`]: Powell's direction-set optimiser with Brent line searches.
//! * [`mod@register`]: the multiresolution registration driver, shared by 2D
//!   and 3D; [`register3()`] runs it on volumes.
//! * [`mod@segment`]: BSP split by the greatest gain of `I(R;X)` and merge by the
//!   core's agglomerative information bottleneck.

pub mod gray;
pub mod gray3;
pub mod joint;
pub mod phantom;
pub mod powell;
pub mod register;
pub mod register3;
pub mod rigid;
pub mod rigid3;
pub mod segment;

pub use gray::Gray;
pub use gray3::Gray3;
pub use joint::{HistogramKind, Metric};
pub use register::{Level, RegisterOptions, Registration, register};
pub use register3::{Registration3, register3};
pub use rigid::Rigid2;
pub use rigid3::Rigid3;
pub use segment::{SegmentOptions, Segmentation, segment};
