//! The CPU backend: an obvhs compressed wide BVH over triangle bounds and
//! the watertight test for each candidate.

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;

use super::node8::{self, Tally};
use super::packet::{self, LANES};
use super::stream;
use super::tree8::{self, Tree8};
use super::watertight::{
    BLOCK, Block, Shear, TriangleLanes, barycentric, before, finish, finish_two, line_misses_box, mask_blocks,
    push_crossing, sphere_crossings, sphere_hit, walk_direction,
};
use super::wide8::{self, Wide8};
use super::{BackendError, Crossing, CrossingBuffer, Hit, Prepared, Tracer};
use crate::lines::Line;

/// Triangle boxes and build parameters shared by the CPU and Vulkan BVHs:
/// obvhs's medium preset with `search_depth_threshold = 0` (measured 10×
/// faster on tessellated walls: `docs/TRACING.md`), and boxes padded by 1e-5
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

/// The CPU backend's BVH over `scene`'s triangles with `params`. With
/// `params.pre_split`, large triangles are first split into several boxes
/// fitted to their parts (obvhs's `split_aabbs_preset`, the spatial split
/// of pbrt's SBVH and Embree's high-quality builder, done before the
/// build): a triangle may then sit in several leaves, and the walks meet
/// it once per leaf (the same `t` each time, so closest hits, occlusion
/// and `trace_all`'s merged crossings are unchanged). Every box, split or
/// not, is padded as [`bvh_input`]'s. (The tracer itself keeps the binary
/// tree for [`Tree8`] too: [`CpuTracer::with_params`].)
#[cfg(test)]
pub(crate) fn build_bvh(scene: &Prepared, params: obvhs::BvhBuildParams) -> CwBvh {
    cwbvh_of(&build_bvh2(scene, params), params)
}

/// The binary tree [`build_bvh`] collapses: obvhs's `build_cwbvh` up to
/// its collapse, step for step (PLOC, then reinsertion), so that the
/// CWBVH is the one `build_cwbvh` builds.
pub(super) fn build_bvh2(scene: &Prepared, params: obvhs::BvhBuildParams) -> obvhs::bvh2::Bvh2 {
    use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
    use obvhs::ploc::PlocBuilder;
    let (mut aabbs, _) = bvh_input(scene);
    let mut indices: Vec<u32> = (0..aabbs.len() as u32).collect();
    if params.pre_split {
        let tris: Vec<obvhs::triangle::Triangle> =
            scene.triangles.iter().map(|&[v0, v1, v2]| obvhs::triangle::Triangle { v0, v1, v2 }).collect();
        // Split the unpadded boxes (as obvhs's own `build_cwbvh_from_tris`), then pad every part.
        let mut boxes: Vec<Aabb> = tris.iter().map(|t| t.aabb()).collect();
        let (largest, sum) = boxes.iter().fold((0.0f32, 0.0f32), |(m, s), b| (m.max(b.half_area()), s + b.half_area()));
        obvhs::splits::split_aabbs_preset(&mut boxes, &mut indices, &tris, sum / tris.len() as f32, largest);
        aabbs.clear();
        let pad = Vec3A::splat(1e-5);
        aabbs.extend(boxes.iter().map(|b| Aabb { min: b.min - pad, max: b.max + pad }));
    }
    let mut bvh2 = PlocBuilder::with_capacity(aabbs.len()).build(
        params.ploc_search_distance,
        &aabbs,
        indices,
        params.sort_precision,
        params.search_depth_threshold,
    );
    bvh2.uses_spatial_splits = params.pre_split;
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    bvh2
}

/// `bvh2` collapsed into obvhs's CWBVH, as `build_cwbvh` does.
pub(super) fn cwbvh_of(bvh2: &obvhs::bvh2::Bvh2, params: obvhs::BvhBuildParams) -> CwBvh {
    obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(bvh2, params.max_prims_per_leaf.clamp(1, 3), true, false)
}

/// The CPU backend.
#[derive(Clone)]
pub struct CpuTracer {
    scene: Prepared,
    bvh: Option<CwBvh>,
    /// The triangles in BVH order (`ordered[k]` is triangle
    /// `bvh.primitive_indices[k]`): a leaf's candidates lie side by side in
    /// memory instead of behind an indirection each.
    ordered: Vec<[Vec3A; 3]>,
    /// `ordered` as a structure of arrays for the 8-wide triangle test of
    /// the CWBVH walk, built at its first use: only where neither
    /// [`Tree8`] nor [`Wide8`] serves the single-ray walks (36 B a
    /// triangle not held otherwise).
    lanes: std::sync::OnceLock<TriangleLanes>,
    /// `bvh` uncompressed (`wide8.rs`): the tree the occlusion packets and
    /// `trace_all`'s ray-stream walk read (and the single-ray walks where
    /// `tree` is `None`), built at the first call that needs it; `None`
    /// inside where [`Wide8::new`] declines, and the CWBVH walks serve.
    wide: std::sync::OnceLock<Option<Wide8>>,
    /// The single-ray walks' tree (`tree8.rs`: leaves of up to eight
    /// triangles in one block each), collapsed from the same binary tree
    /// as `bvh`, when the tracer is built; `None` where [`Tree8::new`]
    /// declines, and `wide`'s walk serves (or the CWBVH's).
    tree: Option<Tree8>,
    /// What `trace_all`'s ray-stream walk records of each crossing, in
    /// BVH order ([`Recorded`]), built at its first call.
    recorded: std::sync::OnceLock<Vec<Recorded>>,
    /// Whether the 8-lane AVX2 node test is used (`node8`).
    avx2: bool,
    /// Whether `trace_all` walks the batch as a ray stream (`stream.rs`):
    /// AVX2 and a triangle scene.
    stream: bool,
    /// Centre and half-extents of the box around every triangle, padded.
    bounds: (Vec3A, Vec3A),
}

