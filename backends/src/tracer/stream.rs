//! Every crossing of a batch of lines by one walk of the whole batch: a
//! ray stream (for [`super::Tracer::trace_all`] on the CPU).
//!
//! A walk of one line at a time (the interleaved walk this module replaced)
//! tests a node's eight children in one vector: each visit is
//! a chain of dependent loads and data-dependent branches (which children,
//! leaf or not, stack empty or not), different for every line. Here the
//! batch walks the tree together: a node is visited once with the list of
//! lines that entered it, and each of its children is tested against eight
//! (sixteen with AVX-512F) of those lines per vector (the lines' slab
//! constants transposed from one 32-byte record each), the lines that enter
//! it packed into the child's list by the mask. The branches are per node
//! and child, not per line and step.
//!
//! The crossings are the single-ray walk's, bit for bit: the walk visits
//! every node whose box the line enters, with no child order and no culling
//! by hits, and every crossed triangle lies in boxes padded by 1e-5, far
//! beyond the slab test's rounding, so the crossings are a property of the
//! triangle test alone ([`Shear::hit_within`]'s arithmetic, per line and
//! triangle). The node test is the fused `plane · inverse − origin ·
//! inverse` of each plane, its near and far distances taken by `min`/`max`
//! of the two planes of an axis: for an occupied slot (lower plane below
//! the upper) the same values as choosing them by the direction's sign
//! (`inverse` is never zero, and the fused products keep the planes'
//! order). Empty slots are skipped: their `±∞` planes would admit every
//! line under `min`/`max`.
//! Each line's crossings are handed over in line order and sorted by the
//! caller ([`super::watertight::finish`]).
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use glam::Vec3A;
use obvhs::ray::Ray;

use super::node8::NODE_EPSILON;
use super::watertight::{Shear, line_misses_box};
use super::wide8::{LEAF, Node, Wide8};
use crate::lines::Line;

/// Lines per vector.
const W: usize = 8;

/// What one batch's walk keeps, reused from batch to batch on a thread.
#[derive(Default)]
pub(super) struct Scratch {
    /// Index in the batch of each line walked (those `take` accepted), in
    /// increasing order.
    pub(super) ids: Vec<u32>,
    /// Per line walked, its slab constants: the inverse direction (x, y,
    /// z), `origin · inverse` (x, y, z) and `tmax`; one more entry, a line
    /// that enters no box, fills the vectors' spare lanes.
    rays: Vec<Rec>,
    /// Per line walked, the watertight test's constants ([`Shear`]): the
    /// axes `k` (x, y, z, their bits), `s` (x, y, z), the origin along `k`
    /// (x, y; then z), `tmin` and `tmax`; the spare lanes' line (`tmin =
    /// +∞`, `tmax = −∞`) crosses nothing.
    tri: Vec<[Rec; 2]>,
    /// The lists of lines of the nodes still to visit, end to end.
    arena: Vec<u32>,
    /// `(node, start, length)` of each list in `arena` still to visit.
    stack: Vec<(u32, u32, u32)>,
    /// The lines entering each child of the node being visited.
    slots: [Vec<u32>; 8],
    /// `(line walked, k, t)` of each crossing found, `k` in BVH order.
    hits: Vec<(u32, u32, f32)>,
    /// Per line walked, the start of its crossings in `found` (one more
    /// entry: the end).
    pub(super) first: Vec<u32>,
    /// `(k, t)` of each crossing, line by line.
    pub(super) found: Vec<(u32, f32)>,
}

/// Whether the CPU has what [`trace`] needs: AVX2, FMA and POPCNT.
#[cfg(target_arch = "x86_64")]
pub(super) fn has_walk_features() -> bool {
    static HAS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *HAS.get_or_init(|| {
        std::is_x86_feature_detected!("avx2")
            && std::is_x86_feature_detected!("fma")
            && std::is_x86_feature_detected!("popcnt")
    })
}

/// Whether the CPU has AVX-512F (sixteen lines per node test).
#[cfg(target_arch = "x86_64")]
pub(super) fn has_avx512() -> bool {
    static HAS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *HAS.get_or_init(|| std::is_x86_feature_detected!("avx512f"))
}

