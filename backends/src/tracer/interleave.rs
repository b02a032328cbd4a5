//! Every crossing of many lines, several BVH walks interleaved step by step
//! (latency hiding for [`super::Tracer::trace_all`] on the CPU), over the
//! uncompressed 8-wide nodes of [`Wide8`].
//!
//! One walk is a chain of dependent loads: a node's children are known only
//! once the node is loaded and tested, a leaf's triangles only once its
//! parent is. On global lines the chain stalls on those loads (the hottest
//! instructions of a profile are the first loads of a node and of a
//! triangle: `docs/TRACING.md`). Here [`LANES`] lines walk at once, one step
//! each in turn. A step tests the triangles of the leaves found at the
//! lane's previous step, then visits the node chosen there and chooses the
//! next one; what it will load next is only prefetched, and loaded a round
//! of the other lanes later, by when it has arrived.
//!
//! The nodes are the CPU tracer's CWBVH decoded (`wide8.rs`: each child's
//! box as `f32` planes, widened by one ulp, so it contains the compressed
//! box): a node test is six aligned loads and six fused multiply-subtracts,
//! with nothing to decode. `trace_all` wants every crossing within each
//! line's full interval, so no child order is kept and no child is culled
//! by a hit: a walk visits every node whose box the line enters, and tests
//! every triangle of those leaves; the order of the visits cannot show.
//! The crossings are then a property of the triangle test alone (every
//! crossed triangle lies in boxes padded by 1e-5, far beyond the slab
//! test's rounding), bit for bit those of the CWBVH walk, and
//! [`super::watertight::finish`] sorts each line's by `(t, triangle)`, a
//! strict order (unit test in `cpu.rs`; `bench/complexity_identity.sh`).
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use glam::Vec3A;
use obvhs::ray::Ray;

use super::node8::NODE_EPSILON;
use super::watertight::Shear;
use super::wide8::{self, Node as WideNode, Wide8};
use crate::lines::Line;

/// Walks in flight at once.
pub(super) const LANES: usize = 8;

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

/// No node chosen.
const NONE: u32 = u32::MAX;

/// One walk over the uncompressed tree ([`Wide8`]): the ray's slab
/// constants, the line's shear, a stack of nodes still to visit, and the
/// crossings found so far.
struct Lane {
    shear: Shear,
    /// Index of the line in the batch, or [`NONE`].
    line: u32,
    /// The node to visit at the next step (prefetched), or [`NONE`].
    pending: u32,
    /// The leaf primitives found at the last node visited and not yet
    /// tested (a mask over the group at `prim_base`; prefetched).
    prims: u32,
    prim_base: u32,
    /// `origin · inverse` and the inverse direction per axis: a plane's
    /// distance is `plane · inverse − origin · inverse` (one fused
    /// multiply-subtract, Embree's form of the slab test).
    org_inv: [f32; 3],
    inv: [f32; 3],
    /// Byte offset in a node of each axis's near-plane row.
    near: [usize; 3],
    tmax: f32,
    depth: usize,
    /// [`wide8::STACK`] entries and eight spare: the pushes store a whole
    /// node's children at once.
    stack: [u32; wide8::STACK + 8],
    /// `(k, t)` of each crossing found (triangle in BVH order).
    found: Vec<(u32, f32)>,
}

impl Lane {
    fn idle() -> Self {
        let (shear, _) = Shear::of(&Line::default());
        Self {
            shear,
            line: NONE,
            pending: NONE,
            prims: 0,
            prim_base: 0,
            org_inv: [0.0; 3],
            inv: [0.0; 3],
            near: [0; 3],
            tmax: 0.0,
            depth: 0,
            stack: [0; wide8::STACK + 8],
            found: Vec::with_capacity(32),
        }
    }

