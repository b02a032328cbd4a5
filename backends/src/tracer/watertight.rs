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
    if let &mut [a, b] = &mut hits[..] {
        hits.clear();
        return finish_two(a, b, out);
    }
    hits.sort_unstable_by(crossing_order);
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

/// The order [`finish`] sorts a line's crossings in: by `t`, then by
/// triangle (crossings equal under it are equal in every field: one
/// triangle's crossing found twice).
#[inline]
fn crossing_order(a: &Crossing, b: &Crossing) -> std::cmp::Ordering {
    a.t.total_cmp(&b.t).then(a.primitive.cmp(&b.primitive))
}

/// [`finish`] of a line with exactly two crossings, most lines' count (in
/// and out of a closed scene): put in order by one comparison and the
/// second merged into the first as `finish` would, without a buffer.
#[inline]
pub(crate) fn finish_two(a: Crossing, b: Crossing, out: &mut CrossingBuffer) {
    let (a, b) = if crossing_order(&b, &a).is_lt() { (b, a) } else { (a, b) };
    out.crossings.push(a);
    if !(b.t - a.t <= 1e-6 && (b.cos > 0.0) == (a.cos > 0.0)) {
        out.crossings.push(b);
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

/// Blocks of triangles laid out for the 8-wide watertight test: each
/// vertex coordinate in its own array (structure of arrays), so one load
/// fetches one coordinate of eight consecutive triangles. Indexed like the
/// CPU backend's BVH-ordered triangles (`k`); padded with zeros so a block
/// read at any `k < len` stays in bounds.
#[derive(Clone, Debug, Default)]
pub(crate) struct TriangleLanes {
    /// `coord[axis][vertex][k]`.
    coord: [[Vec<f32>; 3]; 3],
}

/// Lanes of a [`TriangleLanes`] block.
pub(crate) const BLOCK: usize = 8;

/// The non-empty 8-lane blocks of a primitive `mask` (bit `i`: lane
/// `i % 8` of block `i / 8`), lowest first, as (block, lanes): how the
/// walks split a node's hit leaf primitives into block tests.
#[inline(always)]
pub(crate) fn mask_blocks(mask: u32) -> impl Iterator<Item = (u32, u32)> {
    let mut m = mask;
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let b = m.trailing_zeros() / BLOCK as u32;
            m &= !(0xff << (b * BLOCK as u32));
            (b, (mask >> (b * BLOCK as u32)) & 0xff)
        })
    })
}

/// One block's answers: `t` and the raw barycentric numerators and
/// determinant of each lane, and the lanes crossed within `[tmin, tmax]`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Block {
    pub(crate) t: [f32; BLOCK],
    w1: [f32; BLOCK],
    w2: [f32; BLOCK],
    det: [f32; BLOCK],
    /// Bit `i`: lane `i` crosses within `[tmin, tmax]`.
    pub(crate) hit: u32,
}

impl Block {
    /// Lane `i`'s barycentric numerators and determinant: [`barycentric`]
    /// of them is [`Shear::hit_barycentric`]'s weights, to the bit (a
    /// closest-hit walk divides only for its final hit).
    #[inline]
    pub(crate) fn numerators(&self, i: usize) -> [f32; 3] {
        [self.w1[i], self.w2[i], self.det[i]]
    }
}

/// Barycentric weights of vertices 1 and 2 from [`Block::numerators`].
#[inline]
pub(crate) fn barycentric([w1, w2, det]: [f32; 3]) -> [f32; 2] {
    [w1 / det, w2 / det]
}

impl Block {
    /// Lane `i` from the scalar test (its exact-zero re-evaluation included).
    #[inline]
    fn set_scalar(&mut self, i: usize, shear: &Shear, v: &[Vec3A; 3], tmin: f32, tmax: f32) {
        let (r, crossed) = shear.raw_always(v);
        let t = r.num / r.det;
        self.t[i] = t;
        self.w1[i] = r.w[1];
        self.w2[i] = r.w[2];
        self.det[i] = r.det;
        let within = crossed & (t >= tmin) & (t <= tmax);
        self.hit = (self.hit & !(1 << i)) | (u32::from(within) << i);
    }
}

impl TriangleLanes {
    /// The triangles `ordered` (in the order blocks will index them).
    pub(crate) fn new(ordered: &[[Vec3A; 3]]) -> Self {
        let mut coord: [[Vec<f32>; 3]; 3] = Default::default();
        for (axis, per_vertex) in coord.iter_mut().enumerate() {
            for (vertex, c) in per_vertex.iter_mut().enumerate() {
                c.extend(ordered.iter().map(|t| t[vertex][axis]));
                c.resize(ordered.len() + BLOCK, 0.0);
            }
        }
        Self { coord }
    }