/// The single-ray walks' trees ([`CpuTracer::walk_kind`]): obvhs's CWBVH
/// (`node8::walk_groups`), the CWBVH decoded into wide nodes (`wide8.rs`),
/// the tree collapsed for these walks (`tree8.rs`).
const CWBVH: u8 = 0;
/// See [`CWBVH`].
const WIDE8: u8 = 1;
/// See [`CWBVH`].
const TREE8: u8 = 2;

/// What a crossing of the triangle at BVH position `k` records besides
/// its `t` ([`Crossing`]): the triangle's front normal, patch and index,
/// laid out in BVH order as [`CpuTracer`]'s `ordered` triangles are. A
/// leaf's crossings then read one or two neighbouring cache lines, where
/// `primitive_indices[k]` and then `normals`/`triangle_patch` at that
/// index were two dependent misses per crossing (with the pair matrix
/// sweeping the caches between batches).
#[derive(Clone, Copy)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
struct Recorded {
    normal: [f32; 3],
    patch: u32,
    primitive: u32,
}

impl Recorded {
    /// The crossing at `t` of a line along `dir` (as [`push_crossing`]
    /// records it: `cos` is the normal's dot product with `dir`, glam's
    /// `(x·x' + y·y') + z·z'` on the same three components). Written out
    /// on the three: glam's four-lane product read the `patch` after the
    /// normal as a fourth lane, a subnormal `f32`, and a product of it with
    /// a nonzero fourth lane of `dir` took a microcode assist (~70% of the
    /// recording loop in some builds).
    #[inline]
    fn crossing(&self, dir: Vec3A, t: f32) -> Crossing {
        let [x, y, z] = self.normal;
        Crossing { t, patch: self.patch, cos: (x * dir.x + y * dir.y) + z * dir.z, primitive: self.primitive }
    }
}

/// Padding of [`CpuTracer`]'s bounding box (normalised units): far above
/// the f32 rounding of the line–box test and of the triangle test (~1e-7 at
/// the scene's scale of 1), so a line the test puts outside crosses nothing.
const BOUNDS_PAD: f32 = 1e-4;

/// [`Tracer::batch_lines`] of the CPU backend: the ray-stream walk's
/// vectors fill better the more lines share a node (1,024 lines a batch
/// left half of each eight-line vector empty on `cube-enclosure:30`;
/// 16,384, ~4%), and a leaf's list most: at 16,384 a leaf of
/// `cube-enclosure:30` met ~4 lines a visit, half a vector. 65,536 lines
/// (~8 MB of the walk's buffers a thread) took 5–10% less CPU time at
/// 10^8 lines than 16,384; 262,144 took 10–20% more (out of cache).
const BATCH_LINES: usize = 65_536;

impl CpuTracer {
    /// Builds the BVH over the scene's triangles.
    #[must_use]
    pub fn new(scene: &Prepared) -> Self {
        Self::with_params(scene, bvh_input(scene).1)
    }

    /// [`CpuTracer::new`] with the BVH built with `params` ([`build_bvh`]).
    pub(crate) fn with_params(scene: &Prepared, params: obvhs::BvhBuildParams) -> Self {
        let bvh2 = (!scene.triangles.is_empty()).then(|| build_bvh2(scene, params));
        let bvh = bvh2.as_ref().map(|b| cwbvh_of(b, params));
        let tree = bvh2.and_then(|b| Tree8::new(&b, &scene.triangles, tree8::MAX_LEAF));
        let ordered: Vec<[Vec3A; 3]> = bvh
            .as_ref()
            .map(|b| b.primitive_indices.iter().map(|&i| scene.triangles[i as usize]).collect())
            .unwrap_or_default();
        let (lo, hi) = scene
            .triangles
            .iter()
            .flatten()
            .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        let bounds = ((lo + hi) * 0.5, (hi - lo) * 0.5 + BOUNDS_PAD);
        let avx2 = node8::has_avx2();
        let stream = avx2 && scene.sphere.is_none();
        let lanes = std::sync::OnceLock::new();
        let (wide, recorded) = (std::sync::OnceLock::new(), std::sync::OnceLock::new());
        Self { scene: scene.clone(), bvh, ordered, lanes, wide, tree, recorded, avx2, stream, bounds }
    }

    /// The uncompressed tree, built at the first call.
    #[inline]
    pub(super) fn wide(&self) -> Option<&Wide8> {
        self.wide.get_or_init(|| self.bvh.as_ref().and_then(|b| Wide8::new(b, &self.ordered))).as_ref()
    }

