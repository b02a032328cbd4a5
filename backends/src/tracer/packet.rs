//! Occlusion of up to eight coherent rays in one BVH walk (a ray packet).
//!
//! The viewpoint channel's shadow rays come in coherent groups: one view's
//! rays share the eye, and consecutive rays head for the same triangle (its
//! `m²` sample points) or for neighbouring centroids (Morton order). Walked
//! one at a time, eight such rays load the same nodes and triangles eight
//! times; the walk is memory-bound (`docs/TRACING.md`). Here the eight walk
//! together: each node is loaded once and tested for each ray still active
//! there with the single-ray walk's own node test ([`intersect8`]), so
//! every ray visits exactly the nodes it would alone and tests exactly the
//! same triangles. Occlusion asks only whether any of them is crossed, so
//! every ray's answer is the single-ray walk's, whatever order the packet
//! visits them in.
//!
//! Where the rays share the axes of their watertight shear (nearly always:
//! the dominant axis of nearby directions), a triangle is tested against all
//! of them at once: [`Shear::hit`]'s arithmetic lane by lane, operation for
//! operation (no fused multiply-add), so the same `t` to the bit; a lane
//! whose edge functions hit an exact zero is finished by [`Shear::hit`]
//! itself (its double-precision re-evaluation).
//!
//! The rays of a packet must share the octant of their directions (the
//! compressed nodes' child order depends on it); [`Packet::new`] checks.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_NEQ_OQ, _mm256_add_ps, _mm256_and_ps,
    _mm256_andnot_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_loadu_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps,
    _mm256_set1_ps, _mm256_setzero_ps, _mm256_sub_ps,
};

use glam::Vec3A;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;

#[cfg(target_arch = "x86_64")]
use super::node8::intersect8;
use super::watertight::Shear;
use crate::lines::Line;

/// Lanes of a packet.
pub(crate) const LANES: usize = 8;

/// The octant code obvhs orders a node's children by (`ray_get_octant_inv4`,
/// private there): rays with equal codes walk children in the same order.
#[must_use]
fn octant_inv4(d: Vec3A) -> u32 {
    (if d.x < 0.0 { 0 } else { 0x0404_0404 })
        | (if d.y < 0.0 { 0 } else { 0x0202_0202 })
        | (if d.z < 0.0 { 0 } else { 0x0101_0101 })
}

/// Up to [`LANES`] lines prepared for one walk.
pub(crate) struct Packet {
    n: usize,
    oct_inv4: u32,
    rays: [Ray; LANES],
    shears: [Shear; LANES],
    tmin: [f32; LANES],
    tmax: [f32; LANES],
    /// The shared shear axes `[kx, ky, kz]` of every lane, if they agree.
    axes: Option<[usize; 3]>,
    /// Per lane (structure of arrays, for the 8-wide triangle test): the
    /// origin along the shear axes and the shear constants.
    org: [[f32; LANES]; 3],
    s: [[f32; LANES]; 3],
}

impl Packet {
    /// The packet of `lines` (2 to [`LANES`] of them), or `None` when their
    /// directions are not all in one octant.
    pub(crate) fn new(lines: &[Line]) -> Option<Self> {
        if lines.len() < 2 || lines.len() > LANES {
            return None;
        }
        // Traversal directions as the single-ray walk takes them (no -0.0: see `Shear::of`).
        let oct_inv4 = octant_inv4(Shear::of(&lines[0]).1);
        if lines.iter().any(|l| octant_inv4(Shear::of(l).1) != oct_inv4) {
            return None;
        }
        // Unused lanes repeat the first line (they are never active).
        let line = |i: usize| &lines[if i < lines.len() { i } else { 0 }];
        let shears: [Shear; LANES] = std::array::from_fn(|i| Shear::of(line(i)).0);
        let rays = std::array::from_fn(|i| {
            let l = line(i);
            Ray::new(Vec3A::from(l.origin), Shear::of(l).1, l.tmin, l.tmax)
        });
        let k = shears[0].k;
        let axes = shears.iter().all(|s| s.k == k).then_some(k);
        let org = std::array::from_fn(|a| std::array::from_fn(|i| shears[i].org[k[a]]));
        let s = std::array::from_fn(|a| std::array::from_fn(|i| shears[i].s[a]));
        Some(Self {
            n: lines.len(),
            oct_inv4,
            rays,
            shears,
            tmin: std::array::from_fn(|i| line(i).tmin),
            tmax: std::array::from_fn(|i| line(i).tmax),
            axes,
            org,
            s,
        })
    }

    /// Lanes in use.
    pub(crate) fn len(&self) -> usize {
        self.n
    }

