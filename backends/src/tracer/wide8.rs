//! The renderer's single-ray walk over *uncompressed* 8-wide nodes, the
//! layout of Embree's CPU walk: each node holds its eight children's boxes
//! as `f32` in a structure of arrays (`lower_x[8]`, `upper_x[8]`, … 192
//! bytes) and the children's references, so a node test is six loads, six
//! `(plane − origin) · inverse`, three max, three min and one compare, with
//! no decoding of quantised planes and no child-order bookkeeping.
//!
//! The tree is the CPU backend's obvhs CWBVH decoded node for node (node
//! `i` here is node `i` there, leaves hold the same primitive groups): each
//! child's box is its quantised box `p + e·q` (exact in `f32`: `e` is a
//! power of two, `q` a byte) widened by one ulp outwards, so it contains
//! the compressed box, which contains the padded triangle boxes
//! (`docs/TRACING.md`, *The BVH*). A conservative tree changes which nodes
//! are visited, not the answers: the closest hit is the smallest `t` with
//! ties to the smaller triangle (decided by the caller's leaf test), and
//! occlusion is whether any triangle is crossed.
//!
//! The walk: the ray's direction signs pick, once per ray, which of
//! `lower`/`upper` is the near plane of each axis; a node's leaf children
//! hit by the ray are tested at once (one primitive group, as the CWBVH
//! walk does, `node8::walk_groups`), then the internal children hit are
//! visited nearest first (one: go; two: one compare; more: a small sort by
//! entry distance), the others pushed with their entry distance, and a
//! popped node whose entry is beyond the best hit so far is skipped. The
//! any-hit walk keeps no order (any crossing ends it).
//!
//! Each node's primitive group is also copied into aligned blocks of eight
//! triangles ([`Leaf8`], [`Wide8::leaves`]), so the leaf test reads one
//! aligned row per axis and vertex and finds each lane's triangle index
//! beside its coordinates.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, _CMP_LE_OQ, _mm_cvtsi128_si32, _mm_or_si128, _mm_shuffle_epi32, _mm256_and_si256, _mm256_castsi256_si128,
    _mm256_cmp_ps, _mm256_extracti128_si256, _mm256_load_ps, _mm256_load_si256, _mm256_max_ps, _mm256_min_ps,
    _mm256_movemask_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_srai_epi32, _mm256_storeu_ps, _mm256_sub_ps,
};
use std::mem::MaybeUninit;

use glam::Vec3A;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;

use super::node8::{NODE_EPSILON, Tally};
use super::watertight::{BLOCK, Block, Leaf8, Shear, mask_blocks};

/// A leaf child's entry in [`Node::child`]: this bit, and the child's
/// primitives as a mask over the node's primitive group (bits 0..24).
pub(super) const LEAF: u32 = 1 << 31;

/// Depth of the traversal stack. [`Wide8::new`] computes the most entries
/// any walk of its tree can hold and declines a tree that needs more.
pub(super) const STACK: usize = 128;

/// One 8-wide node: 256 bytes, four cache lines (checked below).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Node {
    /// `bounds[2·axis + side][slot]`: side 0 the lower plane, 1 the upper;
    /// an empty slot has lower `+∞` and upper `−∞` (no ray enters it).
    pub(super) bounds: [[f32; 8]; 6],
    /// Per slot: an internal child's node index, [`LEAF`] with its
    /// primitive mask for a leaf child, 0 for an empty slot.
    pub(super) child: [u32; 8],
    /// First primitive (BVH order) of the node's primitive group.
    pub(super) prim_base: u32,
    /// Bit `i`: slot `i` is an internal child.
    pub(super) imask: u32,
    /// The node's primitive group in [`Wide8::leaves`]: primitive
    /// `prim_base + j` is lane `j % 8` of block `leaf_base + j / 8`.
    pub(super) leaf_base: u32,
    /// Bit `i`: slot `i` is occupied (its `child` is not 0), kept in the
    /// node's spare bytes rather than found from `child` at every visit
    /// (2% of the viewpoint channel's occlusion walk): set by
    /// [`Node::seal`] once the slots are filled.
    pub(super) occupied: u32,
}