    /// [`Shear::hit_within`] for the triangles `first + i` with bit `i` of
    /// `lanes` set (`first + i < len`), one lane each: the same `t` to the
    /// bit, and the hits among `lanes`. `ordered` is the array `self` was
    /// built from (its exact-zero lanes are finished by the scalar test).
    ///
    /// # Safety
    /// `AVX2` only where the CPU has AVX2 (`node8::has_avx2`).
    #[inline(always)]
    pub(crate) unsafe fn block<const AVX2: bool>(
        &self,
        ordered: &[[Vec3A; 3]],
        shear: &Shear,
        first: usize,
        lanes: u32,
        tmin: f32,
        tmax: f32,
    ) -> Block {
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // SAFETY: `AVX2` is true only where the CPU has AVX2 (this
            // function's contract).
            return unsafe { self.block_avx2(ordered, shear, first, lanes, tmin, tmax) };
        }
        let mut b = Block::default();
        let mut l = lanes;
        while l != 0 {
            let i = l.trailing_zeros() as usize;
            l &= l - 1;
            b.set_scalar(i, shear, &ordered[first + i], tmin, tmax);
        }
        b
    }

    /// [`TriangleLanes::block`] with AVX2: [`lanes_avx2`] on the nine
    /// coordinate arrays at `first` (unaligned loads).
    ///
    /// # Safety
    /// The CPU must support AVX2; `first < len`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn block_avx2(
        &self,
        ordered: &[[Vec3A; 3]],
        shear: &Shear,
        first: usize,
        lanes: u32,
        tmin: f32,
        tmax: f32,
    ) -> Block {
        assert!(first + BLOCK <= self.coord[0][0].len(), "a block past the padding");
        // `first + 8 <= len` (asserted above; every array has the same
        // padded length), so each row pointer has eight readable floats.
        let rows = shear.k.map(|axis| [0, 1, 2].map(|v| self.coord[axis][v][first..].as_ptr()));
        // SAFETY: AVX2 (this function's contract); eight floats behind each row.
        unsafe { lanes_avx2::<false>(rows, shear, lanes, tmin, tmax, |i| ordered[first + i]) }
    }
}

/// Eight triangles' vertex coordinates for the watertight test, one
/// aligned row of eight lanes per axis and vertex (`v[axis][vertex]`),
/// and each lane's triangle (scene order; padding lanes `u32::MAX`, never
/// tested): the leaf blocks of the wide tree (`wide8.rs`), 320 bytes, five
/// cache lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Leaf8 {
    pub(crate) v: [[[f32; BLOCK]; 3]; 3],
    pub(crate) tri: [u32; BLOCK],
}

const _: () = assert!(size_of::<Leaf8>() == 320);

impl Leaf8 {
    /// A block with no triangle.
    pub(crate) const EMPTY: Self = Self { v: [[[0.0; BLOCK]; 3]; 3], tri: [u32::MAX; BLOCK] };

    /// Puts triangle `tri` (vertices `v`) in lane `i`.
    pub(crate) fn set(&mut self, i: usize, tri: u32, v: &[Vec3A; 3]) {
        for (axis, rows) in self.v.iter_mut().enumerate() {
            for (vertex, row) in rows.iter_mut().enumerate() {
                row[i] = v[vertex][axis];
            }
        }
        self.tri[i] = tri;
    }

    /// Lane `i`'s vertices.
    #[inline]
    pub(crate) fn vertices(&self, i: usize) -> [Vec3A; 3] {
        [0, 1, 2].map(|vertex| Vec3A::new(self.v[0][vertex][i], self.v[1][vertex][i], self.v[2][vertex][i]))
    }

    /// [`Shear::hit_within`] for the lanes of `lanes`, as
    /// [`TriangleLanes::block`]: the same `t` to the bit.
    ///
    /// # Safety
    /// `AVX2` only where the CPU has AVX2 (`node8::has_avx2`).
    #[inline(always)]
    pub(crate) unsafe fn test<const AVX2: bool>(&self, shear: &Shear, lanes: u32, tmin: f32, tmax: f32) -> Block {
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // Written out, not `array::map`: in a large AVX2 walk the
            // maps stayed calls (6% of a cornell-box render).
            let row = |axis: usize| [self.v[axis][0].as_ptr(), self.v[axis][1].as_ptr(), self.v[axis][2].as_ptr()];
            let rows = [row(shear.k[0]), row(shear.k[1]), row(shear.k[2])];
            // SAFETY: AVX2 (this function's contract); each row is eight
            // floats, 32-byte aligned (`Leaf8` is 64-aligned, rows 32 bytes).
            return unsafe { lanes_avx2::<true>(rows, shear, lanes, tmin, tmax, |i| self.vertices(i)) };
        }
        let mut b = Block::default();
        let mut l = lanes;
        while l != 0 {
            let i = l.trailing_zeros() as usize;
            l &= l - 1;
            b.set_scalar(i, shear, &self.vertices(i), tmin, tmax);
        }
        b
    }
}

