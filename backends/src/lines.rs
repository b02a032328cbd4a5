//! Seeded lines. Line `i` is a pure function of `(seed, i)` through a
//! counter-based hash (PCG's output permutation chained over 32-bit words,
//! so a shader can reproduce it), never of thread scheduling.

use glam::{DVec3, Vec3A};

#[cfg(target_arch = "x86_64")]
mod avx512;

/// A line or ray in the tracer's normalised coordinates: origin,
/// unit direction, and the parameter interval `[tmin, tmax]` it covers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Line {
    /// Origin.
    pub origin: [f32; 3],
    /// Lower end of the parameter interval.
    pub tmin: f32,
    /// Unit direction.
    pub direction: [f32; 3],
    /// Upper end of the parameter interval.
    pub tmax: f32,
}

/// PCG's 32-bit output permutation (O'Neill; as popularised by Jarzynski
/// and Olano, "Hash Functions for GPU Rendering", 2020).
#[inline]
#[must_use]
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The 32-bit hash of a seed that every line's draws start from
/// ([`LineRng::of`]): computed once per run, not once per line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeedHash(u32);

impl SeedHash {
    /// The hash of `seed`.
    #[inline]
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self(pcg(seed as u32 ^ pcg((seed >> 32) as u32 ^ 0x9E37_79B9)))
    }
}

/// The random draws of one line: a pure function of `(seed, index)`.
///
/// Two 32-bit words are hashed from the seed and the 64-bit index once (64
/// bits of state, so distinct lines do not share draws); draw `k` is then
/// `pcg(w1 ^ pcg(w2 + k·φ))`. Only 32-bit integer operations: a compute
/// shader reproduces it exactly.
#[derive(Clone, Copy, Debug)]
pub struct LineRng {
    w1: u32,
    w2: u32,
}

impl LineRng {
    /// The generator of line `index` under `seed`.
    #[inline]
    #[must_use]
    pub fn new(seed: u64, index: u64) -> Self {
        Self::of(SeedHash::new(seed), index)
    }

    /// [`LineRng::new`] with the seed's hash computed once for many lines.
    #[inline]
    #[must_use]
    pub fn of(seed: SeedHash, index: u64) -> Self {
        let s = seed.0;
        let w1 = pcg(s ^ pcg(index as u32 ^ pcg((index >> 32) as u32)));
        let w2 = pcg(w1 ^ 0x85EB_CA6B ^ pcg(index as u32 ^ 0xC2B2_AE35) ^ (index >> 32) as u32);
        Self { w1, w2 }
    }

    /// The generator's two words (`w1`, `w2`), for the 8-lane draws.
    #[inline]
    #[must_use]
    pub(crate) fn words(&self) -> [u32; 2] {
        [self.w1, self.w2]
    }

    /// 32 random bits for draw `k`.
    #[inline]
    #[must_use]
    pub fn u32(&self, k: u32) -> u32 {
        pcg(self.w1 ^ pcg(self.w2.wrapping_add(k.wrapping_mul(0x9E37_79B9))))
    }

    /// A uniform double in `(0, 1)` from draw `k` (32 bits of resolution).
    #[inline]
    #[must_use]
    pub fn uniform(&self, k: u32) -> f64 {
        uniform_of(self.u32(k))
    }

    /// A uniform float in `(0, 1)` from draw `k`: 23 bits, so that
    /// `m + 0.5` is exact in f32 (24 bits would round the top value to 1).
    #[inline]
    #[must_use]
    pub fn uniform32(&self, k: u32) -> f32 {
        ((self.u32(k) >> 9) as f32 + 0.5) * (1.0 / 8_388_608.0)
    }

    /// A uniform point on the unit sphere by Marsaglia's method (no
    /// trigonometry), using draws `first, first+1, ...` until accepted.
    #[inline]
    #[must_use]
    pub fn sphere_point(&self, first: u32) -> DVec3 {
        self.sphere_point_from(first, [self.u32(first), self.u32(first + 1)])
    }

    /// [`LineRng::sphere_point`] with its first two draws (`first`,
    /// `first + 1`) already at hand.
    #[inline]
    fn sphere_point_from(&self, first: u32, mut draws: [u32; 2]) -> DVec3 {
        let mut k = first;
        loop {
            let u = 2.0 * uniform_of(draws[0]) - 1.0;
            let v = 2.0 * uniform_of(draws[1]) - 1.0;
            k += 2;
            let s = u * u + v * v;
            if s < 1.0 {
                let r = 2.0 * (1.0 - s).sqrt();
                return DVec3::new(u * r, v * r, 1.0 - 2.0 * s);
            }
            draws = [self.u32(k), self.u32(k + 1)];
        }
    }
}

/// The uniform double in `(0, 1)` of a 32-bit draw.
#[inline]
fn uniform_of(word: u32) -> f64 {
    (f64::from(word) + 0.5) * (1.0 / 4_294_967_296.0)
}

/// A uniform double in `[0, 1)` for draw `stream` of line `index` (for
/// callers that need one number; [`LineRng`] is cheaper for several).
#[inline]
#[must_use]
pub fn uniform(seed: u64, index: u64, stream: u32) -> f64 {
    LineRng::new(seed, index).uniform(stream)
}