/// Walks the `lines` that enter the scene's box `bounds` (centre,
/// half-extents; [`line_misses_box`], eight lines a test) through `tree`
/// together: the `r`-th
/// line walked is line `s.ids[r]`, and its crossings within `[tmin,
/// tmax]` are left as `(k, t)` (`k` the triangle in BVH order, `ordered`'s
/// index) in `s.found[s.first[r]..s.first[r + 1]]`, in no particular order.
///
/// Node tests take sixteen lines per vector with `sixteen`, eight without.
///
/// # Safety
/// The CPU must support AVX2, FMA and POPCNT, and AVX-512F with `sixteen`
/// ([`has_avx512`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn trace(
    tree: &Wide8,
    ordered: &[[Vec3A; 3]],
    lines: &[Line],
    bounds: (Vec3A, Vec3A),
    sixteen: bool,
    s: &mut Scratch,
) {
    s.ids.clear();
    let eights = lines.len() / W * W;
    for at in (0..eights).step_by(W) {
        // SAFETY: AVX2 and FMA (this function's contract).
        let missed = unsafe { misses8(std::array::from_fn(|j| &lines[at + j]), bounds) };
        s.ids.extend(Bits(!missed & 0xff).map(|j| (at + j) as u32));
    }
    for (i, l) in lines.iter().enumerate().skip(eights) {
        if !line_misses_box(Vec3A::from(l.origin), Vec3A::from(l.direction), bounds) {
            s.ids.push(i as u32);
        }
    }
    let walked = s.ids.len();
    // Each walked line's constants, eight lines at a time, the rest one by one.
    // (Appended, not zeroed first: a batch's records are megabytes.)
    s.rays.clear();
    s.tri.clear();
    s.rays.reserve(walked + 1);
    s.tri.reserve(walked + 1);
    let eights = walked / W * W;
    for at in (0..eights).step_by(W) {
        let group: [&Line; W] = std::array::from_fn(|j| &lines[s.ids[at + j] as usize]);
        // SAFETY: AVX2 and FMA (this function's contract).
        let (rays, tri) = unsafe { constants8(group) };
        s.rays.extend_from_slice(&rays);
        s.tri.extend_from_slice(&tri);
    }
    for at in eights..walked {
        let (ray, tri) = constants(&lines[s.ids[at] as usize]);
        s.rays.push(ray);
        s.tri.push(tri);
    }
    // The spare lanes' line: `tmax = −∞` closes every box to it.
    s.rays.push(Rec([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, f32::NEG_INFINITY, 0.0]));
    let zero = f32::from_bits(0);
    s.tri.push([
        Rec([zero, zero, zero, 1.0, 1.0, 1.0, 1.0, 1.0]),
        Rec([1.0, f32::INFINITY, f32::NEG_INFINITY, 0.0, 0.0, 0.0, 0.0, 0.0]),
    ]);
    s.hits.clear();
    if walked > 0 && !tree.nodes.is_empty() {
        s.arena.clear();
        s.arena.extend(0..walked as u32);
        s.stack.clear();
        s.stack.push((0, 0, walked as u32));
        while let Some((node, start, len)) = s.stack.pop() {
            let n = &tree.nodes[node as usize];
            let (start, len) = (start as usize, len as usize);
            if sixteen {
                // SAFETY: AVX2 and FMA, and AVX-512F with `sixteen` (this function's contract).
                unsafe { partition16(n, s, start, len) };
            } else {
                // SAFETY: AVX2 and FMA (this function's contract).
                unsafe { partition8(n, s, start, len) };
            }
            // SAFETY: AVX2 and FMA, and AVX-512F with `sixteen` (this function's contract).
            unsafe { descend(n, ordered, lines, s, start, sixteen) };
        }
    }
    // The crossings by line walked: counted, then placed (a counting sort).
    s.first.clear();
    s.first.resize(walked + 1, 0);
    for &(r, _, _) in &s.hits {
        s.first[r as usize + 1] += 1;
    }
    let mut sum = 0;
    for f in &mut s.first {
        sum += *f;
        *f = sum;
    }
    s.found.clear();
    s.found.reserve(s.hits.len());
    // `first[r]` moves to the end of line `r`'s crossings as they are
    // placed, then back by one line. (Written in place, not zeroed first.)
    let found = s.found.spare_capacity_mut();
    for &(r, k, t) in &s.hits {
        let at = &mut s.first[r as usize];
        found[*at as usize].write((k, t));
        *at += 1;
    }
    // SAFETY: the slots of line `r` are `first[r]..first[r + 1]` (prefix
    // sums of the counts), so the loop wrote each of the first
    // `hits.len()` entries exactly once.
    unsafe { s.found.set_len(s.hits.len()) };
    s.first.copy_within(0..walked, 1);
    s.first[0] = 0;
}

/// [`line_misses_box`] of eight lines at once, bit `j` set where line `j`
/// misses the box `(centre, half-extents)`: the same IEEE operations lane
/// by lane (glam's cross product is `a.y·b.z − b.y·a.z` and so on, its
/// products the same numbers).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn misses8(lines: [&Line; W], (c, h): (Vec3A, Vec3A)) -> u32 {
    use std::arch::x86_64::{
        __m256, _CMP_GT_OQ, _mm256_add_ps, _mm256_andnot_ps, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_movemask_ps,
        _mm256_mul_ps, _mm256_or_ps, _mm256_set1_ps, _mm256_sub_ps,
    };
    // SAFETY: AVX2 (this function's contract); a `Line` is eight `f32`
    // (`repr(C)`: origin, tmin, direction, tmax), read unaligned.
    let [ox, oy, oz, _, dx, dy, dz, _] =
        transpose8(lines.map(|l| unsafe { _mm256_loadu_ps((l as *const Line).cast::<f32>()) }));
    let sign = _mm256_set1_ps(-0.0);
    let abs = |x: __m256| _mm256_andnot_ps(sign, x);
    let (wx, wy, wz) = (
        _mm256_sub_ps(ox, _mm256_set1_ps(c.x)),
        _mm256_sub_ps(oy, _mm256_set1_ps(c.y)),
        _mm256_sub_ps(oz, _mm256_set1_ps(c.z)),
    );
    let cross =
        |p: __m256, q: __m256, r: __m256, s: __m256| abs(_mm256_sub_ps(_mm256_mul_ps(p, q), _mm256_mul_ps(r, s)));
    let (mx, my, mz) = (cross(wy, dz, dy, wz), cross(wz, dx, dz, wx), cross(wx, dy, dx, wy));
    let (ax, ay, az) = (abs(dx), abs(dy), abs(dz));
    let h = [h.x, h.y, h.z].map(|v| _mm256_set1_ps(v));
    let radius =
        |i: usize, p: __m256, j: usize, q: __m256| _mm256_add_ps(_mm256_mul_ps(h[i], p), _mm256_mul_ps(h[j], q));
    let (rx, ry, rz) = (radius(1, az, 2, ay), radius(0, az, 2, ax), radius(0, ay, 1, ax));
    let gt = |m: __m256, r: __m256| _mm256_cmp_ps::<_CMP_GT_OQ>(m, r);
    _mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(gt(mx, rx), gt(my, ry)), gt(mz, rz))) as u32
}

