//! The CPU backend's BVH walk: obvhs's compressed 8-wide BVH traversed with
//! an 8-lane AVX2 node test (all eight children's slabs in one register)
//! where the CPU has AVX2, obvhs's own two 4-lane SSE passes otherwise.
//!
//! Both node tests do the same IEEE arithmetic in the same order (one
//! multiply, one add, then max/min in the same operand order; no fused
//! multiply-add), so they cull exactly the same children: the walk, and
//! therefore every answer, is the same on any x86-64 CPU. A unit test below
//! compares the two hit masks on every node of a BVH for many rays.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m128i, __m256, _CMP_LE_OQ, _mm_cvtsi64_si128, _mm_cvtsi128_si32, _mm_loadl_epi64, _mm_or_si128,
    _mm_shuffle_epi32, _mm256_add_ps, _mm256_and_si256, _mm256_castps_si256, _mm256_castsi256_si128, _mm256_cmp_ps,
    _mm256_cvtepi32_ps, _mm256_cvtepu8_epi32, _mm256_extracti128_si256, _mm256_max_ps, _mm256_min_ps, _mm256_mul_ps,
    _mm256_set1_ps, _mm256_sllv_epi32,
};

use glam::{UVec2, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray;
use std::mem::MaybeUninit;

/// Depth of the traversal stack: obvhs's (`TRAVERSAL_STACK_SIZE`, private
/// there; its BVH validation keeps trees shallower).
const STACK: usize = 32;

/// obvhs's near cut-off: children nearer than this along the ray are culled
/// (`obvhs::cwbvh::node::EPSILON`, private there; see `docs/TRACING.md`).
pub(super) const NODE_EPSILON: f32 = 0.0001;

/// Whether the AVX2 node test may be used (asked once; std caches it).
#[must_use]
pub(crate) fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Eight children's slabs at once: the hit mask obvhs's
/// `CwBvhNode::intersect_ray` returns for the same node and ray.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn intersect8(node: &CwBvhNode, ray: &Ray, oct_inv4: u32) -> u32 {
    let adj_inv = node.compute_extent() * ray.inv_direction;
    let adj_org = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    // The eight quantised planes of one axis side, as f32 (exact).
    let q = |b: &[u8; 8]| -> __m256 {
        // SAFETY: `b` is 8 readable bytes, exactly what `_mm_loadl_epi64`
        // reads (unaligned loads are allowed); AVX2 is enabled here.
        unsafe { _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(b.as_ptr().cast::<__m128i>()))) }
    };
    let axis = |lo: &[u8; 8], hi: &[u8; 8], neg: bool, inv: f32, org: f32| -> (__m256, __m256) {
        let (near, far) = if neg { (q(hi), q(lo)) } else { (q(lo), q(hi)) };
        let (inv, org) = (_mm256_set1_ps(inv), _mm256_set1_ps(org));
        (_mm256_add_ps(_mm256_mul_ps(near, inv), org), _mm256_add_ps(_mm256_mul_ps(far, inv), org))
    };
    let d = ray.direction;
    let (tmin_x, tmax_x) = axis(&node.child_min_x, &node.child_max_x, d.x < 0.0, adj_inv.x, adj_org.x);
    let (tmin_y, tmax_y) = axis(&node.child_min_y, &node.child_max_y, d.y < 0.0, adj_inv.y, adj_org.y);
    let (tmin_z, tmax_z) = axis(&node.child_min_z, &node.child_max_z, d.z < 0.0, adj_inv.z, adj_org.z);
    // Same operand order as obvhs (max/min pick the second operand on NaN).
    let tmin = _mm256_max_ps(tmin_x, _mm256_max_ps(tmin_y, tmin_z));
    let tmax = _mm256_min_ps(tmax_x, _mm256_min_ps(tmax_y, tmax_z));
    let tmin = _mm256_max_ps(tmin, _mm256_set1_ps(NODE_EPSILON));
    let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(ray.tmax));
    let hit = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax));
    // Branch-free: each hit child's bits shifted to its slot (obvhs's
    // `child_bits << bit_index` per lane; indices are below 32), OR-reduced.
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let bytes = |x: u64| _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(x as i64));
    let lanes = _mm256_and_si256(_mm256_sllv_epi32(bytes(child_bits8), bytes(bit_index8)), hit);
    let x = _mm_or_si128(_mm256_castsi256_si128(lanes), _mm256_extracti128_si256::<1>(lanes));
    let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b0100_1110>(x));
    let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b1011_0001>(x));
    _mm_cvtsi128_si32(x) as u32
}

