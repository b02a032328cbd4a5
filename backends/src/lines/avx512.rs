//! [`global_lines_of`](super::global_lines_of) with AVX-512: 16 lines per
//! step, every line [`global_line_of`](super::global_line_of)'s bits.
//!
//! A chunk of lines goes in three passes: the generators, the first try of
//! both sphere points and the queue of rejected points (16 lanes of 32-bit
//! hashing, 8 lanes of f64); the queue's retries, 16 rejected points at a
//! time whatever their lines, until every point is accepted (a rejected
//! pair of draws costs a lane of a later vector, not a scalar retry and a
//! mispredicted branch); then the chords through the two points (tutorial
//! Part III §1.4), 8 lines at a time, transposed into [`Line`] rows.

use super::{Line, SeedHash, pcg};
use std::arch::x86_64::{
    __m256, __m256i, __m512d, __m512i, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm256_permute2f128_ps,
    _mm256_setzero_ps, _mm256_shuffle_ps, _mm256_storeu_ps, _mm256_unpackhi_ps, _mm256_unpacklo_ps, _mm512_add_epi32,
    _mm512_add_epi64, _mm512_add_pd, _mm512_and_si512, _mm512_castpd_si512, _mm512_castsi256_si512,
    _mm512_castsi512_pd, _mm512_castsi512_si256, _mm512_cmp_pd_mask, _mm512_cmpeq_epi32_mask, _mm512_cmple_epu64_mask,
    _mm512_cvtepi64_epi32, _mm512_cvtepu32_pd, _mm512_cvtpd_ps, _mm512_div_pd, _mm512_extracti64x4_epi64,
    _mm512_fmadd_pd, _mm512_fnmadd_pd, _mm512_inserti64x4, _mm512_loadu_pd, _mm512_loadu_si512, _mm512_mask_blend_pd,
    _mm512_mask_i32scatter_pd, _mm512_maskz_compress_epi32, _mm512_mul_pd, _mm512_mullo_epi32, _mm512_rsqrt14_pd,
    _mm512_set1_epi32, _mm512_set1_epi64, _mm512_set1_pd, _mm512_setr_epi32, _mm512_sqrt_pd, _mm512_srli_epi32,
    _mm512_srli_epi64, _mm512_srlv_epi32, _mm512_storeu_pd, _mm512_storeu_si512, _mm512_sub_epi64, _mm512_sub_pd,
    _mm512_xor_si512,
};

/// Lines per chunk (a multiple of 16): the points (12 KB) and the queue
/// (8 KB) stay in L1 between the passes.
const CHUNK: usize = 256;

/// `φ = 2^32 / golden ratio`, the step between draws ([`LineRng::u32`](super::LineRng::u32)).
const PHI: u32 = 0x9E37_79B9;

/// [`pcg`]'s multiplier and increment.
const PCG_MUL: u32 = 747_796_405;
const PCG_INC: u32 = 2_891_336_453;

/// The lines `first + k·stride` for `k` in `0..count / 16 * 16`, appended to
/// `out` (the rest is the caller's); returns how many.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn global_lines(
    seed: SeedHash,
    first: u64,
    stride: u64,
    count: u64,
    radius: f64,
    out: &mut Vec<Line>,
) -> u64 {
    let total = count / 16 * 16;
    out.reserve(usize::try_from(total).unwrap_or(usize::MAX));
    let mut s = Scratch::new(seed, stride, radius);
    let mut done = 0;
    while done < total {
        let m = (total - done).min(CHUNK as u64) as usize;
        s.first_tries(first.wrapping_add(done.wrapping_mul(stride)), m);
        s.retries();
        // SAFETY: `reserve` above left room for `total` lines past the
        // length, of which `done` are written.
        unsafe { s.chords(out, m) };
        done += m as u64;
    }
    total
}