/// A uniform point on the unit sphere from two uniforms (Archimedes: `z` uniform).
#[inline]
#[must_use]
pub fn sphere_point(u: f64, v: f64) -> DVec3 {
    let z = 1.0 - 2.0 * u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f64::consts::TAU * v;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Global line `index`: the chord through two uniform points of the sphere
/// of `radius` around the origin (Part III §1.4; uniformly distributed lines).
#[must_use]
pub fn global_line(seed: u64, index: u64, radius: f64) -> Line {
    global_line_of(SeedHash::new(seed), index, radius)
}

/// [`global_line`] with the seed's hash computed once for many lines.
#[inline]
#[must_use]
pub fn global_line_of(seed: SeedHash, index: u64, radius: f64) -> Line {
    let rng = LineRng::of(seed, index);
    global_line_from(&rng, [rng.u32(0), rng.u32(1), rng.u32(64), rng.u32(65)], radius)
}

/// [`global_line_of`] from its generator and its draws 0, 1, 64 and 65.
#[inline]
fn global_line_from(rng: &LineRng, draws: [u32; 4], radius: f64) -> Line {
    // Draws 0.. for the first point, 64.. for the second (rejection rarely
    // needs more than a few pairs; 32 pairs fail with probability 0.21^32).
    let p = rng.sphere_point_from(0, [draws[0], draws[1]]) * radius;
    let q = rng.sphere_point_from(64, [draws[2], draws[3]]) * radius;
    chord(p, q)
}

/// The line from `p` to `q`: origin `p`, the unit direction (+z where the
/// points coincide) and `tmax` the distance, in f32.
#[inline]
fn chord(p: DVec3, q: DVec3) -> Line {
    let d = q - p;
    let len = d.length();
    let dir = if len > 0.0 { d / len } else { DVec3::Z };
    Line { origin: p.as_vec3().to_array(), tmin: 0.0, direction: dir.as_vec3().to_array(), tmax: len as f32 }
}

/// The global lines `first`, `first + stride`, … (`count` of them),
/// appended to `out`: [`global_line_of`] for each, bit for bit, 16 lines
/// at a time with AVX-512 (`lines/avx512.rs`), 8 with AVX2, else one by one.
pub fn global_lines_of(seed: SeedHash, first: u64, stride: u64, count: u64, radius: f64, out: &mut Vec<Line>) {
    global_lines_with(Simd::detect(), seed, first, stride, count, radius, out);
}

/// The widest vector instructions a CPU offers the line generator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Simd {
    /// One line at a time.
    Scalar,
    /// AVX2: 8 lines' hashing at a time.
    Avx2,
    /// AVX-512F: 16 lines at a time.
    Avx512,
}

impl Simd {
    /// This CPU's.
    fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                return Self::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Self::Avx2;
            }
        }
        Self::Scalar
    }
}

/// [`global_lines_of`] with the instructions of `simd` (at most: never
/// more than the CPU's, [`Simd::detect`]). With AVX2 the integer hashing (each line's generator
/// and its first draws, 13 of the ~15 [`pcg`] calls of a line) goes in 8
/// lanes, the floating-point rest in two halves of 4 (`global_lines8`);
/// only a rejected pair of draws goes through the scalar code.
fn global_lines_with(
    simd: Simd,
    seed: SeedHash,
    first: u64,
    stride: u64,
    count: u64,
    radius: f64,
    out: &mut Vec<Line>,
) {
    let simd = simd.min(Simd::detect());
    let mut k = 0;
    #[cfg(target_arch = "x86_64")]
    match simd {
        // SAFETY: AVX-512F is detected (`simd` is at most `Simd::detect()`).
        Simd::Avx512 => k = unsafe { avx512::global_lines(seed, first, stride, count, radius, out) },
        Simd::Avx2 => {
            while k + 8 <= count {
                let index: [u64; 8] = std::array::from_fn(|l| first.wrapping_add((k + l as u64).wrapping_mul(stride)));
                // SAFETY: AVX2 is detected (`simd` is at most `Simd::detect()`).
                unsafe {
                    let (w1, w2, d) = hash8(seed, &index);
                    global_lines8(&w1, &w2, &d, radius, out);
                }
                k += 8;
            }
        }
        Simd::Scalar => {}
    }
    out.extend((k..count).map(|k| global_line_of(seed, first.wrapping_add(k.wrapping_mul(stride)), radius)));
}

/// [`global_line_from`] for 8 generators (lane `l`: words `w1[l]`,
/// `w2[l]`, draws 0, 1, 64 and 65 in `draws[..][l]`), appended to `out`
/// in lane order. The same f64 operations in the same order, 4 lanes at a
/// time (IEEE multiplication, addition, square root and division are
/// correctly rounded, and no fused multiply-add is formed, so every lane
/// has the scalar bits); a lane whose first pair of draws for a point is
/// rejected takes that point from [`LineRng::sphere_point_from`].
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn global_lines8(w1: &[u32; 8], w2: &[u32; 8], draws: &[[u32; 8]; 4], radius: f64, out: &mut Vec<Line>) {
    use std::arch::x86_64::{
        _CMP_GT_OQ, _mm_storeu_ps, _mm256_add_pd, _mm256_blendv_pd, _mm256_cmp_pd, _mm256_cvtpd_ps, _mm256_div_pd,
        _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_sqrt_pd, _mm256_sub_pd,
    };
    // Columns of the two points, the rejected lanes' from the scalar code
    // (draws 0 and 1 in rows 0 and 1 of `draws`, 64 and 65 in rows 2 and 3).
    let (mut pc, p_accepted) = sphere_points8(&draws[0], &draws[1], radius);
    let (mut qc, q_accepted) = sphere_points8(&draws[2], &draws[3], radius);
    for l in 0..8 {
        for (first, row, accepted, c) in [(0, 0, p_accepted, &mut pc), (64, 2, q_accepted, &mut qc)] {
            if accepted >> l & 1 == 0 {
                let rng = LineRng { w1: w1[l], w2: w2[l] };
                let v = rng.sphere_point_from(first, [draws[row][l], draws[row + 1][l]]) * radius;
                [c[0][l], c[1][l], c[2][l]] = [v.x, v.y, v.z];
            }
        }
    }
    let mut cols = [[0f32; 8]; 7];
    for h in [0, 4] {
        // SAFETY: each load reads 4 of a column's 8 values, from `h <= 4`;
        // each store writes 4 of `cols`' 8 f32 lanes.
        unsafe {
            let ld = |c: &[f64; 8]| _mm256_loadu_pd(c.as_ptr().add(h));
            let [px, py, pz] = [ld(&pc[0]), ld(&pc[1]), ld(&pc[2])];
            let (dx, dy, dz) =
                (_mm256_sub_pd(ld(&qc[0]), px), _mm256_sub_pd(ld(&qc[1]), py), _mm256_sub_pd(ld(&qc[2]), pz));
            // `DVec3::length`: √((x·x + y·y) + z·z).
            let len = _mm256_sqrt_pd(_mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                _mm256_mul_pd(dz, dz),
            ));
            // `d / len` where `len > 0`, else +z.
            let positive = _mm256_cmp_pd::<_CMP_GT_OQ>(len, _mm256_set1_pd(0.0));
            let unit = |d, z: f64| _mm256_blendv_pd(_mm256_set1_pd(z), _mm256_div_pd(d, len), positive);
            for (c, v) in [px, py, pz, unit(dx, 0.0), unit(dy, 0.0), unit(dz, 1.0), len].into_iter().enumerate() {
                _mm_storeu_ps(cols[c].as_mut_ptr().add(h), _mm256_cvtpd_ps(v));
            }
        }
    }
    let [ox, oy, oz, dx, dy, dz, tmax] = cols;
    out.extend((0..8).map(|l| Line {
        origin: [ox[l], oy[l], oz[l]],
        tmin: 0.0,
        direction: [dx[l], dy[l], dz[l]],
        tmax: tmax[l],
    }));
}