/// Walks the BVH along `ray`, calling `prim(k, &mut tmax)` for every
/// candidate primitive `k` (an index into `bvh.primitive_indices`, i.e.
/// BVH order); `prim` may shrink `tmax` (closest hit) and returns `true` to
/// end the walk (any hit).
#[inline(always)]
fn walk<const AVX2: bool, F: FnMut(u32, &mut f32) -> bool>(bvh: &CwBvh, ray: &Ray, mut prim: F) {
    let mut r = *ray;
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    'walk: {
        obvhs::traverse!(
            bvh,
            node,
            state,
            {
                #[cfg(target_arch = "x86_64")]
                if AVX2 {
                    // SAFETY: `AVX2` is true only in `walk_avx2`, entered
                    // only after `has_avx2()` said the CPU has it.
                    unsafe { intersect8(node, &r, state.oct_inv4) }
                } else {
                    node.intersect_ray(&r, state.oct_inv4)
                }
                #[cfg(not(target_arch = "x86_64"))]
                node.intersect_ray(&r, state.oct_inv4)
            },
            {
                if prim(state.primitive_id, &mut r.tmax) {
                    break 'walk;
                }
            }
        );
    }
}

/// [`walk`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn walk_avx2<F: FnMut(u32, &mut f32) -> bool>(bvh: &CwBvh, ray: &Ray, prim: F) {
    walk::<true, F>(bvh, ray, prim);
}

/// Walks `bvh` along `ray` (see [`walk`]) with the widest node test the CPU
/// has (`avx2` from [`has_avx2`]).
#[inline]
pub(crate) fn traverse<F: FnMut(u32, &mut f32) -> bool>(bvh: &CwBvh, ray: &Ray, avx2: bool, prim: F) {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: the caller got `avx2` from `has_avx2()`.
        unsafe { walk_avx2(bvh, ray, prim) };
        return;
    }
    let _ = avx2;
    walk::<false, F>(bvh, ray, prim);
}

/// Asks for the cache lines of `node`'s internal children (adjacent in
/// `bvh.nodes`): the walk visits one next and pushes the others, whose
/// loads would otherwise wait until they are popped.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn prefetch_children(bvh: &CwBvh, node: &CwBvhNode) {
    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
    let first = bvh.nodes.as_ptr().wrapping_add(node.child_base_idx as usize).cast::<i8>();
    let bytes = node.imask.count_ones() as usize * size_of::<CwBvhNode>();
    for offset in (0..bytes).step_by(64) {
        // SAFETY: a prefetch is only a hint and never faults, whatever the
        // address; the pointer is formed with `wrapping_add`, never read.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(first.wrapping_add(offset)) };
    }
}