/// One chunk's state between the passes.
struct Scratch {
    /// The seed's hash ([`SeedHash`]).
    seed: u32,
    /// `l·stride` for lane `l`, the 64-bit index offsets of a group.
    offsets: [__m512i; 2],
    /// `stride`, to step from group to group.
    stride: u64,
    /// The sphere's radius, 8 lanes.
    radius: __m512d,
    /// The points' `x`, `y` and `z`: slot `l` is line `l`'s first point,
    /// slot `CHUNK + l` its second.
    pts: [[f64; 2 * CHUNK]; 3],
    /// The rejected points: slot, words `w1`, `w2` and `k·φ` of the next
    /// draw `k` (16 spare entries: a compressed vector is stored whole).
    queue: [[u32; 2 * CHUNK + 16]; 4],
    /// The queue's length.
    queued: usize,
}

impl Scratch {
    #[target_feature(enable = "avx512f")]
    fn new(seed: SeedHash, stride: u64, radius: f64) -> Self {
        let step = |l: u64| stride.wrapping_mul(l) as i64;
        let offsets = [0, 8].map(|h| {
            let o: [i64; 8] = std::array::from_fn(|l| step(h + l as u64));
            // SAFETY: `o` is 64 readable bytes; the load is unaligned.
            unsafe { _mm512_loadu_si512(o.as_ptr().cast()) }
        });
        Self {
            seed: seed.0,
            offsets,
            stride,
            radius: _mm512_set1_pd(radius),
            pts: [[0.0; 2 * CHUNK]; 3],
            queue: [[0; 2 * CHUNK + 16]; 4],
            queued: 0,
        }
    }

    /// The first pass over `m` lines from index `base`: each line's first
    /// pair of draws for both points, the accepted points into `pts`, the
    /// rejected ones into the queue.
    #[target_feature(enable = "avx512f")]
    fn first_tries(&mut self, base: u64, m: usize) {
        self.queued = 0;
        for o in (0..m).step_by(16) {
            let index = base.wrapping_add((o as u64).wrapping_mul(self.stride));
            let (w1, w2) = self.words(index);
            let w2a = _mm512_mullo_epi32(w2, splat(PCG_MUL));
            let draw = |k: u32| {
                // `pcg(w2 + k·φ)`'s first step `(w2 + k·φ)·A + B` as
                // `w2·A + (k·φ·A + B)`: the same 32-bit value.
                let state =
                    _mm512_add_epi32(w2a, splat(k.wrapping_mul(PHI).wrapping_mul(PCG_MUL).wrapping_add(PCG_INC)));
                pcg16(_mm512_xor_si512(w1, pcg16_state(state)))
            };
            for (slot, k) in [(o, 0u32), (CHUNK + o, 64)] {
                let accepted = self.store_points(slot, draw(k), draw(k + 1));
                self.enqueue(!accepted, splat_index(slot), w1, w2, splat((k + 2).wrapping_mul(PHI)));
            }
        }
    }

    /// [`super::LineRng::of`]'s words `(w1, w2)` for the 16 lines `index +
    /// l·stride`, operation for operation.
    #[target_feature(enable = "avx512f")]
    fn words(&self, index: u64) -> (__m512i, __m512i) {
        let base = _mm512_set1_epi64(index as i64);
        let [i0, i1] = self.offsets.map(|o| _mm512_add_epi64(base, o));
        let lo = join(_mm512_cvtepi64_epi32(i0), _mm512_cvtepi64_epi32(i1));
        let hi = join(
            _mm512_cvtepi64_epi32(_mm512_srli_epi64::<32>(i0)),
            _mm512_cvtepi64_epi32(_mm512_srli_epi64::<32>(i1)),
        );
        // The high words are nearly always one value: its hash once.
        let hi0 = (index >> 32) as u32;
        let hashed_hi = if _mm512_cmpeq_epi32_mask(hi, splat(hi0)) == u16::MAX { splat(pcg(hi0)) } else { pcg16(hi) };
        let w1 = pcg16(_mm512_xor_si512(splat(self.seed), pcg16(_mm512_xor_si512(lo, hashed_hi))));
        let w2 = pcg16(_mm512_xor_si512(
            _mm512_xor_si512(_mm512_xor_si512(w1, splat(0x85EB_CA6B)), pcg16(_mm512_xor_si512(lo, splat(0xC2B2_AE35)))),
            hi,
        ));
        (w1, w2)
    }