    /// Starts the walk of `l` (line `line` of the batch) at the root, with
    /// obvhs's ray constants (its finite inverse of each component, on the
    /// direction without negative zeros, as the CWBVH walk takes them).
    fn start(&mut self, l: &Line, line: u32) {
        let (shear, dir) = Shear::of(l);
        let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
        let inv = ray.inv_direction.to_array();
        let org = ray.origin.to_array();
        self.shear = shear;
        self.line = line;
        self.pending = 0;
        self.prims = 0;
        self.inv = inv;
        self.org_inv = [0, 1, 2].map(|a| org[a] * inv[a]);
        // Row `2·axis` holds the lower planes, `2·axis + 1` the upper; 32 bytes a row.
        self.near = [0, 1, 2].map(|a| (2 * a + usize::from(inv[a] < 0.0)) * 32);
        self.tmax = l.tmax;
        self.depth = 0;
        self.found.clear();
    }
}

/// Every crossing within `[tmin, tmax]` of each line of `lines` for which
/// `take(line)` holds, [`LANES`] walks of `tree` interleaved:
/// `done(line, found)` is called once per line taken whose walk found
/// crossings, with their `(k, t)` in no particular order (`k` the triangle
/// in BVH order, `ordered`'s index, which `tree`'s leaves hold), lines in
/// the order their walks end. `recorded[k]`, what `done` will read of
/// crossing `k`, is prefetched as the crossing is found.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn trace<R>(
    tree: &Wide8,
    ordered: &[[Vec3A; 3]],
    recorded: &[R],
    lines: &[Line],
    take: impl Fn(&Line) -> bool,
    mut done: impl FnMut(u32, &[(u32, f32)]),
) {
    if tree.nodes.is_empty() {
        return;
    }
    let mut next = 0usize;
    let mut lanes: [Lane; LANES] = std::array::from_fn(|_| Lane::idle());
    let mut active = 0;
    loop {
        for lane in &mut lanes {
            if lane.pending == NONE && lane.prims == 0 {
                // Idle or done: hand over its crossings, then take the next
                // line that enters the scene's box.
                if lane.line != NONE {
                    active -= 1;
                    if !lane.found.is_empty() {
                        done(lane.line, &lane.found);
                    }
                    lane.line = NONE;
                }
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
            // SAFETY: AVX2 and FMA are enabled here, as `step` requires.
            unsafe { step(tree, ordered, recorded, lines, lane) };
        }
        if active == 0 && next >= lines.len() {
            break;
        }
    }
}

/// For each 8-bit mask, the indices of its set bits in increasing order,
/// one per byte (the rest zero): the permutation that packs a node's hit
/// children to the front of a vector.
static PACK: [u64; 256] = {
    let mut table = [0u64; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut slot, mut packed) = (0, 0);
        while slot < 8 {
            if mask >> slot & 1 == 1 {
                table[mask] |= (slot as u64) << (8 * packed);
                packed += 1;
            }
            slot += 1;
        }
        mask += 1;
    }
    table
};

