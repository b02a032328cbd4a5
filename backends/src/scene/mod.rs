//! Scenes: triangles grouped into patches (Part III §1.3), built in or read
//! from Wavefront OBJ.
//!
//! A patch is one polygon of the input or one cell of a subdivision; the
//! visibility channel's states are patches. Triangles keep the winding of
//! their polygon: the front side (counter-clockwise seen from the front) is
//! where the patch emits and receives lines. Enclosures face inwards, solid
//! objects outwards.

//!
//! [`model`](self) holds the types; the built-in scenes sit above it (they
//! are built from [`crate::solids`], [`crate::meshes`] and the render rooms,
//! which use the types), and this file only re-exports both.

pub use builtin::{BUILT_IN, BuiltIn, DefaultCamera, built_in, scene_camera};
pub use error::{Limits, SceneError};
pub(crate) use model::sphere_patches;
pub use model::{Material, Patch, Scene, SphereCells};
pub use vertex_key::{vertex_key, vertex_key32};

mod builtin;
mod error;
mod model;
mod vertex_key;
