//! Up to eight coherent rays in one BVH walk (a ray packet): occlusion and
//! closest hits.
//!
//! The viewpoint channel's rays come in coherent groups: one view's rays
//! share the eye, and consecutive rays head for the same triangle (its `m²`
//! sample points), for neighbouring centroids (Morton order) or through
//! neighbouring pixels. Walked one at a time, eight such rays load the same
//! nodes and triangles eight times; the walk is memory-bound
//! (`docs/TRACING.md`). Here the eight walk together: each node is loaded
//! once and each of its children is tested against all eight rays in one
//! AVX2 register, with the single-ray node test's arithmetic lane by lane
//! ([`super::node8`]: a multiply, then an add, max/min in the same operand
//! order), so each ray visits exactly the nodes it would alone (for
//! occlusion) and tests the same triangles. Occlusion asks only whether any
//! of them is crossed, so every ray's answer is the single-ray walk's,
//! whatever order the packet visits them in; closest hits shrink each ray's
//! own `tmax` and break ties by triangle index, which makes the answer
//! independent of the order too (boxes are padded and quantised outwards:
//! a crossing nearer than the best so far is never culled).
//!
//! Where the rays also share the axes of their watertight shear (nearly
//! always: the dominant axis of nearby directions), a triangle is tested
//! against all of them at once: [`Shear::hit`]'s arithmetic lane by lane,
//! operation for operation (no fused multiply-add), so the same `t` to the
//! bit; a lane whose edge functions hit an exact zero is finished by
//! [`Shear::hit`] itself (its double-precision re-evaluation).
//!
//! The rays of a packet share the octant of their directions (the node
//! test's near and far planes, and the compressed nodes' child order,
//! depend on it); [`Packet::new`] checks. Packets need AVX2 (x86-64); the
//! CPU backend sends every other line through the single-ray walk.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, __m512, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_NEQ_OQ, _mm256_add_ps,
    _mm256_and_ps, _mm256_andnot_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps,
    _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps,
    _mm256_sub_ps, _mm512_add_ps, _mm512_cmp_ps_mask, _mm512_div_ps, _mm512_loadu_ps, _mm512_max_ps, _mm512_min_ps,
    _mm512_mul_ps, _mm512_set1_ps, _mm512_setzero_ps, _mm512_sub_ps,
};

#[cfg(target_arch = "x86_64")]
use std::ops::{BitAnd, BitOrAssign, Not};

use glam::Vec3A;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::safe_inverse;

use super::node8::NODE_EPSILON;
use super::watertight::{Shear, barycentric, before, triangle_hit, walk_direction};
use super::wide8::{LEAF, Node as WideNode, Wide8};
use super::{Hit, Prepared};
use crate::lines::Line;

/// Lanes of a packet.
pub(crate) const LANES: usize = 8;

/// `f32` per lane.
type Lanes = [f32; LANES];

/// Whether a direction component counts as negative for the node test and
/// the child order (obvhs's `ray_get_octant_inv4` and `intersect_ray`).
fn negative(x: f32) -> bool {
    x < 0.0
}

/// Up to [`LANES`] lines prepared for one walk, as structures of arrays.
pub(crate) struct Packet<'a> {
    lines: &'a [Line],
    /// obvhs's octant code (`ray_get_octant_inv4`) shared by every lane.
    oct_inv4: u32,
    /// Whether the direction is negative along x, y, z (every lane alike).
    neg: [bool; 3],
    /// Node test: origin and inverse direction (`safe_inverse`) per axis.
    origin: [Lanes; 3],
    inv: [Lanes; 3],
    /// Triangle test: the shared shear axes `[kx, ky, kz]` (if all lanes
    /// agree), the origin along them and the shear constants.
    axes: Option<[usize; 3]>,
    sheared_origin: [Lanes; 3],
    shear: [Lanes; 3],
    tmin: Lanes,
    tmax: Lanes,
}

impl<'a> Packet<'a> {
    /// The packet of `lines` (2 to [`LANES`] of them), or `None` when their
    /// directions are not all in one octant. Unused lanes repeat the first
    /// line and are never active.
    pub(crate) fn new(lines: &'a [Line]) -> Option<Self> {
        if lines.len() < 2 || lines.len() > LANES {
            return None;
        }
        let d0 = lines[0].direction;
        let neg = d0.map(negative);
        if lines.iter().any(|l| l.direction.map(negative) != neg) {
            return None;
        }
        let oct_inv4 = (if neg[0] { 0 } else { 0x0404_0404 })
            | (if neg[1] { 0 } else { 0x0202_0202 })
            | (if neg[2] { 0 } else { 0x0101_0101 });
        let mut p = Packet {
            lines,
            oct_inv4,
            neg,
            origin: [[0.0; LANES]; 3],
            inv: [[0.0; LANES]; 3],
            axes: None,
            sheared_origin: [[0.0; LANES]; 3],
            shear: [[0.0; LANES]; 3],
            tmin: [0.0; LANES],
            tmax: [0.0; LANES],
        };
        let mut axes = None;
        let mut same = true;
        for i in 0..LANES {
            let l = &lines[if i < lines.len() { i } else { 0 }];
            // The traversal direction as the single-ray walk takes it (no
            // -0.0: see `Shear::of`).
            let (s, dir) = Shear::of(l);
            if *axes.get_or_insert(s.k) != s.k {
                same = false;
            }
            for a in 0..3 {
                p.origin[a][i] = l.origin[a];
                p.inv[a][i] = safe_inverse(dir[a]);
                p.sheared_origin[a][i] = s.org[s.k[a]];
                p.shear[a][i] = s.s[a];
            }
            (p.tmin[i], p.tmax[i]) = (l.tmin, l.tmax);
        }
        p.axes = axes.filter(|_| same);
        Some(p)
    }

    /// Lanes in use.
    pub(crate) fn len(&self) -> usize {
        self.lines.len()
    }

