//! The tracing seam shared by every backend.
//!
//! A [`Tracer`] answers three queries over batches of [`Line`]s through a
//! [`Prepared`] scene:
//!
//! * [`Tracer::trace_all`]: every crossing of each line, sorted (the scene
//!   visibility channel pairs consecutive crossings);
//! * [`Tracer::closest_hit`]: the first crossing only, with barycentrics and
//!   the geometric normal (viewpoints, cameras, path tracing, radiosity);
//! * [`Tracer::occluded`]: whether anything is crossed at all (shadow rays,
//!   mutual visibility of two points).
//!
//! Every engine is written against this trait; backends differ only in how
//! they find crossings, and each answer depends only on its own line. The
//! three queries agree exactly: `closest_hit` is the first element of
//! `trace_all`'s list (smallest `t`, ties to the smaller triangle index) and
//! `occluded` is whether that list is non-empty. The conformance tests
//! (`tests/tests/backends.rs`) hold every backend to the brute-force
//! [`ReferenceTracer`] on every built-in scene.
//!
//! **Who parallelises.** A call traces its batch on the calling thread (the
//! Vulkan backend submits one dispatch per 65,536 lines and serialises
//! submissions). Callers split work into batches and run them with rayon;
//! a batch of a few thousand lines amortises the per-call cost.
//!
//! **Near hits.** The CPU backend's BVH (obvhs) culls boxes nearer than
//! 1e-4 along a line, so a line must start at least [`NEAR`] before anything
//! it has to find: [`Line::ray`] backs the origin off by that much.
//!
//! Geometry is traced in normalised coordinates: the scene is translated to
//! its bounding-box centre and scaled so the half-diagonal is 1 (see
//! [`Prepared`]). Design notes: `docs/TRACING.md`.

mod cpu;
mod error;
mod node8;
mod packet;
mod reference;
mod stream;
mod tree8;
pub(crate) mod watertight;
mod wide8;

use glam::{DVec3, Vec3A};

pub use cpu::CpuTracer;
pub(crate) use cpu::bvh_input;
pub use reference::ReferenceTracer;

use crate::lines::Line;
use crate::scene::{Scene, SphereCells};
pub use error::BackendError;

/// How far [`Line::ray`] backs a ray's origin off (normalised units): ten
/// times obvhs's near-culling distance of 1e-4.
pub const NEAR: f32 = 1e-3;

/// One crossing of a line with a patch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Crossing {
    /// Line parameter of the crossing.
    pub t: f32,
    /// Patch crossed.
    pub patch: u32,
    /// `n · d`: positive when the patch's front side faces along the line.
    pub cos: f32,
    /// Triangle crossed (the cell for an analytic sphere).
    pub primitive: u32,
}

/// The first crossing of a line, as [`Tracer::closest_hit`] reports it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Hit {
    /// Line parameter of the hit.
    pub t: f32,
    /// Patch hit.
    pub patch: u32,
    /// Triangle hit (the cell for an analytic sphere).
    pub primitive: u32,
    /// `n · d` with the front normal: positive when the line arrives at the
    /// patch's back side.
    pub cos: f32,
    /// Barycentric weights of the triangle's second and third vertices
    /// (the first has `1 − b1 − b2`); zero on the analytic sphere.
    pub barycentric: [f32; 2],
    /// Unit geometric front normal at the hit (normalised coordinates have
    /// the scene's orientation, so it is also the scene-space normal).
    pub normal: [f32; 3],
}

/// Crossings of a batch of lines: those of line `i` are
/// `crossings[offsets[i]..offsets[i + 1]]`, sorted by `t`.
#[derive(Clone, Debug, Default)]
pub struct CrossingBuffer {
    /// Start of each line's crossings (`lines + 1` entries).
    pub offsets: Vec<u32>,
    /// All crossings.
    pub crossings: Vec<Crossing>,
}