/// [`LineRng::sphere_point_from`]'s first try, times `radius`, for 8
/// lanes whose two draws are `a[l]` and `b[l]`: the point's `x`, `y` and
/// `z` columns and the mask of lanes whose draws were accepted (the other
/// lanes' columns are meaningless). The same f64 operations as the
/// scalar code, 4 lanes at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn sphere_points8(a: &[u32; 8], b: &[u32; 8], radius: f64) -> ([[f64; 8]; 3], u32) {
    use std::arch::x86_64::{
        _CMP_LT_OQ, _mm_loadu_si128, _mm_set1_epi32, _mm_xor_si128, _mm256_add_pd, _mm256_cmp_pd, _mm256_cvtepi32_pd,
        _mm256_movemask_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_sqrt_pd, _mm256_storeu_pd, _mm256_sub_pd,
    };
    let k = _mm256_set1_pd;
    let (mut c, mut accepted) = ([[0f64; 8]; 3], 0);
    for h in [0, 4] {
        // `2 · uniform_of(w) − 1` of 4 words from `h`: the word, as f64
        // (its signed reading plus 2^31, exact), plus one half, times 2^-32.
        // SAFETY: the load reads 4 of the 8 words, from `h <= 4`.
        let signed = |w: &[u32; 8]| unsafe {
            _mm256_cvtepi32_pd(_mm_xor_si128(_mm_loadu_si128(w.as_ptr().add(h).cast()), _mm_set1_epi32(i32::MIN)))
        };
        let uniform = |w| {
            _mm256_mul_pd(_mm256_add_pd(_mm256_add_pd(signed(w), k(2_147_483_648.0)), k(0.5)), k(1.0 / 4_294_967_296.0))
        };
        let (u, v) = (
            _mm256_sub_pd(_mm256_mul_pd(k(2.0), uniform(a)), k(1.0)),
            _mm256_sub_pd(_mm256_mul_pd(k(2.0), uniform(b)), k(1.0)),
        );
        let s = _mm256_add_pd(_mm256_mul_pd(u, u), _mm256_mul_pd(v, v));
        accepted |= (_mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(s, k(1.0))) as u32) << h;
        let r = _mm256_mul_pd(k(2.0), _mm256_sqrt_pd(_mm256_sub_pd(k(1.0), s)));
        let z = _mm256_sub_pd(k(1.0), _mm256_mul_pd(k(2.0), s));
        for (col, x) in c.iter_mut().zip([_mm256_mul_pd(u, r), _mm256_mul_pd(v, r), z]) {
            // SAFETY: the store writes 4 of the column's 8 values, from `h <= 4`.
            unsafe { _mm256_storeu_pd(col.as_mut_ptr().add(h), _mm256_mul_pd(x, k(radius))) };
        }
    }
    (c, accepted)
}

/// [`pcg`] on 8 lanes: the same 32-bit operations.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn pcg8(v: std::arch::x86_64::__m256i) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::{
        _mm256_add_epi32, _mm256_mullo_epi32, _mm256_set1_epi32, _mm256_srli_epi32, _mm256_srlv_epi32, _mm256_xor_si256,
    };
    let state =
        _mm256_add_epi32(_mm256_mullo_epi32(v, _mm256_set1_epi32(747_796_405)), _mm256_set1_epi32(-1_403_630_843));
    let shift = _mm256_add_epi32(_mm256_srli_epi32::<28>(state), _mm256_set1_epi32(4));
    let word =
        _mm256_mullo_epi32(_mm256_xor_si256(_mm256_srlv_epi32(state, shift), state), _mm256_set1_epi32(277_803_737));
    _mm256_xor_si256(_mm256_srli_epi32::<22>(word), word)
}

/// [`LineRng::uniform32`] of draw `k` for 8 generators, lane `l` of
/// `w1`/`w2` holding generator `l`'s words ([`LineRng::words`]): the same
/// integer operations, and the same f32 conversion (exact: the word's top
/// 23 bits, plus one half, times a power of two).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn uniform32x8(
    w1: std::arch::x86_64::__m256i,
    w2: std::arch::x86_64::__m256i,
    k: u32,
) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::{
        _mm256_add_epi32, _mm256_add_ps, _mm256_cvtepi32_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_srli_epi32,
        _mm256_xor_si256,
    };
    let word = pcg8(_mm256_xor_si256(w1, pcg8(_mm256_add_epi32(w2, splat8(k.wrapping_mul(0x9E37_79B9))))));
    let top = _mm256_cvtepi32_ps(_mm256_srli_epi32::<9>(word));
    _mm256_mul_ps(_mm256_add_ps(top, _mm256_set1_ps(0.5)), _mm256_set1_ps(1.0 / 8_388_608.0))
}

