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
        }
    }
}

impl std::error::Error for SceneError {}

const GIB: f64 = (1u64 << 30) as f64;

/// Size limits of a scene, checked from the parameters before any vertex
/// is allocated.
///
/// Memory per triangle, all stages together: the scene's three `f64`
/// vertices and patch id (76 B), the tracer's normalised `f32` triangle and
/// normal (64 B), the BVH (about two 32 B nodes per triangle plus index
/// and build scratch, 112 B): 256 B. Per patch: the [`super::Patch`] with
/// its name (about 96 B) and the visibility counters and per-patch results
/// (about 160 B): 256 B. The caps keep the estimate near 6 GiB, which a
/// 16 GiB machine holds with the line buffers; a `cube-enclosure:1000`
/// (12 M triangles, 6 M patches) still fits.
pub struct Limits;

impl Limits {
    /// Most triangles of a scene: 2^24.
    pub const MAX_TRIANGLES: u64 = 1 << 24;
    /// Most patches of a scene: 2^23.
    pub const MAX_PATCHES: u64 = 1 << 23;
    /// Estimated bytes per triangle (see the type's documentation).
    pub const BYTES_PER_TRIANGLE: u64 = 256;
    /// Estimated bytes per patch.
    pub const BYTES_PER_PATCH: u64 = 256;
    /// The reason, for messages.
    pub const REASON: &'static str =
        "about 256 bytes per triangle (scene, tracer copy, BVH) and 256 per patch (names, counters)";

    /// Estimated bytes of a scene with these counts, saturating.
    #[must_use]
    pub fn estimate_bytes(triangles: u64, patches: u64) -> u64 {
        triangles.saturating_mul(Self::BYTES_PER_TRIANGLE).saturating_add(patches.saturating_mul(Self::BYTES_PER_PATCH))
    }

    /// Refuses counts over the caps, before allocating.
    ///
    /// # Errors
    /// [`SceneError::TooLarge`] with the counts and the estimated bytes.
    pub fn check(what: &str, triangles: u64, patches: u64) -> Result<(), SceneError> {
        if triangles > Self::MAX_TRIANGLES || patches > Self::MAX_PATCHES {
            return Err(SceneError::TooLarge {
                what: what.to_string(),
                triangles,
                patches,
                bytes: Self::estimate_bytes(triangles, patches),
            });
        }
        Ok(())
    }
}