/// Visits node `n` on `lane`'s walk: the children the ray enters within
/// `[NODE_EPSILON, tmax]` (a slot's entry and exit are its largest
/// near-plane and smallest far-plane distances; empty slots, `+∞`/`−∞`
/// planes, are never entered). The internal ones are pushed onto the
/// stack all at once (packed by [`PACK`], stored as one vector, the depth
/// raised by their count: no branch per child); the leaf ones'
/// primitives are returned, their [`wide8::LEAF`] entries OR-ed under the
/// compare's lanes.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn visit(n: &WideNode, lane: &mut Lane) -> u32 {
    use std::arch::x86_64::{
        __m128i, __m256i, _CMP_LE_OQ, _mm_cvtsi128_si32, _mm_loadl_epi64, _mm_or_si128, _mm_shuffle_epi32,
        _mm256_and_si256, _mm256_castps_si256, _mm256_castsi256_si128, _mm256_cmp_ps, _mm256_cvtepu8_epi32,
        _mm256_extracti128_si256, _mm256_fmsub_ps, _mm256_load_ps, _mm256_load_si256, _mm256_max_ps, _mm256_min_ps,
        _mm256_movemask_ps, _mm256_permutevar8x32_epi32, _mm256_set1_ps, _mm256_srai_epi32, _mm256_storeu_si256,
    };
    let base = (n as *const WideNode).cast::<u8>();
    // SAFETY: AVX2 and FMA (this function's contract). Each row load reads
    // one 32-byte row of `n.bounds` (`near[a]` and `near[a] ^ 32` are rows
    // `2a` and `2a + 1`, at most row 5 of 6), 32-byte aligned as `Node` is
    // 64-aligned; `child` is the 32 bytes at offset 192. The stack store
    // writes entries `d .. d + 8` with `d <= STACK` of `STACK + 8`.
    unsafe {
        macro_rules! t {
            ($off:expr, $a:expr) => {
                _mm256_fmsub_ps(
                    _mm256_load_ps(base.add($off).cast::<f32>()),
                    _mm256_set1_ps(lane.inv[$a]),
                    _mm256_set1_ps(lane.org_inv[$a]),
                )
            };
        }
        let (nx, ny, nz) = (t!(lane.near[0], 0), t!(lane.near[1], 1), t!(lane.near[2], 2));
        let (fx, fy, fz) = (t!(lane.near[0] ^ 32, 0), t!(lane.near[1] ^ 32, 1), t!(lane.near[2] ^ 32, 2));
        let lo = _mm256_max_ps(_mm256_max_ps(nx, ny), _mm256_max_ps(nz, _mm256_set1_ps(NODE_EPSILON)));
        let hi = _mm256_min_ps(_mm256_min_ps(fx, fy), _mm256_min_ps(fz, _mm256_set1_ps(lane.tmax)));
        let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(lo, hi);
        let inner = _mm256_movemask_ps(hit) as u32 & n.imask;
        let c = _mm256_load_si256(n.child.as_ptr().cast::<__m256i>());
        // `Wide8::new` declines a tree whose walks could hold `STACK`
        // entries after taking one child: `depth + inner.count_ones()`
        // stays within `STACK`. The clamp keeps the store in bounds
        // whatever the tree.
        let d = lane.depth.min(wide8::STACK);
        let order = _mm256_cvtepu8_epi32(_mm_loadl_epi64((&raw const PACK[inner as usize & 0xff]).cast::<__m128i>()));
        _mm256_storeu_si256(lane.stack.as_mut_ptr().add(d).cast::<__m256i>(), _mm256_permutevar8x32_epi32(c, order));
        debug_assert!(d + inner.count_ones() as usize <= wide8::STACK);
        lane.depth = (d + inner.count_ones() as usize).min(wide8::STACK);
        let leaves = _mm256_and_si256(_mm256_and_si256(c, _mm256_srai_epi32::<31>(c)), _mm256_castps_si256(hit));
        let x = _mm_or_si128(_mm256_castsi256_si128(leaves), _mm256_extracti128_si256::<1>(leaves));
        let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b0100_1110>(x));
        let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b1011_0001>(x));
        _mm_cvtsi128_si32(x) as u32 & !wide8::LEAF
    }
}