/// A line's constants for the walk: obvhs's slab constants (as the CWBVH
/// walk takes them) and the watertight test's ([`Shear`]), as [`Scratch`]
/// keeps them.
fn constants(l: &Line) -> (Rec, [Rec; 2]) {
    let (shear, dir) = Shear::of(l);
    let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
    let inv = ray.inv_direction.to_array();
    let org = ray.origin.to_array();
    let oi = [0, 1, 2].map(|a| org[a] * inv[a]);
    let [kx, ky, kz] = shear.k.map(|k| f32::from_bits(k as u32));
    let [sx, sy, sz] = shear.s;
    let [ox, oy, oz] = shear.k.map(|k| shear.org[k]);
    (
        Rec([inv[0], inv[1], inv[2], oi[0], oi[1], oi[2], l.tmax, 0.0]),
        [Rec([kx, ky, kz, sx, sy, sz, ox, oy]), Rec([oz, l.tmin, l.tmax, 0.0, 0.0, 0.0, 0.0, 0.0])],
    )
}

/// [`constants`] of eight lines at once, bit for bit: the same IEEE
/// operations lane by lane (obvhs's `safe_inverse`, [`Shear::new`]'s axis
/// choice and divisions), the axes chosen by masks instead of branches (a
/// random line's axis is a branch mispredicted a third of the time), the
/// lines read and the records written through 8×8 transposes. Scalar, the
/// constants were 7% of a 10^8-line run's CPU time.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn constants8(lines: [&Line; W]) -> ([Rec; W], [[Rec; 2]; W]) {
    use std::arch::x86_64::{
        __m256, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm256_add_ps, _mm256_and_ps, _mm256_andnot_ps, _mm256_blendv_ps,
        _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_loadu_ps, _mm256_mul_ps, _mm256_or_ps,
        _mm256_set1_epi32, _mm256_set1_ps, _mm256_setzero_ps,
    };
    // SAFETY: AVX2 (this function's contract); a `Line` is eight `f32`
    // (`repr(C)`: origin, tmin, direction, tmax), read unaligned.
    let [ox, oy, oz, tmin, dx, dy, dz, tmax] =
        transpose8(lines.map(|l| unsafe { _mm256_loadu_ps((l as *const Line).cast::<f32>()) }));
    let zero = _mm256_setzero_ps();
    let sign = _mm256_set1_ps(-0.0);
    let one = _mm256_set1_ps(1.0);
    let eps = _mm256_set1_ps(f32::EPSILON);
    // `walk_direction`: `d + 0.0` (negative zeros made positive).
    let (wx, wy, wz) = (_mm256_add_ps(dx, zero), _mm256_add_ps(dy, zero), _mm256_add_ps(dz, zero));
    // obvhs's `safe_inverse`: `signum(x) / ε` where `|x| <= ε`, else `1 / x`
    // (a NaN fails the test and inverts to NaN, as its scalar form does).
    let safe_inverse = |x: __m256| {
        let small = _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_andnot_ps(sign, x), eps);
        let signum = _mm256_or_ps(_mm256_and_ps(x, sign), one);
        _mm256_blendv_ps(_mm256_div_ps(one, x), _mm256_div_ps(signum, eps), small)
    };
    let (ix, iy, iz) = (safe_inverse(wx), safe_inverse(wy), safe_inverse(wz));
    let rays = [ix, iy, iz, _mm256_mul_ps(ox, ix), _mm256_mul_ps(oy, iy), _mm256_mul_ps(oz, iz), tmax, zero];
    // `Shear::new` on the line's own direction: `kz` the axis of the
    // largest |d| (x over y over z on ties, as its branches decide), then
    // `kx`, `ky` the next two, swapped where `d[kz] < 0`.
    let abs = |x: __m256| _mm256_andnot_ps(sign, x);
    let (ax, ay, az) = (abs(dx), abs(dy), abs(dz));
    let x_over_y = _mm256_cmp_ps::<_CMP_GT_OQ>(ax, ay);
    let kz0 = _mm256_and_ps(x_over_y, _mm256_cmp_ps::<_CMP_GT_OQ>(ax, az));
    let kz1 = _mm256_andnot_ps(x_over_y, _mm256_cmp_ps::<_CMP_GT_OQ>(ay, az));
    // The entry for `kz` = 0, 1 or 2 (else).
    let pick = |v0: __m256, v1: __m256, v2: __m256| _mm256_blendv_ps(_mm256_blendv_ps(v2, v1, kz1), v0, kz0);
    let axis = |k: i32| _mm256_castsi256_ps(_mm256_set1_epi32(k));
    let dkz = pick(dx, dy, dz);
    let swap = _mm256_cmp_ps::<_CMP_LT_OQ>(dkz, zero);
    // (the `kx` and `ky` entries: before the swap, kz + 1 and kz + 2 mod 3)
    let pair = |v0: __m256, v1: __m256, v2: __m256| {
        let (x, y) = (pick(v1, v2, v0), pick(v2, v0, v1));
        (_mm256_blendv_ps(x, y, swap), _mm256_blendv_ps(y, x, swap))
    };
    let (dkx, dky) = pair(dx, dy, dz);
    let (okx, oky) = pair(ox, oy, oz);
    let (kx, ky) = pair(axis(0), axis(1), axis(2));
    let kz = pick(axis(0), axis(1), axis(2));
    let tri0 = [kx, ky, kz, _mm256_div_ps(dkx, dkz), _mm256_div_ps(dky, dkz), _mm256_div_ps(one, dkz), okx, oky];
    let tri1 = [pick(ox, oy, oz), tmin, tmax, zero, zero, zero, zero, zero];
    let store = |cols: [__m256; W]| {
        let mut out = [Rec([0.0; 8]); W];
        for (o, r) in out.iter_mut().zip(transpose8(cols)) {
            // SAFETY: AVX2 (this function's contract); a `Rec` is eight
            // `f32`, 32-byte aligned.
            unsafe { std::arch::x86_64::_mm256_store_ps(o.0.as_mut_ptr(), r) };
        }
        out
    };
    let (r, t0, t1) = (store(rays), store(tri0), store(tri1));
    (r, std::array::from_fn(|j| [t0[j], t1[j]]))
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

/// Asks for the records of chunk `c` (of `width` lines) of a node's
/// `list` a chunk before the node test reads them: in a batch's megabytes
/// of records each is a miss (their loads were 28% of `partition16`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn prefetch_chunk(list: &[u32], c: usize, width: usize, rays: &[Rec]) {
    for &r in list.iter().skip(c * width).take(width) {
        prefetch(rays.as_ptr().wrapping_add(r as usize));
    }
}