const _: () = assert!(size_of::<Node>() == 256);

impl Node {
    /// The occupied child slots, as a bit mask (an empty slot's child is 0).
    #[inline(always)]
    pub(super) fn occupied(&self) -> u32 {
        self.occupied
    }

    /// Records which slots are occupied ([`Node::occupied`]): called once
    /// `child` is final.
    pub(super) fn seal(&mut self) {
        self.occupied = self.child.iter().enumerate().fold(0u32, |m, (c, &x)| m | u32::from(x != 0) << c);
    }
}

/// The CPU backend's BVH as uncompressed 8-wide nodes, and each node's
/// leaf triangles in aligned blocks of eight.
#[derive(Clone, Debug)]
pub(crate) struct Wide8 {
    pub(super) nodes: Vec<Node>,
    /// Each node's primitive group (its leaf children's triangles, in BVH
    /// order) from an aligned block on ([`Node::leaf_base`]): one aligned
    /// load per coordinate for eight of them, the group's primitive mask
    /// read block by block, and each lane's triangle index beside its
    /// coordinates.
    pub(super) leaves: Vec<Leaf8>,
}

impl Wide8 {
    /// Decodes `bvh` node for node, with its triangles `ordered` (BVH
    /// order: `ordered[k]` is triangle `bvh.primitive_indices[k]`) copied
    /// into each node's leaf blocks; `None` if some walk of it could need
    /// more than [`STACK`] stack entries, or if its nodes (256 bytes each,
    /// `bvh.nodes.len()` of them) or its leaf blocks (320 bytes per eight
    /// lanes of each node's group, counted from the nodes) cannot be
    /// allocated (both known before allocating): then the CWBVH walk
    /// serves, with the same answers.
    pub(crate) fn new(bvh: &CwBvh, ordered: &[[Vec3A; 3]]) -> Option<Self> {
        let mut nodes: Vec<Node> = Vec::new();
        nodes.try_reserve_exact(bvh.nodes.len()).ok()?;
        nodes.extend(bvh.nodes.iter().map(decode));
        let blocks: usize = nodes.iter().map(|n| group_len(n).div_ceil(BLOCK)).sum();
        u32::try_from(blocks).ok()?;
        let mut leaves: Vec<Leaf8> = Vec::new();
        leaves.try_reserve_exact(blocks).ok()?;
        for n in &mut nodes {
            n.leaf_base = leaves.len() as u32;
            let len = group_len(n);
            for b in 0..len.div_ceil(BLOCK) {
                let mut leaf = Leaf8::EMPTY;
                for (i, j) in (b * BLOCK..len.min((b + 1) * BLOCK)).enumerate() {
                    let k = n.prim_base as usize + j;
                    leaf.set(i, bvh.primitive_indices[k], &ordered[k]);
                }
                leaves.push(leaf);
            }
        }
        let tree = Self { nodes, leaves };
        (tree.nodes.is_empty() || tree.stack_need(0) < STACK).then_some(tree)
    }

    /// Tests the primitives of `mask` (bit `j`: primitive `prim_base + j`
    /// of `n`'s group, as [`walk_nodes`] hands them) against the ray of
    /// `shear` within `[tmin, tmax]`, one [`Leaf8`] block of up to eight
    /// at a time, handing each block's answers and the block to `each`;
    /// stops, returning `true`, when `each` does.
    ///
    /// # Safety
    /// `AVX2` only where the CPU has AVX2 (`node8::has_avx2`).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) unsafe fn leaf_blocks<const AVX2: bool>(
        &self,
        n: &Node,
        mask: u32,
        shear: &Shear,
        tmin: f32,
        tmax: f32,
        tally: &impl Tally,
        mut each: impl FnMut(&Block, &Leaf8) -> bool,
    ) -> bool {
        for (b, lanes) in mask_blocks(mask) {
            tally.triangles(lanes);
            let leaf = &self.leaves[(n.leaf_base + b) as usize];
            // SAFETY: `AVX2` only where the CPU has it (this function's contract).
            let block = unsafe { leaf.test::<AVX2>(shear, lanes, tmin, tmax) };
            if each(&block, leaf) {
                return true;
            }
        }
        false
    }

    /// Nodes in the tree.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes of the node array and of the leaf blocks.
    #[cfg(test)]
    pub(crate) fn bytes(&self) -> (usize, usize) {
        (self.nodes.len() * size_of::<Node>(), self.leaves.len() * size_of::<Leaf8>())
    }

    /// The most stack entries a walk from `node` holds, or [`STACK`] if
    /// that many or more: at each node it pushes all but one of its
    /// internal children, so the need is the largest sum of those counts
    /// over a path from `node` down. Walked with a heap stack, not by
    /// recursion, so a degenerate (chain-shaped) tree cannot overflow the
    /// thread's own stack here.
    fn stack_need(&self, node: u32) -> usize {
        let mut todo = vec![(node, 0usize)];
        let mut most = 0;
        while let Some((i, above)) = todo.pop() {
            let n = &self.nodes[i as usize];
            let need = above + (n.imask.count_ones() as usize).saturating_sub(1);
            most = most.max(need);
            if most >= STACK {
                return STACK;
            }
            todo.extend((0..8).filter(|&k| n.imask >> k & 1 == 1).map(|k| (n.child[k], need)));
        }
        most
    }
}