    /// The lanes of `lanes` whose ray crosses triangle `v` within its
    /// `[tmin, tmax]`: [`Shear::hit`]'s answer for each.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn crossing(&self, v: &[Vec3A; 3], lanes: u8) -> u8 {
        let Some([kx, ky, kz]) = self.axes else {
            return self.crossing_each(v, lanes);
        };
        // SAFETY: each load reads one [f32; 8] (unaligned loads are allowed).
        let load = |x: &[f32; LANES]| unsafe { _mm256_loadu_ps(x.as_ptr()) };
        let (ox, oy, oz) = (load(&self.org[0]), load(&self.org[1]), load(&self.org[2]));
        let (sx, sy, sz) = (load(&self.s[0]), load(&self.s[1]), load(&self.s[2]));
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
        let any_zero = _mm256_or_ps(
            _mm256_or_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(u, zero), _mm256_cmp_ps::<_CMP_EQ_OQ>(vv, zero)),
            _mm256_cmp_ps::<_CMP_EQ_OQ>(w, zero),
        );
        // Exact zeros: that lane is decided in double precision by `Shear::hit`.
        let exact = _mm256_movemask_ps(any_zero) as u8 & lanes;
        let neg = _mm256_or_ps(
            _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(u, zero), _mm256_cmp_ps::<_CMP_LT_OQ>(vv, zero)),
            _mm256_cmp_ps::<_CMP_LT_OQ>(w, zero),
        );
        let pos = _mm256_or_ps(
            _mm256_or_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(u, zero), _mm256_cmp_ps::<_CMP_GT_OQ>(vv, zero)),
            _mm256_cmp_ps::<_CMP_GT_OQ>(w, zero),
        );
        let det = _mm256_add_ps(_mm256_add_ps(u, vv), w);
        let num = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(u, sz), az), _mm256_mul_ps(_mm256_mul_ps(vv, sz), bz)),
            _mm256_mul_ps(_mm256_mul_ps(w, sz), cz),
        );
        let t = _mm256_div_ps(num, det);
        let inside = _mm256_andnot_ps(_mm256_and_ps(neg, pos), _mm256_cmp_ps::<_CMP_NEQ_OQ>(det, zero));
        let within = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(t, load(&self.tmin)),
            _mm256_cmp_ps::<_CMP_LE_OQ>(t, load(&self.tmax)),
        );
        let fast = _mm256_movemask_ps(_mm256_and_ps(inside, within)) as u8 & lanes & !exact;
        fast | self.crossing_each(v, exact)
    }

    /// [`Packet::crossing`] one lane at a time.
    fn crossing_each(&self, v: &[Vec3A; 3], lanes: u8) -> u8 {
        let mut out = 0;
        let mut l = lanes;
        while l != 0 {
            let i = l.trailing_zeros() as usize;
            l &= l - 1;
            if matches!(self.shears[i].hit(v), Some(t) if t >= self.tmin[i] && t <= self.tmax[i]) {
                out |= 1 << i;
            }
        }
        out
    }
}

/// Which lanes of `packet` are occluded by `triangles` (in BVH order):
/// bit `i` is set when ray `i` crosses one of the triangles its own
/// single-ray walk would test. `stack` is scratch space.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn occluded(
    bvh: &CwBvh,
    triangles: &[[Vec3A; 3]],
    packet: &Packet,
    stack: &mut Vec<(u32, u8)>,
) -> u8 {
    let all = ((1u16 << packet.n) - 1) as u8;
    let oct_inv4 = packet.oct_inv4;
    let mut done = 0u8;
    stack.clear();
    if bvh.nodes.is_empty() {
        return 0;
    }
    stack.push((0, all));
    while let Some((index, lanes)) = stack.pop() {
        let lanes = lanes & !done;
        if lanes == 0 {
            continue;
        }
        let node = &bvh.nodes[index as usize];
        // Each active ray's hit mask: children in bits 24..32 (at their
        // traversal priority), leaf primitives in bits 0..24.
        let mut hits = [0u32; LANES];
        let mut any = 0;
        let mut l = lanes;
        while l != 0 {
            let i = l.trailing_zeros() as usize;
            l &= l - 1;
            // SAFETY: AVX2 is enabled in this function (the caller's promise).
            hits[i] = unsafe { intersect8(node, &packet.rays[i], oct_inv4) };
            any |= hits[i];
        }
        let with_bit = |b: u32| -> u8 {
            let mut m = 0u8;
            for (i, h) in hits.iter().enumerate() {
                m |= (((h >> b) & 1) as u8) << i;
            }
            m
        };
        let mut prims = any & 0x00ff_ffff;
        while prims != 0 {
            let b = prims.trailing_zeros();
            prims &= prims - 1;
            let k = (node.primitive_base_idx + b) as usize;
            let l = with_bit(b) & !done;
            if l != 0 {
                // SAFETY: AVX2 as above.
                done |= unsafe { packet.crossing(&triangles[k], l) };
                if done == all {
                    return done;
                }
            }
        }
        // Children from the lowest priority up, so the highest (nearest
        // first for the packet's octant, as obvhs) is walked next.
        let mut inner = any & 0xff00_0000;
        while inner != 0 {
            let b = inner.trailing_zeros();
            inner &= inner - 1;
            let slot = (b - 24) ^ (oct_inv4 & 0xff);
            let relative = (u32::from(node.imask) & !(u32::MAX << slot)).count_ones();
            stack.push((node.child_base_idx + relative, with_bit(b)));
        }
    }
    done
}