    /// The first crossing of one line: the walk shrinks the interval as hits
    /// are found, and ties in `t` go to the smaller triangle. Each node's
    /// leaf triangles are tested eight at a time (a [`Tree8`] leaf's block,
    /// [`Wide8::leaf_blocks`] on the decoded tree's walk, or
    /// [`TriangleLanes::block`] on the CWBVH walk; [`Shear::hit`]'s
    /// arithmetic per lane), and the best one's
    /// barycentric numerators are kept from its block, not recomputed, and
    /// divided once the walk ends (the same [`Hit`] as [`triangle_hit`](super::watertight::triangle_hit)'s,
    /// to the bit).
    pub(crate) fn closest(&self, l: &Line) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `self.avx2` came from `has_avx2()`.
            return unsafe { self.closest_avx2(l) };
        }
        match self.walk_kind() {
            TREE8 => self.closest_with::<false, TREE8>(l, &()),
            WIDE8 => self.closest_with::<false, WIDE8>(l, &()),
            _ => self.closest_with::<false, CWBVH>(l, &()),
        }
    }

    /// [`CpuTracer::closest`] compiled for AVX2, the walk, the triangle
    /// blocks and the bookkeeping in one function.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn closest_avx2(&self, l: &Line) -> Option<Hit> {
        if self.tree.is_some() {
            return self.closest_with::<true, TREE8>(l, &());
        }
        // SAFETY: as this function's.
        unsafe { self.closest_fallback_avx2(l) }
    }

    /// [`CpuTracer::closest_avx2`] where [`Tree8::new`] declined: out of
    /// line, so that the walk above stays small.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    #[cold]
    unsafe fn closest_fallback_avx2(&self, l: &Line) -> Option<Hit> {
        match self.walk_kind() {
            WIDE8 => self.closest_with::<true, WIDE8>(l, &()),
            _ => self.closest_with::<true, CWBVH>(l, &()),
        }
    }

    /// Which tree the single-ray walks read: [`TREE8`] where it was
    /// built, else [`WIDE8`] where [`Wide8::new`] accepts, else [`CWBVH`].
    #[inline]
    fn walk_kind(&self) -> u8 {
        if self.tree.is_some() {
            TREE8
        } else if self.wide().is_some() {
            WIDE8
        } else {
            CWBVH
        }
    }

    /// The closest hit with the AVX2 tests or not, walking the tree `WALK`
    /// ([`CpuTracer::walk_kind`]; `None` if that tree is absent): one walk
    /// per instance, so that the leaf closure is inlined into the AVX2
    /// caller.
    #[inline(always)]
    fn closest_with<const AVX2: bool, const WALK: u8>(&self, l: &Line, tally: &impl Tally) -> Option<Hit> {
        if let Some(s) = &self.scene.sphere {
            return sphere_hit(s, l);
        }
        let bvh = self.bvh.as_ref()?;
        let (shear, dir) = Shear::of(l);
        let mut best: Option<(f32, u32)> = None;
        let mut numerators = [0.0f32; 3];
        let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
        // SAFETY: `AVX2` is true only in `closest_avx2`, entered after `has_avx2()`.
        unsafe {
            if WALK == TREE8 {
                let w = self.tree.as_ref()?;
                tree8::walk::<AVX2, true, _>(w, &ray, tally, |leaf, lanes, tmax| {
                    let block = leaf.test::<AVX2>(&shear, lanes, l.tmin, l.tmax);
                    keep_best(&block, |i| leaf.tri[i], &mut best, &mut numerators, tmax);
                    false
                });
            } else if WALK == WIDE8 {
                let w = self.wide()?;
                wide8::walk_nodes::<AVX2, true, _>(w, &ray, tally, |n, mask, tmax| {
                    w.leaf_blocks::<AVX2>(n, mask, &shear, l.tmin, l.tmax, tally, |block, leaf| {
                        keep_best(block, |i| leaf.tri[i], &mut best, &mut numerators, tmax);
                        false
                    })
                });
            } else {
                node8::walk_groups::<AVX2, _>(bvh, &ray, tally, |first, mask, tmax| {
                    self.blocks::<AVX2>(&shear, l, first, mask, tally, |block, base| {
                        keep_best(block, |i| bvh.primitive_indices[base + i], &mut best, &mut numerators, tmax);
                        false
                    })
                });
            }
        }
        best.map(|(t, tri)| {
            let n = self.scene.normals[tri as usize];
            Hit {
                t,
                patch: self.scene.triangle_patch[tri as usize],
                primitive: tri,
                cos: n.dot(dir),
                barycentric: barycentric(numerators),
                normal: n.into(),
            }
        })
    }

    /// Whether `l` crosses anything: the walk ends at the first block with
    /// a crossing.
    fn any(&self, l: &Line) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `self.avx2` came from `has_avx2()`.
            return unsafe { self.any_avx2(l) };
        }
        match self.walk_kind() {
            TREE8 => self.any_with::<false, TREE8>(l, &()),
            WIDE8 => self.any_with::<false, WIDE8>(l, &()),
            _ => self.any_with::<false, CWBVH>(l, &()),
        }
    }

    /// [`CpuTracer::any`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn any_avx2(&self, l: &Line) -> bool {
        if self.tree.is_some() {
            return self.any_with::<true, TREE8>(l, &());
        }
        // SAFETY: as this function's.
        unsafe { self.any_fallback_avx2(l) }
    }

    /// [`CpuTracer::any_avx2`] where [`Tree8::new`] declined: out of
    /// line, so that the walk above stays small.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    #[cold]
    unsafe fn any_fallback_avx2(&self, l: &Line) -> bool {
        match self.walk_kind() {
            WIDE8 => self.any_with::<true, WIDE8>(l, &()),
            _ => self.any_with::<true, CWBVH>(l, &()),
        }
    }

    /// Occlusion, as [`CpuTracer::closest_with`].
    #[inline(always)]
    fn any_with<const AVX2: bool, const WALK: u8>(&self, l: &Line, tally: &impl Tally) -> bool {
        if let Some(s) = &self.scene.sphere {
            return sphere_hit(s, l).is_some();
        }
        let Some(bvh) = &self.bvh else { return false };
        let (shear, dir) = Shear::of(l);
        let mut hit = false;
        let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
        // SAFETY: `AVX2` is true only in `any_avx2`, entered after `has_avx2()`.
        unsafe {
            // Any crossing ends the walk: the nodes in no order.
            if WALK == TREE8 {
                let Some(w) = &self.tree else { return false };
                tree8::walk::<AVX2, false, _>(w, &ray, tally, |leaf, lanes, _| {
                    hit = leaf.test::<AVX2>(&shear, lanes, l.tmin, l.tmax).hit != 0;
                    hit
                });
            } else if WALK == WIDE8 {
                let Some(w) = self.wide() else { return false };
                wide8::walk_nodes::<AVX2, false, _>(w, &ray, tally, |n, mask, _| {
                    hit = w.leaf_blocks::<AVX2>(n, mask, &shear, l.tmin, l.tmax, tally, |block, _| block.hit != 0);
                    hit
                });
            } else {
                node8::walk_groups::<AVX2, _>(bvh, &ray, tally, |first, mask, _| {
                    hit = self.blocks::<AVX2>(&shear, l, first, mask, tally, |block, _| block.hit != 0);
                    hit
                });
            }
        }
        hit
    }

    /// Tests a node's primitive group (primitive `first + i` for each bit
    /// `i` of `mask`, below 24) against `l`, a [`Block`] of up to eight
    /// triangles at a time, handing each to `each(block, first triangle)`;
    /// stops, returning `true`, when `each` does.
    #[inline(always)]
    fn blocks<const AVX2: bool>(
        &self,
        shear: &Shear,
        l: &Line,
        first: u32,
        mask: u32,
        tally: &impl Tally,
        mut each: impl FnMut(&Block, usize) -> bool,
    ) -> bool {
        let soa = self.lanes.get_or_init(|| TriangleLanes::new(&self.ordered));
        for (b, lanes) in mask_blocks(mask) {
            let base = first as usize + (b as usize) * BLOCK;
            tally.triangles(lanes);
            // SAFETY: `AVX2` is true only in the `*_avx2` callers, entered after `has_avx2()`.
            let block = unsafe { soa.block::<AVX2>(&self.ordered, shear, base, lanes, l.tmin, l.tmax) };
            if each(&block, base) {
                return true;
            }
        }
        false
    }
}