    /// Per child slot of `node`, the lanes of `lanes` whose ray enters the
    /// child's box before its own `tmax[lane]`: obvhs's slab test
    /// (`CwBvhNode::intersect_ray`, [`super::node8`]) lane by lane.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn node(&self, node: &CwBvhNode, tmax: &Lanes, lanes: u8) -> [u8; 8] {
        // SAFETY: each load reads one [f32; 8] (unaligned loads are allowed).
        let load = |x: &Lanes| unsafe { _mm256_loadu_ps(x.as_ptr()) };
        let ext = node.compute_extent();
        // Per axis: the planes nearer and farther along the ray, the ray's
        // scale and offset in the node's quantised frame.
        let axis = |a: usize, lo: &[u8; 8], hi: &[u8; 8]| {
            let inv = load(&self.inv[a]);
            let adj_inv = _mm256_mul_ps(_mm256_set1_ps(ext[a]), inv);
            let adj_org = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(node.p[a]), load(&self.origin[a])), inv);
            let (near, far) = if self.neg[a] { (*hi, *lo) } else { (*lo, *hi) };
            (near, far, adj_inv, adj_org)
        };
        let x = axis(0, &node.child_min_x, &node.child_max_x);
        let y = axis(1, &node.child_min_y, &node.child_max_y);
        let z = axis(2, &node.child_min_z, &node.child_max_z);
        // `t` of a quantised plane `q` along each lane: q · adj_inv + adj_org.
        let plane =
            |q: u8, inv: __m256, org: __m256| _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(f32::from(q)), inv), org);
        let (eps, ray_tmax) = (_mm256_set1_ps(NODE_EPSILON), load(tmax));
        let mut out = [0u8; 8];
        for (c, o) in out.iter_mut().enumerate() {
            if node.child_meta[c] == 0 {
                continue;
            }
            let tmin =
                _mm256_max_ps(plane(x.0[c], x.2, x.3), _mm256_max_ps(plane(y.0[c], y.2, y.3), plane(z.0[c], z.2, z.3)));
            let tfar =
                _mm256_min_ps(plane(x.1[c], x.2, x.3), _mm256_min_ps(plane(y.1[c], y.2, y.3), plane(z.1[c], z.2, z.3)));
            let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_max_ps(tmin, eps), _mm256_min_ps(tfar, ray_tmax));
            *o = _mm256_movemask_ps(hit) as u8 & lanes;
        }
        out
    }

    /// The lanes of `lanes` whose ray crosses triangle `v` within its
    /// `[tmin, tmax]`, with each crossing's `t` in `ts`: [`Shear::hit`]'s
    /// answer for each.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn crossing(&self, v: &[Vec3A; 3], lanes: u8, ts: &mut Lanes) -> u8 {
        // SAFETY: AVX2 (this function's contract).
        let (fast, exact) = unsafe { self.crossing_with::<false>(v, lanes, ts, &mut [[0.0; LANES]; 3]) };
        fast | exact
    }

    /// [`Packet::crossing`], the lanes answered by the 8-lane test and
    /// those answered by [`Shear::hit`] (an exact zero, or axes not
    /// shared) apart; with `KEEP`, each lane's barycentric numerators
    /// `[w1, w2, det]` ([`super::watertight::Block::numerators`]'s order:
    /// [`Shear::hit_barycentric`] divides the same numbers) in `numerators`,
    /// meaningful for the first mask's lanes.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn crossing_with<const KEEP: bool>(
        &self,
        v: &[Vec3A; 3],
        lanes: u8,
        ts: &mut Lanes,
        numerators: &mut [Lanes; 3],
    ) -> (u8, u8) {
        let Some([kx, ky, kz]) = self.axes else {
            return (0, self.crossing_each(v, lanes, ts));
        };
        // SAFETY: each load reads one [f32; 8] (unaligned loads are allowed).
        let load = |x: &Lanes| unsafe { _mm256_loadu_ps(x.as_ptr()) };
        let (ox, oy, oz) =
            (load(&self.sheared_origin[0]), load(&self.sheared_origin[1]), load(&self.sheared_origin[2]));
        let (sx, sy, sz) = (load(&self.shear[0]), load(&self.shear[1]), load(&self.shear[2]));
        // Each vertex relative to each lane's origin, sheared: `Shear::raw`.
        let shear = |p: &Vec3A| -> (__m256, __m256, __m256) {
            let az = _mm256_sub_ps(_mm256_set1_ps(p[kz]), oz);
            let ax = _mm256_sub_ps(_mm256_sub_ps(_mm256_set1_ps(p[kx]), ox), _mm256_mul_ps(sx, az));
            let ay = _mm256_sub_ps(_mm256_sub_ps(_mm256_set1_ps(p[ky]), oy), _mm256_mul_ps(sy, az));
            (ax, ay, az)
        };
        let (ax, ay, az) = shear(&v[0]);
        let (bx, by, bz) = shear(&v[1]);
        let (cx, cy, cz) = shear(&v[2]);
        let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
        let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
        let vv = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
        let zero = _mm256_setzero_ps();
        let any3 = |f: &dyn Fn(__m256) -> __m256| _mm256_or_ps(_mm256_or_ps(f(u), f(vv)), f(w));
        // Exact zeros: that lane is decided in double precision by `Shear::hit`.
        let exact = _mm256_movemask_ps(any3(&|e| _mm256_cmp_ps::<_CMP_EQ_OQ>(e, zero))) as u8 & lanes;
        let neg = any3(&|e| _mm256_cmp_ps::<_CMP_LT_OQ>(e, zero));
        let pos = any3(&|e| _mm256_cmp_ps::<_CMP_GT_OQ>(e, zero));
        let det = _mm256_add_ps(_mm256_add_ps(u, vv), w);
        let inside = _mm256_andnot_ps(_mm256_and_ps(neg, pos), _mm256_cmp_ps::<_CMP_NEQ_OQ>(det, zero));
        // Most tests miss every lane: no division then (`t` and the
        // numerators are read only for the lanes answered here).
        if _mm256_movemask_ps(inside) as u8 & lanes & !exact == 0 {
            return (0, self.crossing_each(v, exact, ts));
        }
        let num = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(u, sz), az), _mm256_mul_ps(_mm256_mul_ps(vv, sz), bz)),
            _mm256_mul_ps(_mm256_mul_ps(w, sz), cz),
        );
        let t = _mm256_div_ps(num, det);
        let within = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(t, load(&self.tmin)),
            _mm256_cmp_ps::<_CMP_LE_OQ>(t, load(&self.tmax)),
        );
        let fast = _mm256_movemask_ps(_mm256_and_ps(inside, within)) as u8 & lanes & !exact;
        // SAFETY: `ts` and each row of `numerators` are 8 writable f32
        // (unaligned stores are allowed).
        unsafe {
            _mm256_storeu_ps(ts.as_mut_ptr(), t);
            if KEEP {
                _mm256_storeu_ps(numerators[0].as_mut_ptr(), vv);
                _mm256_storeu_ps(numerators[1].as_mut_ptr(), w);
                _mm256_storeu_ps(numerators[2].as_mut_ptr(), det);
            }
        }
        (fast, self.crossing_each(v, exact, ts))
    }

    /// [`Packet::crossing`] one lane at a time.
    fn crossing_each(&self, v: &[Vec3A; 3], lanes: u8, ts: &mut Lanes) -> u8 {
        let mut out = 0;
        let mut l = lanes;
        while l != 0 {
            let i = l.trailing_zeros() as usize;
            l &= l - 1;
            if let Some(t) = Shear::of(&self.lines[i]).0.hit(v)
                && t >= self.tmin[i]
                && t <= self.tmax[i]
            {
                ts[i] = t;
                out |= 1 << i;
            }
        }
        out
    }
}

