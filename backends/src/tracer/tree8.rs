//! The renderer's single-ray walks' own 8-wide tree (`closest_hit` and
//! `occluded` for the rays no packet takes): the same node layout as
//! [`Wide8`](super::wide8::Wide8) (eight children's `f32` boxes as a
//! structure of arrays, [`Node`]), but built here from obvhs's binary tree
//! instead of decoded from its CWBVH, so that a leaf is one aligned block
//! of up to eight triangles ([`Leaf8`]) instead of up to three triangles
//! inside a node's primitive group.
//!
//! The collapse is top-down: a wide node starts from a binary node's two
//! children and opens the child of largest surface area (the one a random
//! ray most likely enters) until it has eight children or none is left to
//! open; a binary subtree of at most `leaf` triangles is not opened but
//! becomes one leaf block. A child's box is the binary node's box, which
//! contains its triangles' padded boxes (`cpu::bvh_input`), so the tree is
//! conservative and the answers are the binary tree's: the closest hit is
//! the smallest `t` with ties to the smaller triangle, decided by the
//! caller's leaf test, and occlusion is whether any triangle is crossed,
//! whatever the tree and the order of the walk.
//!
//! A leaf child's entry in [`Node::child`] is [`LEAF`], its lane count
//! less one in bits 28..31 and its block's index below. The fields
//! `prim_base` and `leaf_base` are unused (0): this tree is read only by
//! the walks below, not by the packets or `trace_all`, which read the
//! decoded CWBVH ([`Wide8`](super::wide8::Wide8)) and its primitive order.
//!
//! The closest-hit walk visits a node's hit children, leaves and internal
//! nodes alike, nearest entry first: leaves before the nearest internal
//! child are tested at once (skipped once a hit nearer than their entry is
//! found), the nearest internal child is visited next, and the rest wait
//! on the stack with their entry distance, skipped when popped beyond the
//! best hit so far. The any-hit walk keeps no order.

use std::mem::MaybeUninit;

use glam::Vec3A;
use obvhs::bvh2::Bvh2;
use obvhs::ray::Ray;

use super::node8::Tally;
use super::watertight::Leaf8;
use super::wide8::{Consts, LEAF, Node, STACK, test_scalar};

/// Bits of a leaf's entry below its lane count: the block's index.
const BLOCK_BITS: u32 = 28;

/// The most triangles a leaf may hold: one block.
pub(crate) const MAX_LEAF: usize = 8;

/// The renderer's single-ray tree: 8-wide nodes and one aligned block of
/// up to eight triangles a leaf.
#[derive(Clone, Debug)]
pub(crate) struct Tree8 {
    nodes: Vec<Node>,
    leaves: Vec<Leaf8>,
}