    /// The points of the 16 draw pairs `(a[l], b[l])` ([`point8`]) into
    /// slots `slot + l` (a rejected lane's until its retry overwrites it);
    /// returns the accepted lanes.
    #[target_feature(enable = "avx512f")]
    fn store_points(&mut self, slot: usize, a: __m512i, b: __m512i) -> u16 {
        let mut accepted = 0;
        for h in 0..2 {
            let (c, acc) = point8(half(a, h), half(b, h), self.radius);
            for (col, v) in self.pts.iter_mut().zip(c) {
                // SAFETY: `slot + 16 <= 2·CHUNK` (a group of a chunk), so
                // the 8 values from `slot + 8h` are inside the column.
                unsafe { _mm512_storeu_pd(col.as_mut_ptr().add(slot + 8 * h), v) };
            }
            accepted |= u16::from(acc) << (8 * h);
        }
        accepted
    }

    /// Appends the lanes of `mask` to the queue.
    #[target_feature(enable = "avx512f")]
    fn enqueue(&mut self, mask: u16, slots: __m512i, w1: __m512i, w2: __m512i, kphi: __m512i) {
        if mask == 0 {
            return;
        }
        for (q, v) in self.queue.iter_mut().zip([slots, w1, w2, kphi]) {
            // SAFETY: the queue holds at most `2·CHUNK` entries before this
            // store (one per point of the chunk) and has 16 spare ones.
            unsafe {
                _mm512_storeu_si512(q.as_mut_ptr().add(self.queued).cast(), _mm512_maskz_compress_epi32(mask, v))
            };
        }
        self.queued += mask.count_ones() as usize;
    }

    /// The second pass: the queued points' next draws, 16 points at a time,
    /// until every point is accepted ([`super::LineRng::sphere_point_from`]'s
    /// loop); the accepted points go to their slots, the rejected ones back
    /// to the queue (compacted in place: entries are written below where
    /// they are read).
    #[target_feature(enable = "avx512f")]
    fn retries(&mut self) {
        while self.queued > 0 {
            let n = std::mem::take(&mut self.queued);
            for i in (0..n).step_by(16) {
                let live = if n - i >= 16 { u16::MAX } else { (1u16 << (n - i)) - 1 };
                // SAFETY: `i < n <= 2·CHUNK` and each row has 16 spare
                // entries past `2·CHUNK`, so 16 from `i` are in the row.
                let [slots, w1, w2, kphi] =
                    self.queue.each_ref().map(|q| unsafe { _mm512_loadu_si512(q.as_ptr().add(i).cast()) });
                let draw = |kphi| pcg16(_mm512_xor_si512(w1, pcg16(_mm512_add_epi32(w2, kphi))));
                let accepted = self.retry_points(slots, draw(kphi), draw(_mm512_add_epi32(kphi, splat(PHI))), live);
                self.enqueue(!accepted & live, slots, w1, w2, _mm512_add_epi32(kphi, splat(PHI.wrapping_mul(2))));
            }
        }
    }

    /// [`Scratch::store_points`] for 16 queued points: the accepted ones
    /// of `live` scattered to their slots `slots[l]`.
    #[target_feature(enable = "avx512f")]
    fn retry_points(&mut self, slots: __m512i, a: __m512i, b: __m512i, live: u16) -> u16 {
        let mut accepted = 0;
        for h in 0..2 {
            let (c, acc) = point8(half(a, h), half(b, h), self.radius);
            let acc = acc & (live >> (8 * h)) as u8;
            for (col, v) in self.pts.iter_mut().zip(c) {
                // SAFETY: every queued slot is below `2·CHUNK`, inside the column.
                unsafe { _mm512_mask_i32scatter_pd::<8>(col.as_mut_ptr(), acc, half(slots, h), v) };
            }
            accepted |= u16::from(acc) << (8 * h);
        }
        accepted
    }