/// Pushes the internal children of `node` that some lane enters, with
/// their lanes, lowest traversal priority first, so the highest (nearest
/// first for the packet's octant, as obvhs orders them) is walked next.
fn push_children(node: &CwBvhNode, hit: &[u8; 8], oct_inv4: u32, stack: &mut Vec<(u32, u8)>) {
    // Priority of slot c is c ^ (octant bits), as obvhs's `traverse!`.
    let oct = (oct_inv4 & 7) as usize;
    for p in 0..8 {
        let c = p ^ oct;
        if hit[c] != 0 && node.imask & (1 << c) != 0 {
            let relative = (u32::from(node.imask) & !(u32::MAX << c)).count_ones();
            stack.push((node.child_base_idx + relative, hit[c]));
        }
    }
}

/// The leaf primitives of slot `c` (indices into the BVH-ordered triangles).
fn leaf(node: &CwBvhNode, c: usize) -> std::ops::Range<usize> {
    let meta = node.child_meta[c];
    let first = node.primitive_base_idx as usize + usize::from(meta & 0b1_1111);
    first..first + (meta >> 5).count_ones() as usize
}

/// The wide tree's node test for every lane of `lanes` against each
/// occupied slot of `n`: per slot, the lanes whose ray enters the child's
/// box within `[NODE_EPSILON, tmax[lane]]`, with the single-ray wide test's
/// arithmetic lane by lane (`wide8::test_scalar`: `(plane − origin) ·
/// inverse`, the same max/min order). The boxes are the CWBVH's, widened
/// (`wide8.rs`), so a crossing the CWBVH walk reaches is reached here too.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn wide_node(p: &Packet, n: &WideNode, occupied: u32, tmax: __m256, lanes: u8) -> [u8; 8] {
    // SAFETY: each load reads one [f32; 8] (unaligned loads are allowed).
    let load = |x: &Lanes| unsafe { _mm256_loadu_ps(x.as_ptr()) };
    let (ox, oy, oz) = (load(&p.origin[0]), load(&p.origin[1]), load(&p.origin[2]));
    let (ix, iy, iz) = (load(&p.inv[0]), load(&p.inv[1]), load(&p.inv[2]));
    // Row of `bounds` holding each axis's near plane (the far one is `^ 1`).
    let near = [0, 1, 2].map(|a| 2 * a + usize::from(p.neg[a]));
    let eps = _mm256_set1_ps(NODE_EPSILON);
    let mut out = [0u8; 8];
    let mut m = occupied;
    while m != 0 {
        let c = m.trailing_zeros() as usize;
        m &= m - 1;
        let t = |row: usize, o: __m256, i: __m256| _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(n.bounds[row][c]), o), i);
        let (nx, ny, nz) = (t(near[0], ox, ix), t(near[1], oy, iy), t(near[2], oz, iz));
        let (fx, fy, fz) = (t(near[0] ^ 1, ox, ix), t(near[1] ^ 1, oy, iy), t(near[2] ^ 1, oz, iz));
        let lo = _mm256_max_ps(_mm256_max_ps(nx, ny), _mm256_max_ps(nz, eps));
        let hi = _mm256_min_ps(_mm256_min_ps(fx, fy), _mm256_min_ps(fz, tmax));
        out[c] = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(lo, hi)) as u8 & lanes;
    }
    out
}

/// [`occluded`] over the wide tree (`wide8.rs`, node `i` there is node `i`
/// of the CWBVH, with the same slots and primitive groups): the same walk,
/// children in the same order, without decoding quantised planes. Each
/// lane's answer is the single-ray wide walk's ([`super::cpu`]'s `any`):
/// whether one of the triangles it reaches is crossed.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn occluded_wide(tree: &Wide8, triangles: &[[Vec3A; 3]], packet: &Packet, stack: &mut Vec<(u32, u8)>) -> u8 {
    let all = ((1u16 << packet.len()) - 1) as u8;
    // SAFETY: AVX2 (this function's contract), what `Packet`'s walk needs.
    unsafe { occluded_walk(tree, triangles, packet, all, stack) }
}

/// The lanes of one occlusion walk over the wide tree ([`occluded_walk`]):
/// a packet (8 lanes, AVX2) or two packets as a [`Pair`] (16, AVX-512F),
/// with the node and triangle tests at that width.
#[cfg(target_arch = "x86_64")]
trait Walk {
    /// A bit per lane.
    type Mask: Copy + Eq + Default + BitAnd<Output = Self::Mask> + BitOrAssign + Not<Output = Self::Mask>;
    /// The octant bits that order a node's children (`slot ^ octant`).
    fn octant(&self) -> usize;
    /// Per slot of `n`, the lanes of `lanes` whose ray enters it.
    ///
    /// # Safety
    /// The CPU must support the walk's instructions.
    unsafe fn enter(&self, n: &WideNode, occupied: u32, lanes: Self::Mask) -> [Self::Mask; 8];
    /// The lanes of `lanes` whose ray crosses `v`.
    ///
    /// # Safety
    /// As [`Walk::enter`].
    unsafe fn crosses(&self, v: &[Vec3A; 3], lanes: Self::Mask, ts: &mut Lanes) -> Self::Mask;
}

#[cfg(target_arch = "x86_64")]
impl Walk for Packet<'_> {
    type Mask = u8;
    fn octant(&self) -> usize {
        (self.oct_inv4 & 7) as usize
    }
    #[inline(always)]
    unsafe fn enter(&self, n: &WideNode, occupied: u32, lanes: u8) -> [u8; 8] {
        // SAFETY: AVX2 (the caller's promise); reads one [f32; 8].
        unsafe { wide_node(self, n, occupied, _mm256_loadu_ps(self.tmax.as_ptr()), lanes) }
    }
    #[inline(always)]
    unsafe fn crosses(&self, v: &[Vec3A; 3], lanes: u8, ts: &mut Lanes) -> u8 {
        // SAFETY: AVX2 (the caller's promise).
        unsafe { self.crossing(v, lanes, ts) }
    }
}