/// [`walk`] by primitive groups: `group(first, mask, &mut tmax)` gets all
/// the candidates a node's leaf children hold at once (primitive
/// `first + i` for each bit `i` of `mask`, below 24), in the order obvhs's
/// `traverse!` reaches them; the same nodes as [`walk`] for the same
/// `tmax` updates. Returns `true` from `group` to end the walk. `tally`
/// counts the nodes tested.
///
/// # Safety
/// `AVX2` (the 8-lane node test) only where the CPU has AVX2 ([`has_avx2`]).
#[inline(always)]
pub(super) unsafe fn walk_groups<const AVX2: bool, F: FnMut(u32, u32, &mut f32) -> bool>(
    bvh: &CwBvh,
    ray: &Ray,
    tally: &impl Tally,
    mut group: F,
) {
    let mut r = *ray;
    let oct_inv4 = bvh.new_traversal(ray.direction).oct_inv4;
    // obvhs's `traverse!`, with its inner loop over one primitive group
    // handed to `group` whole, and its traversal stack (`StackStack`, the
    // same depth and the same overflow rule) left uninitialised instead of
    // zeroing its 256 bytes for every ray.
    let mut stack = [MaybeUninit::<UVec2>::uninit(); STACK];
    let mut depth = 0usize;
    let mut current_group = if bvh.nodes.is_empty() { UVec2::ZERO } else { UVec2::new(0, 0x8000_0000) };
    let mut primitive_group = UVec2::ZERO;
    loop {
        if primitive_group.y != 0 && group(primitive_group.x, primitive_group.y, &mut r.tmax) {
            return;
        }
        primitive_group = UVec2::ZERO;
        if current_group.y & 0xff00_0000 != 0 {
            let hits_imask = current_group.y;
            let child_index_offset = obvhs::cwbvh::firstbithigh(hits_imask);
            let child_index_base = current_group.x;
            current_group.y &= !(1u32 << child_index_offset);
            if current_group.y & 0xff00_0000 != 0 {
                // As `StackStack::push`: a full stack overwrites its top.
                stack[depth] = MaybeUninit::new(current_group);
                depth = (depth + 1).min(STACK - 1);
            }
            let slot_index = (child_index_offset - 24) ^ (oct_inv4 & 0xff);
            let relative_index = (hits_imask & !(0xffff_ffffu32 << slot_index)).count_ones();
            let node = &bvh.nodes[(child_index_base + relative_index) as usize];
            #[cfg(target_arch = "x86_64")]
            let hitmask = if AVX2 {
                // SAFETY: `AVX2` is true only where the CPU has AVX2
                // (this function's contract).
                unsafe { intersect8(node, &r, oct_inv4) }
            } else {
                node.intersect_ray(&r, oct_inv4)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let hitmask = node.intersect_ray(&r, oct_inv4);
            tally.node();
            #[cfg(target_arch = "x86_64")]
            if AVX2 && (hitmask >> 24).count_ones() > 1 {
                prefetch_children(bvh, node);
            }
            current_group = UVec2::new(node.child_base_idx, (hitmask & 0xff00_0000) | u32::from(node.imask));
            primitive_group = UVec2::new(node.primitive_base_idx, hitmask & 0x00ff_ffff);
        } else {
            current_group = UVec2::ZERO;
        }
        if primitive_group.y == 0 && (current_group.y & 0xff00_0000) == 0 {
            if depth == 0 {
                return;
            }
            depth -= 1;
            // SAFETY: every slot below `depth` was written by a push since
            // this walk began (a push writes `stack[depth]` before raising
            // `depth`, and a pop lowers it first).
            current_group = unsafe { stack[depth].assume_init() };
        }
    }
}

/// Counts of a walk: nodes tested and triangles tested
/// (`docs/TRACING.md`'s per-ray statistics); `()` counts nothing.
pub(crate) trait Tally {
    /// A node's children were tested.
    fn node(&self);
    /// The triangles of `mask` were tested.
    fn triangles(&self, mask: u32);
}

impl Tally for () {
    #[inline(always)]
    fn node(&self) {}
    #[inline(always)]
    fn triangles(&self, _: u32) {}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lines::global_line;
    use crate::scene::built_in;
    use crate::tracer::{Prepared, bvh_input};

    /// The AVX2 node test culls exactly what obvhs's SSE test culls, on
    /// every node of the BVHs of a tessellated enclosure and a box room,
    /// for global lines at full length and cut short (closest-hit walks
    /// shrink `tmax`).
    #[test]
    fn avx2_node_test_matches_obvhs() {
        if !has_avx2() {
            return;
        }
        for spec in ["cube-enclosure:6", "cubes-room:16", "geosphere", "table-chairs:2"] {
            let scene = built_in(spec).unwrap();
            let p = Prepared::new(&scene);
            let (aabbs, params) = bvh_input(&p);
            let bvh = obvhs::cwbvh::builder::build_cwbvh(&aabbs, params, &mut std::time::Duration::default());
            let mut tested = 0u64;
            for i in 0..300 {
                let l = global_line(5, i, 1.1);
                for tmax in [l.tmax, l.tmax * 0.5, 0.3] {
                    let dir = Vec3A::from(l.direction);
                    let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, tmax);
                    let oct = bvh.new_traversal(dir).oct_inv4;
                    for node in &bvh.nodes {
                        // SAFETY: AVX2 checked above.
                        let wide = unsafe { intersect8(node, &ray, oct) };
                        assert_eq!(wide, node.intersect_ray(&ray, oct), "{spec} line {i}");
                        tested += u64::from(wide != 0);
                    }
                }
            }
            assert!(tested > 100, "{spec}: only {tested} non-empty masks");
        }
    }
}