/// Empties the children's lists for a node of `len` lines, each with room
/// for `len + width` (the last vector's store of `width` entries); their
/// start pointers.
fn open_slots(s: &mut Scratch, len: usize, width: usize) -> [*mut u32; 8] {
    for v in &mut s.slots {
        v.clear();
        v.reserve(len + width);
    }
    std::array::from_fn(|i| s.slots[i].as_mut_ptr())
}

/// Sets each child's list to the `ends[slot]` entries written.
///
/// # Safety
/// The first `ends[slot]` entries of list `slot` must have been written
/// since [`open_slots`] (within its reserved capacity).
unsafe fn close_slots(s: &mut Scratch, ends: &[usize; 8]) {
    for (v, &e) in s.slots.iter_mut().zip(ends) {
        // SAFETY: the caller's contract.
        unsafe { v.set_len(e) };
    }
}

/// Sorts the lines `s.arena[start..start + len]` that enter node `n` into
/// the lists of the children they enter (`s.slots`), each child's box
/// tested against eight lines per vector.
///
/// # Safety
/// The CPU must support AVX2, FMA and POPCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt")]
unsafe fn partition8(n: &Node, s: &mut Scratch, start: usize, len: usize) {
    use std::arch::x86_64::{
        __m128i, __m256, __m256i, _CMP_LE_OQ, _mm_loadl_epi64, _mm256_cmp_ps, _mm256_cvtepu8_epi32, _mm256_fmsub_ps,
        _mm256_loadu_si256, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps, _mm256_permutevar8x32_epi32,
        _mm256_set1_ps, _mm256_storeu_si256,
    };
    let occupied = n.occupied();
    let outs = open_slots(s, len, W);
    let spare = (s.rays.len() - 1) as u32;
    let eps = _mm256_set1_ps(NODE_EPSILON);
    let mut ends = [0usize; 8];
    let list = &s.arena[start..start + len];
    for (c, chunk) in list.chunks(W).enumerate() {
        prefetch_chunk(list, c + 1, W, &s.rays);
        let mut idx = [spare; W];
        idx[..chunk.len()].copy_from_slice(chunk);
        // SAFETY: AVX2 and FMA (this function's contract). The index
        // vector reads the 32 bytes of `idx`; every index is a line walked
        // or `spare`, each an entry of `rays`. A child's list has `len + W` entries reserved and
        // holds at most `len` before this chunk's store of eight. Empty
        // slots are skipped (`occupied`).
        unsafe {
            let vi = _mm256_loadu_si256(idx.as_ptr().cast::<__m256i>());
            let [ix, iy, iz, ox, oy, oz, tmax, _] = columns(idx.map(|r| s.rays.as_ptr().add(r as usize)));
            for slot in 0..8 {
                // The same for every chunk of the node: predicted.
                if occupied >> slot & 1 == 0 {
                    continue;
                }
                let t =
                    |row: usize, inv: __m256, oi: __m256| _mm256_fmsub_ps(_mm256_set1_ps(n.bounds[row][slot]), inv, oi);
                let (x0, x1) = (t(0, ix, ox), t(1, ix, ox));
                let (y0, y1) = (t(2, iy, oy), t(3, iy, oy));
                let (z0, z1) = (t(4, iz, oz), t(5, iz, oz));
                let near = _mm256_max_ps(
                    _mm256_max_ps(_mm256_min_ps(x0, x1), _mm256_min_ps(y0, y1)),
                    _mm256_max_ps(_mm256_min_ps(z0, z1), eps),
                );
                let far = _mm256_min_ps(
                    _mm256_min_ps(_mm256_max_ps(x0, x1), _mm256_max_ps(y0, y1)),
                    _mm256_min_ps(_mm256_max_ps(z0, z1), tmax),
                );
                let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as usize;
                let order = _mm256_cvtepu8_epi32(_mm_loadl_epi64((&raw const PACK[hit]).cast::<__m128i>()));
                _mm256_storeu_si256(
                    outs[slot].add(ends[slot]).cast::<__m256i>(),
                    _mm256_permutevar8x32_epi32(vi, order),
                );
                ends[slot] += hit.count_ones() as usize;
            }
        }
    }
    // SAFETY: the stores above wrote the first `ends[slot]` entries of each list.
    unsafe { close_slots(s, &ends) };
}