/// The occlusion walk of `w`'s lanes (`all`) over the wide tree: each
/// node's slots tested against the lanes still open, each leaf triangle
/// against the lanes that reach it, children pushed in `slot ^ octant`
/// order; a lane is done at its first crossing, the walk when every lane
/// is. The one walk of [`occluded_wide`] and [`occluded_pair`].
///
/// # Safety
/// The CPU must support `W`'s instructions ([`Walk::enter`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn occluded_walk<W: Walk>(
    tree: &Wide8,
    triangles: &[[Vec3A; 3]],
    w: &W,
    all: W::Mask,
    stack: &mut Vec<(u32, W::Mask)>,
) -> W::Mask {
    let none = W::Mask::default();
    let mut done = none;
    stack.clear();
    if tree.nodes.is_empty() {
        return none;
    }
    let oct = w.octant();
    stack.push((0, all));
    let mut ts = [0.0; LANES];
    while let Some((index, lanes)) = stack.pop() {
        let lanes = lanes & !done;
        if lanes == none {
            continue;
        }
        let n = &tree.nodes[index as usize];
        let occupied = n.occupied();
        // SAFETY: `W`'s instructions (the caller's promise).
        let hit = unsafe { w.enter(n, occupied, lanes) };
        let mut leaves = occupied & !n.imask;
        while leaves != 0 {
            let c = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            if hit[c] == none {
                continue;
            }
            let mut prims = n.child[c] & !LEAF;
            while prims != 0 {
                let k = (n.prim_base + prims.trailing_zeros()) as usize;
                prims &= prims - 1;
                let l = hit[c] & !done;
                if l != none {
                    // SAFETY: as above.
                    done |= unsafe { w.crosses(&triangles[k], l, &mut ts) };
                }
            }
            if done == all {
                return done;
            }
        }
        push_wide_children(n, &hit, oct, stack);
    }
    done
}

/// Pushes the internal children of `n` that some lane entered, lowest
/// traversal priority first (slot `p ^ octant`, as [`push_children`]), so
/// the nearest is walked next: the packet walks' one push over the wide
/// nodes.
#[inline(always)]
fn push_wide_children<M: Copy + Default + PartialEq>(
    n: &WideNode,
    hit: &[M; 8],
    oct: usize,
    stack: &mut Vec<(u32, M)>,
) {
    for q in 0..8 {
        let c = q ^ oct;
        if hit[c] != M::default() && n.imask & (1 << c) != 0 {
            stack.push((n.child[c], hit[c]));
        }
    }
}

/// Which lanes of `packet` are occluded by `triangles` (in BVH order):
/// bit `i` is set when ray `i` crosses one of the triangles its own
/// single-ray walk would test. The walk is over `wide` where there is one
/// (as the single-ray walks), else over `bvh`. `stack` is scratch space.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn occluded(
    bvh: &CwBvh,
    wide: Option<&Wide8>,
    triangles: &[[Vec3A; 3]],
    packet: &Packet,
    stack: &mut Vec<(u32, u8)>,
) -> u8 {
    // SAFETY: AVX2 (the caller's promise).
    unsafe {
        match wide {
            Some(w) => occluded_wide(w, triangles, packet, stack),
            None => occluded_cwbvh(bvh, triangles, packet, stack),
        }
    }
}

/// Two packets of one octant as one walk of up to 16 rays: the lanes of
/// the first are bits 0-7 of each mask, the second's bits 8-15.
#[cfg(target_arch = "x86_64")]
struct Pair<'p, 'a> {
    halves: [&'p Packet<'a>; 2],
    origin: [[f32; 2 * LANES]; 3],
    inv: [[f32; 2 * LANES]; 3],
    tmin: [f32; 2 * LANES],
    tmax: [f32; 2 * LANES],
    /// The shear axes both halves share, if they do, with the sheared
    /// origins and shear constants of all 16 lanes.
    axes: Option<[usize; 3]>,
    sheared_origin: [[f32; 2 * LANES]; 3],
    shear: [[f32; 2 * LANES]; 3],
}

#[cfg(target_arch = "x86_64")]
impl<'p, 'a> Pair<'p, 'a> {
    /// The pair of `a` and `b`, or `None` when their octants differ.
    fn new(a: &'p Packet<'a>, b: &'p Packet<'a>) -> Option<Self> {
        if a.neg != b.neg {
            return None;
        }
        let join = |x: &Lanes, y: &Lanes| {
            let mut out = [0.0; 2 * LANES];
            out[..LANES].copy_from_slice(x);
            out[LANES..].copy_from_slice(y);
            out
        };
        Some(Self {
            halves: [a, b],
            origin: [0, 1, 2].map(|k| join(&a.origin[k], &b.origin[k])),
            inv: [0, 1, 2].map(|k| join(&a.inv[k], &b.inv[k])),
            tmin: join(&a.tmin, &b.tmin),
            tmax: join(&a.tmax, &b.tmax),
            axes: a.axes.filter(|_| a.axes == b.axes),
            sheared_origin: [0, 1, 2].map(|k| join(&a.sheared_origin[k], &b.sheared_origin[k])),
            shear: [0, 1, 2].map(|k| join(&a.shear[k], &b.shear[k])),
        })
    }

    /// The lanes of `lanes` (both halves) whose ray crosses `v`: all 16
    /// in one AVX-512 register ([`Pair::crossing16`]) where the halves
    /// share their shear axes, else each half's [`Packet::crossing`].
    ///
    /// # Safety
    /// The CPU must support AVX-512F and AVX2.
    #[target_feature(enable = "avx512f,avx2")]
    unsafe fn crossing(&self, v: &[Vec3A; 3], lanes: u16, ts: &mut Lanes) -> u16 {
        if let Some(axes) = self.axes {
            // SAFETY: AVX-512F (this function's contract).
            let (fast, exact) = unsafe { self.crossing16(axes, v, lanes) };
            return fast | self.each(exact, |half, l| half.crossing_each(v, l, ts));
        }
        // SAFETY: AVX2 (this function's contract).
        self.each(lanes, |half, l| unsafe { half.crossing(v, l, ts) })
    }

    /// `f(half, its lanes)` for each half with lanes in `lanes`, the
    /// answers as one mask.
    fn each(&self, lanes: u16, mut f: impl FnMut(&Packet, u8) -> u8) -> u16 {
        let mut out = 0;
        for (h, half) in self.halves.iter().enumerate() {
            let l = (lanes >> (LANES * h)) as u8;
            if l != 0 {
                out |= u16::from(f(half, l)) << (LANES * h);
            }
        }
        out
    }