/// One step of `lane`'s walk over the wide nodes: the leaf primitives
/// found at its previous step tested (`recorded` of each crossing
/// prefetched), then the pending node visited (its
/// internal children hit pushed, its leaf primitives kept for the next
/// step and prefetched) and the next node taken off the stack and
/// prefetched: what a step loads was asked for a round of the other
/// lanes earlier.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn step<R>(tree: &Wide8, ordered: &[[Vec3A; 3]], recorded: &[R], lines: &[Line], lane: &mut Lane) {
    if lane.prims != 0 {
        let l = &lines[lane.line as usize];
        // A group holds at most 24 triangles; each is written to the spare
        // capacity and kept by advancing the length, not by a branch.
        lane.found.reserve(24);
        let spare = lane.found.spare_capacity_mut();
        let mut found = 0;
        let mut m = lane.prims;
        while m != 0 {
            let k = lane.prim_base + m.trailing_zeros();
            m &= m - 1;
            let (t, crossed) = lane.shear.hit_within(&ordered[k as usize], l.tmin, l.tmax);
            spare[found].write((k, t));
            found += usize::from(crossed);
        }
        // SAFETY: the first `found` spare entries were written above, and
        // `found` is at most the 24 reserved.
        unsafe { lane.found.set_len(lane.found.len() + found) };
        for &(k, _) in &lane.found[lane.found.len() - found..] {
            prefetch(recorded.as_ptr().wrapping_add(k as usize), size_of::<R>());
        }
        lane.prims = 0;
    }
    if lane.pending == NONE {
        return;
    }
    let n = &tree.nodes[lane.pending as usize];
    // SAFETY: AVX2 and FMA are enabled here.
    let prims = unsafe { visit(n, lane) };
    if prims != 0 {
        lane.prims = prims;
        lane.prim_base = n.prim_base;
        let first = (n.prim_base + prims.trailing_zeros()) as usize;
        let last = (n.prim_base + 31 - prims.leading_zeros()) as usize;
        prefetch(ordered.as_ptr().wrapping_add(first), (last + 1 - first) * size_of::<[Vec3A; 3]>());
    }
    if lane.depth == 0 {
        lane.pending = NONE; // done once its last triangles are tested
        return;
    }
    lane.depth -= 1;
    lane.pending = lane.stack[lane.depth];
    prefetch(tree.nodes.as_ptr().wrapping_add(lane.pending as usize), size_of::<WideNode>());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lines::global_line;
    use crate::scene::built_in;
    use crate::tracer::{CpuTracer, CrossingBuffer, Prepared, Tracer};

    /// What the walk does per global line on `cube-enclosure:30` and
    /// `cubes-room:512`: nodes visited, triangles tested, crossings kept,
    /// and the nodes a walk that stopped after the line's last crossing
    /// could skip (those the line enters only past it, beyond the 1e-5
    /// padding). The scalar slab test here is the one [`visit`] vectorises;
    /// a figure for `docs/TRACING.md`, run with `--release --ignored
    /// --nocapture`.
    #[test]
    #[ignore = "statistics"]
    fn walk_statistics() {
        for spec in ["cube-enclosure:30", "cubes-room:512"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let t = CpuTracer::new(&p);
            let tree = t.wide().unwrap();
            let n = 100_000u64;
            let lines: Vec<Line> = (0..n).map(|i| global_line(1, i, crate::visibility::SPHERE_SCALE)).collect();
            let mut buf = CrossingBuffer::default();
            t.trace_all(&lines, &mut buf).unwrap();
            let (mut nodes, mut tris, mut past, mut crossed) = (0u64, 0u64, 0u64, 0u64);
            for (i, l) in lines.iter().enumerate() {
                let Some(last) = buf.line(i).last().map(|c| c.t) else { continue };
                crossed += 1;
                let ray = Ray::new(Vec3A::from(l.origin), Shear::of(l).1, l.tmin, l.tmax);
                let (inv, org) = (ray.inv_direction.to_array(), ray.origin.to_array());
                let mut stack = vec![(0u32, 0.0f32)];
                while let Some((k, entry)) = stack.pop() {
                    nodes += 1;
                    past += u64::from(entry > last + 1e-5);
                    let node = &tree.nodes[k as usize];
                    for slot in 0..8 {
                        let mut lo = NODE_EPSILON;
                        let mut hi = l.tmax;
                        for (a, (&i, &o)) in inv.iter().zip(&org).enumerate() {
                            // `plane · inverse − origin · inverse`, fused, as `visit`'s.
                            let d = |row: usize| node.bounds[row][slot].mul_add(i, -(o * i));
                            let (near, far) = if i < 0.0 { (2 * a + 1, 2 * a) } else { (2 * a, 2 * a + 1) };
                            lo = lo.max(d(near));
                            hi = hi.min(d(far));
                        }
                        if lo > hi {
                            continue;
                        }
                        let c = node.child[slot];
                        if node.imask >> slot & 1 == 1 {
                            stack.push((c, lo));
                        } else if c & wide8::LEAF != 0 {
                            tris += u64::from((c & !wide8::LEAF).count_ones());
                        }
                    }
                }
            }
            let per = |x: u64| x as f64 / crossed as f64;
            eprintln!(
                "{spec}: {crossed} of {n} lines cross; per crossing line: {:.2} nodes, {:.2} triangles tested, {:.2} crossings kept, {:.3} nodes entered only past the last crossing",
                per(nodes),
                per(tris),
                per(buf.crossings.len() as u64),
                per(past),
            );
        }
    }
}