/// Keeps the closest crossing of `block` in `best` (smallest `t`, ties to
/// the smaller triangle: [`before`]), lane `i` being triangle `tri(i)`,
/// with its barycentric numerators, and shrinks `tmax` to it.
#[inline(always)]
fn keep_best(
    block: &Block,
    tri: impl Fn(usize) -> u32,
    best: &mut Option<(f32, u32)>,
    numerators: &mut [f32; 3],
    tmax: &mut f32,
) {
    let mut h = block.hit;
    while h != 0 {
        let i = h.trailing_zeros() as usize;
        h &= h - 1;
        let t = block.t[i];
        let tri = tri(i);
        if before(t, tri, *best) {
            *best = Some((t, tri));
            *numerators = block.numerators(i);
        }
        if t < *tmax {
            *tmax = t;
        }
    }
}

/// The walk stacks of [`CpuTracer::occluded_group`]: one packet's lanes
/// (8 bits a node) and a pair's (16 bits).
struct Stacks {
    narrow: Vec<(u32, u8)>,
    wide: Vec<(u32, u16)>,
}

impl CpuTracer {
    /// Occlusion of up to `2 ·` [`LANES`] lines, appended to `out`: two
    /// packets walked together ([`packet::occluded_pair`]) where both
    /// halves make packets (`packet.rs`) in one octant, the CPU has
    /// AVX-512F and the wide tree is built; else each half as one packet
    /// ([`packet::occluded`]) where it makes one (AVX2, a triangle scene,
    /// at least two lines in one octant); else line by line. Each answer
    /// is [`CpuTracer::any`]'s.
    fn occluded_group(&self, group: &[Line], stacks: &mut Stacks, out: &mut Vec<bool>) {
        #[cfg(target_arch = "x86_64")]
        {
            let (first, rest) = group.split_at(group.len().min(LANES));
            let packets = [self.packet(first), if rest.is_empty() { None } else { self.packet(rest) }];
            if let ([Some((_, a)), Some((_, b))], true, Some(wide)) = (&packets, stream::has_avx512(), self.wide())
                // SAFETY: `packet` checked `self.avx2` (from `has_avx2()`), `has_avx512` AVX-512F.
                && let Some(done) = unsafe { packet::occluded_pair(wide, &self.ordered, a, b, &mut stacks.wide) }
            {
                out.extend((0..group.len()).map(|i| done >> i & 1 == 1));
                return;
            }
            for (half, packet) in [first, rest].into_iter().zip(packets) {
                if let Some((bvh, p)) = packet {
                    // SAFETY: `packet` checked `self.avx2`, which came from `has_avx2()`.
                    let done = unsafe { packet::occluded(bvh, self.wide(), &self.ordered, &p, &mut stacks.narrow) };
                    out.extend((0..p.len()).map(|i| done >> i & 1 == 1));
                } else {
                    out.extend(half.iter().map(|l| self.any(l)));
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = stacks;
            out.extend(group.iter().map(|l| self.any(l)));
        }
    }

    /// Closest hits of up to [`LANES`] coherent lines as one packet, as
    /// [`CpuTracer::occluded_packet`]; each answer is [`CpuTracer::closest`]'s.
    fn closest_packet(&self, lines: &[Line], stack: &mut Vec<(u32, u8)>, out: &mut Vec<Option<Hit>>) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some((bvh, p)) = self.packet(lines) {
            // SAFETY: as in `occluded_packet`.
            let best = unsafe { packet::closest(bvh, self.wide(), &self.ordered, &bvh.primitive_indices, &p, stack) };
            best.hits(&self.scene, lines, out);
            return true;
        }
        let _ = (lines, stack, out);
        false
    }

    /// The BVH and the packet of `lines`, where a packet applies: AVX2, a
    /// triangle scene, and at least two lines in one octant.
    #[cfg(target_arch = "x86_64")]
    fn packet<'a>(&self, lines: &'a [Line]) -> Option<(&CwBvh, packet::Packet<'a>)> {
        let bvh = self.bvh.as_ref()?;
        if !self.avx2 || self.scene.sphere.is_some() {
            return None;
        }
        Some((bvh, packet::Packet::new(lines)?))
    }
}