/// Primitives in `n`'s group: its leaf children's primitive masks are
/// contiguous from bit 0 (a CWBVH node's leaves share one run of
/// primitives from `primitive_base_idx`).
fn group_len(n: &Node) -> usize {
    let prims = (0..8).filter(|&i| n.imask >> i & 1 == 0).fold(0, |m, i| m | n.child[i]) & !LEAF;
    (32 - prims.leading_zeros()) as usize
}

/// Node `n` of a CWBVH, uncompressed.
fn decode(n: &obvhs::cwbvh::node::CwBvhNode) -> Node {
    let mut node = Node {
        bounds: [
            [f32::INFINITY; 8],
            [f32::NEG_INFINITY; 8],
            [f32::INFINITY; 8],
            [f32::NEG_INFINITY; 8],
            [f32::INFINITY; 8],
            [f32::NEG_INFINITY; 8],
        ],
        child: [0; 8],
        prim_base: n.primitive_base_idx,
        imask: u32::from(n.imask),
        leaf_base: 0,
        occupied: 0,
    };
    for slot in 0..8 {
        if n.is_child_empty(slot) {
            continue;
        }
        let b = n.child_aabb(slot);
        for axis in 0..3 {
            node.bounds[2 * axis][slot] = b.min[axis].next_down();
            node.bounds[2 * axis + 1][slot] = b.max[axis].next_up();
        }
        node.child[slot] = if n.is_leaf(slot) {
            let (first, count) = n.child_primitives(slot);
            LEAF | (((1u32 << count) - 1) << (first - n.primitive_base_idx))
        } else {
            n.child_node_index(slot)
        };
    }
    node.seal();
    node
}

/// A ray's constants for the node test.
pub(super) struct Consts {
    org: [f32; 3],
    inv: [f32; 3],
    /// Row of [`Node::bounds`] holding each axis's near plane; the far
    /// plane is the other side (`near ^ 1`).
    near: [usize; 3],
}

impl Consts {
    pub(super) fn new(ray: &Ray) -> Self {
        let inv = ray.inv_direction.to_array();
        // Written out, not `array::map`, which stayed a call in the
        // collapsed tree's walk (1.2% of a mirror-room render).
        let near = |a: usize| 2 * a + usize::from(inv[a] < 0.0);
        Self { org: ray.origin.to_array(), inv, near: [near(0), near(1), near(2)] }
    }
}

/// The children of `n` that the ray enters within `[NODE_EPSILON, tmax]`
/// (bit `i` for slot `i`) and each child's entry distance.
#[inline(always)]
pub(super) fn test_scalar(n: &Node, c: &Consts, tmax: f32) -> (u32, [f32; 8]) {
    let mut hit = 0;
    let mut near = [0.0f32; 8];
    for (i, entry) in near.iter_mut().enumerate() {
        let t = |row: usize, a: usize| (n.bounds[row][i] - c.org[a]) * c.inv[a];
        let (nx, ny, nz) = (t(c.near[0], 0), t(c.near[1], 1), t(c.near[2], 2));
        let (fx, fy, fz) = (t(c.near[0] ^ 1, 0), t(c.near[1] ^ 1, 1), t(c.near[2] ^ 1, 2));
        let lo = nx.max(ny).max(nz.max(NODE_EPSILON));
        let hi = fx.min(fy).min(fz.min(tmax));
        *entry = lo;
        hit |= u32::from(lo <= hi) << i;
    }
    (hit, near)
}