/// [`permute`] of 8 lanes when each lane's `len` is a power of two (`w` =
/// `len − 1`): the cycle walk then ends after one round, so this is that
/// round's operations and the final masked sum, lane by lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn permute8_pow2(
    i: std::arch::x86_64::__m256i,
    w: std::arch::x86_64::__m256i,
    p: std::arch::x86_64::__m256i,
) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::{
        _mm256_add_epi32, _mm256_and_si256, _mm256_mullo_epi32, _mm256_or_si256, _mm256_srli_epi32, _mm256_xor_si256,
    };
    let mul = |a, c: u32| _mm256_mullo_epi32(a, splat8(c));
    let mut i = _mm256_xor_si256(i, p);
    i = mul(i, 0xe170_893d);
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<16>(p));
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<4>(_mm256_and_si256(i, w)));
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<8>(p));
    i = mul(i, 0x0929_eb3f);
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<23>(p));
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<1>(_mm256_and_si256(i, w)));
    i = _mm256_mullo_epi32(i, _mm256_or_si256(splat8(1), _mm256_srli_epi32::<27>(p)));
    i = mul(i, 0x6935_fa69);
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<11>(_mm256_and_si256(i, w)));
    i = mul(i, 0x74dc_b303);
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<2>(_mm256_and_si256(i, w)));
    i = mul(i, 0x9e50_1cc3);
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<2>(_mm256_and_si256(i, w)));
    i = mul(i, 0xc860_a3df);
    i = _mm256_and_si256(i, w);
    i = _mm256_xor_si256(i, _mm256_srli_epi32::<5>(i));
    _mm256_and_si256(_mm256_add_epi32(i, p), w)
}

/// [`LineRng::of`] for 8 line indices, and draws 0, 1, 64 and 65 of each:
/// `(w1, w2, draws)`, lane `l` for `index[l]`.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn hash8(seed: SeedHash, index: &[u64; 8]) -> ([u32; 8], [u32; 8], [[u32; 8]; 4]) {
    use std::arch::x86_64::{_mm256_add_epi32, _mm256_xor_si256};
    let (lo, hi) = (load8(&index.map(|i| i as u32)), load8(&index.map(|i| (i >> 32) as u32)));
    // `LineRng::of`'s words, operation for operation.
    let w1 = pcg8(_mm256_xor_si256(splat8(seed.0), pcg8(_mm256_xor_si256(lo, pcg8(hi)))));
    let w2 = pcg8(_mm256_xor_si256(
        _mm256_xor_si256(_mm256_xor_si256(w1, splat8(0x85EB_CA6B)), pcg8(_mm256_xor_si256(lo, splat8(0xC2B2_AE35)))),
        hi,
    ));
    // `LineRng::u32(k)` for the four draws.
    let mut draws = [[0u32; 8]; 4];
    for (d, k) in draws.iter_mut().zip([0u32, 1, 64, 65]) {
        let v = pcg8(_mm256_xor_si256(w1, pcg8(_mm256_add_epi32(w2, splat8(k.wrapping_mul(0x9E37_79B9))))));
        *d = store8(v);
    }
    (store8(w1), store8(w2), draws)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn splat8(x: u32) -> std::arch::x86_64::__m256i {
    std::arch::x86_64::_mm256_set1_epi32(x as i32)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn load8(a: &[u32; 8]) -> std::arch::x86_64::__m256i {
    // SAFETY: `a` is 32 readable bytes; the load is unaligned.
    unsafe { std::arch::x86_64::_mm256_loadu_si256(a.as_ptr().cast()) }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn store8(v: std::arch::x86_64::__m256i) -> [u32; 8] {
    let mut a = [0u32; 8];
    // SAFETY: `a` is 32 writable bytes; the store is unaligned.
    unsafe { std::arch::x86_64::_mm256_storeu_si256(a.as_mut_ptr().cast(), v) };
    a
}

/// A cosine-distributed unit direction around `n` (Malley's method).
#[must_use]
pub fn cosine_direction(n: DVec3, u: f64, v: f64) -> DVec3 {
    let r = u.sqrt();
    let phi = std::f64::consts::TAU * v;
    let (x, y) = (r * phi.cos(), r * phi.sin());
    let z = (1.0 - u).max(0.0).sqrt();
    let (t, b) = n.any_orthonormal_pair();
    (t * x + b * y + n * z).normalize()
}

/// `⌊f⌋` as an integer without libm's `floorf` (a call where SSE2, which
/// has no rounding instruction, is the target): truncation, one less where
/// it rounded up. Exact for `|f| < 2³¹`; NaN gives 0 and the ends
/// saturate, as `f.floor() as i32` does.
#[inline]
fn floor_i32(f: f32) -> i32 {
    let t = f as i32;
    t.saturating_sub(i32::from(t as f32 > f))
}

/// `(cos 2πv, sin 2πv)` for `v` in `[0, 1)` in f32 without a library
/// call: the quarter turn `⌊4v⌋` is applied exactly, and the angle left,
/// in `[0, π/2)`, goes through Taylor polynomials to `x¹¹`/`x¹²` (error
/// below 6e-8, under f32's resolution near 1).
#[inline]
#[must_use]
pub fn cos_sin_turn(v: f32) -> (f32, f32) {
    let f = v * 4.0;
    let q = floor_i32(f);
    let x = (f - q as f32) * std::f32::consts::FRAC_PI_2;
    let x2 = x * x;
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0 + x2 * (-1.0 / 39_916_800.0))))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0 + x2 / 479_001_600.0)))));
    match q & 3 {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    }
}

/// [`cosine_direction`] in f32 with [`cos_sin_turn`] (no `sincos` call):
/// a cosine-distributed unit direction around unit `n` (Malley's method).
#[inline]
#[must_use]
pub fn cosine_direction32(n: Vec3A, u: f32, v: f32) -> Vec3A {
    let r = u.sqrt();
    let (c, s) = cos_sin_turn(v);
    let z = (1.0 - u).max(0.0).sqrt();
    let (t, b) = n.any_orthonormal_pair();
    (t * (r * c) + b * (r * s) + n * z).normalize()
}