impl CrossingBuffer {
    /// Crossings of line `i`.
    #[must_use]
    pub fn line(&self, i: usize) -> &[Crossing] {
        &self.crossings[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    pub(crate) fn clear(&mut self) {
        self.offsets.clear();
        self.crossings.clear();
        self.offsets.push(0);
    }
}

/// A way to trace batches of lines through a prepared scene.
pub trait Tracer: Send + Sync {
    /// Stable name used by `--backend` and in JSON output.
    fn name(&self) -> &'static str;

    /// Appends every crossing of each line within `[tmin, tmax]`, sorted by
    /// `t`. Crossings within 1e-6 of each other and facing the same way (a
    /// line through an edge shared by two triangles) are merged into the first.
    ///
    /// # Errors
    /// Device failures only; scene problems are caught when preparing.
    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError>;

    /// Replaces `out` with the first crossing of each line within
    /// `[tmin, tmax]` (either side facing), or `None`: exactly the first
    /// element [`Tracer::trace_all`] would list.
    ///
    /// # Errors
    /// Device failures only.
    fn closest_hit(&self, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError>;

    /// Replaces `out` with whether each line crosses anything within
    /// `[tmin, tmax]`: exactly whether [`Tracer::trace_all`] would list a crossing.
    ///
    /// # Errors
    /// Device failures only.
    fn occluded(&self, lines: &[Line], out: &mut Vec<bool>) -> Result<(), BackendError>;

    /// How many lines a caller with many should hand in per call: enough to
    /// amortise a call (a device submission), few enough that a CPU batch's
    /// lines and crossings stay in cache beside the BVH.
    fn batch_lines(&self) -> usize {
        1 << 16
    }
}

impl Line {
    /// A ray from `origin` along unit `direction` covering `[tmin, tmax]`
    /// measured from `origin`, with the origin backed off by [`NEAR`] so the
    /// CPU backend's BVH sees hits right at `tmin` (see the module docs).
    /// Hits report `t` from the backed-off origin: subtract [`NEAR`].
    #[must_use]
    pub fn ray(origin: DVec3, direction: DVec3, tmin: f64, tmax: f64) -> Line {
        let o = origin - direction * f64::from(NEAR);
        Line {
            origin: o.as_vec3().to_array(),
            tmin: (tmin + f64::from(NEAR)) as f32,
            direction: direction.as_vec3().to_array(),
            tmax: (tmax + f64::from(NEAR)) as f32,
        }
    }

    /// [`Line::ray`] in f32 (the path tracer's rays): the same backing off.
    #[inline]
    #[must_use]
    pub fn ray32(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> Line {
        let o = origin - direction * NEAR;
        Line { origin: o.to_array(), tmin: tmin + NEAR, direction: direction.to_array(), tmax: tmax + NEAR }
    }
}

/// A scene ready to trace: triangles in normalised coordinates with unit
/// front normals, patch ids, and the map back to scene units.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// Triangle vertices (normalised).
    pub triangles: Vec<[Vec3A; 3]>,
    /// Unit front normal of each triangle.
    pub normals: Vec<Vec3A>,
    /// Patch of each triangle.
    pub triangle_patch: Vec<u32>,
    /// The analytic sphere, if the scene is one (normalised radius 1).
    pub sphere: Option<SphereCells>,
    /// Scene-unit centre of the normalisation.
    pub centre: DVec3,
    /// Scene units per normalised unit.
    pub scale: f64,
    /// Number of patches.
    pub patches: usize,
}

impl crate::camera::Camera {
    /// The same camera in the tracer's normalised coordinates.
    #[must_use]
    pub fn normalised(&self, p: &Prepared) -> Self {
        Self { eye: p.to_normalised(self.eye), ..*self }
    }
}

impl Prepared {
    /// Normalises a validated scene.
    #[must_use]
    pub fn new(scene: &Scene) -> Self {
        let (lo, hi) = scene.bounds();
        let centre = (lo + hi) * 0.5;
        let scale = ((hi - lo) * 0.5).length().max(f64::MIN_POSITIVE);
        let map = |v: DVec3| Vec3A::from(((v - centre) / scale).as_vec3());
        let triangles: Vec<[Vec3A; 3]> = scene.triangles.iter().map(|t| [map(t[0]), map(t[1]), map(t[2])]).collect();
        let normals = scene
            .triangles
            .iter()
            .map(|t| Vec3A::from((t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero().as_vec3()))
            .collect();
        let sphere = scene.sphere.map(|s| SphereCells { radius: s.radius / scale, ..s });
        Self {
            triangles,
            normals,
            triangle_patch: scene.triangle_patch.clone(),
            sphere,
            centre,
            scale,
            patches: scene.patches.len(),
        }
    }

    /// A scene-space point in normalised coordinates.
    #[must_use]
    pub fn to_normalised(&self, p: DVec3) -> DVec3 {
        (p - self.centre) / self.scale
    }

    /// A normalised point in scene space.
    #[must_use]
    pub fn to_scene(&self, p: DVec3) -> DVec3 {
        p * self.scale + self.centre
    }
}
