//! The exact primitive tests every backend shares: the watertight
//! ray-triangle test of Woop, Benthin and Wald (JCGT 2013), the analytic
//! sphere, and the sorting and merging of a line's crossings.
//!
//! The Vulkan kernel (`shaders/trace.wgsl`) repeats [`Shear::hit`]'s
//! arithmetic operation for operation; the host finishes every device hit
//! with the functions here, so all backends decide hits identically.

use glam::{DVec3, Vec3, Vec3A};

use super::{Crossing, CrossingBuffer, Hit, Prepared};
use crate::lines::Line;
use crate::scene::SphereCells;

/// Per-ray constants of the watertight test.
pub(crate) struct Shear {
    pub(crate) org: Vec3A,
    pub(crate) k: [usize; 3],
    pub(crate) s: [f32; 3],
    /// The origin along the axes `k`: `[org[kx], org[ky], org[kz]]`.
    org_k: [f32; 3],
}

/// The raw result of the test: numerator of `t`, and the three edge
/// functions (weights of the triangle's vertices 0, 1, 2, unnormalised).
struct Raw {
    num: f32,
    w: [f32; 3],
    det: f32,
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
        Self {
            org,
            k: [kx, ky, kz],
            s: [dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]],
            org_k: [org[kx], org[ky], org[kz]],
        }
    }

    /// The shear constants of line `l`, with its direction for the BVH
    /// traversal: negative zeros made positive (`-0.0 + 0.0 = +0.0`, every
    /// other value unchanged). obvhs takes a child's near plane by
    /// `direction < 0.0` (false for `-0.0`) but inverts `-0.0` to
    /// `-1/EPSILON` (`signum(-0.0) = -1`): near and far swap and the ray
    /// misses every box that is flat across that axis, such as an
    /// axis-aligned wall seen head-on (tests/tests/backends.rs, `axis_rays`).
    pub(crate) fn of(l: &Line) -> (Self, Vec3A) {
        let org = Vec3A::from(Vec3::from(l.origin));
        let dir = Vec3A::from(Vec3::from(l.direction));
        (Self::new(org, dir), walk_direction(l))
    }

    #[inline(always)]
    fn raw(&self, v: &[Vec3A; 3]) -> Option<Raw> {
        let (r, crossed) = self.raw_always(v);
        crossed.then_some(r)
    }

    /// [`Shear::raw`]'s numbers whether or not the line crosses, and whether
    /// it does: no branch on the answer (only on exact zeros, which are rare).
    #[inline(always)]
    fn raw_always(&self, v: &[Vec3A; 3]) -> (Raw, bool) {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.s;
        let [ox, oy, oz] = self.org_k;
        // `(v - org)[k]` component by component: each vertex coordinate is
        // read at its index (no branch on the axes, which differ from line
        // to line), the subtraction is the same IEEE operation.
        let rel = |p: &Vec3A| {
            let p: &[f32; 3] = p.as_ref();
            (p[kx] - ox, p[ky] - oy, p[kz] - oz)
        };
        let (a, b, c) = (rel(&v[0]), rel(&v[1]), rel(&v[2]));
        let (ax, ay) = (a.0 - sx * a.2, a.1 - sy * a.2);
        let (bx, by) = (b.0 - sx * b.2, b.1 - sy * b.2);
        let (cx, cy) = (c.0 - sx * c.2, c.1 - sy * c.2);
        let (az, bz, cz) = (a.2, b.2, c.2);
        let mut u = cx * by - cy * bx;
        let mut w = bx * ay - by * ax;
        let mut vv = ax * cy - ay * cx;
        if (u == 0.0) | (vv == 0.0) | (w == 0.0) {
            // Exact edge cases: decide in double precision.
            let f = |p: f32, q: f32, r: f32, s: f32| (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32;
            u = f(cx, by, cy, bx);
            vv = f(ax, cy, ay, cx);
            w = f(bx, ay, by, ax);
        }
        let det = u + vv + w;
        let outside = ((u < 0.0) | (vv < 0.0) | (w < 0.0)) & ((u > 0.0) | (vv > 0.0) | (w > 0.0));
        let num = u * sz * az + vv * sz * bz + w * sz * cz;
        (Raw { num, w: [u, vv, w], det }, !outside & (det != 0.0))
    }

    /// [`Shear::hit`] within `[tmin, tmax]` without a branch on the answer:
    /// `t` (meaningful only when crossed) and whether the line crosses
    /// there; the same `t` to the bit.
    #[inline(always)]
    pub(crate) fn hit_within(&self, v: &[Vec3A; 3], tmin: f32, tmax: f32) -> (f32, bool) {
        let (r, crossed) = self.raw_always(v);
        let t = r.num / r.det;
        (t, crossed & (t >= tmin) & (t <= tmax))
    }

    /// Parameter `t` of the crossing with triangle `v`, if any. Watertight:
    /// a line through an edge shared by two triangles crosses at least one.
    #[inline(always)]
    pub(crate) fn hit(&self, v: &[Vec3A; 3]) -> Option<f32> {
        self.raw(v).map(|r| r.num / r.det)
    }

    /// `t` and the barycentric weights of vertices 1 and 2, from the same
    /// arithmetic as [`Shear::hit`] (so the same `t` to the bit).
    pub(crate) fn hit_barycentric(&self, v: &[Vec3A; 3]) -> Option<(f32, [f32; 2])> {
        self.raw(v).map(|r| (r.num / r.det, [r.w[1] / r.det, r.w[2] / r.det]))
    }
}