/// Eight 3-vectors as three f32 columns (`x`, `y`, `z`, lane `l` holding
/// vector `l`): the path tracer's 8-wide shading. Each operation is glam's
/// `Vec3A` operation lane by lane, in the same order (a dot product is
/// `(x·x' + y·y') + z·z'`, as glam's SSE2 `dot3`), so the results are the
/// scalar code's bits.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Vec3x8 {
    pub(crate) x: std::arch::x86_64::__m256,
    pub(crate) y: std::arch::x86_64::__m256,
    pub(crate) z: std::arch::x86_64::__m256,
}

#[cfg(target_arch = "x86_64")]
impl Vec3x8 {
    /// The eight vectors `rows` as columns (a 4 × 4 transpose in each
    /// 128-bit half; exact: moves only).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn from_rows(rows: [Vec3A; 8]) -> Self {
        use std::arch::x86_64::{__m128, _mm256_set_m128, _mm256_shuffle_ps, _mm256_unpackhi_ps, _mm256_unpacklo_ps};
        let r = rows.map(__m128::from);
        // Rows `l` and `l + 4` side by side, then the in-lane transpose.
        let [a0, a1, a2, a3] = [0, 1, 2, 3].map(|l| _mm256_set_m128(r[l + 4], r[l]));
        let (xy01, xy23) = (_mm256_unpacklo_ps(a0, a1), _mm256_unpacklo_ps(a2, a3));
        let (zw01, zw23) = (_mm256_unpackhi_ps(a0, a1), _mm256_unpackhi_ps(a2, a3));
        Self {
            x: _mm256_shuffle_ps::<0b01_00_01_00>(xy01, xy23),
            y: _mm256_shuffle_ps::<0b11_10_11_10>(xy01, xy23),
            z: _mm256_shuffle_ps::<0b01_00_01_00>(zw01, zw23),
        }
    }

    /// Lane `l` of each column, as one array per column.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn lanes(self) -> [[f32; 8]; 3] {
        [store8f(self.x), store8f(self.y), store8f(self.z)]
    }

    /// `self + o`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn add(self, o: Self) -> Self {
        use std::arch::x86_64::_mm256_add_ps;
        Self { x: _mm256_add_ps(self.x, o.x), y: _mm256_add_ps(self.y, o.y), z: _mm256_add_ps(self.z, o.z) }
    }

    /// `self − o`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn sub(self, o: Self) -> Self {
        use std::arch::x86_64::_mm256_sub_ps;
        Self { x: _mm256_sub_ps(self.x, o.x), y: _mm256_sub_ps(self.y, o.y), z: _mm256_sub_ps(self.z, o.z) }
    }

    /// `self * o`, component by component.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn mul(self, o: Self) -> Self {
        use std::arch::x86_64::_mm256_mul_ps;
        Self { x: _mm256_mul_ps(self.x, o.x), y: _mm256_mul_ps(self.y, o.y), z: _mm256_mul_ps(self.z, o.z) }
    }

    /// `self * s`, lane `l` scaled by `s`'s lane `l`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn scale(self, s: std::arch::x86_64::__m256) -> Self {
        use std::arch::x86_64::_mm256_mul_ps;
        Self { x: _mm256_mul_ps(self.x, s), y: _mm256_mul_ps(self.y, s), z: _mm256_mul_ps(self.z, s) }
    }

    /// `self / s`, lane `l` divided by `s`'s lane `l`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn div(self, s: std::arch::x86_64::__m256) -> Self {
        use std::arch::x86_64::_mm256_div_ps;
        Self { x: _mm256_div_ps(self.x, s), y: _mm256_div_ps(self.y, s), z: _mm256_div_ps(self.z, s) }
    }

    /// `(x·x' + y·y') + z·z'`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn dot(self, o: Self) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::{_mm256_add_ps, _mm256_mul_ps};
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(self.x, o.x), _mm256_mul_ps(self.y, o.y)), _mm256_mul_ps(self.z, o.z))
    }

    /// `√(self · self)`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn length(self) -> std::arch::x86_64::__m256 {
        std::arch::x86_64::_mm256_sqrt_ps(self.dot(self))
    }

    /// `self / |self|` (glam's `normalize`: a division by the length).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn normalize(self) -> Self {
        self.div(self.length())
    }

    /// glam's `any_orthonormal_pair` of unit vectors (Duff et al. 2017),
    /// lane by lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn any_orthonormal_pair(self) -> (Self, Self) {
        use std::arch::x86_64::{
            _CMP_UNORD_Q, _mm256_add_ps, _mm256_and_ps, _mm256_blendv_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_mul_ps,
            _mm256_or_ps, _mm256_set1_ps, _mm256_xor_ps,
        };
        let (x, y, z) = (self.x, self.y, self.z);
        let sign_bit = _mm256_set1_ps(-0.0);
        let one = _mm256_set1_ps(1.0);
        // `z.signum()`: ±1 with `z`'s sign, NaN for NaN.
        let sign =
            _mm256_blendv_ps(_mm256_or_ps(_mm256_and_ps(z, sign_bit), one), z, _mm256_cmp_ps::<_CMP_UNORD_Q>(z, z));
        let a = _mm256_div_ps(_mm256_set1_ps(-1.0), _mm256_add_ps(sign, z));
        let b = _mm256_mul_ps(_mm256_mul_ps(x, y), a);
        let neg = |v| _mm256_xor_ps(v, sign_bit);
        let t = Self {
            x: _mm256_add_ps(one, _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(sign, x), x), a)),
            y: _mm256_mul_ps(sign, b),
            z: _mm256_mul_ps(neg(sign), x),
        };
        let u = Self { x: b, y: _mm256_add_ps(sign, _mm256_mul_ps(_mm256_mul_ps(y, y), a)), z: neg(y) };
        (t, u)
    }
}