/// [`test_scalar`] with AVX2: the same operations, eight slots at once.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) unsafe fn test_avx2(n: &Node, c: &Consts, tmax: f32) -> (u32, __m256) {
    // SAFETY: AVX2 (this function's contract); every load reads one
    // 32-byte row of `n.bounds`, 32-byte aligned (`Node` is 64-aligned,
    // rows are 32 bytes).
    unsafe {
        // A macro, not a closure: a closure is not compiled for AVX2, and
        // its intrinsics then stay calls.
        macro_rules! t {
            ($row:expr, $a:expr) => {
                _mm256_mul_ps(
                    _mm256_sub_ps(_mm256_load_ps(n.bounds[$row].as_ptr()), _mm256_set1_ps(c.org[$a])),
                    _mm256_set1_ps(c.inv[$a]),
                )
            };
        }
        let (nx, ny, nz) = (t!(c.near[0], 0), t!(c.near[1], 1), t!(c.near[2], 2));
        let (fx, fy, fz) = (t!(c.near[0] ^ 1, 0), t!(c.near[1] ^ 1, 1), t!(c.near[2] ^ 1, 2));
        // Operand order as `f32::max`/`min` above on ordered values (the
        // planes are finite or ±∞ and `inv` finite and non-zero: no NaN
        // unless the ray's origin is not finite).
        let lo = _mm256_max_ps(_mm256_max_ps(nx, ny), _mm256_max_ps(nz, _mm256_set1_ps(NODE_EPSILON)));
        let hi = _mm256_min_ps(_mm256_min_ps(fx, fy), _mm256_min_ps(fz, _mm256_set1_ps(tmax)));
        let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(lo, hi);
        (_mm256_movemask_ps(hit) as u32, lo)
    }
}

/// The primitive mask of the leaf children among `hit` (bits 0..24 of
/// the node's primitive group).
#[inline(always)]
fn leaf_prims_scalar(n: &Node, hit: u32) -> u32 {
    let mut m = hit & !n.imask;
    let mut prims = 0;
    while m != 0 {
        let i = m.trailing_zeros() as usize;
        m &= m - 1;
        prims |= n.child[i];
    }
    prims & !LEAF
}

/// [`leaf_prims_scalar`] without a loop: the slots' entries masked by
/// their own [`LEAF`] bit and by `hit`, OR-reduced.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn leaf_prims_avx2(n: &Node, hit: u32) -> u32 {
    use std::arch::x86_64::{__m256i, _mm256_cmpeq_epi32, _mm256_set1_epi32, _mm256_setr_epi32};
    // SAFETY: AVX2 (this function's contract); `child` is 32 bytes at
    // offset 192 of a 64-aligned `Node`, so 32-byte aligned.
    unsafe {
        let c = _mm256_load_si256(n.child.as_ptr().cast::<__m256i>());
        let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let hitv = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(hit as i32), bit), bit);
        let lanes = _mm256_and_si256(_mm256_and_si256(c, _mm256_srai_epi32::<31>(c)), hitv);
        let x = _mm_or_si128(_mm256_castsi256_si128(lanes), _mm256_extracti128_si256::<1>(lanes));
        let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b0100_1110>(x));
        let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b1011_0001>(x));
        _mm_cvtsi128_si32(x) as u32 & !LEAF
    }
}