/// [`Shear::raw_always`]'s operations on eight triangles with AVX2, lane
/// by lane in the same order (no fused multiply-add): `rows[j][v]` points
/// at eight floats, coordinate `shear.k[j]` of vertex `v` of each lane
/// (32-byte aligned where `ALIGNED`); lanes whose edge functions are
/// exactly zero are finished by the scalar test on `vertices(i)`.
///
/// Always inlined, so that in the AVX2-compiled walks (`closest_avx2`,
/// `any_avx2`) its intrinsics become single instructions with no call
/// and no `Block` through memory (as a `target_feature` function it
/// stayed out of line at some call sites: 7% of a render).
///
/// # Safety
/// The CPU must support AVX2; every row pointer has eight readable floats,
/// 32-byte aligned where `ALIGNED`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn lanes_avx2<const ALIGNED: bool>(
    rows: [[*const f32; 3]; 3],
    shear: &Shear,
    lanes: u32,
    tmin: f32,
    tmax: f32,
    vertices: impl Fn(usize) -> [Vec3A; 3],
) -> Block {
    use std::arch::x86_64::{
        __m256, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_NEQ_UQ, _mm256_add_ps, _mm256_and_ps,
        _mm256_andnot_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_load_ps, _mm256_loadu_ps, _mm256_movemask_ps,
        _mm256_mul_ps, _mm256_or_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps, _mm256_sub_ps,
    };
    // SAFETY: the CPU has AVX2 (this function's contract); the loads read
    // eight floats behind each row pointer (aligned where `ALIGNED`), the
    // stores write one [f32; 8] each.
    unsafe {
        let [ox, oy, oz] = shear.org_k.map(|o| _mm256_set1_ps(o));
        let [sx, sy, sz] = shear.s.map(|s| _mm256_set1_ps(s));
        macro_rules! load {
            ($p:expr) => {
                if ALIGNED { _mm256_load_ps($p) } else { _mm256_loadu_ps($p) }
            };
        }
        // `rel` then the shear, as `Shear::raw_always`.
        let (mut x, mut y, mut z) = ([_mm256_setzero_ps(); 3], [_mm256_setzero_ps(); 3], [_mm256_setzero_ps(); 3]);
        for j in 0..3 {
            let (rx, ry, rz) = (
                _mm256_sub_ps(load!(rows[0][j]), ox),
                _mm256_sub_ps(load!(rows[1][j]), oy),
                _mm256_sub_ps(load!(rows[2][j]), oz),
            );
            x[j] = _mm256_sub_ps(rx, _mm256_mul_ps(sx, rz));
            y[j] = _mm256_sub_ps(ry, _mm256_mul_ps(sy, rz));
            z[j] = rz;
        }
        let ([ax, bx, cx], [ay, by, cy], [az, bz, cz]) = (x, y, z);
        let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
        let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
        let vv = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
        let zero = _mm256_setzero_ps();
        let or3 = |a: __m256, b: __m256, c: __m256| _mm256_or_ps(_mm256_or_ps(a, b), c);
        let exact = or3(
            _mm256_cmp_ps::<_CMP_EQ_OQ>(u, zero),
            _mm256_cmp_ps::<_CMP_EQ_OQ>(vv, zero),
            _mm256_cmp_ps::<_CMP_EQ_OQ>(w, zero),
        );
        let exact = _mm256_movemask_ps(exact) as u32 & lanes;
        let neg = or3(
            _mm256_cmp_ps::<_CMP_LT_OQ>(u, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(vv, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(w, zero),
        );
        let pos = or3(
            _mm256_cmp_ps::<_CMP_GT_OQ>(u, zero),
            _mm256_cmp_ps::<_CMP_GT_OQ>(vv, zero),
            _mm256_cmp_ps::<_CMP_GT_OQ>(w, zero),
        );
        let det = _mm256_add_ps(_mm256_add_ps(u, vv), w);
        let num = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(u, sz), az), _mm256_mul_ps(_mm256_mul_ps(vv, sz), bz)),
            _mm256_mul_ps(_mm256_mul_ps(w, sz), cz),
        );
        let t = _mm256_div_ps(num, det);
        // Rust's `det != 0.0` is true for NaN: the unordered comparison.
        let crossed = _mm256_andnot_ps(_mm256_and_ps(neg, pos), _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero));
        let within = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(t, _mm256_set1_ps(tmin)),
            _mm256_cmp_ps::<_CMP_LE_OQ>(t, _mm256_set1_ps(tmax)),
        );
        let mut b = Block {
            hit: _mm256_movemask_ps(_mm256_and_ps(crossed, within)) as u32 & lanes & !exact,
            ..Block::default()
        };
        _mm256_storeu_ps(b.t.as_mut_ptr(), t);
        _mm256_storeu_ps(b.w1.as_mut_ptr(), vv);
        _mm256_storeu_ps(b.w2.as_mut_ptr(), w);
        _mm256_storeu_ps(b.det.as_mut_ptr(), det);
        let mut l = exact;
        while l != 0 {
            let i = l.trailing_zeros() as usize;
            l &= l - 1;
            b.set_scalar(i, shear, &vertices(i), tmin, tmax);
        }
        b
    }
}