    /// [`Packet::crossing_with`]'s 8-lane test on all 16 lanes in one
    /// AVX-512 register (the same operations lane by lane, in the same
    /// order, no fused multiply-add: the same answers), for halves that
    /// share the shear `axes`: the lanes it answers, and those with an
    /// exact zero left to [`Packet::crossing_each`].
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    unsafe fn crossing16(&self, [kx, ky, kz]: [usize; 3], v: &[Vec3A; 3], lanes: u16) -> (u16, u16) {
        // SAFETY: each load reads one [f32; 16] (unaligned loads are allowed).
        let load = |x: &[f32; 2 * LANES]| unsafe { _mm512_loadu_ps(x.as_ptr()) };
        let (ox, oy, oz) =
            (load(&self.sheared_origin[0]), load(&self.sheared_origin[1]), load(&self.sheared_origin[2]));
        let (sx, sy, sz) = (load(&self.shear[0]), load(&self.shear[1]), load(&self.shear[2]));
        let shear = |p: &Vec3A| -> (__m512, __m512, __m512) {
            let az = _mm512_sub_ps(_mm512_set1_ps(p[kz]), oz);
            let ax = _mm512_sub_ps(_mm512_sub_ps(_mm512_set1_ps(p[kx]), ox), _mm512_mul_ps(sx, az));
            let ay = _mm512_sub_ps(_mm512_sub_ps(_mm512_set1_ps(p[ky]), oy), _mm512_mul_ps(sy, az));
            (ax, ay, az)
        };
        let (ax, ay, az) = shear(&v[0]);
        let (bx, by, bz) = shear(&v[1]);
        let (cx, cy, cz) = shear(&v[2]);
        let u = _mm512_sub_ps(_mm512_mul_ps(cx, by), _mm512_mul_ps(cy, bx));
        let w = _mm512_sub_ps(_mm512_mul_ps(bx, ay), _mm512_mul_ps(by, ax));
        let vv = _mm512_sub_ps(_mm512_mul_ps(ax, cy), _mm512_mul_ps(ay, cx));
        let zero = _mm512_setzero_ps();
        let any3 = |f: &dyn Fn(__m512) -> u16| f(u) | f(vv) | f(w);
        let exact = any3(&|e| _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(e, zero)) & lanes;
        let neg = any3(&|e| _mm512_cmp_ps_mask::<_CMP_LT_OQ>(e, zero));
        let pos = any3(&|e| _mm512_cmp_ps_mask::<_CMP_GT_OQ>(e, zero));
        let det = _mm512_add_ps(_mm512_add_ps(u, vv), w);
        let inside = !(neg & pos) & _mm512_cmp_ps_mask::<_CMP_NEQ_OQ>(det, zero) & lanes & !exact;
        // Most tests miss every lane: no division then (the answer needs
        // `t` only where the lane is inside).
        if inside == 0 {
            return (0, exact);
        }
        let num = _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(_mm512_mul_ps(u, sz), az), _mm512_mul_ps(_mm512_mul_ps(vv, sz), bz)),
            _mm512_mul_ps(_mm512_mul_ps(w, sz), cz),
        );
        let t = _mm512_div_ps(num, det);
        let within = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(t, load(&self.tmin))
            & _mm512_cmp_ps_mask::<_CMP_LE_OQ>(t, load(&self.tmax));
        (inside & within, exact)
    }
}

/// [`wide_node`] for the 16 lanes of a [`Pair`] in one AVX-512 register:
/// the same operations lane by lane, in the same order, so each lane's
/// answer is its own packet's.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn wide_node16(p: &Pair, n: &WideNode, occupied: u32, lanes: u16) -> [u16; 8] {
    // SAFETY: each load reads one [f32; 16] (unaligned loads are allowed).
    let load = |x: &[f32; 2 * LANES]| unsafe { _mm512_loadu_ps(x.as_ptr()) };
    let (ox, oy, oz) = (load(&p.origin[0]), load(&p.origin[1]), load(&p.origin[2]));
    let (ix, iy, iz) = (load(&p.inv[0]), load(&p.inv[1]), load(&p.inv[2]));
    let tmax = load(&p.tmax);
    let near = [0, 1, 2].map(|a| 2 * a + usize::from(p.halves[0].neg[a]));
    let eps = _mm512_set1_ps(NODE_EPSILON);
    let mut out = [0u16; 8];
    let mut m = occupied;
    while m != 0 {
        let c = m.trailing_zeros() as usize;
        m &= m - 1;
        let t = |row: usize, o: __m512, i: __m512| _mm512_mul_ps(_mm512_sub_ps(_mm512_set1_ps(n.bounds[row][c]), o), i);
        let (nx, ny, nz) = (t(near[0], ox, ix), t(near[1], oy, iy), t(near[2], oz, iz));
        let (fx, fy, fz) = (t(near[0] ^ 1, ox, ix), t(near[1] ^ 1, oy, iy), t(near[2] ^ 1, oz, iz));
        let lo = _mm512_max_ps(_mm512_max_ps(nx, ny), _mm512_max_ps(nz, eps));
        let hi = _mm512_min_ps(_mm512_min_ps(fx, fy), _mm512_min_ps(fz, tmax));
        out[c] = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(lo, hi) & lanes;
    }
    out
}

/// [`occluded`] of two packets at once over the wide tree, where they share
/// an octant (else `None`): one walk of up to 16 lanes, each node loaded
/// once for both and tested in one AVX-512 register ([`wide_node16`]), each
/// triangle tested by the packet whose lanes reach it. Each lane's answer
/// is its own packet's walk's (occlusion asks only whether some triangle
/// the lane reaches is crossed): bits 0-7 for `a`, 8-15 for `b`. The
/// viewpoint channel's sample rays come 16 to a triangle (its 4 × 4
/// points): half the walks of two packets.
///
/// # Safety
/// The CPU must support AVX-512F and AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2")]
pub(crate) unsafe fn occluded_pair(
    tree: &Wide8,
    triangles: &[[Vec3A; 3]],
    a: &Packet,
    b: &Packet,
    stack: &mut Vec<(u32, u16)>,
) -> Option<u16> {
    let pair = Pair::new(a, b)?;
    let all = ((1u32 << a.len()) - 1) as u16 | (((1u32 << b.len()) - 1) as u16) << LANES;
    // SAFETY: AVX-512F and AVX2 (this function's contract), what a pair's walk needs.
    Some(unsafe { occluded_walk(tree, triangles, &pair, all, stack) })
}