/// The descent of an ordered walk where three or more children are hit:
/// `first`, `second` and the slots left in `m`, sorted by entry distance
/// (its bits order as the values do, all being at least `NODE_EPSILON >
/// 0`), ties by slot; all but the nearest pushed, farthest first, and the
/// nearest returned to be visited next. Shared by this tree's walk and
/// [`Tree8`](super::tree8::Tree8)'s.
#[inline(always)]
pub(super) fn push_by_entry(
    child: &[u32; 8],
    near: &[f32; 8],
    first: usize,
    second: usize,
    mut m: u32,
    stack: &mut [MaybeUninit<(u32, f32)>; STACK],
    depth: &mut usize,
) -> u32 {
    let key = |i: usize| u64::from(near[i].to_bits()) << 3 | i as u64;
    let mut keys = [0u64; 8];
    keys[0] = key(first);
    keys[1] = key(second);
    let mut k = 2;
    while m != 0 {
        keys[k] = key(m.trailing_zeros() as usize);
        m &= m - 1;
        k += 1;
    }
    // Insertion sort, descending (k ≤ 8).
    for a in 1..k {
        let v = keys[a];
        let mut j = a;
        while j > 0 && keys[j - 1] < v {
            keys[j] = keys[j - 1];
            j -= 1;
        }
        keys[j] = v;
    }
    for &v in &keys[..k - 1] {
        let i = (v & 7) as usize;
        stack[*depth] = MaybeUninit::new((child[i], near[i]));
        *depth += 1;
    }
    child[(keys[k - 1] & 7) as usize]
}

