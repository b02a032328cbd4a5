//! Every crossing of many lines, several BVH walks interleaved step by step
//! (latency hiding for [`super::Tracer::trace_all`] on the CPU).
//!
//! One walk is a chain of dependent loads: a node's children are known only
//! once the node is loaded and tested, a leaf's triangles only once its
//! parent is. On global lines the chain stalls on those loads (the hottest
//! instructions of a profile are the first loads of a node and of a
//! triangle: `docs/TRACING.md`). Here [`LANES`] lines walk at once, one step
//! each in turn. A step visits the node chosen at the lane's previous step
//! and chooses the next one, or tests the triangles of the last leaves
//! found; what it will load next is only prefetched, and loaded a round of
//! the other lanes later, by when it has arrived.
//!
//! Each lane keeps obvhs's `traverse!` bookkeeping (groups of children
//! still to visit on a stack, the child order of the octant) and
//! [`super::node8::intersect8`] as its node test. `trace_all` keeps each
//! line's full interval, so the nodes and triangles a line visits do not
//! depend on the order of the visits: exactly those of its single walk.
//! [`super::watertight::finish`] then sorts each line's crossings by
//! `(t, triangle)`, a strict order, so the order in which they were found
//! cannot show: the crossings are bit for bit the single walk's (unit test
//! in `cpu.rs`).
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use glam::{UVec2, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;

use super::watertight::Shear;
use crate::lines::Line;

/// Walks in flight at once.
pub(super) const LANES: usize = 8;

/// obvhs's traversal stack depth (`TRAVERSAL_STACK_SIZE`, private there):
/// a push onto a full stack overwrites its top entry, as obvhs's does.
const STACK: usize = 32;

/// One walk's state: obvhs's `Traversal` plus the line it belongs to.
struct Lane {
    ray: Ray,
    shear: Shear,
    /// Index of the line in the batch.
    line: u32,
    oct_inv4: u32,
    current: UVec2,
    primitives: UVec2,
    stack: [UVec2; STACK],
    depth: usize,
    /// The node to visit at the next step (prefetched), or [`NONE`].
    pending: u32,
}

impl Lane {
    /// A lane with no line.
    fn idle() -> Self {
        let (shear, _) = Shear::of(&Line::default());
        Self {
            ray: Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 0.0),
            shear,
            line: NONE,
            oct_inv4: 0,
            current: UVec2::ZERO,
            primitives: UVec2::ZERO,
            stack: [UVec2::ZERO; STACK],
            depth: 0,
            pending: NONE,
        }
    }

    /// Starts the walk of `l` (line `line` of the batch) at the root.
    fn start(&mut self, l: &Line, line: u32) {
        let (shear, dir) = Shear::of(l);
        self.ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
        self.shear = shear;
        self.line = line;
        // obvhs's `ray_get_octant_inv4`.
        self.oct_inv4 = (if dir.x < 0.0 { 0 } else { 0x0404_0404 })
            | (if dir.y < 0.0 { 0 } else { 0x0202_0202 })
            | (if dir.z < 0.0 { 0 } else { 0x0101_0101 });
        self.pending = 0;
    }
}

/// A crossing found by a walk: the line (in the batch), the triangle (BVH
/// order) and `t`.
pub(super) type RawHit = (u32, u32, f32);

/// Every crossing within `[tmin, tmax]` of each line of `lines` for which
/// `take(line)` holds, appended to `hits` in no particular order.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn trace(
    bvh: &CwBvh,
    ordered: &[[Vec3A; 3]],
    lines: &[Line],
    take: impl Fn(&Line) -> bool,
    hits: &mut Vec<RawHit>,
) {
    if bvh.nodes.is_empty() {
        return;
    }
    let mut next = 0usize;
    let mut lanes: [Lane; LANES] = std::array::from_fn(|_| Lane::idle());
    let mut active = 0;
    loop {
        for lane in &mut lanes {
            if lane.pending == NONE && lane.primitives.y == 0 && lane.current.y & 0xff00_0000 == 0 && lane.depth == 0 {
                // Idle or done: the next line that enters the scene's box.
                active -= usize::from(lane.line != NONE);
                lane.line = NONE;
                while next < lines.len() {
                    next += 1;
                    if take(&lines[next - 1]) {
                        lane.start(&lines[next - 1], (next - 1) as u32);
                        active += 1;
                        break;
                    }
                }
                if lane.line == NONE {
                    continue;
                }
            }
            // SAFETY: AVX2 is enabled here, as `step` requires.
            unsafe { step(bvh, ordered, lines, lane, hits) };
        }
        if active == 0 && next >= lines.len() {
            break;
        }
    }
}