/// [`partition8`] with sixteen lines per vector.
///
/// # Safety
/// The CPU must support AVX-512F, AVX2, FMA and POPCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma,popcnt")]
unsafe fn partition16(n: &Node, s: &mut Scratch, start: usize, len: usize) {
    use std::arch::x86_64::{
        __m512, __m512i, _CMP_LE_OQ, _mm256_castps_pd, _mm512_castpd_ps, _mm512_castps_pd, _mm512_castps256_ps512,
        _mm512_cmp_ps_mask, _mm512_fmsub_ps, _mm512_insertf64x4, _mm512_loadu_si512, _mm512_maskz_compress_epi32,
        _mm512_max_ps, _mm512_min_ps, _mm512_set1_ps, _mm512_storeu_si512,
    };
    const W16: usize = 16;
    let occupied = n.occupied();
    let outs = open_slots(s, len, W16);
    let spare = (s.rays.len() - 1) as u32;
    let eps = _mm512_set1_ps(NODE_EPSILON);
    let mut ends = [0usize; 8];
    let list = &s.arena[start..start + len];
    for (c, chunk) in list.chunks(W16).enumerate() {
        prefetch_chunk(list, c + 1, W16, &s.rays);
        let mut idx = [spare; W16];
        idx[..chunk.len()].copy_from_slice(chunk);
        // SAFETY: AVX-512F, AVX2 and FMA (this function's contract). The
        // index vector reads the 64 bytes of `idx`; every index is a line
        // walked or `spare`, each an entry of `rays`. A child's list has
        // `len + 16` entries reserved and holds at most `len` before this
        // chunk's store of sixteen. Empty slots are skipped.
        unsafe {
            let vi = _mm512_loadu_si512(idx.as_ptr().cast::<__m512i>());
            let lo = columns(std::array::from_fn(|j| s.rays.as_ptr().add(idx[j] as usize)));
            let hi = columns(std::array::from_fn(|j| s.rays.as_ptr().add(idx[8 + j] as usize)));
            let join = |a: usize| {
                _mm512_castpd_ps(_mm512_insertf64x4::<1>(
                    _mm512_castps_pd(_mm512_castps256_ps512(lo[a])),
                    _mm256_castps_pd(hi[a]),
                ))
            };
            let [ix, iy, iz, ox, oy, oz, tmax] = [0, 1, 2, 3, 4, 5, 6].map(join);
            for slot in 0..8 {
                if occupied >> slot & 1 == 0 {
                    continue;
                }
                let t =
                    |row: usize, inv: __m512, oi: __m512| _mm512_fmsub_ps(_mm512_set1_ps(n.bounds[row][slot]), inv, oi);
                let (x0, x1) = (t(0, ix, ox), t(1, ix, ox));
                let (y0, y1) = (t(2, iy, oy), t(3, iy, oy));
                let (z0, z1) = (t(4, iz, oz), t(5, iz, oz));
                let near = _mm512_max_ps(
                    _mm512_max_ps(_mm512_min_ps(x0, x1), _mm512_min_ps(y0, y1)),
                    _mm512_max_ps(_mm512_min_ps(z0, z1), eps),
                );
                let far = _mm512_min_ps(
                    _mm512_min_ps(_mm512_max_ps(x0, x1), _mm512_max_ps(y0, y1)),
                    _mm512_min_ps(_mm512_max_ps(z0, z1), tmax),
                );
                let hit = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(near, far);
                _mm512_storeu_si512(outs[slot].add(ends[slot]).cast::<__m512i>(), _mm512_maskz_compress_epi32(hit, vi));
                ends[slot] += hit.count_ones() as usize;
            }
        }
    }
    // SAFETY: the stores above wrote the first `ends[slot]` entries of each list.
    unsafe { close_slots(s, &ends) };
}

/// After [`partition8`] or [`partition16`] at node `n` (whose list began
/// at `start`): the lines entering each internal child pushed as its
/// list, those entering each leaf child tested against its triangles
/// (sixteen lines a vector with `sixteen` where more than eight enter).
///
/// # Safety
/// The CPU must support AVX2, FMA and POPCNT, and AVX-512F with `sixteen`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn descend(n: &Node, ordered: &[[Vec3A; 3]], lines: &[Line], s: &mut Scratch, start: usize, sixteen: bool) {
    // This node's list is spent; its children's lists take its place.
    s.arena.truncate(start);
    // The leaves' lines' triangle constants asked for before the first
    // leaf is tested: each record is a miss, and the later leaves' arrive
    // while the first are tested.
    for slot in Bits(n.occupied() & !n.imask) {
        if n.child[slot] & LEAF != 0 {
            for &r in &s.slots[slot] {
                let p = s.tri.as_ptr().wrapping_add(r as usize).cast::<u8>();
                prefetch(p);
                prefetch(p.wrapping_add(size_of::<[Rec; 2]>() - 1));
            }
        }
    }
    for slot in Bits(n.occupied()) {
        let c = n.child[slot];
        let v = &s.slots[slot];
        if v.is_empty() {
            continue;
        } else if n.imask >> slot & 1 == 1 {
            s.stack.push((c, s.arena.len() as u32, v.len() as u32));
            s.arena.extend_from_slice(v);
        } else if c & LEAF != 0 {
            let from = (lines, &s.ids[..]);
            if sixteen && v.len() > W {
                // SAFETY: AVX-512F with `sixteen` (this function's contract).
                unsafe { leaf16(ordered, n.prim_base, c & !LEAF, v, &s.tri, from, &mut s.hits) };
            } else {
                // SAFETY: AVX2 and FMA (this function's contract).
                unsafe { leaf(ordered, n.prim_base, c & !LEAF, v, &s.tri, from, &mut s.hits) };
            }
        }
    }
}