/// Whether the infinite line through `o` along `d` misses the box of
/// centre `c` and half-extents `h`: the box and the line project apart on
/// one of the axes `e_i × d` (the line projects to a point there, the box
/// to an interval of radius `h_j |d_k| + h_k |d_j|`; Ericson, *Real-Time
/// Collision Detection*, §5.3.3). No division, no BVH state: most global
/// lines that miss a scene are rejected here.
#[inline]
pub(crate) fn line_misses_box(o: Vec3A, d: Vec3A, (c, h): (Vec3A, Vec3A)) -> bool {
    let w = o - c;
    let m = w.cross(d).abs();
    let a = d.abs();
    let r = Vec3A::new(h.y * a.z + h.z * a.y, h.x * a.z + h.z * a.x, h.x * a.y + h.y * a.x);
    m.cmpgt(r).any()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lines::LineRng;
    use crate::scene::built_in;
    use crate::tracer::node8::has_avx2;

    /// Every lane of a block, AVX2 or not, from the BVH-ordered arrays or
    /// a [`Leaf8`], is the scalar test's answer to
    /// the bit (`t`, crossed within `[tmin, tmax]`, barycentrics), for
    /// random rays and for rays along the axes from grid points, which
    /// meet vertices and edges exactly (the edge functions' exact zeros).
    #[test]
    fn blocks_match_the_scalar_test() {
        let mut crossed = 0u64;
        for spec in ["cornell-box", "cube-enclosure:4", "geosphere"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let tris = &p.triangles;
            let lanes = TriangleLanes::new(tris);
            for i in 0..3_000u64 {
                let r = LineRng::new(17, i);
                let grid = |k: u32| (r.uniform(k) * 8.0).floor() / 8.0 - 0.5;
                let (o, d) = if i % 2 == 0 {
                    let o = DVec3::new(grid(0), grid(1), grid(2));
                    let mut d = DVec3::ZERO;
                    d[(i / 2 % 3) as usize] = if i % 4 == 0 { 1.0 } else { -1.0 };
                    (o, d)
                } else {
                    let o = DVec3::new(r.uniform(0), r.uniform(1), r.uniform(2)) - 0.5;
                    (o, DVec3::new(r.uniform(3) - 0.5, r.uniform(4) - 0.5, r.uniform(5) - 0.5).normalize())
                };
                let l = Line::ray(o, d, 0.0, 0.2 + r.uniform(6));
                let (shear, _) = Shear::of(&l);
                for first in (0..tris.len()).step_by(BLOCK) {
                    let n = (tris.len() - first).min(BLOCK);
                    let all = (1u32 << n) - 1;
                    let mut leaf = Leaf8::EMPTY;
                    for k in 0..n {
                        leaf.set(k, (first + k) as u32, &tris[first + k]);
                    }
                    // SAFETY: `true` only where the CPU has AVX2.
                    let blocks = unsafe {
                        [
                            Some(lanes.block::<false>(tris, &shear, first, all, l.tmin, l.tmax)),
                            has_avx2().then(|| lanes.block::<true>(tris, &shear, first, all, l.tmin, l.tmax)),
                            Some(leaf.test::<false>(&shear, all, l.tmin, l.tmax)),
                            has_avx2().then(|| leaf.test::<true>(&shear, all, l.tmin, l.tmax)),
                        ]
                    };
                    for b in blocks.iter().flatten() {
                        for k in 0..n {
                            let (t, within) = shear.hit_within(&tris[first + k], l.tmin, l.tmax);
                            assert_eq!(b.hit >> k & 1 == 1, within, "{spec} ray {i} triangle {}", first + k);
                            if within {
                                crossed += 1;
                                assert_eq!(b.t[k].to_bits(), t.to_bits());
                                let (_, bary) = shear.hit_barycentric(&tris[first + k]).unwrap();
                                assert_eq!(barycentric(b.numerators(k)).map(f32::to_bits), bary.map(f32::to_bits));
                            }
                        }
                    }
                }
            }
        }
        assert!(crossed > 1_000, "only {crossed} crossings compared");
    }
}
