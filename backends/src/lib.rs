//! # itgfx-backends
//!
//! Scenes and the backends that trace lines through them for itgfx:
//!
//! * [`scene`]: patches of triangles; built-in scenes ([`scene::built_in`])
//!   and Wavefront OBJ ([`obj::load_obj`]), subdivision.
//! * [`formats`]: scene files by extension or magic ([`formats::load`]):
//!   OBJ, PLY, glTF 2.0 / GLB and Mitsuba 3 XML (read and written).
//! * [`tracer`]: the [`tracer::Tracer`] seam (every crossing, closest hit,
//!   occlusion), the CPU backend (rayon + obvhs) and the brute-force
//!   reference backend.
//! * [`backend`]: choosing and opening a backend ([`BackendChoice`],
//!   [`open`], [`BackendError`]).
//! * [`files`]: opening inputs (regular files only: a FIFO would hang).
//! * [`camera`]: the pinhole camera; [`preview`]: patch-colour previews.
//! * [`lines`]: seeded counter-based global and local lines.
//! * [`meshes`]: built-in objects seen from outside (geodesic sphere, torus,
//!   table with chairs).
//! * [`viewpoint`]: the viewpoint channel of Part V.
//! * [`simplify`]: viewpoint-driven mesh simplification (Part VII).
//! * [`volume`]: volumes, ray casting and the viewpoint channel over voxels (Part VI).
//! * [`vulkan`]: the Vulkan compute backend (ash + naga), tracing and reductions.
//! * [`imaging`]: mutual-information registration and information-channel
//!   segmentation of images (syllabus Part 8).
//! * [`visibility`]: the scene visibility channel of Part III, with
//!   jackknife standard errors.

#![deny(clippy::undocumented_unsafe_blocks)]

pub mod backend;
pub mod camera;
pub mod files;
pub mod formats;
pub mod imaging;
pub mod lines;
pub mod memory;
pub mod meshes;
pub mod obj;
pub mod preview;
pub mod radiosity;
pub mod render;
pub mod scene;
pub mod shapes;
pub mod shards;
pub mod simplify;
pub mod solids;
pub mod tracer;
pub mod viewpoint;
pub mod visibility;
pub mod volume;
pub mod vulkan;

pub use backend::{BackendChoice, BackendError, open};