#[cfg(target_arch = "x86_64")]
impl Walk for Pair<'_, '_> {
    type Mask = u16;
    fn octant(&self) -> usize {
        (self.halves[0].oct_inv4 & 7) as usize
    }
    #[inline(always)]
    unsafe fn enter(&self, n: &WideNode, occupied: u32, lanes: u16) -> [u16; 8] {
        // SAFETY: AVX-512F (the caller's promise).
        unsafe { wide_node16(self, n, occupied, lanes) }
    }
    #[inline(always)]
    unsafe fn crosses(&self, v: &[Vec3A; 3], lanes: u16, ts: &mut Lanes) -> u16 {
        // SAFETY: AVX-512F and AVX2 (the caller's promise).
        unsafe { self.crossing(v, lanes, ts) }
    }
}

/// [`occluded`] over the compressed nodes.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn occluded_cwbvh(bvh: &CwBvh, triangles: &[[Vec3A; 3]], packet: &Packet, stack: &mut Vec<(u32, u8)>) -> u8 {
    let all = ((1u16 << packet.len()) - 1) as u8;
    let mut done = 0u8;
    stack.clear();
    if bvh.nodes.is_empty() {
        return 0;
    }
    stack.push((0, all));
    let mut ts = [0.0; LANES];
    while let Some((index, lanes)) = stack.pop() {
        let lanes = lanes & !done;
        if lanes == 0 {
            continue;
        }
        let node = &bvh.nodes[index as usize];
        // SAFETY: AVX2 (the caller's promise).
        let hit = unsafe { packet.node(node, &packet.tmax, lanes) };
        for (c, &lanes) in hit.iter().enumerate() {
            if lanes == 0 || node.imask & (1 << c) != 0 {
                continue;
            }
            for k in leaf(node, c) {
                let l = lanes & !done;
                if l != 0 {
                    // SAFETY: AVX2 as above.
                    done |= unsafe { packet.crossing(&triangles[k], l, &mut ts) };
                }
            }
            if done == all {
                return done;
            }
        }
        push_children(node, &hit, packet.oct_inv4, stack);
    }
    done
}

/// The closest crossing `(t, original[k])` of each lane of `packet` with
/// `triangles` (in BVH order), ties in `t` to the smaller original index:
/// each lane's walk shrinks its own `tmax` as hits are found, as the
/// single-ray walk does. The walk is over `wide` where there is one
/// ([`closest_wide`]), else over `bvh`; the answers are the same (the
/// smallest `t` of the triangles crossed, whatever the order or the tree).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn closest(
    bvh: &CwBvh,
    wide: Option<&Wide8>,
    triangles: &[[Vec3A; 3]],
    original: &[u32],
    packet: &Packet,
    stack: &mut Vec<(u32, u8)>,
) -> Closest {
    // SAFETY: AVX2 (the caller's promise).
    unsafe {
        match wide {
            Some(w) => closest_wide(w, triangles, original, packet, stack),
            None => closest_cwbvh(bvh, triangles, original, packet, stack),
        }
    }
}

/// What a closest-hit packet walk found, lane by lane.
pub(crate) struct Closest {
    /// Each lane's closest crossing `(t, triangle)`.
    pub(crate) best: [Option<(f32, u32)>; LANES],
    /// The barycentric numerators `[w1, w2, det]` of each lane's best
    /// crossing, where the 8-lane test found it.
    numerators: [[f32; 3]; LANES],
    /// Lanes whose best crossing [`Shear::hit`] decided (an exact zero):
    /// their numerators are not kept.
    exact: u8,
}

impl Closest {
    /// Nothing found yet.
    fn new() -> Self {
        Self { best: [None; LANES], numerators: [[0.0; 3]; LANES], exact: 0 }
    }

    /// Takes the crossings at `ts` of triangle `tri` for the lanes of
    /// `fast` (numerators in `numerators`) and `exact`, where one comes
    /// [`before`] the lane's best, and shrinks each lane's `tmax` to it.
    #[inline(always)]
    fn keep(&mut self, fast: u8, exact: u8, ts: &Lanes, numerators: &[Lanes; 3], tri: u32, tmax: &mut Lanes) {
        let mut l = fast | exact;
        while l != 0 {
            let i = l.trailing_zeros() as usize;
            l &= l - 1;
            let t = ts[i];
            if before(t, tri, self.best[i]) {
                self.best[i] = Some((t, tri));
                if exact >> i & 1 == 1 {
                    self.exact |= 1 << i;
                } else {
                    self.exact &= !(1 << i);
                    self.numerators[i] = [numerators[0][i], numerators[1][i], numerators[2][i]];
                }
            }
            if t < tmax[i] {
                tmax[i] = t;
            }
        }
    }

    /// Each lane's [`Hit`] on `scene` (whose triangles the walk tested;
    /// lane `i` is `lines[i]`), appended to `out`: from the kept
    /// numerators, which is [`triangle_hit`]'s answer to the bit (the same
    /// `t`, and the same numbers divided), or by [`triangle_hit`] where
    /// [`Shear::hit`] decided the lane.
    pub(crate) fn hits(&self, scene: &Prepared, lines: &[Line], out: &mut Vec<Option<Hit>>) {
        out.extend(lines.iter().enumerate().map(|(i, l)| {
            let (t, tri) = self.best[i]?;
            if self.exact >> i & 1 == 1 {
                return triangle_hit(scene, l, tri);
            }
            let n = scene.normals[tri as usize];
            Some(Hit {
                t,
                patch: scene.triangle_patch[tri as usize],
                primitive: tri,
                cos: n.dot(walk_direction(l)),
                barycentric: barycentric(self.numerators[i]),
                normal: n.into(),
            })
        }));
    }
}

/// [`closest`] over the wide tree, as [`occluded_wide`] walks it: each
/// node's eight boxes tested against the lanes from six aligned rows
/// ([`wide_node`], no quantised planes decoded), each lane against its own
/// shrinking `tmax`; the hit leaf children's triangles tested against
/// their lanes, then the internal children pushed in the CWBVH walk's
/// order.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn closest_wide(
    tree: &Wide8,
    triangles: &[[Vec3A; 3]],
    original: &[u32],
    packet: &Packet,
    stack: &mut Vec<(u32, u8)>,
) -> Closest {
    let mut best = Closest::new();
    stack.clear();
    if tree.nodes.is_empty() {
        return best;
    }
    let mut tmax = packet.tmax;
    let oct = (packet.oct_inv4 & 7) as usize;
    stack.push((0, ((1u16 << packet.len()) - 1) as u8));
    let (mut ts, mut numerators) = ([0.0; LANES], [[0.0; LANES]; 3]);
    while let Some((index, lanes)) = stack.pop() {
        let n = &tree.nodes[index as usize];
        let occupied = n.occupied();
        // SAFETY: AVX2 (the caller's promise); reads one [f32; 8].
        let hit = unsafe { wide_node(packet, n, occupied, _mm256_loadu_ps(tmax.as_ptr()), lanes) };
        let mut leaves = occupied & !n.imask;
        while leaves != 0 {
            let c = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            if hit[c] == 0 {
                continue;
            }
            let mut prims = n.child[c] & !LEAF;
            while prims != 0 {
                let k = (n.prim_base + prims.trailing_zeros()) as usize;
                prims &= prims - 1;
                // SAFETY: AVX2 as above.
                let (fast, exact) =
                    unsafe { packet.crossing_with::<true>(&triangles[k], hit[c], &mut ts, &mut numerators) };
                best.keep(fast, exact, &ts, &numerators, original[k], &mut tmax);
            }
        }
        push_wide_children(n, &hit, oct, stack);
    }
    best
}