    /// The third pass: the chords of the chunk's `m` lines
    /// ([`super::chord`]), appended to `out`.
    ///
    /// # Safety
    /// `out` must have room for `m` more lines.
    #[target_feature(enable = "avx512f")]
    unsafe fn chords(&self, out: &mut Vec<Line>, m: usize) {
        let len = out.len();
        let dst = out.spare_capacity_mut().as_mut_ptr().cast::<f32>();
        for o in (0..m).step_by(8) {
            // SAFETY: `o + 8 <= m <= CHUNK`, so each load reads 8 of a
            // column's `2·CHUNK` values.
            let ld = |c: usize, slot: usize| unsafe { _mm512_loadu_pd(self.pts[c].as_ptr().add(slot)) };
            let p = [0, 1, 2].map(|c| ld(c, o));
            let q = [0, 1, 2].map(|c| ld(c, CHUNK + o));
            let rows = chord8(p, q);
            // SAFETY: the caller leaves room for `m` lines past `len`, and
            // a line is 8 f32 ([`Line`] is `repr(C)`, 32 bytes).
            unsafe { store_rows(dst.add(8 * o), rows) };
        }
        // SAFETY: the `m` lines past `len` were written just above.
        unsafe { out.set_len(len + m) };
    }
}

/// [`super::chord`] of 8 point pairs `p[c][l]`, `q[c][l]`: each line's
/// columns (origin `x`, `y`, `z`, direction `x`, `y`, `z`, `tmax`) in f32.
/// The same f64 operations up to the squared length; its square root and
/// the three divisions are [`approximate_chord8`]'s where that proves the
/// same f32, else the scalar operations for all 8 lanes.
#[target_feature(enable = "avx512f")]
fn chord8(p: [__m512d; 3], q: [__m512d; 3]) -> [__m256; 7] {
    let d = [0, 1, 2].map(|c| _mm512_sub_pd(q[c], p[c]));
    // `DVec3::length`'s square: (x·x + y·y) + z·z.
    let l2 =
        _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(d[0], d[0]), _mm512_mul_pd(d[1], d[1])), _mm512_mul_pd(d[2], d[2]));
    let (len, dir) = approximate_chord8(d, l2).unwrap_or_else(|| {
        let len = _mm512_sqrt_pd(l2);
        // `d / len` where `len > 0`, else +z.
        let positive = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(len, _mm512_set1_pd(0.0));
        let z = [0.0, 0.0, 1.0];
        (len, [0, 1, 2].map(|c| _mm512_mask_blend_pd(positive, _mm512_set1_pd(z[c]), _mm512_div_pd(d[c], len))))
    });
    [p[0], p[1], p[2], dir[0], dir[1], dir[2], len].map(|c| _mm512_cvtpd_ps(c))
}