impl Tree8 {
    /// Collapses `bvh` (over `triangles`: its primitive `k` is triangle
    /// `bvh.primitive_indices[k]`) into 8-wide nodes whose leaves hold up
    /// to `leaf` (1..=8) triangles; `None` if some walk of it could need
    /// [`STACK`] stack entries or more, if a leaf of `bvh` holds more than
    /// eight triangles, if there are 2^28 primitives or more, or if its
    /// nodes or blocks cannot be allocated (fallible reservations as they
    /// grow): then the decoded CWBVH's walk serves, with the same answers.
    pub(crate) fn new(bvh: &Bvh2, triangles: &[[Vec3A; 3]], leaf: usize) -> Option<Self> {
        assert!((1..=MAX_LEAF).contains(&leaf), "leaves of 1 to 8 triangles");
        if bvh.nodes.is_empty() {
            return None;
        }
        let counts = prim_counts(bvh)?;
        // A binary leaf is never opened (its `first_index` is a primitive's).
        let leafy = |b: u32| counts[b as usize] as usize <= leaf || bvh.nodes[b as usize].is_leaf();
        // Every leaf holds at least one primitive, so block indices fit.
        (counts[0] < 1 << BLOCK_BITS).then_some(())?;
        // Both arrays grow by fallible reservations (a node's children at
        // a time), so a tree that cannot be allocated is declined.
        let mut nodes: Vec<Node> = Vec::new();
        let mut leaves: Vec<Leaf8> = Vec::new();
        nodes.try_reserve(1).ok()?;
        nodes.push(EMPTY);
        // (binary node, wide node it fills)
        let mut todo: Vec<(u32, u32)> = vec![(0, 0)];
        let mut prims: Vec<u32> = Vec::with_capacity(MAX_LEAF);
        while let Some((b, w)) = todo.pop() {
            let node = &bvh.nodes[b as usize];
            let mut kids: Vec<u32> = if leafy(b) { vec![b] } else { vec![node.first_index, node.first_index + 1] };
            while kids.len() < 8 {
                // The largest child still to open.
                let open = kids
                    .iter()
                    .enumerate()
                    .filter(|&(_, &c)| !leafy(c))
                    .max_by(|a, c| area(bvh, *a.1).total_cmp(&area(bvh, *c.1)))
                    .map(|(i, _)| i);
                let Some(i) = open else { break };
                let c = bvh.nodes[kids[i] as usize].first_index;
                kids[i] = c;
                kids.push(c + 1);
            }
            nodes.try_reserve(kids.len()).ok()?;
            leaves.try_reserve(kids.len()).ok()?;
            // Internal children take consecutive nodes (their lines are
            // then neighbours, as the CWBVH's are).
            let mut next = nodes.len() as u32;
            let mut out = EMPTY;
            for (slot, &c) in kids.iter().enumerate() {
                let bb = &bvh.nodes[c as usize].aabb;
                for axis in 0..3 {
                    out.bounds[2 * axis][slot] = bb.min[axis];
                    out.bounds[2 * axis + 1][slot] = bb.max[axis];
                }
                if leafy(c) {
                    prims.clear();
                    gather(bvh, c, &mut prims);
                    let mut block = Leaf8::EMPTY;
                    for (i, &k) in prims.iter().enumerate() {
                        let tri = bvh.primitive_indices[k as usize];
                        block.set(i, tri, &triangles[tri as usize]);
                    }
                    out.child[slot] = LEAF | ((prims.len() as u32 - 1) << BLOCK_BITS) | leaves.len() as u32;
                    leaves.push(block);
                } else {
                    out.child[slot] = next;
                    out.imask |= 1 << slot;
                    todo.push((c, next));
                    next += 1;
                }
            }
            out.seal();
            nodes[w as usize] = out;
            nodes.resize(next as usize, EMPTY);
        }
        let tree = Self { nodes, leaves };
        (tree.stack_need() < STACK).then_some(tree)
    }

    /// Nodes and leaf blocks in the tree.
    #[cfg(test)]
    pub(crate) fn len(&self) -> (usize, usize) {
        (self.nodes.len(), self.leaves.len())
    }

    /// Bytes of the node array and of the leaf blocks.
    #[cfg(test)]
    pub(crate) fn bytes(&self) -> (usize, usize) {
        (self.nodes.len() * size_of::<Node>(), self.leaves.len() * size_of::<Leaf8>())
    }

    /// Lanes filled, of all the blocks' lanes.
    #[cfg(test)]
    pub(crate) fn fill(&self) -> f64 {
        let used: usize = self.leaves.iter().map(|b| b.tri.iter().filter(|&&t| t != u32::MAX).count()).sum();
        used as f64 / (self.leaves.len() * 8) as f64
    }

    /// The leaf entry `code`'s block and its lanes' mask.
    #[inline(always)]
    pub(super) fn leaf(&self, code: u32) -> (&Leaf8, u32) {
        let lanes = (1u32 << (((code >> BLOCK_BITS) & 7) + 1)) - 1;
        (&self.leaves[(code & ((1 << BLOCK_BITS) - 1)) as usize], lanes)
    }

