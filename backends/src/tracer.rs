//! The tracing seam shared by every backend, and the CPU implementations.
//!
//! A [`Tracer`] turns batches of [`Line`]s into the ordered list of patch
//! crossings of each line. Every engine (scene visibility, viewpoints,
//! radiosity) is written against this trait; backends differ only in how
//! they find crossings. Output `i` depends only on line `i`.
//!
//! Geometry is traced in normalised coordinates: the scene is translated to
//! its bounding-box centre and scaled so the half-diagonal is 1 (see
//! [`Prepared`]). Every measure the channel needs is scale-invariant.

use std::fmt;

use glam::{DVec3, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::ray::Ray;

use crate::lines::Line;
use crate::scene::{Scene, SphereCells};

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
    /// Triangle crossed (for debugging; the cell for an analytic sphere).
    pub primitive: u32,
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

/// Why a backend could not trace.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BackendError {
    /// The backend is not available here (compiled out, no device, no loader).
    Unavailable {
        /// Backend name.
        backend: &'static str,
        /// Why, with the fix where there is one.
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
            BackendError::OutOfMemory => write!(f, "out of device memory"),
            BackendError::DeviceLost => write!(f, "device lost"),
        }
    }
}

impl std::error::Error for BackendError {}

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
}

/// Which backend to open.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendChoice {
    /// rayon + obvhs on the CPU.
    Cpu,
    /// The brute-force reference tracer (test oracle; O(lines × triangles)).
    Reference,
    /// Vulkan compute (issue 4).
    Vulkan,
}

impl BackendChoice {
    /// Parses `cpu`, `reference` or `vulkan`.
    ///
    /// # Errors
    /// A message listing the choices.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "cpu" => Ok(BackendChoice::Cpu),
            "reference" => Ok(BackendChoice::Reference),
            "vulkan" => Ok(BackendChoice::Vulkan),
            other => Err(format!("unknown backend {other:?}: expected cpu, vulkan or reference")),
        }
    }
}

/// Opens a backend on a prepared scene.
///
/// # Errors
/// [`BackendError::Unavailable`] when Vulkan has no loader, driver or device.
pub fn open(choice: BackendChoice, scene: &Prepared) -> Result<Box<dyn Tracer>, BackendError> {
    match choice {
        BackendChoice::Cpu => Ok(Box::new(CpuTracer::new(scene))),
        BackendChoice::Reference => Ok(Box::new(ReferenceTracer { scene: scene.clone() })),
        BackendChoice::Vulkan => Ok(Box::new(crate::vulkan::tracer::VulkanTracer::new(scene)?)),
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
}

/// Per-ray constants of the watertight test (Woop, Benthin, Wald 2013).
pub(crate) struct Shear {
    org: Vec3A,
    pub(crate) k: [usize; 3],
    pub(crate) s: [f32; 3],
}

impl Shear {
    pub(crate) fn new(org: Vec3A, dir: Vec3A) -> Self {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Self { org, k: [kx, ky, kz], s: [dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]] }
    }

    /// Parameter `t` of the crossing with triangle `v`, if any. Watertight:
    /// a line through an edge shared by two triangles crosses at least one.
    #[inline]
    fn hit(&self, v: &[Vec3A; 3]) -> Option<f32> {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.s;
        let (a, b, c) = (v[0] - self.org, v[1] - self.org, v[2] - self.org);
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut w = bx * ay - by * ax;
        let mut vv = ax * cy - ay * cx;
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            // Exact edge cases: decide in double precision.
            let f = |p: f32, q: f32, r: f32, s: f32| (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32;
            u = f(cx, by, cy, bx);
            vv = f(ax, cy, ay, cx);
            w = f(bx, ay, by, ax);
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        let t = (u * sz * a[kz] + vv * sz * b[kz] + w * sz * c[kz]) / det;
        Some(t)
    }
}

/// Records the crossing of line `l` with triangle `tri`, if any, within `[tmin, tmax]`.
#[inline]
pub(crate) fn test_triangle(
    scene: &Prepared,
    shear: &Shear,
    l: &Line,
    dir: Vec3A,
    tri: usize,
    hits: &mut Vec<Crossing>,
) {
    if let Some(t) = shear.hit(&scene.triangles[tri]) {
        if t >= l.tmin && t <= l.tmax {
            let cos = scene.normals[tri].dot(dir);
            hits.push(Crossing { t, patch: scene.triangle_patch[tri], cos, primitive: tri as u32 });
        }
    }
}

/// Sorts and merges coincident crossings, appending them to `out`.
pub(crate) fn finish(hits: &mut Vec<Crossing>, out: &mut CrossingBuffer) {
    hits.sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.primitive.cmp(&b.primitive)));
    // Crossings chained less than 1e-6 apart and facing the same way are one
    // crossing of the surface (through an edge or vertex shared by several
    // triangles): keep the first. Opposite-facing ones are kept: whether they
    // are a touch or a real tiny segment is the caller's question.
    for h in hits.drain(..) {
        if let Some(l) = out.crossings.last() {
            let same_line = out.crossings.len() > *out.offsets.last().unwrap_or(&0) as usize;
            if same_line && h.t - l.t <= 1e-6 && (h.cos > 0.0) == (l.cos > 0.0) {
                continue;
            }
        }
        out.crossings.push(h);
    }
    out.offsets.push(out.crossings.len() as u32);
}