/// `(len, d / len)` with `len = √l2`, each within 10 f64 ulps of the
/// correctly rounded f64 value and, checked, at least 64 ulps from every
/// f32 rounding boundary, so that both round to the same f32; `None` if a
/// lane fails a check (`l2` outside `[2^-250, 2^254]`, a direction
/// component outside `[2^-125, 2]`: f32 subnormals, zero, NaN).
///
/// `r ≈ 1/√l2` is AVX-512's 14-bit estimate refined by two Newton steps
/// `r ← r + r·(1/2 − (l2/2)·r²)` (relative error `ε ← 1.5ε² + 1.5·2^-53`:
/// `2^-14`, then below `2^-27`, then below `2.25·2^-53`); `len = l2·r` and
/// `d·r` add one rounding each (below `3.25·2^-53` from the exact values),
/// and the scalar `√l2` and `d / len` are within `2^-53` and `2·2^-53`:
/// at most `5.25·2^-53` apart, under 6 ulps (within the 10 the tests
/// allow; the margin is 64).
#[target_feature(enable = "avx512f")]
fn approximate_chord8(d: [__m512d; 3], l2: __m512d) -> Option<(__m512d, [__m512d; 3])> {
    let k = _mm512_set1_pd;
    let in_range =
        |v, lo: f64, hi: f64| _mm512_cmp_pd_mask::<_CMP_GE_OQ>(v, k(lo)) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(v, k(hi));
    if in_range(l2, 2f64.powi(-250), 2f64.powi(254)) != u8::MAX {
        return None;
    }
    let (len, dir) = newton_chord8(d, l2);
    let mut risky = near_boundary(len);
    for c in dir {
        let abs = _mm512_castsi512_pd(_mm512_and_si512(_mm512_castpd_si512(c), _mm512_set1_epi64(i64::MAX)));
        risky |= near_boundary(c) | !in_range(abs, 2f64.powi(-125), 2.0);
    }
    (risky == 0).then_some((len, dir))
}

/// `(l2·r, d·r)` with `r` [`approximate_chord8`]'s `1/√l2`, unchecked.
#[target_feature(enable = "avx512f")]
fn newton_chord8(d: [__m512d; 3], l2: __m512d) -> (__m512d, [__m512d; 3]) {
    let k = _mm512_set1_pd;
    let half = _mm512_mul_pd(l2, k(0.5));
    let mut r = _mm512_rsqrt14_pd(l2);
    for _ in 0..2 {
        r = _mm512_fmadd_pd(r, _mm512_fnmadd_pd(half, _mm512_mul_pd(r, r), k(0.5)), r);
    }
    (_mm512_mul_pd(l2, r), d.map(|c| _mm512_mul_pd(c, r)))
}

/// The lanes of `y` at most 64 f64 ulps from an f32 rounding boundary (a
/// midpoint between two f32: the low 29 of the 52 fraction bits `1000…0`),
/// where a value that close may round to another f32 (for `|y|` in f32's
/// normal range, where f32 keeps the top 23 fraction bits).
#[target_feature(enable = "avx512f")]
fn near_boundary(y: __m512d) -> u8 {
    const MARGIN: i64 = 64;
    let low = _mm512_and_si512(_mm512_castpd_si512(y), _mm512_set1_epi64(0x1FFF_FFFF));
    _mm512_cmple_epu64_mask(
        _mm512_sub_epi64(low, _mm512_set1_epi64(0x1000_0000 - MARGIN)),
        _mm512_set1_epi64(2 * MARGIN),
    )
}