/// Eight f32 lanes from `a`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn load8f(a: &[f32; 8]) -> std::arch::x86_64::__m256 {
    // SAFETY: `a` is 32 readable bytes; the load is unaligned.
    unsafe { std::arch::x86_64::_mm256_loadu_ps(a.as_ptr()) }
}

/// The eight f32 lanes of `v`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn store8f(v: std::arch::x86_64::__m256) -> [f32; 8] {
    let mut a = [0f32; 8];
    // SAFETY: `a` is 32 writable bytes; the store is unaligned.
    unsafe { std::arch::x86_64::_mm256_storeu_ps(a.as_mut_ptr(), v) };
    a
}

/// [`cos_sin_turn`] of 8 lanes: the same f32 operations lane by lane
/// (AVX's rounding instruction for the floor), so the same bits for `v`
/// in `[0, 1)`, its contract (outside it, `-0.0` gives `sin`'s zero the
/// other sign and `|4v| ≥ 2³¹` another quarter; every caller passes a
/// draw in `(0, 1)`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn cos_sin_turn8(v: std::arch::x86_64::__m256) -> (std::arch::x86_64::__m256, std::arch::x86_64::__m256) {
    use std::arch::x86_64::{
        _mm256_add_epi32, _mm256_add_ps, _mm256_and_si256, _mm256_blendv_ps, _mm256_castsi256_ps, _mm256_cmpeq_epi32,
        _mm256_cvttps_epi32, _mm256_div_ps, _mm256_floor_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_slli_epi32,
        _mm256_sub_ps, _mm256_xor_ps,
    };
    let k = _mm256_set1_ps;
    let f = _mm256_mul_ps(v, k(4.0));
    let q = _mm256_floor_ps(f);
    let x = _mm256_mul_ps(_mm256_sub_ps(f, q), k(std::f32::consts::FRAC_PI_2));
    let x2 = _mm256_mul_ps(x, x);
    // `a + x2 · b`, as the scalar polynomials nest.
    let step = |a: f32, b| _mm256_add_ps(k(a), _mm256_mul_ps(x2, b));
    let s = _mm256_mul_ps(
        x,
        step(
            1.0,
            step(-1.0 / 6.0, step(1.0 / 120.0, step(-1.0 / 5040.0, step(1.0 / 362_880.0, k(-1.0 / 39_916_800.0))))),
        ),
    );
    let c = step(
        1.0,
        step(
            -0.5,
            step(
                1.0 / 24.0,
                step(
                    -1.0 / 720.0,
                    step(1.0 / 40_320.0, _mm256_add_ps(k(-1.0 / 3_628_800.0), _mm256_div_ps(x2, k(479_001_600.0)))),
                ),
            ),
        ),
    );
    // Quarter `q & 3`: 0 (c, s), 1 (−s, c), 2 (−c, −s), 3 (s, −c).
    let q = _mm256_cvttps_epi32(q);
    let odd = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(q, splat8(1)), splat8(1)));
    let (cos, sin) = (_mm256_blendv_ps(c, s, odd), _mm256_blendv_ps(s, c, odd));
    // The sign bit where the quarter negates: cos for 1 and 2 (bit 1 of
    // `q + 1`), sin for 2 and 3 (bit 1 of `q`), moved to bit 31.
    let flip = |m| _mm256_castsi256_ps(_mm256_slli_epi32::<30>(_mm256_and_si256(m, splat8(2))));
    (_mm256_xor_ps(cos, flip(_mm256_add_epi32(q, splat8(1)))), _mm256_xor_ps(sin, flip(q)))
}

/// [`cosine_direction32`] of 8 lanes (unit normals `n`, draws `u`, `v`):
/// the same operations lane by lane, so the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn cosine_direction32x8(n: Vec3x8, u: std::arch::x86_64::__m256, v: std::arch::x86_64::__m256) -> Vec3x8 {
    use std::arch::x86_64::{
        _mm256_max_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_sqrt_ps, _mm256_sub_ps,
    };
    let r = _mm256_sqrt_ps(u);
    let (c, s) = cos_sin_turn8(v);
    let z = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(_mm256_set1_ps(1.0), u), _mm256_setzero_ps()));
    let (t, b) = n.any_orthonormal_pair();
    t.scale(_mm256_mul_ps(r, c)).add(b.scale(_mm256_mul_ps(r, s))).add(n.scale(z)).normalize()
}

/// Element `i` of a pseudo-random permutation of `0..len` chosen by `key`
/// (Kensler, "Correlated Multi-Jittered Sampling", 2013: a hash invertible
/// on the next power of two, cycle-walked into `0..len`). `i < len`.
#[inline]
#[must_use]
pub fn permute(mut i: u32, len: u32, key: u32) -> u32 {
    if len <= 1 {
        return 0;
    }
    let mut w = len - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    let p = key;
    loop {
        i ^= p;
        i = i.wrapping_mul(0xe170_893d);
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | p >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < len {
            break;
        }
    }
    let j = i.wrapping_add(p);
    // For a power of two `len == w + 1`: the same remainder without a division.
    if len.is_power_of_two() { j & w } else { j % len }
}