pub(crate) fn sphere_crossings(s: &SphereCells, l: &Line, hits: &mut Vec<Crossing>) {
    let o = DVec3::from(l.origin.map(f64::from));
    let d = DVec3::from(l.direction.map(f64::from));
    let b = o.dot(d);
    let c = o.length_squared() - s.radius * s.radius;
    let disc = b * b - c;
    if disc <= 0.0 {
        return;
    }
    let r = disc.sqrt();
    for t in [-b - r, -b + r] {
        if t >= f64::from(l.tmin) && t <= f64::from(l.tmax) {
            let p = o + d * t;
            let n = -p / s.radius; // inward
            let cell = s.cell(p);
            hits.push(Crossing { t: t as f32, patch: cell, cos: n.dot(d) as f32, primitive: cell });
        }
    }
}

/// Triangle boxes and build parameters shared by the CPU and Vulkan BVHs:
/// obvhs's medium preset with `search_depth_threshold = 0` (TRACING.md
/// measured it 10× faster on tessellated walls), and boxes padded by 1e-5
/// (normalised units), since obvhs's f32 slab test can cull a box the line
/// only grazes and wall triangles have flat boxes. The watertight triangle
/// test still decides every hit.
pub(crate) fn bvh_input(scene: &Prepared) -> (Vec<Aabb>, obvhs::BvhBuildParams) {
    let pad = Vec3A::splat(1e-5);
    let aabbs: Vec<Aabb> = scene
        .triangles
        .iter()
        .map(|t| Aabb { min: t[0].min(t[1]).min(t[2]) - pad, max: t[0].max(t[1]).max(t[2]) + pad })
        .collect();
    let mut params = obvhs::BvhBuildParams::medium_build();
    params.search_depth_threshold = 0;
    (aabbs, params)
}

/// The CPU backend: an obvhs compressed wide BVH over triangle bounds, the
/// watertight test above for each candidate, all crossings collected.
pub struct CpuTracer {
    scene: Prepared,
    bvh: Option<CwBvh>,
}

impl CpuTracer {
    /// Builds the BVH (obvhs's medium preset with `search_depth_threshold = 0`,
    /// which TRACING.md measured 10× faster on tessellated walls).
    #[must_use]
    pub fn new(scene: &Prepared) -> Self {
        let bvh = (!scene.triangles.is_empty()).then(|| {
            let (aabbs, params) = bvh_input(scene);
            build_cwbvh(&aabbs, params, &mut std::time::Duration::default())
        });
        Self { scene: scene.clone(), bvh }
    }
}

impl Tracer for CpuTracer {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        out.clear();
        let mut hits = Vec::with_capacity(16);
        for l in lines {
            if let Some(s) = &self.scene.sphere {
                sphere_crossings(s, l, &mut hits);
            } else if let Some(bvh) = &self.bvh {
                let org = Vec3A::from(Vec3::from(l.origin));
                let dir = Vec3A::from(Vec3::from(l.direction));
                let shear = Shear::new(org, dir);
                let ray = Ray::new(org, dir, l.tmin, l.tmax);
                bvh.ray_traverse_anyhit(ray, |_, id| {
                    test_triangle(&self.scene, &shear, l, dir, bvh.primitive_indices[id] as usize, &mut hits);
                });
            }
            finish(&mut hits, out);
        }
        Ok(())
    }
}

/// The brute-force reference: every triangle tested against every line.
/// Slow by design; the oracle both real backends are tested against.
pub struct ReferenceTracer {
    scene: Prepared,
}

impl ReferenceTracer {
    /// A reference tracer over a prepared scene.
    #[must_use]
    pub fn new(scene: &Prepared) -> Self {
        Self { scene: scene.clone() }
    }
}

impl Tracer for ReferenceTracer {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        out.clear();
        let mut hits = Vec::new();
        for l in lines {
            if let Some(s) = &self.scene.sphere {
                sphere_crossings(s, l, &mut hits);
            } else {
                let org = Vec3A::from(Vec3::from(l.origin));
                let dir = Vec3A::from(Vec3::from(l.direction));
                let shear = Shear::new(org, dir);
                for tri in 0..self.scene.triangles.len() {
                    test_triangle(&self.scene, &shear, l, dir, tri, &mut hits);
                }
            }
            finish(&mut hits, out);
        }
        Ok(())
    }
}