    /// The most stack entries a walk holds, or [`STACK`] if that many or
    /// more: at each node the closest-hit walk pushes at most all but one
    /// of its children, leaves included, so the need is the largest sum of
    /// those counts over a path from the root down (a heap stack here, no
    /// recursion).
    fn stack_need(&self) -> usize {
        let mut todo = vec![(0u32, 0usize)];
        let mut most = 0;
        while let Some((i, above)) = todo.pop() {
            let n = &self.nodes[i as usize];
            let occupied = n.child.iter().filter(|&&c| c != 0).count();
            let need = above + occupied.saturating_sub(1);
            most = most.max(need);
            if most >= STACK {
                return STACK;
            }
            todo.extend((0..8).filter(|&k| n.imask >> k & 1 == 1).map(|k| (n.child[k], need)));
        }
        most
    }
}

/// A node with every slot empty (no ray enters a box of lower `+∞` and
/// upper `−∞`).
const EMPTY: Node = Node {
    bounds: [
        [f32::INFINITY; 8],
        [f32::NEG_INFINITY; 8],
        [f32::INFINITY; 8],
        [f32::NEG_INFINITY; 8],
        [f32::INFINITY; 8],
        [f32::NEG_INFINITY; 8],
    ],
    child: [0; 8],
    prim_base: 0,
    imask: 0,
    leaf_base: 0,
    occupied: 0,
};

/// Half the surface area of binary node `b`'s box.
fn area(bvh: &Bvh2, b: u32) -> f32 {
    bvh.nodes[b as usize].aabb.half_area()
}

/// Primitives under each binary node (saturating at `u32::MAX`), by an
/// explicit post-order walk; `None` if the count array cannot be
/// allocated or a binary leaf holds more than a block ([`MAX_LEAF`]).
fn prim_counts(bvh: &Bvh2) -> Option<Vec<u32>> {
    let mut counts: Vec<u32> = Vec::new();
    counts.try_reserve_exact(bvh.nodes.len()).ok()?;
    counts.resize(bvh.nodes.len(), 0);
    let mut todo = vec![(0u32, false)];
    while let Some((b, children_done)) = todo.pop() {
        let n = &bvh.nodes[b as usize];
        if n.is_leaf() {
            if n.prim_count as usize > MAX_LEAF {
                return None;
            }
            counts[b as usize] = n.prim_count;
        } else if children_done {
            counts[b as usize] = counts[n.first_index as usize].saturating_add(counts[n.first_index as usize + 1]);
        } else {
            todo.push((b, true));
            todo.push((n.first_index, false));
            todo.push((n.first_index + 1, false));
        }
    }
    Some(counts)
}

/// The primitives (BVH order) under binary node `b`, appended to `out`.
fn gather(bvh: &Bvh2, b: u32, out: &mut Vec<u32>) {
    let mut todo = vec![b];
    while let Some(b) = todo.pop() {
        let n = &bvh.nodes[b as usize];
        if n.is_leaf() {
            out.extend(n.first_index..n.first_index + n.prim_count);
        } else {
            todo.push(n.first_index + 1);
            todo.push(n.first_index);
        }
    }
}