/// Index of the first element of the cumulative sums `cdf` exceeding `x`.
#[must_use]
pub fn sample_cdf(cdf: &[f64], x: f64) -> usize {
    cdf.partition_point(|&c| c <= x).min(cdf.len().saturating_sub(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_is_deterministic_and_spread() {
        assert_eq!(uniform(1, 7, 0), uniform(1, 7, 0));
        assert_ne!(uniform(1, 7, 0), uniform(2, 7, 0));
        assert_ne!(uniform(1, 7, 0), uniform(1, 8, 0));
        assert_ne!(uniform(1, 7, 0), uniform(1, 7, 1));
        assert_ne!(uniform(1, 7, 0), uniform(1, 7 + (1 << 32), 0));
        // Lines never share their draws: 10^6 consecutive indices, distinct states.
        let mut seen = std::collections::HashSet::new();
        for i in 0..1_000_000u64 {
            let r = LineRng::new(5, i);
            assert!(seen.insert((r.u32(0), r.u32(1))), "line {i} repeats an earlier line's draws");
        }
        // Mean and variance of 10^5 draws: 1/2 and 1/12 within 5 standard errors.
        let n = 100_000;
        let xs: Vec<f64> = (0..n).map(|i| uniform(42, i, 3)).collect();
        let m = xs.iter().sum::<f64>() / n as f64;
        let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n as f64;
        assert!((m - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt());
        assert!((v - 1.0 / 12.0).abs() < 5e-3);
    }

    #[test]
    fn uniform32_stays_inside_the_open_interval() {
        let r = LineRng::new(0, 0);
        // The extreme words, through the same arithmetic.
        for m in [0u32, 1, (1 << 23) - 1] {
            let x = (m as f32 + 0.5) * (1.0 / 8_388_608.0);
            assert!(x > 0.0 && x < 1.0, "{m}: {x}");
        }
        assert!((0..10_000).map(|k| r.uniform32(k)).all(|x| x > 0.0 && x < 1.0));
    }

    #[test]
    fn floor_i32_is_floor() {
        let r = LineRng::new(9, 1);
        for k in 0..100_000 {
            for f in [(r.uniform32(k) - 0.5) * 2e6, r.uniform32(k) * 4.0] {
                assert_eq!(floor_i32(f), f.floor() as i32, "{f}");
            }
        }
        for f in [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            3.999_999_8,
            4.0,
            -2.5,
            0.5,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -3e9,
            3e9,
        ] {
            assert_eq!(floor_i32(f), f.floor() as i32, "{f}");
        }
    }

    #[test]
    fn cos_sin_turn_matches_the_library() {
        let mut worst = 0.0f64;
        for i in 0..100_000u32 {
            let v = (i as f32 + 0.5) / 100_000.0;
            let (c, s) = cos_sin_turn(v);
            let (ls, lc) = (std::f64::consts::TAU * f64::from(v)).sin_cos();
            worst = worst.max((f64::from(c) - lc).abs()).max((f64::from(s) - ls).abs());
        }
        assert!(worst < 3e-7, "worst error {worst}");
    }

    /// The 8-lane cosine directions are the scalar ones bit for bit:
    /// normals all over the sphere (both signs of `z`, the poles), draws
    /// over the unit square with the quarter turns' edges.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn cosine_direction32x8_is_the_scalar_direction() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut cases = Vec::new();
        for i in 0..4000u32 {
            let r = LineRng::new(4, u64::from(i));
            let n = r.sphere_point(0).as_vec3a();
            let v = if i % 5 == 0 {
                [0.25f32, 0.5, 0.75, 1.0 - f32::EPSILON / 2.0][(i / 5) as usize % 4]
            } else {
                r.uniform32(8)
            };
            cases.push((n, r.uniform32(9), v));
        }
        cases.extend([(Vec3A::Z, 0.3, 0.2), (Vec3A::NEG_Z, 0.7, 0.6), (Vec3A::X, 0.5, 0.9), (Vec3A::NEG_Y, 0.1, 0.4)]);
        cases.extend([(Vec3A::Z, 0.3, 0.2); 4]);
        for group in cases.chunks_exact(8) {
            let col = |f: &dyn Fn(&(Vec3A, f32, f32)) -> f32| -> [f32; 8] { std::array::from_fn(|l| f(&group[l])) };
            // SAFETY: AVX2 was detected above.
            let [x, y, z] = unsafe {
                let n = Vec3x8::from_rows(std::array::from_fn(|l| group[l].0));
                let columns =
                    Vec3x8 { x: load8f(&col(&|c| c.0.x)), y: load8f(&col(&|c| c.0.y)), z: load8f(&col(&|c| c.0.z)) };
                assert_eq!(n.lanes().map(|c| c.map(f32::to_bits)), columns.lanes().map(|c| c.map(f32::to_bits)));
                cosine_direction32x8(n, load8f(&col(&|c| c.1)), load8f(&col(&|c| c.2))).lanes()
            };
            for (l, &(n, u, v)) in group.iter().enumerate() {
                let want = cosine_direction32(n, u, v);
                assert_eq!([x[l], y[l], z[l]].map(f32::to_bits), want.to_array().map(f32::to_bits), "{n} {u} {v}");
            }
            // SAFETY: AVX2 was detected above.
            let (c, s) = unsafe {
                let (c, s) = cos_sin_turn8(load8f(&col(&|c| c.2)));
                (store8f(c), store8f(s))
            };
            for (l, &(_, _, v)) in group.iter().enumerate() {
                let (wc, ws) = cos_sin_turn(v);
                assert_eq!((c[l].to_bits(), s[l].to_bits()), (wc.to_bits(), ws.to_bits()), "{v}");
            }
        }
    }

    #[test]
    fn permute_is_a_permutation() {
        for len in [1u32, 2, 7, 8, 60, 64, 256, 1000] {
            for key in [0u32, 1, 0xdead_beef, 12345] {
                let mut seen = vec![false; len as usize];
                for i in 0..len {
                    let j = permute(i, len, key) as usize;
                    assert!(!seen[j], "len {len} key {key}: {j} twice");
                    seen[j] = true;
                }
            }
        }
        // Different keys give different orders.
        let a: Vec<u32> = (0..64).map(|i| permute(i, 64, 1)).collect();
        let b: Vec<u32> = (0..64).map(|i| permute(i, 64, 2)).collect();
        assert_ne!(a, b);
    }

    #[test]
    fn cosine_direction32_is_cosine_distributed() {
        // E[cos θ] = 2/3 and E[cos² θ] = 1/2 under p = cos θ / π; the
        // tangential components average 0.
        let n = Vec3A::new(0.3, -0.5, 0.8).normalize();
        let m = 200_000;
        let (mut c1, mut c2, mut t) = (0.0f64, 0.0f64, Vec3A::ZERO);
        for i in 0..m {
            let r = LineRng::new(11, i);
            let d = cosine_direction32(n, r.uniform32(0), r.uniform32(1));
            assert!((d.length() - 1.0).abs() < 1e-5);
            let c = f64::from(d.dot(n));
            assert!(c >= -1e-6);
            c1 += c;
            c2 += c * c;
            t += d - n * d.dot(n);
        }
        let m = m as f64;
        assert!((c1 / m - 2.0 / 3.0).abs() < 5.0 * (1.0f64 / 18.0 / m).sqrt(), "{}", c1 / m);
        assert!((c2 / m - 0.5).abs() < 5e-3, "{}", c2 / m);
        assert!((t / m as f32).length() < 5e-3);
    }

    /// The SIMD levels this CPU runs, the scalar one first.
    fn levels() -> Vec<Simd> {
        [Simd::Scalar, Simd::Avx2, Simd::Avx512].into_iter().filter(|&s| s <= Simd::detect()).collect()
    }

    /// The batched lines at every SIMD level the CPU has are each
    /// [`global_line_of`]'s, bit for bit: many seeds, rejections (a fifth
    /// of the points), counts around the 16-line groups and the 256-line
    /// chunks, strides (0, odd, huge and wrapping), indices whose high
    /// words differ within a group, and the ends of the index range.
    #[test]
    fn batched_lines_are_the_single_lines() {
        let mut cases = vec![
            (1u64, 0u64, 1u64, 20_011u64, 0.9),
            (7, 5, 8, 3_000, 0.9),
            (u64::MAX, (1 << 32) - 9, 3, 1_000, 0.9),
            (3, u64::MAX - 64, 1, 64, 0.9),
            (3, u64::MAX - 100, 1, 300, 0.5),
            (4, 123, 0, 40, 2.0),
            (5, 1 << 40, (1 << 32) + 1, 777, 1e-3),
            (6, 99, u64::MAX / 3, 513, 1e6),
            (8, (1 << 33) - 5, 1, 1024, 0.9),
        ];
        for seed in 10..60u64 {
            let count = [0, 1, 15, 16, 17, 31, 255, 256, 257, 1024][seed as usize % 10];
            cases.push((seed.wrapping_mul(0x9E37_79B9_7F4A_7C15), seed * 1_000_003, seed % 7 + 1, count, 0.9));
        }
        for (seed, first, stride, count, radius) in cases {
            let h = SeedHash::new(seed);
            for simd in levels() {
                let mut batch = vec![Line::default(); 3];
                global_lines_with(simd, h, first, stride, count, radius, &mut batch);
                assert_eq!(batch.len() as u64, count + 3);
                for (k, l) in batch[3..].iter().enumerate() {
                    let i = first.wrapping_add((k as u64).wrapping_mul(stride));
                    assert_eq!(*l, global_line_of(h, i, radius), "{simd:?} seed {seed} line {k}");
                    let bits = |l: &Line| [l.origin, l.direction, [l.tmin, l.tmax, 0.0]].map(|c| c.map(f32::to_bits));
                    assert_eq!(bits(l), bits(&global_line_of(h, i, radius)), "{simd:?} seed {seed} line {k}");
                }
            }
        }
    }

    /// Line generation alone, ns per line: [`global_lines_with`] at each
    /// SIMD level the CPU has, in the tracer's batches of 1024, alternately
    /// on the same 10^7 indices, fastest of 5 rounds.
    #[test]
    #[ignore = "timing: cargo test --release -p itgfx-backends --lib lines::tests::line_generation_speed -- --ignored --nocapture"]
    fn line_generation_speed() {
        let (seed, n, batch) = (SeedHash::new(1), 10_000_000u64, 1024u64);
        let mut out = Vec::with_capacity(batch as usize);
        let mut run = |simd: Simd| {
            let start = std::time::Instant::now();
            let mut sum = 0u32;
            for b0 in (0..n).step_by(batch as usize) {
                out.clear();
                global_lines_with(simd, seed, b0, 1, batch.min(n - b0), 0.9, &mut out);
                sum ^= std::hint::black_box(&out).iter().fold(0, |a, l| a ^ l.tmax.to_bits() ^ l.origin[0].to_bits());
            }
            (start.elapsed().as_secs_f64() * 1e9 / n as f64, sum)
        };
        let levels = levels();
        let (mut best, mut sums) = (vec![f64::INFINITY; levels.len()], vec![0; levels.len()]);
        for round in 0..5 {
            for (v, &simd) in levels.iter().enumerate() {
                let (ns, sum) = run(simd);
                best[v] = best[v].min(ns);
                sums[v] = sum;
                println!("round {round} {simd:?}: {ns:.2} ns/line");
            }
        }
        assert!(sums.iter().all(|&s| s == sums[0]));
        for (simd, ns) in levels.iter().zip(best) {
            println!("fastest {simd:?}: {ns:.2} ns/line");
        }
    }

    #[test]
    fn global_lines_cross_a_cube_with_probability_area_ratio() {
        // Cauchy–Crofton: a uniform line meeting the sphere meets a convex body
        // with probability (its area)/(the sphere's area). Unit cube centred in
        // a sphere of radius 0.9: 6 / (4π 0.81) = 0.5895 (the 59.0% of Table 6).
        let n = 200_000;
        let mut hit = 0;
        for i in 0..n {
            let l = global_line(3, i, 0.9);
            let (o, d) = (DVec3::from(l.origin.map(f64::from)), DVec3::from(l.direction.map(f64::from)));
            // slab test against [-0.5, 0.5]^3
            let (mut t0, mut t1) = (0.0f64, f64::from(l.tmax));
            for k in 0..3 {
                let inv = 1.0 / d[k];
                let (a, b) = ((-0.5 - o[k]) * inv, (0.5 - o[k]) * inv);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
            hit += u64::from(t0 <= t1);
        }
        let p = hit as f64 / n as f64;
        let want = 6.0 / (4.0 * std::f64::consts::PI * 0.81);
        assert!((p - want).abs() < 5.0 * (want * (1.0 - want) / n as f64).sqrt(), "{p} vs {want}");
    }
}