/// Tests the triangles of `mask` (bit `j`: `ordered[base + j]`) against
/// the lines walked `list`, eight per vector, each lane
/// [`Shear::hit_within`]'s arithmetic operation for operation (so the same
/// `t` and answer to the bit): the vertex coordinates along the lane's
/// axes `k` picked by a permute, then the same subtractions, products and
/// sums in the same order, never fused. A lane whose edge function is
/// exactly zero takes the scalar test (its double-precision branch) on its
/// line (`lines[ids[r]]` for line walked `r`).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn leaf(
    ordered: &[[Vec3A; 3]],
    base: u32,
    mask: u32,
    list: &[u32],
    tri: &[[Rec; 2]],
    (lines, ids): (&[Line], &[u32]),
    hits: &mut Vec<(u32, u32, f32)>,
) {
    use std::arch::x86_64::{
        __m128, __m256, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_NEQ_UQ, _mm256_add_ps,
        _mm256_and_ps, _mm256_andnot_ps, _mm256_broadcast_ps, _mm256_castps_si256, _mm256_cmp_ps, _mm256_div_ps,
        _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_permutevar_ps, _mm256_setzero_ps, _mm256_storeu_ps,
        _mm256_sub_ps,
    };
    let spare = (tri.len() - 1) as u32;
    for chunk in list.chunks(W) {
        let mut idx = [spare; W];
        idx[..chunk.len()].copy_from_slice(chunk);
        let valid = (1u32 << chunk.len()) - 1;
        // SAFETY: AVX2 and FMA (this function's contract); every index is
        // a line walked or `spare`, an entry of `tri`.
        let ([kx, ky, kz, sx, sy, sz, ox, oy], [oz, tmin, tmax, ..]) = unsafe {
            (columns(idx.map(|r| &raw const tri[r as usize][0])), columns(idx.map(|r| &raw const tri[r as usize][1])))
        };
        let (kx, ky, kz) = (_mm256_castps_si256(kx), _mm256_castps_si256(ky), _mm256_castps_si256(kz));
        for bit in Bits(mask) {
            let k = base + bit as u32;
            let v = &ordered[k as usize];
            // SAFETY: AVX2 and FMA (this function's contract); each vertex
            // load reads the 16 bytes of a `Vec3A`.
            let (t, crossed, zero) = unsafe {
                // `(p − org)[k]` component by component, as `raw_always`'s.
                let rel = |p: &Vec3A| {
                    let p = _mm256_broadcast_ps(&*(p as *const Vec3A).cast::<__m128>());
                    (
                        _mm256_sub_ps(_mm256_permutevar_ps(p, kx), ox),
                        _mm256_sub_ps(_mm256_permutevar_ps(p, ky), oy),
                        _mm256_sub_ps(_mm256_permutevar_ps(p, kz), oz),
                    )
                };
                let (a, b, c) = (rel(&v[0]), rel(&v[1]), rel(&v[2]));
                let sh = |q: (__m256, __m256, __m256)| {
                    (_mm256_sub_ps(q.0, _mm256_mul_ps(sx, q.2)), _mm256_sub_ps(q.1, _mm256_mul_ps(sy, q.2)))
                };
                let ((ax, ay), (bx, by), (cx, cy)) = (sh(a), sh(b), sh(c));
                let (az, bz, cz) = (a.2, b.2, c.2);
                let cross = |p: __m256, q: __m256, r: __m256, s: __m256| {
                    _mm256_sub_ps(_mm256_mul_ps(p, q), _mm256_mul_ps(r, s))
                };
                let u = cross(cx, by, cy, bx);
                let w = cross(bx, ay, by, ax);
                let vv = cross(ax, cy, ay, cx);
                let zero = _mm256_setzero_ps();
                let eq = |x: __m256| _mm256_cmp_ps::<_CMP_EQ_OQ>(x, zero);
                let exact = _mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(eq(u), eq(vv)), eq(w))) as u32;
                let det = _mm256_add_ps(_mm256_add_ps(u, vv), w);
                let lt = |x: __m256| _mm256_cmp_ps::<_CMP_LT_OQ>(x, zero);
                let gt = |x: __m256| _mm256_cmp_ps::<_CMP_GT_OQ>(x, zero);
                let outside = _mm256_and_ps(
                    _mm256_or_ps(_mm256_or_ps(lt(u), lt(vv)), lt(w)),
                    _mm256_or_ps(_mm256_or_ps(gt(u), gt(vv)), gt(w)),
                );
                let term = |e: __m256, z: __m256| _mm256_mul_ps(_mm256_mul_ps(e, sz), z);
                let num = _mm256_add_ps(_mm256_add_ps(term(u, az), term(vv, bz)), term(w, cz));
                let t = _mm256_div_ps(num, det);
                let ok = _mm256_andnot_ps(outside, _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero));
                let ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(t, tmin));
                let ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LE_OQ>(t, tmax));
                let mut ts = [0f32; W];
                _mm256_storeu_ps(ts.as_mut_ptr(), t);
                (ts, _mm256_movemask_ps(ok) as u32, exact)
            };
            record(chunk, k, &t, (crossed & valid, zero & valid), v, (lines, ids), hits);
        }
    }
}

/// The crossings of triangle `k` (vertices `v`) by the lanes of `chunk`
/// (lines walked) a leaf test found: `t[lane]` of each lane of `crossed`
/// not in `zero`, and the scalar test's answer for each lane of `zero`
/// (an edge function exactly zero: the line's shear made again, rare and
/// cheaper than keeping every line's).
#[inline(always)]
fn record(
    chunk: &[u32],
    k: u32,
    t: &[f32],
    (crossed, zero): (u32, u32),
    v: &[Vec3A; 3],
    (lines, ids): (&[Line], &[u32]),
    hits: &mut Vec<(u32, u32, f32)>,
) {
    for lane in Bits(crossed & !zero) {
        hits.push((chunk[lane], k, t[lane]));
    }
    for lane in Bits(zero) {
        let r = chunk[lane];
        let l = &lines[ids[r as usize] as usize];
        let (t, crossed) = Shear::of(l).0.hit_within(v, l.tmin, l.tmax);
        if crossed {
            hits.push((r, k, t));
        }
    }
}

