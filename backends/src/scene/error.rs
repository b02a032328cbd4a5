//! Why a scene could not be made, and the size limits checked before a
//! scene is allocated.

use std::fmt;

/// Why a scene could not be made. Every message is one line.
#[derive(Debug, Clone, PartialEq)]
pub enum SceneError {
    /// Not a built-in scene name.
    UnknownScene {
        /// The name given.
        name: String,
        /// The built-in names, for the message.
        known: String,
    },
    /// A built-in parameter is not an integer in its range (or not one of its words).
    BadParameter {
        /// The whole spec, e.g. `"torus:2,8"`.
        spec: String,
        /// Parameter name as in the syntax (`"U"`).
        name: &'static str,
        /// What is allowed (`"an integer in 3..=4096"`).
        expected: String,
        /// What was given.
        got: String,
    },
    /// More `:`/`,` parameters than the built-in takes.
    ExtraParameters {
        /// The whole spec.
        spec: String,
        /// The built-in's syntax, e.g. `"cube"` or `"sphere[:B,S]"`.
        syntax: &'static str,
    },
    /// The scene would pass the size limits of [`Limits`] (checked before
    /// allocating).
    TooLarge {
        /// What was being made (`"sphere:4096,4096"`, `"x.obj subdivided 8 x 8"`).
        what: String,
        /// Triangles it would have.
        triangles: u64,
        /// Patches it would have.
        patches: u64,
        /// Estimated bytes (see [`Limits::estimate_bytes`]).
        bytes: u64,
    },
    /// A scene file (OBJ, MTL, PLY, glTF, Mitsuba XML) could not be read or parsed.
    Obj {
        /// File path.
        path: String,
        /// What went wrong, with `line N:` where known.
        message: String,
    },
    /// Geometry that cannot be traced.
    Geometry(String),
    /// The scene's memory estimate ([`Limits::estimate_bytes`]) is over
    /// what the process may use ([`crate::memory`]).
    Memory(crate::memory::OutOfMemory),
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::UnknownScene { name, known } => {
                write!(f, "unknown scene {name:?}: not a built-in ({known}) and no such scene file")
            }
            SceneError::BadParameter { spec, name, expected, got } => {
                write!(f, "{spec}: {name} must be {expected}, got {got:?}")
            }
            SceneError::ExtraParameters { spec, syntax } => {
                write!(f, "{spec}: too many parameters (syntax: {syntax})")
            }
            SceneError::TooLarge { what, triangles, patches, bytes } => write!(
                f,
                "{what}: {triangles} triangles and {patches} patches (about {:.1} GiB) exceed the limits of {} triangles and {} patches (about {:.1} GiB of memory): {}",
                *bytes as f64 / GIB,
                Limits::MAX_TRIANGLES,
                Limits::MAX_PATCHES,
                Limits::estimate_bytes(Limits::MAX_TRIANGLES, Limits::MAX_PATCHES) as f64 / GIB,
                Limits::REASON
            ),
            SceneError::Obj { path, message } => write!(f, "{path}: {message}"),
            SceneError::Geometry(m) => f.write_str(m),
            SceneError::Memory(e) => write!(f, "{e}: a smaller scene"),
        }
    }
}

impl std::error::Error for SceneError {}

const GIB: f64 = (1u64 << 30) as f64;