/// Walks `tree` along `ray`, calling `leaf(block, lanes, &mut tmax)` for
/// each leaf the walk tests ([`Tree8::leaf`]'s block and lane mask); `leaf`
/// may shrink `tmax` (closest hit) and returns `true` to end the walk (any
/// hit). `tally` counts the nodes tested.
///
/// A node's hit children, leaves and internal nodes alike, are taken one
/// at a time: the first is visited (a leaf tested, a node's children
/// tested) and the others wait on the stack. `ORDERED` (closest hit): the
/// first is the nearest entry (ties by slot), the others are pushed
/// farthest first with their entry distance and skipped when popped
/// beyond `tmax`. Not `ORDERED` (any hit, where the order cannot change
/// the answer): slot order, no distance kept or compared. `leaf` is called
/// at one place only, so the leaf test is inlined once.
///
/// # Safety
/// `AVX2` only where the CPU has AVX2 (`node8::has_avx2`).
#[inline(always)]
pub(super) unsafe fn walk<const AVX2: bool, const ORDERED: bool, F: FnMut(&Leaf8, u32, &mut f32) -> bool>(
    tree: &Tree8,
    ray: &Ray,
    tally: &impl Tally,
    mut leaf: F,
) {
    let c = Consts::new(ray);
    let mut tmax = ray.tmax;
    // (child entry, entry distance): a node index or a leaf's entry; at
    // most `STACK - 1` of them (`Tree8::new`).
    let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); STACK];
    let mut depth = 0usize;
    // The root node, then each child taken.
    let mut item = 0u32;
    'walk: loop {
        if item & LEAF != 0 {
            let (block, lanes) = tree.leaf(item);
            tally.triangles(lanes);
            if leaf(block, lanes, &mut tmax) {
                return;
            }
        } else {
            let n = &tree.nodes[item as usize];
            tally.node();
            let mut near = [0.0f32; 8];
            #[cfg(target_arch = "x86_64")]
            let hit = if AVX2 {
                // SAFETY: `AVX2` only where the CPU has AVX2 (this function's contract).
                unsafe {
                    let (hit, lo) = super::wide8::test_avx2(n, &c, tmax);
                    if ORDERED {
                        std::arch::x86_64::_mm256_storeu_ps(near.as_mut_ptr(), lo);
                    }
                    hit
                }
            } else {
                let (hit, lo) = test_scalar(n, &c, tmax);
                near = lo;
                hit
            };
            #[cfg(not(target_arch = "x86_64"))]
            let hit = {
                let (hit, lo) = test_scalar(n, &c, tmax);
                near = lo;
                hit
            };
            let mut m = hit;
            if m != 0 {
                let first = m.trailing_zeros() as usize;
                m &= m - 1;
                if m == 0 {
                    item = n.child[first];
                    continue;
                }
                if !ORDERED {
                    item = n.child[first];
                    while m != 0 {
                        stack[depth] = MaybeUninit::new((n.child[m.trailing_zeros() as usize], 0.0));
                        depth += 1;
                        m &= m - 1;
                    }
                    continue;
                }
                let second = m.trailing_zeros() as usize;
                m &= m - 1;
                if m == 0 {
                    let (a, b) = if near[second] < near[first] { (second, first) } else { (first, second) };
                    stack[depth] = MaybeUninit::new((n.child[b], near[b]));
                    depth += 1;
                    item = n.child[a];
                    continue;
                }
                item = super::wide8::push_by_entry(&n.child, &near, first, second, m, &mut stack, &mut depth);
                continue;
            }
        }
        while depth > 0 {
            depth -= 1;
            // SAFETY: every slot below `depth` was written by a push since
            // this walk began (a push writes `stack[depth]` before raising
            // `depth`, and a pop lowers it first).
            let (next, entry) = unsafe { stack[depth].assume_init() };
            if !ORDERED || entry <= tmax {
                item = next;
                continue 'walk;
            }
        }
        return;
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::lines::{Line, LineRng};
    use crate::scene::built_in;
    use crate::tracer::cpu::build_bvh2;
    use crate::tracer::node8::has_avx2;
    use crate::tracer::watertight::Shear;
    use crate::tracer::{Prepared, bvh_input};

    /// Every triangle sits in exactly one leaf (no split boxes here), in
    /// a lane below its leaf's count, inside every box on its path from
    /// the root; each node's internal children are the consecutive nodes
    /// its entries name; and a tree of leaves of `leaf` holds no larger
    /// one.
    #[test]
    fn every_triangle_in_one_leaf_inside_its_boxes() {
        for spec in ["cube-enclosure:6", "cubes-room:16", "geosphere", "mirror-room", "cornell-box"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let bvh2 = build_bvh2(&p, bvh_input(&p).1);
            for leaf in [1, 3, 8] {
                let tree = Tree8::new(&bvh2, &p.triangles, leaf).unwrap();
                let mut seen = vec![0u32; p.triangles.len()];
                // (node, the boxes above it as lower and upper corners)
                let mut todo = vec![(0u32, Vec3A::NEG_INFINITY, Vec3A::INFINITY)];
                while let Some((i, lo, hi)) = todo.pop() {
                    let n = &tree.nodes[i as usize];
                    let mut kids = vec![];
                    for slot in 0..8 {
                        let code = n.child[slot];
                        if code == 0 {
                            assert_eq!(n.bounds[0][slot], f32::INFINITY, "{spec}: an empty slot has no box");
                            continue;
                        }
                        let b = |side: usize| Vec3A::from([0, 1, 2].map(|a| n.bounds[2 * a + side][slot]));
                        let (blo, bhi) = (b(0).max(lo), b(1).min(hi));
                        if code & LEAF == 0 {
                            assert_ne!(n.imask >> slot & 1, 0);
                            kids.push(code);
                            todo.push((code, blo, bhi));
                            continue;
                        }
                        assert_eq!(n.imask >> slot & 1, 0);
                        let (block, lanes) = tree.leaf(code);
                        assert!(lanes.count_ones() as usize <= leaf, "{spec}: a leaf over {leaf}");
                        for (lane, &tri) in block.tri.iter().enumerate() {
                            if lanes >> lane & 1 == 0 {
                                assert_eq!(tri, u32::MAX, "{spec}: a padding lane holds a triangle");
                                continue;
                            }
                            let v = p.triangles[tri as usize];
                            assert_eq!(block.vertices(lane), v, "{spec}");
                            for c in v {
                                assert!(c.cmpge(blo).all() && c.cmple(bhi).all(), "{spec}: triangle {tri} outside");
                            }
                            seen[tri as usize] += 1;
                        }
                    }
                    // Consecutive internal children, in slot order.
                    for w in kids.windows(2) {
                        assert_eq!(w[1], w[0] + 1, "{spec}");
                    }
                }
                assert!(seen.iter().all(|&k| k == 1), "{spec}: a triangle not in exactly one leaf");
                assert!(tree.stack_need() < STACK);
            }
        }
    }

    /// Build times (best of 3) of the binary tree, its CWBVH, this tree
    /// and the decoded CWBVH on the 69k-triangle bunny, and the trees'
    /// bytes: for `docs/TRACING.md`, run with `--release --ignored
    /// --nocapture`.
    #[test]
    #[ignore = "timing"]
    fn build_times() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/meshes/stanford-bunny.obj");
        let Ok(scene) = crate::formats::load(&path) else { return eprintln!("no bunny at {}", path.display()) };
        let p = Prepared::new(&scene);
        let params = bvh_input(&p).1;
        let mut best = [f64::MAX; 4];
        for _ in 0..3 {
            let clock = std::time::Instant::now();
            let bvh2 = build_bvh2(&p, params);
            best[0] = best[0].min(clock.elapsed().as_secs_f64());
            let clock = std::time::Instant::now();
            let cw = crate::tracer::cpu::cwbvh_of(&bvh2, params);
            best[1] = best[1].min(clock.elapsed().as_secs_f64());
            let clock = std::time::Instant::now();
            let tree = Tree8::new(&bvh2, &p.triangles, MAX_LEAF).unwrap();
            best[2] = best[2].min(clock.elapsed().as_secs_f64());
            let ordered: Vec<[Vec3A; 3]> = cw.primitive_indices.iter().map(|&i| p.triangles[i as usize]).collect();
            let clock = std::time::Instant::now();
            let wide = crate::tracer::wide8::Wide8::new(&cw, &ordered).unwrap();
            best[3] = best[3].min(clock.elapsed().as_secs_f64());
            eprintln!(
                "{} triangles: tree8 {:?} nodes/blocks {:?} bytes fill {:.2}; wide8 {} nodes {:?} bytes",
                p.triangles.len(),
                tree.len(),
                tree.bytes(),
                tree.fill(),
                wide.len(),
                wide.bytes()
            );
        }
        let ms = best.map(|s| s * 1e3);
        eprintln!("ms: binary tree {:.1}, CWBVH {:.1}, tree8 {:.1}, wide8 {:.1}", ms[0], ms[1], ms[2], ms[3]);
    }

    /// The walk, ordered or not, with AVX2 or not, tests every triangle a
    /// ray crosses before its `tmax` (found by testing every triangle), on
    /// rays from inside the scenes, cut short and not; and the closest
    /// hit it keeps is the smallest `t`, ties to the smaller triangle.
    #[test]
    fn the_walk_reaches_every_crossed_triangle() {
        for spec in ["cube-enclosure:6", "cubes-room:16", "table-chairs:2", "mirror-room", "cornell-box"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let bvh2 = build_bvh2(&p, bvh_input(&p).1);
            let tree = Tree8::new(&bvh2, &p.triangles, MAX_LEAF).unwrap();
            let mut reached = 0u64;
            for i in 0..2_000u64 {
                let r = LineRng::new(8, i);
                let o = DVec3::new(r.uniform(0), r.uniform(1), r.uniform(2)) * 0.8 - 0.4;
                let d = DVec3::new(r.uniform(3) - 0.5, r.uniform(4) - 0.5, r.uniform(5) - 0.5).normalize();
                let l = Line::ray(o, d, 0.0, 2.0 * r.uniform(6));
                let (shear, dir) = Shear::of(&l);
                let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
                let crossed: Vec<(f32, u32)> = (0..p.triangles.len() as u32)
                    .filter_map(|tri| shear.hit(&p.triangles[tri as usize]).map(|t| (t, tri)))
                    .filter(|&(t, _)| t >= l.tmin && t <= l.tmax)
                    .collect();
                let nearest = crossed.iter().copied().min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                for (avx2, ordered) in [(false, true), (has_avx2(), true), (false, false), (has_avx2(), false)] {
                    let mut seen = vec![false; p.triangles.len()];
                    let mut best: Option<(f32, u32)> = None;
                    let visit = |block: &Leaf8, lanes: u32, tmax: &mut f32| {
                        let mut m = lanes;
                        while m != 0 {
                            let lane = m.trailing_zeros() as usize;
                            m &= m - 1;
                            let tri = block.tri[lane];
                            seen[tri as usize] = true;
                            if ordered
                                && let Some(t) = shear.hit(&p.triangles[tri as usize])
                                && t >= l.tmin
                                && t <= *tmax
                            {
                                if best.is_none_or(|(bt, btri)| t < bt || (t == bt && tri < btri)) {
                                    best = Some((t, tri));
                                }
                                *tmax = t;
                            }
                        }
                        false
                    };
                    // SAFETY: `avx2` only where the CPU has it.
                    unsafe {
                        match (avx2, ordered) {
                            (true, true) => walk::<true, true, _>(&tree, &ray, &(), visit),
                            (false, true) => walk::<false, true, _>(&tree, &ray, &(), visit),
                            (true, false) => walk::<true, false, _>(&tree, &ray, &(), visit),
                            (false, false) => walk::<false, false, _>(&tree, &ray, &(), visit),
                        }
                    }
                    if ordered {
                        assert_eq!(best, nearest, "{spec} ray {i}");
                    } else {
                        for &(t, tri) in &crossed {
                            assert!(seen[tri as usize], "{spec} ray {i}: triangle {tri} at {t} not reached");
                            reached += 1;
                        }
                    }
                }
            }
            assert!(reached > 1_000, "{spec}: only {reached} crossings checked");
        }
    }
}