/// [`leaf`] with sixteen lines per vector: the same operations lane by
/// lane, the lines' constants read through four 8×8 transposes.
///
/// # Safety
/// The CPU must support AVX-512F, AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn leaf16(
    ordered: &[[Vec3A; 3]],
    base: u32,
    mask: u32,
    list: &[u32],
    tri: &[[Rec; 2]],
    from: (&[Line], &[u32]),
    hits: &mut Vec<(u32, u32, f32)>,
) {
    use std::arch::x86_64::{
        __m128, __m256, __m512, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_NEQ_UQ,
        _mm256_castps_pd, _mm512_add_ps, _mm512_broadcast_f32x4, _mm512_castpd_ps, _mm512_castps_pd,
        _mm512_castps_si512, _mm512_castps256_ps512, _mm512_cmp_ps_mask, _mm512_div_ps, _mm512_insertf64x4,
        _mm512_mul_ps, _mm512_permutevar_ps, _mm512_setzero_ps, _mm512_storeu_ps, _mm512_sub_ps,
    };
    const W16: usize = 16;
    let spare = (tri.len() - 1) as u32;
    for chunk in list.chunks(W16) {
        let mut idx = [spare; W16];
        idx[..chunk.len()].copy_from_slice(chunk);
        let valid = ((1u64 << chunk.len()) - 1) as u32;
        // SAFETY: AVX-512F, AVX2 and FMA (this function's contract); every
        // index is a line walked or `spare`, an entry of `tri`.
        let [kx, ky, kz, sx, sy, sz, ox, oy, oz, tmin, tmax] = unsafe {
            let half =
                |h: usize, rec: usize| columns(std::array::from_fn(|j| &raw const tri[idx[8 * h + j] as usize][rec]));
            let (lo0, hi0, lo1, hi1) = (half(0, 0), half(1, 0), half(0, 1), half(1, 1));
            let join = |lo: __m256, hi: __m256| {
                _mm512_castpd_ps(_mm512_insertf64x4::<1>(
                    _mm512_castps_pd(_mm512_castps256_ps512(lo)),
                    _mm256_castps_pd(hi),
                ))
            };
            let a: [__m512; 8] = std::array::from_fn(|c| join(lo0[c], hi0[c]));
            let b: [__m512; 3] = std::array::from_fn(|c| join(lo1[c], hi1[c]));
            [a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], b[0], b[1], b[2]]
        };
        let (kx, ky, kz) = (_mm512_castps_si512(kx), _mm512_castps_si512(ky), _mm512_castps_si512(kz));
        for bit in Bits(mask) {
            let k = base + bit as u32;
            let v = &ordered[k as usize];
            // SAFETY: AVX-512F (this function's contract); each vertex load
            // reads the 16 bytes of a `Vec3A`.
            let rel = |p: &Vec3A| unsafe {
                let p = _mm512_broadcast_f32x4(*(p as *const Vec3A).cast::<__m128>());
                (
                    _mm512_sub_ps(_mm512_permutevar_ps(p, kx), ox),
                    _mm512_sub_ps(_mm512_permutevar_ps(p, ky), oy),
                    _mm512_sub_ps(_mm512_permutevar_ps(p, kz), oz),
                )
            };
            let (a, b, c) = (rel(&v[0]), rel(&v[1]), rel(&v[2]));
            let sh = |q: (__m512, __m512, __m512)| {
                (_mm512_sub_ps(q.0, _mm512_mul_ps(sx, q.2)), _mm512_sub_ps(q.1, _mm512_mul_ps(sy, q.2)))
            };
            let ((ax, ay), (bx, by), (cx, cy)) = (sh(a), sh(b), sh(c));
            let (az, bz, cz) = (a.2, b.2, c.2);
            let cross =
                |p: __m512, q: __m512, r: __m512, s: __m512| _mm512_sub_ps(_mm512_mul_ps(p, q), _mm512_mul_ps(r, s));
            let u = cross(cx, by, cy, bx);
            let w = cross(bx, ay, by, ax);
            let vv = cross(ax, cy, ay, cx);
            let zero = _mm512_setzero_ps();
            let eq = |x: __m512| _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(x, zero);
            let exact = u32::from(eq(u) | eq(vv) | eq(w));
            let det = _mm512_add_ps(_mm512_add_ps(u, vv), w);
            let lt = |x: __m512| _mm512_cmp_ps_mask::<_CMP_LT_OQ>(x, zero);
            let gt = |x: __m512| _mm512_cmp_ps_mask::<_CMP_GT_OQ>(x, zero);
            let outside = (lt(u) | lt(vv) | lt(w)) & (gt(u) | gt(vv) | gt(w));
            let term = |e: __m512, z: __m512| _mm512_mul_ps(_mm512_mul_ps(e, sz), z);
            let num = _mm512_add_ps(_mm512_add_ps(term(u, az), term(vv, bz)), term(w, cz));
            let t = _mm512_div_ps(num, det);
            let ok = !outside
                & _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(det, zero)
                & _mm512_cmp_ps_mask::<_CMP_GE_OQ>(t, tmin)
                & _mm512_cmp_ps_mask::<_CMP_LE_OQ>(t, tmax);
            let mut ts = [0f32; W16];
            // SAFETY: AVX-512F (this function's contract); the store writes
            // the 64 bytes of `ts`.
            unsafe { _mm512_storeu_ps(ts.as_mut_ptr(), t) };
            record(chunk, k, &ts, (u32::from(ok) & valid, exact & valid), v, from, hits);
        }
    }
}

/// Eight records of eight `f32` as eight columns: column `a` holds entry
/// `a` of each record (an 8×8 transpose in registers: eight loads and 24
/// shuffles, where eight-lane gathers were a quarter of the walk).
///
/// # Safety
/// The CPU must support AVX2; each pointer must point at a [`Rec`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn columns(recs: [*const Rec; 8]) -> [std::arch::x86_64::__m256; 8] {
    use std::arch::x86_64::_mm256_load_ps;
    // SAFETY: the caller's contract; a `Rec` is 32 bytes, 32-aligned.
    transpose8(recs.map(|p| unsafe { _mm256_load_ps(p.cast::<f32>()) }))
}

/// The 8×8 transpose of eight rows of eight `f32`: column `a` of the result
/// holds entry `a` of each row (24 shuffles; its own inverse).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn transpose8(r: [std::arch::x86_64::__m256; 8]) -> [std::arch::x86_64::__m256; 8] {
    use std::arch::x86_64::{_mm256_permute2f128_ps, _mm256_shuffle_ps, _mm256_unpackhi_ps, _mm256_unpacklo_ps};
    {
        let t = [
            _mm256_unpacklo_ps(r[0], r[1]),
            _mm256_unpackhi_ps(r[0], r[1]),
            _mm256_unpacklo_ps(r[2], r[3]),
            _mm256_unpackhi_ps(r[2], r[3]),
            _mm256_unpacklo_ps(r[4], r[5]),
            _mm256_unpackhi_ps(r[4], r[5]),
            _mm256_unpacklo_ps(r[6], r[7]),
            _mm256_unpackhi_ps(r[6], r[7]),
        ];
        let u = [
            _mm256_shuffle_ps::<0x44>(t[0], t[2]),
            _mm256_shuffle_ps::<0xEE>(t[0], t[2]),
            _mm256_shuffle_ps::<0x44>(t[1], t[3]),
            _mm256_shuffle_ps::<0xEE>(t[1], t[3]),
            _mm256_shuffle_ps::<0x44>(t[4], t[6]),
            _mm256_shuffle_ps::<0xEE>(t[4], t[6]),
            _mm256_shuffle_ps::<0x44>(t[5], t[7]),
            _mm256_shuffle_ps::<0xEE>(t[5], t[7]),
        ];
        [
            _mm256_permute2f128_ps::<0x20>(u[0], u[4]),
            _mm256_permute2f128_ps::<0x20>(u[1], u[5]),
            _mm256_permute2f128_ps::<0x20>(u[2], u[6]),
            _mm256_permute2f128_ps::<0x20>(u[3], u[7]),
            _mm256_permute2f128_ps::<0x31>(u[0], u[4]),
            _mm256_permute2f128_ps::<0x31>(u[1], u[5]),
            _mm256_permute2f128_ps::<0x31>(u[2], u[6]),
            _mm256_permute2f128_ps::<0x31>(u[3], u[7]),
        ]
    }
}