/// Size limits of a scene, checked from the parameters before any vertex
/// is allocated, and its memory estimate, compared with what the process
/// may use ([`crate::memory`]).
///
/// The estimate bounds the peak of `complexity` (`viewpoints` adds its
/// channel's entries to it) at up to 10⁶ lines (measured with `/usr/bin/time -v`, release build: maximum RSS of
/// `complexity cube-enclosure:300 --lines 1000` 480 MiB for 1.08 M
/// triangles and 540 k patches, estimate 0.71 GiB; `torus:2048,512` 926 MiB
/// for 2.1 M triangles, estimate 1.31 GiB; the analytic `sphere:1024,1024`
/// 200 MiB for 1 M patches and no triangle, estimate 0.31 GiB;
/// `cube-enclosure:150 --lines 1000000` 171 MiB, estimate 229 MiB; the test
/// `the_scene_estimate_bounds_the_address_space_it_uses` of
/// `cli/tests/defects_mem.rs` runs scenes under the tightest `ulimit -v`
/// the check accepts). Per triangle: the scene's three `f64`
/// vertices and patch id (76 B, up to twice that in a vector's spare
/// capacity), the tracer's `f32` triangle and normal (64 B), the BVH build
/// (nodes, indices, the builder's two node arrays: about 200 B): 512 B.
/// The renderer's uncompressed 8-wide nodes (`tracer/wide8.rs`, 256 B a
/// CWBVH node: 27 B a triangle on `mirror-room`, under 256 B on any tree,
/// which has fewer nodes than triangles) and their leaf blocks (320 B per
/// eight lanes of a node's leaf triangles: 51 B a triangle on
/// `mirror-room`, 40 B plus 320 B a node at most) are allocated, with a
/// fallible reservation, at the first query that walks them (an
/// occlusion packet or `trace_all`'s ray-stream walk, or a single-ray
/// walk where the tree below is declined), after the build's temporaries
/// (about 200 B a triangle) are given back. The single-ray walks' own tree
/// (`tracer/tree8.rs`: 256 B a node, 320 B a leaf of up to eight
/// triangles; 66 B a triangle on `mirror-room`, 66 B on the 69k bunny,
/// under 576 B at most: a block and a node a triangle) is built with the
/// tracer from obvhs's binary tree, by
/// fallible reservations (a tree that cannot be allocated is declined and
/// the walks above serve); the BVH-ordered triangle lanes (36 B a
/// triangle) are built only where the CWBVH's own walk serves.
/// Per patch: the [`super::Patch`] with its name and the visibility
/// counters and per-patch results: 256 B (a sphere's cells measure 200 B).
/// Plus [`Limits::BASE_BYTES`] for the program, its line buffers and
/// threads. The caps keep the largest scene near 11 GiB (the
/// `torus:4096,2048` at the caps is refused on a machine with less to give,
/// where it once panicked inside the BVH build).
pub struct Limits;

impl Limits {
    /// Most triangles of a scene: 2^24.
    pub const MAX_TRIANGLES: u64 = 1 << 24;
    /// Most patches of a scene: 2^23.
    pub const MAX_PATCHES: u64 = 1 << 23;
    /// Estimated bytes per triangle (see the type's documentation).
    pub const BYTES_PER_TRIANGLE: u64 = 512;
    /// Estimated bytes per patch.
    pub const BYTES_PER_PATCH: u64 = 256;
    /// Estimated bytes of the program besides the scene: 64 MiB.
    pub const BASE_BYTES: u64 = 64 << 20;
    /// The reason, for messages.
    pub const REASON: &'static str =
        "about 512 bytes per triangle (scene, tracer copy, BVH) and 256 per patch (names, counters)";

    /// Estimated bytes of a scene with these counts and the program
    /// around it, saturating: a bound on the peak (see the type's docs).
    #[must_use]
    pub fn estimate_bytes(triangles: u64, patches: u64) -> u64 {
        triangles
            .saturating_mul(Self::BYTES_PER_TRIANGLE)
            .saturating_add(patches.saturating_mul(Self::BYTES_PER_PATCH))
            .saturating_add(Self::BASE_BYTES)
    }

    /// Refuses counts over the caps, or whose estimate is over the memory
    /// the process may use, before allocating.
    ///
    /// # Errors
    /// [`SceneError::TooLarge`] with the counts and the estimated bytes;
    /// [`SceneError::Memory`] when the estimate is over the budget.
    pub fn check(what: &str, triangles: u64, patches: u64) -> Result<(), SceneError> {
        Self::check_within(crate::memory::budget(), what, triangles, patches)
    }

    /// [`Limits::check`] against a `budget` read once before the reader's
    /// loop ([`crate::memory::check_within`]), for checks made per face.
    ///
    /// # Errors
    /// As [`Limits::check`].
    pub fn check_within(
        budget: Option<crate::memory::Budget>,
        what: &str,
        triangles: u64,
        patches: u64,
    ) -> Result<(), SceneError> {
        let bytes = Self::estimate_bytes(triangles, patches);
        if triangles > Self::MAX_TRIANGLES || patches > Self::MAX_PATCHES {
            return Err(SceneError::TooLarge { what: what.to_string(), triangles, patches, bytes });
        }
        crate::memory::check_within(budget, || format!("{what} ({triangles} triangles, {patches} patches)"), bytes)
            .map_err(SceneError::Memory)
    }
}