/// Brings the cache lines of `len` bytes at `p` towards the core (a hint:
/// never faults, whatever the address).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn prefetch<T>(p: *const T, len: usize) {
    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
    let p = p.cast::<i8>();
    let mut off = 0;
    while off < len {
        // SAFETY: a prefetch reads nothing architecturally and never faults.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
        off += 64;
    }
    // SAFETY: as above.
    unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(len.saturating_sub(1))) };
}

/// One step of `lane`'s walk (a leaf group's triangles tested, or one node
/// visited and the next one chosen). The node chosen is only prefetched
/// here and visited at the lane's next step, and a node's triangles are
/// prefetched when it is visited and tested at the next step: what a step
/// loads was asked for a round of the other lanes earlier.
///
/// The bookkeeping is obvhs's `traverse!` loop (groups of children still
/// to visit on a stack, the child order of the octant), only the order of
/// visits differs (a node's triangles wait while its first child is
/// chosen): `trace_all` keeps the full interval, so the set of nodes and
/// triangles visited does not depend on the order.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn step(bvh: &CwBvh, ordered: &[[Vec3A; 3]], lines: &[Line], lane: &mut Lane, hits: &mut Vec<RawHit>) {
    if lane.primitives.y != 0 {
        let l = &lines[lane.line as usize];
        // A group holds at most 24 triangles; each is written to the spare
        // capacity and kept by advancing the length, not by a branch.
        hits.reserve(24);
        let spare = hits.spare_capacity_mut();
        let mut found = 0;
        while lane.primitives.y != 0 {
            let local = 31 - lane.primitives.y.leading_zeros();
            lane.primitives.y &= !(1u32 << local);
            let k = lane.primitives.x + local;
            let (t, crossed) = lane.shear.hit_within(&ordered[k as usize], l.tmin, l.tmax);
            spare[found].write((lane.line, k, t));
            found += usize::from(crossed);
        }
        // SAFETY: the first `found` spare entries were written above, and
        // `found` is at most the 24 reserved.
        unsafe { hits.set_len(hits.len() + found) };
        return;
    }
    if lane.pending != NONE {
        let node = &bvh.nodes[lane.pending as usize];
        lane.pending = NONE;
        // SAFETY: AVX2 is enabled here.
        let hitmask = unsafe { super::node8::intersect8(node, &lane.ray, lane.oct_inv4) };
        if lane.current.y & 0xff00_0000 != 0 {
            lane.stack[lane.depth] = lane.current;
            lane.depth = (lane.depth + 1).min(STACK - 1);
        }
        lane.current = UVec2::new(node.child_base_idx, (hitmask & 0xff00_0000) | u32::from(node.imask));
        let prims = hitmask & 0x00ff_ffff;
        lane.primitives = UVec2::new(node.primitive_base_idx, prims);
        if prims != 0 {
            let first = (node.primitive_base_idx + prims.trailing_zeros()) as usize;
            let last = (node.primitive_base_idx + 31 - prims.leading_zeros()) as usize;
            prefetch(ordered.as_ptr().wrapping_add(first), (last + 1 - first) * size_of::<[Vec3A; 3]>());
        }
    }
    if lane.current.y & 0xff00_0000 == 0 {
        if lane.depth == 0 {
            return; // done once its last triangles are tested
        }
        lane.depth -= 1;
        lane.current = lane.stack[lane.depth];
    }
    let hits_imask = lane.current.y;
    let child_index_offset = 31 - hits_imask.leading_zeros();
    lane.current.y &= !(1u32 << child_index_offset);
    let slot_index = (child_index_offset - 24) ^ (lane.oct_inv4 & 0xff);
    let relative_index = (hits_imask & !(0xffff_ffffu32 << slot_index)).count_ones();
    lane.pending = lane.current.x + relative_index;
    prefetch(bvh.nodes.as_ptr().wrapping_add(lane.pending as usize), size_of::<obvhs::cwbvh::node::CwBvhNode>());
}

/// No node chosen.
const NONE: u32 = u32::MAX;