/// The direction of `l` as the BVH walk and [`push_crossing`] take it:
/// negative zeros made positive (see [`Shear::of`]).
#[inline]
pub(crate) fn walk_direction(l: &Line) -> Vec3A {
    Vec3A::from(Vec3::from(l.direction)) + Vec3A::ZERO
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
    if let Some(t) = shear.hit(&scene.triangles[tri])
        && t >= l.tmin
        && t <= l.tmax
    {
        push_crossing(scene, dir, t, tri, hits);
    }
}

/// Records a crossing at `t` of a line along `dir` with triangle `tri`.
#[inline]
pub(crate) fn push_crossing(scene: &Prepared, dir: Vec3A, t: f32, tri: usize, hits: &mut Vec<Crossing>) {
    let cos = scene.normals[tri].dot(dir);
    hits.push(Crossing { t, patch: scene.triangle_patch[tri], cos, primitive: tri as u32 });
}

/// Whether crossing `(t, primitive)` comes before `(bt, bp)` in a line's
/// sorted list: smaller `t`, ties to the smaller triangle.
#[inline]
pub(crate) fn before(t: f32, primitive: u32, best: Option<(f32, u32)>) -> bool {
    best.is_none_or(|(bt, bp)| t < bt || (t == bt && primitive < bp))
}

/// The [`Hit`] of line `l` on triangle `tri`, or `None` if this test finds
/// no crossing within `[tmin, tmax]` (a device that rounded differently).
pub(crate) fn triangle_hit(scene: &Prepared, l: &Line, tri: u32) -> Option<Hit> {
    let (shear, dir) = Shear::of(l);
    let (t, barycentric) = shear.hit_barycentric(&scene.triangles[tri as usize])?;
    if !(t >= l.tmin && t <= l.tmax) {
        return None;
    }
    let n = scene.normals[tri as usize];
    Some(Hit {
        t,
        patch: scene.triangle_patch[tri as usize],
        primitive: tri,
        cos: n.dot(dir),
        barycentric,
        normal: n.into(),
    })
}

/// The first crossing of `l` with the analytic sphere, as a [`Hit`].
pub(crate) fn sphere_hit(s: &SphereCells, l: &Line) -> Option<Hit> {
    let mut hits = Vec::with_capacity(2);
    sphere_crossings(s, l, &mut hits);
    hits.first().map(|c| {
        let o = DVec3::from(l.origin.map(f64::from));
        let d = DVec3::from(l.direction.map(f64::from));
        let n = -(o + d * f64::from(c.t)) / s.radius; // the front side faces inwards
        Hit {
            t: c.t,
            patch: c.patch,
            primitive: c.primitive,
            cos: c.cos,
            barycentric: [0.0; 2],
            normal: n.normalize_or_zero().as_vec3().to_array(),
        }
    })
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

/// Both crossings of `l` with the analytic sphere within `[tmin, tmax]`.
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