/// Writes the 8 lines of `cols` (origin `x`, `y`, `z`, direction `x`, `y`,
/// `z`, `tmax`, lane `l` for line `l`) as [`Line`] rows from `dst`: two
/// 4 × 4 transposes in each 128-bit half (origin and `tmin = 0`, direction
/// and `tmax`), then the halves paired.
///
/// # Safety
/// `dst` must be valid for writing 64 f32.
#[target_feature(enable = "avx512f")]
unsafe fn store_rows(dst: *mut f32, cols: [__m256; 7]) {
    let [ox, oy, oz, dx, dy, dz, tmax] = cols;
    let transpose = |a, b, c, d| {
        let (t0, t1) = (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
        let (t2, t3) = (_mm256_unpacklo_ps(c, d), _mm256_unpackhi_ps(c, d));
        [
            _mm256_shuffle_ps::<0b01_00_01_00>(t0, t2),
            _mm256_shuffle_ps::<0b11_10_11_10>(t0, t2),
            _mm256_shuffle_ps::<0b01_00_01_00>(t1, t3),
            _mm256_shuffle_ps::<0b11_10_11_10>(t1, t3),
        ]
    };
    // Row `j` of `o` (`d`): line `j`'s origin (direction) in its low
    // half, line `j + 4`'s in its high half.
    let o = transpose(ox, oy, oz, _mm256_setzero_ps());
    let d = transpose(dx, dy, dz, tmax);
    for j in 0..4 {
        // SAFETY: lines `j` and `j + 4` are 8 f32 each within the 64 the
        // caller guarantees.
        unsafe {
            _mm256_storeu_ps(dst.add(8 * j), _mm256_permute2f128_ps::<0x20>(o[j], d[j]));
            _mm256_storeu_ps(dst.add(8 * (j + 4)), _mm256_permute2f128_ps::<0x31>(o[j], d[j]));
        }
    }
}

/// [`super::LineRng::sphere_point_from`]'s try with draws `a[l]`, `b[l]`,
/// times `radius`, for 8 lanes: the point's `x`, `y`, `z` and the lanes
/// that accept their draws (the others' values are meaningless). The
/// scalar code's f64 operations, lane by lane.
#[target_feature(enable = "avx512f")]
fn point8(a: __m256i, b: __m256i, radius: __m512d) -> ([__m512d; 3], u8) {
    let k = _mm512_set1_pd;
    // `2 · uniform_of(w) − 1`; the conversion of a u32 is exact.
    let centred = |w| {
        let uniform = _mm512_mul_pd(_mm512_add_pd(_mm512_cvtepu32_pd(w), k(0.5)), k(1.0 / 4_294_967_296.0));
        _mm512_sub_pd(_mm512_mul_pd(k(2.0), uniform), k(1.0))
    };
    let (u, v) = (centred(a), centred(b));
    let s = _mm512_add_pd(_mm512_mul_pd(u, u), _mm512_mul_pd(v, v));
    let accepted = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(s, k(1.0));
    let r = _mm512_mul_pd(k(2.0), _mm512_sqrt_pd(_mm512_sub_pd(k(1.0), s)));
    let z = _mm512_sub_pd(k(1.0), _mm512_mul_pd(k(2.0), s));
    ([_mm512_mul_pd(u, r), _mm512_mul_pd(v, r), z].map(|x| _mm512_mul_pd(x, radius)), accepted)
}

/// [`pcg`] on 16 lanes: the same 32-bit operations.
#[target_feature(enable = "avx512f")]
fn pcg16(v: __m512i) -> __m512i {
    pcg16_state(_mm512_add_epi32(_mm512_mullo_epi32(v, splat(PCG_MUL)), splat(PCG_INC)))
}

/// [`pcg`] from its state `v·A + B`.
#[target_feature(enable = "avx512f")]
fn pcg16_state(state: __m512i) -> __m512i {
    let shift = _mm512_add_epi32(_mm512_srli_epi32::<28>(state), splat(4));
    let word = _mm512_mullo_epi32(_mm512_xor_si512(_mm512_srlv_epi32(state, shift), state), splat(277_803_737));
    _mm512_xor_si512(_mm512_srli_epi32::<22>(word), word)
}

/// Sixteen lanes of `x`.
#[target_feature(enable = "avx512f")]
fn splat(x: u32) -> __m512i {
    _mm512_set1_epi32(x as i32)
}

/// The slot numbers `slot + l` of lanes `l`.
#[target_feature(enable = "avx512f")]
fn splat_index(slot: usize) -> __m512i {
    _mm512_add_epi32(splat(slot as u32), _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
}

/// Lanes `8h..8h + 8` of `v`.
#[target_feature(enable = "avx512f")]
fn half(v: __m512i, h: usize) -> __m256i {
    if h == 0 { _mm512_castsi512_si256(v) } else { _mm512_extracti64x4_epi64::<1>(v) }
}

/// `lo` in lanes 0..8, `hi` in 8..16.
#[target_feature(enable = "avx512f")]
fn join(lo: __m256i, hi: __m256i) -> __m512i {
    _mm512_inserti64x4::<1>(_mm512_castsi256_si512(lo), hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// [`chord8`] and [`store_rows`] of 8 point pairs.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    unsafe fn lines8(pairs: &[(DVec3, DVec3)]) -> [Line; 8] {
        let col = |f: &dyn Fn(&(DVec3, DVec3)) -> f64| {
            let a: [f64; 8] = std::array::from_fn(|l| f(&pairs[l]));
            // SAFETY: `a` is 64 readable bytes; the load is unaligned.
            unsafe { _mm512_loadu_pd(a.as_ptr()) }
        };
        let p = [col(&|c| c.0.x), col(&|c| c.0.y), col(&|c| c.0.z)];
        let q = [col(&|c| c.1.x), col(&|c| c.1.y), col(&|c| c.1.z)];
        let mut out = [Line::default(); 8];
        // SAFETY: `out` is 8 lines, 64 f32.
        unsafe { store_rows(out.as_mut_ptr().cast(), chord8(p, q)) };
        out
    }

    /// Differences `d` whose length or direction is an f32 rounding
    /// boundary (a midpoint between two f32) moved by `j` f64 ulps: `x`
    /// (length `|x|`), and lengths of exactly `2^e` with a component `2^e·x`
    /// (direction `x`), the cases where the approximate chord must not decide.
    fn near_boundaries() -> Vec<DVec3> {
        let mut out = Vec::new();
        for a in [0.6f32, 0.5, 0.75, 0.999_999_94, 0.3, 0.1, 1e-3, 1e-30] {
            let mid = f64::from(a) + f64::from(a.next_up() - a) / 2.0;
            for j in -80i64..=80 {
                let x = f64::from_bits(mid.to_bits().wrapping_add_signed(j));
                // The length itself `x` (`√(x²)` rounds to `|x|`).
                out.extend([DVec3::new(x, 0.0, 0.0), DVec3::new(0.0, 0.0, -x)]);
                let z0 = (1.0 - x * x).sqrt();
                // A `z` (a few ulps either way) for which the length is 1.
                let z = (-8i64..=8)
                    .map(|t| f64::from_bits(z0.to_bits().wrapping_add_signed(t)))
                    .find(|&z| DVec3::new(x, 0.0, z).length() == 1.0);
                let Some(z) = z else { continue };
                for e in [0, -3, 5, -200] {
                    let s = 2f64.powi(e);
                    for v in [DVec3::new(x, 0.0, z), DVec3::new(0.0, -x, z), DVec3::new(z, 0.0, x)] {
                        assert_eq!((v * s).length(), s);
                        out.push(v * s);
                    }
                }
            }
        }
        assert!(out.len() > 1000, "{} cases", out.len());
        out
    }

    /// The unchecked approximations are within the 10 ulps that
    /// [`approximate_chord8`]'s margin of 64 assumes (the largest error
    /// seen is printed), over lengths in all of its range, next to powers
    /// of two (where an ulp halves) and random directions.
    #[test]
    fn newton_chord8_is_within_10_ulps() {
        if !std::arch::is_x86_feature_detected!("avx512f") {
            return;
        }
        let ulps = |a: f64, b: f64| a.to_bits().abs_diff(b.to_bits());
        let mut worst = [0u64; 2];
        for i in 0..400_000u64 {
            let r = super::super::LineRng::new(17, i);
            let e = (r.u32(3) % 250) as i32 - 125;
            // Lengths spread over `[2^-125, 2^127)`, every eighth a power of
            // two moved by a few ulps.
            let scale = if i % 8 == 0 {
                f64::from_bits(2f64.powi(e).to_bits().wrapping_add_signed(i64::from(r.u32(4) % 9) - 4))
            } else {
                2f64.powi(e) * (1.0 + r.uniform(5))
            };
            let d = r.sphere_point(0) * scale;
            let l2 = d.length_squared();
            if !(2f64.powi(-250)..=2f64.powi(254)).contains(&l2) {
                continue;
            }
            // SAFETY: AVX-512F was detected above.
            let (len, dir) = unsafe {
                let (len, dir) = newton_chord8(d.to_array().map(|c| _mm512_set1_pd(c)), _mm512_set1_pd(l2));
                let mut out = [0f64; 32];
                for (j, v) in [len, dir[0], dir[1], dir[2]].into_iter().enumerate() {
                    _mm512_storeu_pd(out.as_mut_ptr().add(8 * j), v);
                }
                (out[0], [out[8], out[16], out[24]])
            };
            let want = d.length();
            worst[0] = worst[0].max(ulps(len, want));
            for c in 0..3 {
                if (d[c] / want).abs() >= 2f64.powi(-125) {
                    worst[1] = worst[1].max(ulps(dir[c], d[c] / want));
                }
            }
        }
        println!("worst errors: length {} ulps, direction {} ulps", worst[0], worst[1]);
        assert!(worst[0] <= 10 && worst[1] <= 10, "{worst:?}");
    }

    /// [`near_boundary`] flags exactly the values within 64 ulps of an f32
    /// rounding boundary.
    #[test]
    fn near_boundary_flags_64_ulps() {
        if !std::arch::is_x86_feature_detected!("avx512f") {
            return;
        }
        for a in [0.6f32, -0.5, 1e-30, 3e30, 0.999_999_94] {
            let mid = f64::from(a) + f64::from(a.next_up() - a) / 2.0;
            for j in -100i64..=100 {
                let y = f64::from_bits(mid.to_bits().wrapping_add_signed(j));
                // SAFETY: AVX-512F was detected above.
                let flagged = unsafe { near_boundary(_mm512_set1_pd(y)) } == u8::MAX;
                assert_eq!(flagged, j.abs() <= 64, "{a} {j}");
            }
        }
    }

    /// The chords are the scalar [`super::super::chord`]'s, bit for bit:
    /// quotients on and next to f32 rounding boundaries, coincident points,
    /// tiny, subnormal, huge, infinite and NaN differences, random pairs.
    #[test]
    fn chord8_is_the_scalar_chord() {
        if !std::arch::is_x86_feature_detected!("avx512f") {
            return;
        }
        let mut pairs: Vec<(DVec3, DVec3)> = near_boundaries().into_iter().map(|d| (DVec3::ZERO, d)).collect();
        let p = DVec3::new(0.3, -0.4, 0.5);
        for d in [
            DVec3::ZERO,
            DVec3::splat(1e-160),
            DVec3::new(1e-50, 1.0, 0.0),
            DVec3::new(1e-40, -1e-39, 1e-38),
            DVec3::new(f64::MIN_POSITIVE, 0.0, -f64::MIN_POSITIVE),
            DVec3::new(5e-324, 0.0, 0.0),
            DVec3::new(1e300, -1e300, 1e300),
            DVec3::new(f64::INFINITY, 0.0, 1.0),
            DVec3::new(f64::NAN, 0.0, 1.0),
            DVec3::new(-0.0, 0.0, -1.0),
        ] {
            pairs.push((DVec3::ZERO, d));
            pairs.push((p, p + d));
            pairs.push((d, d));
        }
        for i in 0..20_000u64 {
            let r = super::super::LineRng::new(13, i);
            let scale = [0.9, 1e-3, 1e5][i as usize % 3];
            pairs.push((r.sphere_point(0) * scale, r.sphere_point(64) * scale));
        }
        while !pairs.len().is_multiple_of(8) {
            pairs.push((DVec3::ZERO, DVec3::X));
        }
        let bits = |l: &Line| [l.origin, l.direction, [l.tmin, l.tmax, 0.0]].map(|c| c.map(f32::to_bits));
        for group in pairs.chunks_exact(8) {
            // SAFETY: AVX-512F was detected above.
            let got = unsafe { lines8(group) };
            for (l, &(p, q)) in got.iter().zip(group) {
                assert_eq!(bits(l), bits(&super::super::chord(p, q)), "{p} {q}");
            }
        }
    }
}
