//! Closest hits and occlusion of a batch of rays, several single-ray BVH
//! walks interleaved step by step (latency hiding for
//! [`super::Tracer::closest_hit`] and [`super::Tracer::occluded`] on the
//! CPU, as `interleave.rs` does for `trace_all`).
//!
//! A walk is a chain of dependent loads and tests: a ray's next node is
//! known only once its parent is loaded and tested (`docs/TRACING.md`,
//! *Per-ray walk statistics*: 5.6 nodes a closest hit on mirror-room).
//! Here [`WALKS`] rays walk at once, one step each in turn. A step tests
//! the leaf triangles of the node the walk visited at its previous step,
//! visits the node it chose then, and chooses the next one; the node
//! chosen and the triangles found are only prefetched, and used a round of
//! the other walks later, by when they have arrived and the other walks'
//! arithmetic has filled the wait.
//!
//! Each walk is exactly [`super::node8::walk_groups`]'s for its ray: the
//! same bookkeeping (`node8::take_child`, `node8::Stack`), the same node
//! test ([`super::node8::intersect8`]) and 8-wide triangle blocks
//! ([`TriangleLanes::block`]), and the same order of visits and of updates
//! of the ray's shrinking `tmax` (a node's triangles are tested before the
//! child chosen after it is visited, whose choice does not depend on
//! `tmax`). So every ray visits the same nodes, tests the same triangles
//! and keeps the same best hit (ties to the smaller triangle index,
//! [`before`]) as alone: the answers are the single walk's to the bit (unit
//! tests in `cpu.rs`), whatever the order of the rays.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use glam::{UVec2, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;

use super::node8::{Stack, groups_of, has_children, take_child};
use super::watertight::{BLOCK, Shear, TriangleLanes, before};
use crate::lines::Line;

/// Walks in flight at once (measured: docs/RENDER.md, *Interleaved walks*).
pub(super) const WALKS: usize = 8;

/// EXPERIMENT knobs: ITGFX_WALKS (0 = single walk), ITGFX_TP, ITGFX_PACKETS.
pub(super) fn knobs() -> (usize, bool, bool, bool) {
    static K: std::sync::OnceLock<(usize, bool, bool, bool)> = std::sync::OnceLock::new();
    *K.get_or_init(|| {
        let g = |n: &str, d: usize| std::env::var(n).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
        (g("ITGFX_WALKS", 8), g("ITGFX_TP", 1) == 1, g("ITGFX_PACKETS", 1) == 1, g("ITGFX_SORT", 0) == 1)
    })
}

/// EXPERIMENT dispatch.
#[cfg(target_arch = "x86_64")]
pub(super) unsafe fn walk_any<const ANY: bool>(
    bvh: &CwBvh,
    ordered: &[[Vec3A; 3]],
    lanes: &TriangleLanes,
    lines: &[Line],
    order: &[u32],
    done: impl FnMut(u32, &Found),
) {
    let (k, tp, _, _) = knobs();
    unsafe {
        match (k, tp) {
            (1, false) => walk::<ANY, 1, false>(bvh, ordered, lanes, lines, order, done),
            (4, false) => walk::<ANY, 4, false>(bvh, ordered, lanes, lines, order, done),
            (8, false) => walk::<ANY, 8, false>(bvh, ordered, lanes, lines, order, done),
            (16, false) => walk::<ANY, 16, false>(bvh, ordered, lanes, lines, order, done),
            _ => walk::<ANY, 8, true>(bvh, ordered, lanes, lines, order, done),
        }
    }
}

/// No node chosen, no line.
const NONE: u32 = u32::MAX;

/// What a walk found: for a closest hit, the best `(t, triangle)` (the
/// triangle's index in the scene, not in BVH order) and its barycentric
/// numerators ([`super::watertight::Block::numerators`]); for occlusion,
/// `best` is `Some` when anything was crossed.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Found {
    pub(super) best: Option<(f32, u32)>,
    pub(super) numerators: [f32; 3],
}

/// One ray's walk: `walk_groups`'s state, kept from step to step.
struct Walk {
    /// The node test's ray (its `tmax` shrinks to the best hit's `t`).
    ray: Ray,
    shear: Shear,
    /// The line's interval, for the triangle test.
    tmin: f32,
    tmax: f32,
    /// Index of the line in the batch, or [`NONE`].
    line: u32,
    oct_inv4: u32,
    /// Internal children still to visit (of the last node visited).
    current: UVec2,
    /// Leaf triangles of the last node visited, tested at the next step.
    primitives: UVec2,
    /// The node to visit at the next step (prefetched), or [`NONE`].
    pending: u32,
    found: Found,
    stack: Stack,
}