/// [`closest`] over the compressed nodes.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn closest_cwbvh(
    bvh: &CwBvh,
    triangles: &[[Vec3A; 3]],
    original: &[u32],
    packet: &Packet,
    stack: &mut Vec<(u32, u8)>,
) -> Closest {
    let mut best = Closest::new();
    stack.clear();
    if bvh.nodes.is_empty() {
        return best;
    }
    let mut tmax = packet.tmax;
    stack.push((0, ((1u16 << packet.len()) - 1) as u8));
    let (mut ts, mut numerators) = ([0.0; LANES], [[0.0; LANES]; 3]);
    while let Some((index, lanes)) = stack.pop() {
        let node = &bvh.nodes[index as usize];
        // SAFETY: AVX2 (the caller's promise).
        let hit = unsafe { packet.node(node, &tmax, lanes) };
        for (c, &lanes) in hit.iter().enumerate() {
            if lanes == 0 || node.imask & (1 << c) != 0 {
                continue;
            }
            for k in leaf(node, c) {
                // SAFETY: AVX2 as above.
                let (fast, exact) =
                    unsafe { packet.crossing_with::<true>(&triangles[k], lanes, &mut ts, &mut numerators) };
                best.keep(fast, exact, &ts, &numerators, original[k], &mut tmax);
            }
        }
        push_children(node, &hit, packet.oct_inv4, stack);
    }
    best
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::lines::global_line;
    use crate::scene::built_in;
    use crate::tracer::node8::{has_avx2, intersect8};
    use crate::tracer::{Prepared, bvh_input};
    use obvhs::ray::Ray;

    /// The packet's node test gives every lane exactly the children the
    /// single-ray node test gives its ray (the same IEEE operations), on
    /// every node of four BVHs, for packets of nearby lines at full length
    /// and cut short.
    #[test]
    fn packet_node_test_matches_the_single_ray_test() {
        if !has_avx2() {
            return;
        }
        for spec in ["cube-enclosure:6", "cubes-room:16", "geosphere", "table-chairs:2"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let (aabbs, params) = bvh_input(&p);
            let bvh = obvhs::cwbvh::builder::build_cwbvh(&aabbs, params, &mut std::time::Duration::default());
            let (mut packets, mut entered) = (0, 0u64);
            for g in 0..200 {
                let base = global_line(7, g, 1.1);
                let lines: Vec<Line> = (0..8)
                    .map(|i| {
                        let mut l = base;
                        l.origin[i % 3] += 1e-3 * i as f32;
                        l.direction[(i + 1) % 3] += 1e-3 * (i as f32 - 4.0);
                        l.tmax *= [1.0, 0.5, 0.1][i % 3];
                        l
                    })
                    .collect();
                let Some(pk) = Packet::new(&lines) else { continue };
                packets += 1;
                for node in &bvh.nodes {
                    // SAFETY: AVX2 checked above.
                    let hit = unsafe { pk.node(node, &pk.tmax, 0xff) };
                    for (i, l) in lines.iter().enumerate() {
                        let ray = Ray::new(Vec3A::from(l.origin), Vec3A::from(l.direction), l.tmin, l.tmax);
                        // SAFETY: AVX2 checked above.
                        let single = unsafe { intersect8(node, &ray, pk.oct_inv4) };
                        let (child_bits, bit_index) = node.get_child_and_index_bits(pk.oct_inv4);
                        for (c, &lanes) in hit.iter().enumerate() {
                            let bits = ((child_bits >> (8 * c)) & 0xff) as u32;
                            let index = ((bit_index >> (8 * c)) & 0xff) as u32;
                            let expect = bits != 0 && single & (bits << index) != 0;
                            assert_eq!(lanes >> i & 1 == 1, expect, "{spec}: packet {g} lane {i} slot {c}");
                            entered += u64::from(expect);
                        }
                    }
                }
            }
            assert!(packets > 100 && entered > 1000, "{spec}: {packets} packets, {entered} children entered");
        }
    }

    /// Closest hits walked over the wide tree and over the CWBVH give every
    /// lane [`triangle_hit`]'s [`Hit`] (bit for bit: the kept numerators
    /// divided as it divides them) of the nearest triangle crossed within
    /// its `[tmin, tmax]`, ties to the smaller index, found by testing
    /// every triangle; for packets of camera rays (one eye, nearby
    /// directions, as the renderer sends them) and of parallel lines, cut
    /// short and not, and toward triangles' vertices.
    #[test]
    fn wide_and_compressed_packet_closest_hits_agree_with_every_triangle() {
        if !has_avx2() {
            return;
        }
        for spec in ["cube-enclosure:6", "cubes-room:16", "geosphere", "table-chairs:2", "mirror-room", "cornell-box"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let bvh = crate::tracer::cpu::build_bvh(&p, bvh_input(&p).1);
            let ordered: Vec<[Vec3A; 3]> = bvh.primitive_indices.iter().map(|&i| p.triangles[i as usize]).collect();
            let wide = Wide8::new(&bvh, &ordered).unwrap();
            let mut stack = Vec::new();
            let (mut packets, mut hits, mut misses) = (0, 0, 0);
            for g in 0..400u64 {
                let r = crate::lines::LineRng::new(11, g);
                let eye = glam::DVec3::new(r.uniform(0), r.uniform(1), r.uniform(2)) * 1.2 - 0.6;
                let target = glam::DVec3::new(r.uniform(3), r.uniform(4), r.uniform(5)) * 2.0 - 1.0;
                let lines: Vec<Line> = (0..8)
                    .map(|i| match g % 3 {
                        0 => {
                            let q = target + glam::DVec3::new(0.01 * f64::from(i), 0.004 * f64::from(i % 3), 0.0);
                            Line::ray(eye, (q - eye).normalize(), 0.0, [1e5, 0.5, 0.05][i as usize % 3])
                        }
                        // Toward the vertices of one triangle and its
                        // neighbours in the list (edges shared).
                        1 => {
                            let t = p.triangles[(g as usize * 7 + i as usize / 3) % p.triangles.len()];
                            let q = t[i as usize % 3].as_dvec3();
                            Line::ray(eye, (q - eye).normalize(), 0.0, 1e5)
                        }
                        _ => {
                            let mut l = global_line(3, g, 1.1);
                            l.origin[i as usize % 3] += 1e-3 * i as f32;
                            l.tmax *= [1.0, 0.5, 0.1][i as usize % 3];
                            l
                        }
                    })
                    .collect();
                let Some(pk) = Packet::new(&lines) else { continue };
                packets += 1;
                let (mut w, mut c) = (Vec::new(), Vec::new());
                // SAFETY: AVX2 checked above.
                let (bw, bc) = unsafe {
                    (
                        closest_wide(&wide, &ordered, &bvh.primitive_indices, &pk, &mut stack),
                        closest_cwbvh(&bvh, &ordered, &bvh.primitive_indices, &pk, &mut stack),
                    )
                };
                bw.hits(&p, &lines, &mut w);
                bc.hits(&p, &lines, &mut c);
                for (i, l) in lines.iter().enumerate() {
                    let (shear, _) = Shear::of(l);
                    let mut best = None;
                    for (k, t) in p.triangles.iter().enumerate() {
                        if let Some(t) = shear.hit(t).filter(|&t| t >= l.tmin && t <= l.tmax)
                            && before(t, k as u32, best)
                        {
                            best = Some((t, k as u32));
                        }
                    }
                    let want = best.and_then(|(_, k)| triangle_hit(&p, l, k));
                    let bits = |h: Option<Hit>| {
                        h.map(|h| (h.t.to_bits(), h.primitive, h.cos.to_bits(), h.barycentric.map(f32::to_bits)))
                    };
                    assert_eq!(bits(w[i]), bits(want), "{spec}: packet {g} lane {i}, wide tree");
                    assert_eq!(bits(c[i]), bits(want), "{spec}: packet {g} lane {i}, CWBVH");
                    assert_eq!(w[i], want);
                    if want.is_some() {
                        hits += 1;
                    } else {
                        misses += 1;
                    }
                }
            }
            assert!(packets > 150 && hits > 500 && misses > 50, "{spec}: {packets} packets, {hits}/{misses}");
        }
    }

    /// Occlusion walked over the wide tree and over the CWBVH, and two
    /// packets walked as one pair (where AVX-512F is present), gives every
    /// lane the answer of testing every triangle (crossed within its
    /// `[tmin, tmax]`), for packets of shadow rays from one eye to nearby
    /// points (as the viewpoint channel casts them) and of parallel lines,
    /// cut short and not.
    #[test]
    fn wide_and_compressed_packet_occlusion_agree_with_every_triangle() {
        if !has_avx2() {
            return;
        }
        for spec in ["cube-enclosure:6", "cubes-room:16", "geosphere", "table-chairs:2", "mirror-room"] {
            let p = Prepared::new(&built_in(spec).unwrap());
            let bvh = crate::tracer::cpu::build_bvh(&p, bvh_input(&p).1);
            let ordered: Vec<[Vec3A; 3]> = bvh.primitive_indices.iter().map(|&i| p.triangles[i as usize]).collect();
            let wide = Wide8::new(&bvh, &ordered).unwrap();
            let (mut stack, mut stack16) = (Vec::new(), Vec::new());
            let (mut packets, mut pairs, mut blocked, mut open) = (0, 0, 0, 0);
            for g in 0..400u64 {
                let r = crate::lines::LineRng::new(9, g);
                let eye = glam::DVec3::new(r.uniform(0), r.uniform(1), r.uniform(2)) * 1.6 - 0.8;
                let target = glam::DVec3::new(r.uniform(3), r.uniform(4), r.uniform(5)) * 1.6 - 0.8;
                let lines: Vec<Line> = (0..16)
                    .map(|i| {
                        if g % 2 == 0 {
                            let q = target + glam::DVec3::new(0.01 * f64::from(i), 0.003 * f64::from(i % 3), 0.0);
                            let d = q - eye;
                            Line::ray(eye, d.normalize(), 0.0, d.length() * (1.0 - 1e-5))
                        } else {
                            let mut l = global_line(3, g, 1.1);
                            l.origin[i as usize % 3] += 1e-3 * i as f32;
                            l.tmax *= [1.0, 0.5, 0.1][i as usize % 3];
                            l
                        }
                    })
                    .collect();
                let every: Vec<bool> = lines
                    .iter()
                    .map(|l| {
                        let (shear, _) = Shear::of(l);
                        p.triangles.iter().any(|t| shear.hit(t).is_some_and(|t| t >= l.tmin && t <= l.tmax))
                    })
                    .collect();
                let (Some(a), Some(b)) = (Packet::new(&lines[..8]), Packet::new(&lines[8..])) else { continue };
                for (h, pk) in [&a, &b].into_iter().enumerate() {
                    packets += 1;
                    // SAFETY: AVX2 checked above.
                    let (w, c) = unsafe {
                        (occluded_wide(&wide, &ordered, pk, &mut stack), occluded_cwbvh(&bvh, &ordered, pk, &mut stack))
                    };
                    for (i, &every) in every[8 * h..8 * h + 8].iter().enumerate() {
                        assert_eq!(w >> i & 1 == 1, every, "{spec}: packet {g}.{h} lane {i}, wide tree");
                        assert_eq!(c >> i & 1 == 1, every, "{spec}: packet {g}.{h} lane {i}, CWBVH");
                        if every {
                            blocked += 1;
                        } else {
                            open += 1;
                        }
                    }
                }
                if !crate::tracer::stream::has_avx512() {
                    continue;
                }
                // SAFETY: AVX2 checked above, AVX-512F here.
                if let Some(both) = unsafe { occluded_pair(&wide, &ordered, &a, &b, &mut stack16) } {
                    pairs += 1;
                    for (i, &every) in every.iter().enumerate() {
                        assert_eq!(both >> i & 1 == 1, every, "{spec}: pair {g} lane {i}");
                    }
                }
            }
            assert!(packets > 400 && blocked > 200 && open > 200, "{spec}: {packets} packets, {blocked}/{open}");
            assert!(pairs > 100 || !crate::tracer::stream::has_avx512(), "{spec}: {pairs} pairs");
        }
    }
}