/// Asks for the cache line at `p` (a hint: never faults, reads nothing).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn prefetch<T>(p: *const T) {
    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
    // SAFETY: a prefetch reads nothing architecturally and never faults.
    unsafe { _mm_prefetch::<_MM_HINT_T0>(p.cast::<i8>()) };
}

/// Eight `f32` of one line, 32-byte aligned (one load each).
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Rec([f32; 8]);

/// The indices of the set bits of a mask, lowest first.
struct Bits(u32);

impl Iterator for Bits {
    type Item = usize;

    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        (self.0 != 0).then(|| {
            let i = self.0.trailing_zeros() as usize;
            self.0 &= self.0 - 1;
            i
        })
    }
}

#[cfg(test)]
mod tests {
    use obvhs::ray::Ray;

    use super::*;
    use crate::lines::global_line;
    use crate::scene::built_in;
    use crate::tracer::{CpuTracer, CrossingBuffer, Prepared, Tracer};

    /// The eight-line constants and box test are the scalar ones bit for bit, on global
    /// lines and on directions that take every branch of the scalar forms:
    /// zeros of both signs, components at and under `f32::EPSILON`, ties
    /// between axes, every sign.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_line_constants_are_the_scalar_ones() {
        if !(std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")) {
            return;
        }
        let e = f32::EPSILON;
        let r = std::f32::consts::FRAC_1_SQRT_2;
        let t = 1.0 / 3f32.sqrt();
        let mut dirs: Vec<[f32; 3]> = vec![
            [1.0, 0.0, 0.0],
            [-1.0, -0.0, 0.0],
            [0.0, -1.0, -0.0],
            [-0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [r, r, 0.0],
            [-r, r, -0.0],
            [r, 0.0, -r],
            [0.0, -r, -r],
            [t, t, t],
            [-t, -t, t],
            [t, -t, -t],
            [1.0, e, -e],
            [1.0, e / 2.0, -e / 2.0],
            [-e, 1.0, e * 1.5],
            [e, -e, -1.0],
            [0.6, 0.8, 0.0],
            [-0.8, 0.0, 0.6],
        ];
        dirs.extend((0..46u64).map(|i| global_line(9, i, 1.0).direction));
        let lines: Vec<Line> = dirs
            .iter()
            .enumerate()
            .map(|(i, &d)| {
                let o = [0.3 - i as f32 * 0.11, -0.7 + i as f32 * 0.05, 1.25e-3 * i as f32];
                Line { origin: o, tmin: i as f32 * 1e-3, direction: d, tmax: 2.0 + i as f32 }
            })
            .collect();
        let bits = |r: &Rec| r.0.map(f32::to_bits);
        let boxes = [
            (Vec3A::ZERO, Vec3A::splat(0.5)),
            (Vec3A::new(0.3, -0.2, 0.1), Vec3A::new(0.05, 0.4, 0.0)),
            (Vec3A::new(-1.0, 2.0, 0.5), Vec3A::new(1.5, 0.25, 3.0)),
            (Vec3A::new(0.1, 0.2, -0.3), Vec3A::splat(4.0)),
        ];
        let mut missed = [0usize; 2];
        for group in lines.chunks_exact(W) {
            for b in boxes {
                // SAFETY: AVX2 was detected above.
                let mask = unsafe { misses8(std::array::from_fn(|j| &group[j]), b) };
                for (j, l) in group.iter().enumerate() {
                    let scalar = line_misses_box(Vec3A::from(l.origin), Vec3A::from(l.direction), b);
                    assert_eq!(mask >> j & 1 == 1, scalar, "{l:?} against {b:?}");
                    missed[usize::from(scalar)] += 1;
                }
            }
            // SAFETY: AVX2 and FMA were detected above.
            let (rays, tri) = unsafe { constants8(std::array::from_fn(|j| &group[j])) };
            for (j, l) in group.iter().enumerate() {
                let (ray, t) = constants(l);
                assert_eq!(bits(&rays[j]), bits(&ray), "slab constants of {l:?}");
                assert_eq!(bits(&tri[j][0]), bits(&t[0]), "shear constants of {l:?}");
                assert_eq!(bits(&tri[j][1]), bits(&t[1]), "shear constants of {l:?}");
            }
        }
        assert!(missed[0] > 20 && missed[1] > 20, "both answers tested: {missed:?}");
    }

    /// What the walk does per global line on `cube-enclosure:30` and
    /// `cubes-room:512`: nodes visited, triangles tested, crossings kept,
    /// and the nodes a walk that stopped after the line's last crossing
    /// could skip (those the line enters only past it, beyond the 1e-5
    /// padding). The scalar slab test here is the one [`partition8`] vectorises;
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
                            // `plane · inverse − origin · inverse`, fused, as `partition8`'s.
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
                        } else if c & LEAF != 0 {
                            tris += u64::from((c & !LEAF).count_ones());
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