impl CpuTracer {
    /// [`Tracer::trace_all`] one line at a time, appended to `out`.
    fn trace_single(&self, lines: &[Line], out: &mut CrossingBuffer) {
        let mut hits = Vec::with_capacity(16);
        for l in lines {
            if let Some(s) = &self.scene.sphere {
                sphere_crossings(s, l, &mut hits);
            } else if let Some(bvh) = &self.bvh
                && !line_misses_box(Vec3A::from(l.origin), Vec3A::from(l.direction), self.bounds)
            {
                let (shear, dir) = Shear::of(l);
                let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
                node8::traverse(bvh, &ray, self.avx2, |k, _| {
                    if let Some(t) = shear.hit(&self.ordered[k as usize])
                        && t >= l.tmin
                        && t <= l.tmax
                    {
                        push_crossing(&self.scene, dir, t, bvh.primitive_indices[k as usize] as usize, &mut hits);
                    }
                    false
                });
            }
            finish(&mut hits, out);
        }
    }
}

impl CpuTracer {
    /// What `trace_all` records of each crossing, in BVH order.
    #[cfg(target_arch = "x86_64")]
    fn recorded(&self, bvh: &CwBvh) -> &[Recorded] {
        self.recorded.get_or_init(|| {
            let s = &self.scene;
            let of = |i: usize| Recorded {
                normal: s.normals[i].to_array(),
                patch: s.triangle_patch[i],
                primitive: i as u32,
            };
            bvh.primitive_indices.iter().map(|&i| of(i as usize)).collect()
        })
    }

    /// [`Tracer::trace_all`] by the ray-stream walk over the wide nodes
    /// (`stream.rs`; node tests of sixteen lines with `sixteen`, which
    /// needs AVX-512F): each line's crossings sorted and merged as the
    /// single walk's are ([`finish`]). Without AVX2 and FMA, or where
    /// [`Wide8::new`] declines the tree, the single walk finds the same
    /// crossings.
    #[cfg(target_arch = "x86_64")]
    fn trace_stream(&self, bvh: &CwBvh, lines: &[Line], out: &mut CrossingBuffer, sixteen: bool) {
        let tree = match self.wide() {
            Some(tree) if stream::has_walk_features() => tree,
            _ => return self.trace_single(lines, out),
        };
        let recorded = self.recorded(bvh);
        let sixteen = sixteen && stream::has_avx512();
        // A caller's batch is walked [`BATCH_LINES`] lines at a time: the
        // buffers (kept per thread) and their `u32` indices stay bounded
        // whatever the batch; each line's crossings are its own.
        let mut hits = Vec::with_capacity(16);
        STREAM.with_borrow_mut(|s| {
            for lines in lines.chunks(BATCH_LINES) {
                // SAFETY: AVX2, FMA and POPCNT were detected
                // (`has_walk_features`), AVX-512F where `sixteen`.
                unsafe { stream::trace(tree, &self.ordered, lines, self.bounds, sixteen, s) };
                // The lines not walked (outside the scene's box) cross
                // nothing: their ends are the next line's start.
                let base = out.offsets.len();
                let skip_to = |id: usize, out: &mut CrossingBuffer| {
                    let len = out.crossings.len() as u32;
                    out.offsets.resize(base + id, len);
                };
                for (&id, w) in s.ids.iter().zip(s.first.windows(2)) {
                    let id = id as usize;
                    skip_to(id, out);
                    let dir = walk_direction(&lines[id]);
                    let found = &s.found[w[0] as usize..w[1] as usize];
                    // Each crossing's record asked for eight crossings
                    // ahead (in a walk's megabytes, a miss in L1 and L2).
                    for &(k, _) in s.found.iter().skip(w[0] as usize + AHEAD).take(found.len()) {
                        stream::prefetch(recorded.as_ptr().wrapping_add(k as usize));
                    }
                    if let &[(ka, ta), (kb, tb)] = found {
                        let (a, b) = (recorded[ka as usize].crossing(dir, ta), recorded[kb as usize].crossing(dir, tb));
                        finish_two(a, b, out);
                    } else {
                        hits.extend(found.iter().map(|&(k, t)| recorded[k as usize].crossing(dir, t)));
                        finish(&mut hits, out);
                    }
                }
                skip_to(lines.len(), out);
            }
        });
    }
}

/// Crossings ahead of the one recorded whose [`Recorded`] is prefetched.
#[cfg(target_arch = "x86_64")]
const AHEAD: usize = 8;

#[cfg(target_arch = "x86_64")]
thread_local! {
    /// The ray-stream walk's buffers, kept between batches on each thread.
    static STREAM: std::cell::RefCell<stream::Scratch> = std::cell::RefCell::default();
}