/// Walks `tree` along `ray`, calling `leaves(node, mask, &mut tmax)` with
/// each visited node and the primitives of its hit leaf children (bit `j`
/// of `mask`, below 24: primitive `node.prim_base + j` in BVH order, lane
/// `j % 8` of its block `node.leaf_base + j / 8` in [`Wide8::leaves`]);
/// `leaves` may shrink `tmax` (closest hit) and returns `true` to end the
/// walk (any hit). `tally` counts the nodes tested.
///
/// `ORDERED` (closest hit): a node's internal children are visited
/// nearest first, the others pushed with their entry distance, and a
/// popped node entered beyond `tmax` is skipped. Not `ORDERED` (any hit,
/// where the order cannot change the answer): they are visited in slot
/// order, the stack holds node indices only, and no entry distance is kept
/// or compared (a popped node is visited whatever `tmax` is then).
///
/// # Safety
/// `AVX2` only where the CPU has AVX2 (`node8::has_avx2`).
#[inline(always)]
pub(super) unsafe fn walk_nodes<const AVX2: bool, const ORDERED: bool, F: FnMut(&Node, u32, &mut f32) -> bool>(
    tree: &Wide8,
    ray: &Ray,
    tally: &impl Tally,
    mut leaves: F,
) {
    if tree.nodes.is_empty() {
        return;
    }
    let c = Consts::new(ray);
    let mut tmax = ray.tmax;
    // (node, entry distance); at most `STACK - 1` entries (`Wide8::new`).
    // The unordered walk writes its distances as 0 and never reads them.
    let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); STACK];
    let mut depth = 0usize;
    let mut node = 0u32;
    'walk: loop {
        let n = &tree.nodes[node as usize];
        tally.node();
        let mut near = [0.0f32; 8];
        #[cfg(target_arch = "x86_64")]
        let (hit, prims) = if AVX2 {
            // SAFETY: `AVX2` only where the CPU has AVX2 (this function's contract).
            unsafe {
                let (hit, lo) = test_avx2(n, &c, tmax);
                if ORDERED {
                    _mm256_storeu_ps(near.as_mut_ptr(), lo);
                }
                (hit, leaf_prims_avx2(n, hit))
            }
        } else {
            let (hit, lo) = test_scalar(n, &c, tmax);
            near = lo;
            (hit, leaf_prims_scalar(n, hit))
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (hit, prims) = {
            let (hit, lo) = test_scalar(n, &c, tmax);
            near = lo;
            (hit, leaf_prims_scalar(n, hit))
        };
        let mut m = hit & n.imask;
        if prims != 0 {
            if leaves(n, prims, &mut tmax) {
                return;
            }
            // Children entered beyond a hit just found are not visited.
            let mut k = if ORDERED { m } else { 0 };
            while k != 0 {
                let i = k.trailing_zeros();
                k &= k - 1;
                if near[i as usize] > tmax {
                    m &= !(1 << i);
                }
            }
        }
        if !ORDERED {
            if m != 0 {
                node = n.child[m.trailing_zeros() as usize];
                m &= m - 1;
                while m != 0 {
                    stack[depth] = MaybeUninit::new((n.child[m.trailing_zeros() as usize], 0.0));
                    depth += 1;
                    m &= m - 1;
                }
                continue;
            }
            if depth == 0 {
                return;
            }
            depth -= 1;
            // SAFETY: as the pop below.
            node = unsafe { stack[depth].assume_init() }.0;
            continue;
        }
        if m != 0 {
            let first = m.trailing_zeros() as usize;
            m &= m - 1;
            if m == 0 {
                node = n.child[first];
                continue;
            }
            let second = m.trailing_zeros() as usize;
            m &= m - 1;
            if m == 0 {
                let (a, b) = if near[second] < near[first] { (second, first) } else { (first, second) };
                stack[depth] = MaybeUninit::new((n.child[b], near[b]));
                depth += 1;
                node = n.child[a];
                continue;
            }
            node = push_by_entry(&n.child, &near, first, second, m, &mut stack, &mut depth);
            continue;
        }
        while depth > 0 {
            depth -= 1;
            // SAFETY: every slot below `depth` was written by a push since
            // this walk began (a push writes `stack[depth]` before raising
            // `depth`, and a pop lowers it first).
            let (next, entry) = unsafe { stack[depth].assume_init() };
            if entry <= tmax {
                node = next;
                continue 'walk;
            }
        }
        return;
    }
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Vec3A};

    use super::*;
    use crate::lines::{Line, LineRng, global_line};
    use crate::scene::built_in;
    use crate::tracer::cpu::build_bvh;
    use crate::tracer::node8::has_avx2;
    use crate::tracer::{Prepared, bvh_input};

    /// Every decoded box contains its compressed box, leaves hold the
    /// CWBVH's primitives, each node's leaf blocks hold its group's
    /// triangles lane by lane, and the AVX2 node test returns the scalar
    /// test's mask and entry distances on every node for many rays.
    #[test]
    fn decoded_nodes_and_node_tests_agree() {
        for spec in ["cube-enclosure:6", "cubes-room:16", "geosphere", "table-chairs:2", "mirror-room"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let bvh = build_bvh(&p, bvh_input(&p).1);
            let tree = Wide8::new(&bvh, &ordered(&p, &bvh)).unwrap();
            assert_eq!(tree.len(), bvh.nodes.len());
            for (n, w) in bvh.nodes.iter().zip(&tree.nodes) {
                // The group's triangles, lane by lane, then empty lanes.
                let len = group_len(w);
                for j in 0..len.div_ceil(BLOCK) * BLOCK {
                    let leaf = &tree.leaves[w.leaf_base as usize + j / BLOCK];
                    let k = w.prim_base as usize + j;
                    if j < len {
                        let tri = bvh.primitive_indices[k];
                        assert_eq!(leaf.tri[j % BLOCK], tri, "{spec}");
                        assert_eq!(leaf.vertices(j % BLOCK), p.triangles[tri as usize], "{spec}");
                    } else {
                        assert_eq!(leaf.tri[j % BLOCK], u32::MAX, "{spec}");
                    }
                }
                let mut prims = 0u32;
                for slot in 0..8 {
                    if n.is_child_empty(slot) {
                        assert_eq!(w.child[slot], 0);
                        continue;
                    }
                    let b = n.child_aabb(slot);
                    for axis in 0..3 {
                        assert!(w.bounds[2 * axis][slot] < b.min[axis] && w.bounds[2 * axis + 1][slot] > b.max[axis]);
                    }
                    if n.is_leaf(slot) {
                        let (first, count) = n.child_primitives(slot);
                        let mask = w.child[slot] & !LEAF;
                        assert_eq!((mask.trailing_zeros() + n.primitive_base_idx, mask.count_ones()), (first, count));
                        assert_eq!(prims & mask, 0, "{spec}: leaves overlap");
                        prims |= mask;
                    }
                }
            }
            let mut nonempty = 0;
            for i in 0..200 {
                let l = global_line(5, i, 1.1);
                let ray = Ray::new(Vec3A::from(l.origin), Vec3A::from(l.direction), l.tmin, l.tmax);
                let c = Consts::new(&ray);
                for n in &tree.nodes {
                    for tmax in [l.tmax, 0.5] {
                        let (hit, near) = test_scalar(n, &c, tmax);
                        nonempty += u32::from(hit != 0);
                        assert_eq!(leaf_prims_scalar(n, hit) & !0x00ff_ffff, 0);
                        #[cfg(target_arch = "x86_64")]
                        if has_avx2() {
                            // SAFETY: AVX2 checked.
                            let (h, lo, prims) = unsafe {
                                let (h, lo) = test_avx2(n, &c, tmax);
                                let mut out = [0.0f32; 8];
                                _mm256_storeu_ps(out.as_mut_ptr(), lo);
                                (h, out, leaf_prims_avx2(n, hit))
                            };
                            assert_eq!(h, hit, "{spec}");
                            assert_eq!(lo.map(f32::to_bits), near.map(f32::to_bits), "{spec}");
                            assert_eq!(prims, leaf_prims_scalar(n, hit), "{spec}");
                        }
                    }
                }
            }
            assert!(nonempty > 100, "{spec}: only {nonempty} non-empty masks");
        }
    }

    /// The scene's triangles in `bvh`'s order.
    fn ordered(p: &Prepared, bvh: &CwBvh) -> Vec<[Vec3A; 3]> {
        bvh.primitive_indices.iter().map(|&i| p.triangles[i as usize]).collect()
    }

    /// The wide walk, ordered or not, visits, for each ray, a superset of the leaf
    /// primitives that can hold its closest hit: with a leaf test that
    /// records every candidate, a ray's crossings found by the reference
    /// (every triangle) before its `tmax` are all among them. Checked on
    /// rays from inside the scenes, cut short and not.
    #[test]
    fn the_walk_reaches_every_crossed_triangle() {
        for spec in ["cube-enclosure:6", "cubes-room:16", "table-chairs:2", "mirror-room", "cornell-box"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let bvh = build_bvh(&p, bvh_input(&p).1);
            let tree = Wide8::new(&bvh, &ordered(&p, &bvh)).unwrap();
            let mut reached = 0u64;
            for i in 0..2_000u64 {
                let r = LineRng::new(8, i);
                let o = DVec3::new(r.uniform(0), r.uniform(1), r.uniform(2)) * 0.8 - 0.4;
                let d = DVec3::new(r.uniform(3) - 0.5, r.uniform(4) - 0.5, r.uniform(5) - 0.5).normalize();
                let l = Line::ray(o, d, 0.0, 2.0 * r.uniform(6));
                let (shear, dir) = crate::tracer::watertight::Shear::of(&l);
                let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
                for (avx2, ordered) in [(false, true), (has_avx2(), true), (false, false), (has_avx2(), false)] {
                    let mut seen = vec![false; bvh.primitive_indices.len()];
                    let visit = |n: &Node, mask: u32, _: &mut f32| {
                        let mut m = mask;
                        while m != 0 {
                            seen[(n.prim_base + m.trailing_zeros()) as usize] = true;
                            m &= m - 1;
                        }
                        false
                    };
                    // SAFETY: `avx2` only where the CPU has it.
                    unsafe {
                        match (avx2, ordered) {
                            (true, true) => walk_nodes::<true, true, _>(&tree, &ray, &(), visit),
                            (false, true) => walk_nodes::<false, true, _>(&tree, &ray, &(), visit),
                            (true, false) => walk_nodes::<true, false, _>(&tree, &ray, &(), visit),
                            (false, false) => walk_nodes::<false, false, _>(&tree, &ray, &(), visit),
                        }
                    }
                    for (k, &tri) in bvh.primitive_indices.iter().enumerate() {
                        if let Some(t) = shear.hit(&p.triangles[tri as usize])
                            && t >= l.tmin
                            && t <= l.tmax
                        {
                            assert!(seen[k], "{spec} ray {i}: triangle {tri} at {t} not reached");
                            reached += 1;
                        }
                    }
                }
            }
            assert!(reached > 1_000, "{spec}: only {reached} crossings checked");
        }
    }
}