impl Walk {
    /// A walk with no line.
    fn idle() -> Self {
        let (shear, _) = Shear::of(&Line::default());
        Self {
            ray: Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 0.0),
            shear,
            tmin: 0.0,
            tmax: 0.0,
            line: NONE,
            oct_inv4: 0,
            current: UVec2::ZERO,
            primitives: UVec2::ZERO,
            pending: NONE,
            found: Found::default(),
            stack: Stack::new(),
        }
    }

    /// Starts the walk of `l` (line `line` of the batch) at the root (the
    /// node `node8::root_group` leads to, visited first).
    fn start(&mut self, bvh: &CwBvh, l: &Line, line: u32) {
        let (shear, dir) = Shear::of(l);
        self.ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
        self.shear = shear;
        (self.tmin, self.tmax) = (l.tmin, l.tmax);
        self.line = line;
        self.oct_inv4 = bvh.new_traversal(dir).oct_inv4;
        self.current = UVec2::ZERO;
        self.primitives = UVec2::ZERO;
        self.pending = 0;
        self.found = Found::default();
        self.stack.clear();
    }
}

/// Walks the lines `order` (indices into `lines`) through `bvh`, [`WALKS`]
/// at a time, and hands each line's answer to `done(line, found)` (in no
/// particular order). `ANY`: occlusion (a walk ends at its first block
/// with a crossing); otherwise the closest hit. `ordered` and `lanes` are
/// the CPU backend's triangles in BVH order.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn walk<const ANY: bool, const WALKS: usize, const TP: bool>(
    bvh: &CwBvh,
    ordered: &[[Vec3A; 3]],
    lanes: &TriangleLanes,
    lines: &[Line],
    order: &[u32],
    mut done: impl FnMut(u32, &Found),
) {
    if bvh.nodes.is_empty() {
        for &i in order {
            done(i, &Found::default());
        }
        return;
    }
    let mut walks: [Walk; WALKS] = std::array::from_fn(|_| Walk::idle());
    let mut next = order.iter();
    let mut active = 0usize;
    for w in &mut walks {
        if let Some(&i) = next.next() {
            w.start(bvh, &lines[i as usize], i);
            active += 1;
        }
    }
    while active > 0 {
        for w in &mut walks {
            if w.line == NONE {
                continue;
            }
            // SAFETY: AVX2 is enabled here, as `step` requires.
            if unsafe { step::<ANY, TP>(bvh, ordered, lanes, w) } {
                done(w.line, &w.found);
                match next.next() {
                    Some(&i) => w.start(bvh, &lines[i as usize], i),
                    None => {
                        w.line = NONE;
                        active -= 1;
                    }
                }
            }
        }
    }
}

/// One step of `w`'s walk: the triangles of the node visited at the
/// previous step tested, the node chosen then visited, and the next node
/// chosen and prefetched (with the visited node's triangles). Returns
/// whether the walk is over.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn step<const ANY: bool, const TP: bool>(bvh: &CwBvh, ordered: &[[Vec3A; 3]], lanes: &TriangleLanes, w: &mut Walk) -> bool {
    if w.primitives.y != 0 {
        // `CpuTracer::blocks`' split of a group into blocks of eight.
        let (first, mut m) = (w.primitives.x, w.primitives.y);
        w.primitives.y = 0;
        while m != 0 {
            let b = m.trailing_zeros() / BLOCK as u32;
            let mask = (m >> (b * BLOCK as u32)) & 0xff;
            m &= !(0xff << (b * BLOCK as u32));
            let base = first as usize + (b as usize) * BLOCK;
            // SAFETY: AVX2 is enabled here; `base` is a primitive of the BVH.
            let block = unsafe { lanes.block::<true>(ordered, &w.shear, base, mask, w.tmin, w.tmax) };
            if ANY {
                if block.hit != 0 {
                    w.found.best = Some((0.0, 0));
                    return true;
                }
                continue;
            }
            // `CpuTracer::closest_with`'s update of the best hit.
            let mut h = block.hit;
            while h != 0 {
                let i = h.trailing_zeros() as usize;
                h &= h - 1;
                let t = block.t[i];
                let tri = bvh.primitive_indices[base + i];
                if before(t, tri, w.found.best) {
                    w.found.best = Some((t, tri));
                    w.found.numerators = block.numerators(i);
                }
                if t < w.ray.tmax {
                    w.ray.tmax = t;
                }
            }
        }
    }
    if w.pending == NONE {
        return true;
    }
    let node = &bvh.nodes[w.pending as usize];
    // SAFETY: AVX2 is enabled here.
    let hitmask = unsafe { super::node8::intersect8(node, &w.ray, w.oct_inv4) };
    (w.current, w.primitives) = groups_of(node, hitmask);
    if TP && w.primitives.y != 0 {
        let p = w.primitives;
        let first = (p.x + p.y.trailing_zeros()) as usize;
        let last = (p.x + 31 - p.y.leading_zeros()) as usize;
        lanes.prefetch(first, last);
    }
    if !has_children(w.current) {
        match w.stack.pop() {
            Some(g) => w.current = g,
            None => {
                w.pending = NONE;
                return w.primitives.y == 0;
            }
        }
    }
    w.pending = take_child(&mut w.current, w.oct_inv4);
    if has_children(w.current) {
        w.stack.push(w.current);
    }
    super::node8::prefetch_lines(bvh.nodes.as_ptr().wrapping_add(w.pending as usize), size_of_val(node));
    false
}