impl Tracer for CpuTracer {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn batch_lines(&self) -> usize {
        BATCH_LINES
    }

    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        out.clear();
        #[cfg(target_arch = "x86_64")]
        if self.stream
            && let Some(bvh) = &self.bvh
        {
            self.trace_stream(bvh, lines, out, true);
            return Ok(());
        }
        self.trace_single(lines, out);
        Ok(())
    }

    fn closest_hit(&self, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
        out.clear();
        let mut stack = Vec::with_capacity(256);
        for chunk in lines.chunks(LANES) {
            if !self.closest_packet(chunk, &mut stack, out) {
                out.extend(chunk.iter().map(|l| self.closest(l)));
            }
        }
        Ok(())
    }

    fn occluded(&self, lines: &[Line], out: &mut Vec<bool>) -> Result<(), BackendError> {
        out.clear();
        let mut stacks = Stacks { narrow: Vec::with_capacity(256), wide: Vec::with_capacity(256) };
        for group in lines.chunks(2 * LANES) {
            self.occluded_group(group, &mut stacks, out);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::lines::{LineRng, global_line};
    use crate::scene::built_in;
    use crate::tracer::ReferenceTracer;

    /// The ray-stream walk, eight and sixteen lines a node test, finds
    /// exactly the single walk's crossings (and the reference's), bit for
    /// bit, on scenes with shared edges, occluders, open edges and thin
    /// parts, for global lines and lines grazing the box.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn stream_walk_finds_the_single_walks_crossings() {
        if !node8::has_avx2() {
            return;
        }
        for spec in ["cube-enclosure:12", "cubes-room:64", "table-chairs:2", "geosphere", "cornell-box"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let (cpu, reference) = (CpuTracer::new(&p), ReferenceTracer::new(&p));
            let mut lines: Vec<Line> = (0..4_000).map(|i| global_line(3, i, 1.1)).collect();
            // Rays from inside, some cut short.
            lines.extend((0..2_000u64).map(|i| {
                let r = LineRng::new(8, i);
                let o = DVec3::new(r.uniform(0), r.uniform(1), r.uniform(2)) * 0.8 - 0.4;
                let d = DVec3::new(r.uniform(3) - 0.5, r.uniform(4) - 0.5, r.uniform(5) - 0.5).normalize();
                Line::ray(o, d, 0.0, 2.0 * r.uniform(6))
            }));
            let bvh = cpu.bvh.as_ref().unwrap();
            let (mut a, mut b, mut c) =
                (CrossingBuffer::default(), CrossingBuffer::default(), CrossingBuffer::default());
            // Batches of odd sizes: partial vectors at every node.
            for batch in lines.chunks(777) {
                let (mut x, mut y, mut z) =
                    (CrossingBuffer::default(), CrossingBuffer::default(), CrossingBuffer::default());
                x.clear();
                cpu.trace_stream(bvh, batch, &mut x, false);
                y.clear();
                cpu.trace_single(batch, &mut y);
                z.clear();
                cpu.trace_stream(bvh, batch, &mut z, true);
                assert_eq!(x.offsets, y.offsets, "{spec}");
                assert_eq!(x.crossings, y.crossings, "{spec}");
                assert_eq!((&z.offsets, &z.crossings), (&x.offsets, &x.crossings), "{spec}");
                a.crossings.extend(x.crossings);
                b.crossings.extend(y.crossings);
            }
            reference.trace_all(&lines, &mut c).unwrap();
            assert!(c.crossings.len() > 2_000, "{spec}: too few crossings to compare");
            assert_eq!(a.crossings, c.crossings, "{spec}");
            // All the lines as one batch: leaves met by more than eight
            // lines at once (the sixteen-lane triangle test).
            let mut whole = CrossingBuffer::default();
            cpu.trace_stream(bvh, &lines, &mut whole, true);
            assert_eq!(whole.crossings, c.crossings, "{spec}");
        }
    }

    /// Time per global line of the single walk and the ray-stream walk
    /// (eight and, where the CPU has AVX-512F, sixteen lines a node test;
    /// best of 8), which must find the same crossings: a timing for
    /// `docs/TRACING.md`, run with `--release --ignored --nocapture`.
    #[cfg(target_arch = "x86_64")]
    #[test]
    #[ignore = "timing"]
    fn stream_timing() {
        if !node8::has_avx2() {
            return;
        }
        for spec in ["cube-enclosure:3", "cube-enclosure:30", "cubes-room:512", "cube-enclosure:100"] {
            let t = CpuTracer::new(&Prepared::new(&built_in(spec).unwrap()));
            let bvh = t.bvh.as_ref().unwrap();
            let n = 200_000;
            let lines: Vec<Line> = (0..n).map(|i| global_line(1, i, crate::visibility::SPHERE_SCALE)).collect();
            let mut best = [f64::MAX; 3];
            for _ in 0..8 {
                let mut out: [CrossingBuffer; 3] = Default::default();
                for (k, o) in out.iter_mut().enumerate() {
                    let clock = std::time::Instant::now();
                    for c in lines.chunks(BATCH_LINES) {
                        o.clear();
                        match k {
                            0 => t.trace_single(c, o),
                            _ => t.trace_stream(bvh, c, o, k == 2),
                        }
                    }
                    best[k] = best[k].min(clock.elapsed().as_secs_f64());
                }
                for o in &out[1..] {
                    assert_eq!((&o.offsets, &o.crossings), (&out[0].offsets, &out[0].crossings), "{spec}");
                }
            }
            let ns = |s: f64| s / n as f64 * 1e9;
            eprintln!(
                "{spec}: single walk {:.1} ns/line, stream of 8 {:.1} ns/line, stream of 16 {:.1} ns/line{}",
                ns(best[0]),
                ns(best[1]),
                ns(best[2]),
                if stream::has_avx512() { "" } else { " (no AVX-512F: 8)" },
            );
        }
    }

    /// A [`Tally`] that counts.
    #[derive(Default)]
    struct Counts {
        nodes: std::cell::Cell<u64>,
        triangles: std::cell::Cell<u64>,
        blocks: std::cell::Cell<u64>,
    }

    impl Tally for Counts {
        fn node(&self) {
            self.nodes.set(self.nodes.get() + 1);
        }
        fn triangles(&self, mask: u32) {
            self.triangles.set(self.triangles.get() + u64::from(mask.count_ones()));
            self.blocks.set(self.blocks.get() + 1);
        }
    }

    /// Per ray: nodes, triangles and 8-lane blocks tested.
    fn per_ray(c: &Counts, rays: usize) -> String {
        let per = |x: &std::cell::Cell<u64>| x.get() as f64 / rays as f64;
        format!("{:.2} nodes {:.2} tris {:.2} blocks", per(&c.nodes), per(&c.triangles), per(&c.blocks))
    }

    /// The single-ray walks of `t` over the tree `WALK`, counted, with
    /// their answers.
    fn counted<const WALK: u8>(
        t: &CpuTracer,
        closest: &[Line],
        shadow: &[Line],
    ) -> (String, String, Vec<Option<Hit>>, Vec<bool>) {
        let (c, s) = (Counts::default(), Counts::default());
        let hits: Vec<Option<Hit>> = closest.iter().map(|l| t.closest_with::<false, WALK>(l, &c)).collect();
        let blocked: Vec<bool> = shadow.iter().map(|l| t.any_with::<false, WALK>(l, &s)).collect();
        (per_ray(&c, closest.len()), per_ray(&s, shadow.len()), hits, blocked)
    }

    /// Best of 5 single walks (`closest`, `any`: AVX2 where the CPU has
    /// it, no packets) of each tracer in turn, ns per closest-hit and per
    /// shadow ray.
    fn single_walk_ns(tracers: &[&CpuTracer], closest: &[Line], shadow: &[Line]) -> Vec<(f64, f64)> {
        let mut best = vec![(f64::MAX, f64::MAX); tracers.len()];
        for _ in 0..5 {
            for (k, tracer) in tracers.iter().enumerate() {
                let clock = std::time::Instant::now();
                let n = closest.iter().filter(|l| tracer.closest(l).is_some()).count();
                best[k].0 = best[k].0.min(clock.elapsed().as_secs_f64() / closest.len() as f64 * 1e9);
                let clock = std::time::Instant::now();
                let m = shadow.iter().filter(|l| tracer.any(l)).count();
                best[k].1 = best[k].1.min(clock.elapsed().as_secs_f64() / shadow.len() as f64 * 1e9);
                assert!(n + m > 0);
            }
        }
        best
    }

    /// A tracer that records the lines a render asks about.
    struct Recorder {
        inner: CpuTracer,
        closest: std::sync::Mutex<Vec<Line>>,
        shadow: std::sync::Mutex<Vec<Line>>,
    }

    impl Tracer for Recorder {
        fn name(&self) -> &'static str {
            "recorder"
        }
        fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
            self.inner.trace_all(lines, out)
        }
        fn closest_hit(&self, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
            self.closest.lock().unwrap().extend_from_slice(lines);
            self.inner.closest_hit(lines, out)
        }
        fn occluded(&self, lines: &[Line], out: &mut Vec<bool>) -> Result<(), BackendError> {
            self.shadow.lock().unwrap().extend_from_slice(lines);
            self.inner.occluded(lines, out)
        }
    }

    /// The rays of a 64², 16-spp render of `spec` (seed 1, one thread):
    /// closest-hit and shadow rays, in the order the renderer asks.
    fn render_rays(spec: &str) -> (Prepared, Vec<Line>, Vec<Line>) {
        use crate::render::{Job, Sampling, Shading, render, views};
        let scene = built_in(spec).unwrap();
        let p = Prepared::new(&scene);
        let shading = Shading::new(&scene, &p).unwrap();
        let camera = views::default_camera(&scene);
        let rec = Recorder { inner: CpuTracer::new(&p), closest: Default::default(), shadow: Default::default() };
        let job = Job {
            tracer: &rec,
            scene: &scene,
            prepared: &p,
            shading: &shading,
            camera: &camera,
            size: (64, 64),
            seed: 1,
            sampling: &Sampling::Uniform(16),
            maps: None,
            rows: None,
            time_budget: None,
        };
        rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| render(&job, &|_, _| {})).unwrap();
        (p, rec.closest.into_inner().unwrap(), rec.shadow.into_inner().unwrap())
    }

    /// Per-ray statistics (nodes, triangles and blocks tested by the
    /// single-ray walks) and trace times of a render's rays for BVHs built
    /// with several obvhs parameter sets, each walked over the collapsed
    /// tree (`tree8.rs`), the decoded CWBVH (`wide8.rs`) and the CWBVH,
    /// whose answers must all be the default's; then the collapsed tree
    /// with leaves of 1 to 8 triangles: the tables of `docs/TRACING.md`,
    /// run with `--release --ignored --nocapture`.
    #[test]
    #[ignore = "timing"]
    fn walk_statistics() {
        use obvhs::BvhBuildParams;
        use obvhs::ploc::{PlocSearchDistance, SortPrecision};
        let base = bvh_input(&Prepared::new(&built_in("cube-enclosure:1").unwrap())).1;
        let mut configs: Vec<(&str, BvhBuildParams)> = vec![("default", base)];
        configs.push(("pre_split", BvhBuildParams { pre_split: true, ..base }));
        configs.push(("reinsert 1.0", BvhBuildParams { reinsertion_batch_ratio: 1.0, ..base }));
        configs.push(("ploc high", BvhBuildParams { ploc_search_distance: PlocSearchDistance::High, ..base }));
        configs.push(("ploc very high", BvhBuildParams { ploc_search_distance: PlocSearchDistance::VeryHigh, ..base }));
        configs.push(("sort u128", BvhBuildParams { sort_precision: SortPrecision::U128, ..base }));
        let slow = BvhBuildParams { search_depth_threshold: 0, ..BvhBuildParams::very_slow_build() };
        configs.push(("very slow, sdt 0", slow));
        for spec in ["mirror-room", "cornell-box"] {
            let (p, closest, shadow) = render_rays(spec);
            eprintln!("{spec}: {} closest-hit rays, {} shadow rays", closest.len(), shadow.len());
            let mut expect: Option<(Vec<Option<Hit>>, Vec<bool>)> = None;
            let mut check = |name: &str, hits: Vec<Option<Hit>>, blocked: Vec<bool>| match &expect {
                None => expect = Some((hits, blocked)),
                Some((h, b)) => {
                    assert!(*h == hits, "{spec} {name}: closest hits differ");
                    assert!(*b == blocked, "{spec} {name}: occlusion differs");
                }
            };
            for (name, params) in &configs {
                let clock = std::time::Instant::now();
                let t = CpuTracer::with_params(&p, *params);
                let build = clock.elapsed().as_secs_f64();
                assert_eq!(t.walk_kind(), TREE8);
                let wide = CpuTracer { tree: None, ..t.clone() };
                let cwbvh = CpuTracer { tree: None, wide: None.into(), ..t.clone() };
                let ns = single_walk_ns(&[&t, &wide, &cwbvh], &closest, &shadow);
                let (tc, ts, hits, blocked) = counted::<TREE8>(&t, &closest, &shadow);
                let (wc, ws, wh, wb) = counted::<WIDE8>(&t, &closest, &shadow);
                let (cc, cs, ch, cb) = counted::<CWBVH>(&t, &closest, &shadow);
                assert!(hits == wh && hits == ch && blocked == wb && blocked == cb, "{spec} {name}: walks differ");
                let mut batch = Vec::new();
                for chunk in closest.chunks(1024) {
                    let mut out = Vec::new();
                    t.closest_hit(chunk, &mut out).unwrap();
                    batch.extend(out);
                }
                assert_eq!(batch, hits, "{spec} {name}: batch and single walks differ");
                let tree = t.tree.as_ref().unwrap();
                eprintln!(
                    "{spec} | {name} | build {:.1} ms | tree8 {:?} nodes/blocks, {:?} bytes, fill {:.2} | wide8 {} nodes, {:?} bytes",
                    build * 1e3,
                    tree.len(),
                    tree.bytes(),
                    tree.fill(),
                    t.wide().map_or(0, Wide8::len),
                    t.wide().map_or((0, 0), Wide8::bytes),
                );
                for (walk, (c, s), (nc, ns)) in
                    [("tree8", (tc, ts), ns[0]), ("wide8", (wc, ws), ns[1]), ("cwbvh", (cc, cs), ns[2])]
                {
                    eprintln!("{spec} | {name} | {walk} | closest {c}, {nc:.0} ns | shadow {s}, {ns:.0} ns");
                }
                check(name, hits, blocked);
            }
            let t = CpuTracer::new(&p);
            let bvh2 = build_bvh2(&p, base);
            let trees: Vec<CpuTracer> = (1..=tree8::MAX_LEAF)
                .map(|leaf| CpuTracer { tree: Tree8::new(&bvh2, &p.triangles, leaf), ..t.clone() })
                .collect();
            let ns = single_walk_ns(&trees.iter().collect::<Vec<_>>(), &closest, &shadow);
            for (k, t) in trees.iter().enumerate() {
                let (c, s, hits, blocked) = counted::<TREE8>(t, &closest, &shadow);
                let tree = t.tree.as_ref().unwrap();
                eprintln!(
                    "{spec} | leaves of <= {} | {:?} nodes/blocks, {:?} bytes, fill {:.2} | closest {c}, {:.0} ns | shadow {s}, {:.0} ns",
                    k + 1,
                    tree.len(),
                    tree.bytes(),
                    tree.fill(),
                    ns[k].0,
                    ns[k].1
                );
                check("leaves", hits, blocked);
            }
        }
    }

    /// Lines grazing the scene's box (along a face, through an edge, just
    /// outside and just inside it) and global lines: the box test rejects
    /// many, and every line, rejected or not, has exactly the reference
    /// backend's crossings.
    #[test]
    fn box_rejection_loses_no_crossing() {
        for spec in ["cube-enclosure:6", "geosphere", "table-chairs:2", "cubes-room:16"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let (cpu, reference) = (CpuTracer::new(&p), ReferenceTracer::new(&p));
            let (c, h) = cpu.bounds;
            let h = h - BOUNDS_PAD; // the unpadded box
            let mut lines: Vec<Line> = (0..3_000).map(|i| global_line(9, i, 1.1)).collect();
            for i in 0..6_000u64 {
                let r = LineRng::new(4, i);
                let u = |k| r.uniform(k) * 2.0 - 1.0;
                // A point on a face of the box, pushed out (or in) by a hair.
                let axis = (i % 3) as usize;
                let mut q = DVec3::new(u(0), u(1), u(2)) * h.as_dvec3();
                q[axis] = h.as_dvec3()[axis] * if u(3) < 0.0 { -1.0 } else { 1.0 };
                q[axis] += [-1e-5, 0.0, 1e-6, 1e-5, 1e-3][(i / 3 % 5) as usize] * q[axis].signum();
                // Along the face, or through one of its edges.
                let mut d = DVec3::new(u(4), u(5), u(6));
                d[axis] = if i % 2 == 0 { 0.0 } else { d[axis] * 0.01 };
                let d = d.normalize();
                let o = c.as_dvec3() + q - d * 3.0;
                lines.push(Line::ray(o, d, 0.0, 6.0));
            }
            let rejected = lines
                .iter()
                .filter(|l| line_misses_box(Vec3A::from(l.origin), Vec3A::from(l.direction), cpu.bounds))
                .count();
            assert!(rejected > 1_000, "{spec}: only {rejected} lines rejected");
            let (mut a, mut b) = (CrossingBuffer::default(), CrossingBuffer::default());
            cpu.trace_all(&lines, &mut a).unwrap();
            reference.trace_all(&lines, &mut b).unwrap();
            assert!(b.crossings.len() > 1_000, "{spec}: too few crossings to compare");
            assert_eq!(a.offsets, b.offsets, "{spec}");
            assert_eq!(a.crossings, b.crossings, "{spec}");
        }
    }
}
