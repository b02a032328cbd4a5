//! The path tracer: next-event estimation toward the area lights, combined
//! with cosine-weighted BSDF sampling by multiple importance sampling (power
//! heuristic), ideal mirrors, and Russian roulette.
//!
//! Paths are traced as a wavefront through the [`Tracer`] seam: every live
//! path's next segment in one [`Tracer::closest_hit`] call, then every
//! shadow ray in one [`Tracer::occluded`] call, so any backend (cpu,
//! reference, vulkan) renders the same way. A path's random numbers are draws
//! of its own [`LineRng`], a pure function of `(seed, sample id)`: the image
//! does not depend on how samples are grouped or on the thread count.
//!
//! Surfaces are two-sided for reflection (the shading normal faces the
//! arriving ray); emission leaves the front side only.
//!
//! Shading is f32 (hit points, throughput, densities; the tracer's hits are
//! f32 already): a path's radiance is summed in f32 and handed back in f64.
//! Russian roulette starts after the fifth surface interaction, on the
//! throughput's largest channel capped at 0.95, as Mitsuba 3's `path`
//! integrator (`rr_depth = 5`). Starting at the third, as before, left the
//! per-sample noise (relMSE between two seeds) 1.47x this one's on
//! cornell-box and 1.34x on mirror-room, for 1.33-1.39x less CPU time a
//! sample (docs/RENDER.md, *Noise and speed against Mitsuba*).
//!
//! Camera samples that come with a [`Stratum`] (the pixel loop's batches)
//! also stratify the two 2D draws of each diffuse vertex of their path, the
//! light point of next-event estimation and the BSDF direction: the batch's
//! `a × b` grid again, each pair and vertex under its own pseudo-random
//! permutation of the batch's samples ([`permute`]), jittered within the
//! cell (stratified sampling padded across dimensions, as pbrt's stratified
//! sampler). Every draw stays uniform, so the estimator stays unbiased; the
//! batch's samples cover each 2D domain once, as they cover the pixel.

use std::f32::consts::FRAC_1_PI;

use glam::{DVec3, Vec3A};

use super::lights::{Lights, Surfaces};
use crate::lines::{Line, LineRng, cosine_direction32, pcg, permute};
use crate::tracer::{BackendError, Prepared, Tracer};

/// `a × b` strata of a batch of `n` samples: `a` the largest divisor ≤ √n.
#[must_use]
pub fn strata(n: u32) -> (u32, u32) {
    if n.is_power_of_two() {
        // The same grid without the square root and divisions: for `n = 2^k`
        // the largest divisor ≤ √n is `2^⌊k/2⌋`.
        let k = n.trailing_zeros();
        return (1 << (k / 2), n >> (k / 2));
    }
    let mut a = (f64::from(n).sqrt() as u32).max(1);
    while a > 1 && !n.is_multiple_of(a) {
        a -= 1;
    }
    (a, n / a.max(1))
}

/// Offset of a new ray's origin along the shading normal (normalised
/// units; f32 hit points are good to about 1e-7).
const EPSILON: f32 = 1e-5;
/// Far end of every path segment (normalised units: the scene is within 1).
const FAR: f32 = 1e5;
/// Surface interactions after which Russian roulette starts (Mitsuba 3's
/// `rr_depth`).
const ROULETTE_FROM: u32 = 5;
/// Random draws used before the first bounce (the pixel jitter).
pub const CAMERA_DRAWS: u32 = 2;
/// Random draws per bounce: light choice, light point (2), direction (2), roulette.
const DRAWS_PER_BOUNCE: u32 = 6;

/// A scene ready to render: tracer, geometry, materials and lights.
pub struct PathTracer<'a> {
    /// The tracing backend.
    pub tracer: &'a dyn Tracer,
    /// Normalised geometry.
    pub prepared: &'a Prepared,
    /// Materials by triangle.
    pub surfaces: &'a Surfaces,
    /// Area lights.
    pub lights: &'a Lights,
    /// Longest path in segments (a cap; Russian roulette ends paths first).
    pub max_depth: u32,
}

/// One camera ray to follow: origin and unit direction (normalised
/// coordinates) and the path's random numbers.
#[derive(Clone, Copy, Debug)]
pub struct Start {
    /// Ray origin.
    pub origin: DVec3,
    /// Unit direction.
    pub direction: DVec3,
    /// The path's random draws.
    pub rng: LineRng,
}

/// Where a camera sample sits in its pixel's batch of `count` samples:
/// sample `index` of it, `key` choosing the batch's permutations.
#[derive(Clone, Copy, Debug)]
pub struct Stratum {
    /// The sample's place in its batch, `< count`.
    pub index: u32,
    /// Samples in the batch.
    pub count: u32,
    /// Random key of the batch (same for all its samples).
    pub key: u32,
}

impl Stratum {
    /// Draws `(u, v)` (uniform in the unit square) moved into this sample's
    /// cell of the batch's `a × b` grid under permutation `which`.
    #[cfg(test)]
    fn place(&self, grid: (u32, u32), which: u32, u: f32, v: f32) -> (f32, f32) {
        self.place_hashed(grid, pcg(self.key ^ which), u, v)
    }

    /// [`Stratum::place`] with the permutation's key already hashed:
    /// `hashed = pcg(key ^ which)`.
    #[inline(always)]
    fn place_hashed(&self, (a, b): (u32, u32), hashed: u32, u: f32, v: f32) -> (f32, f32) {
        let cell = permute(self.index, self.count, hashed);
        // `cx + u` can round up to `cx + 1`: keep the draw below 1.
        let below_one = 1.0 - f32::EPSILON / 2.0;
        let (x, y) = if a.is_power_of_two() && b.is_power_of_two() {
            // The same numbers without divisions (they were most of this
            // function's time): shifts and masks, and multiplying by `1/a`,
            // which is exact for a power of two, so equals dividing by `a`.
            let (ka, kb) = (a.trailing_zeros(), b.trailing_zeros());
            let inv = |k: u32| f32::from_bits((127 - k) << 23);
            (((cell & (a - 1)) as f32 + u) * inv(ka), ((cell >> ka) as f32 + v) * inv(kb))
        } else {
            let (cx, cy) = (cell % a, cell / a);
            ((cx as f32 + u) / a as f32, (cy as f32 + v) / b as f32)
        };
        (x.min(below_one), y.min(below_one))
    }
}

/// The first permutation words of a bounce's two stratified pairs (light
/// point, BSDF direction) at `depth`: `key ^` these, hashed, key them.
#[inline]
fn which(depth: u32) -> [u32; 2] {
    let v = depth.wrapping_mul(0x9E37_79B9);
    [v ^ 0x4c49_4748, v ^ 0x4449_5245]
}

/// What became of a live path at its vertex this bounce.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Fate {
    /// Ended: escaped, absorbed, at the depth cap, or a direction of zero density.
    Ended,
    /// Goes on (a mirror, or a diffuse vertex whose direction is drawn).
    Continues,
}

/// The wavefront's buffers, kept per thread between calls so that a batch
/// neither allocates nor touches fresh pages (a chunk's paths are ~0.6 MB,
/// above the allocator's threshold for returning memory to the system).
///
/// Per-path state is a structure of arrays indexed by the path's slot (its
/// start's index): nothing of a path is copied between bounces; the live
/// paths are a list of slots, compacted as paths end. All live paths are at
/// the same depth (one bounce per wavefront step), so the depth is one
/// number per step, not an array.
#[derive(Default)]
struct Scratch {
    /// Ray origin of each path's current segment (after its vertex: the
    /// offset vertex the next segment leaves from).
    origin: Vec<Vec3A>,
    /// Unit direction of each path's current segment.
    direction: Vec<Vec3A>,
    /// Throughput of each path.
    beta: Vec<Vec3A>,
    /// Solid-angle density of the BSDF sample that made each path's
    /// current segment; 0 after the camera or a mirror (emission then
    /// counts in full).
    pdf: Vec<f32>,
    /// Each path's random draws.
    rng: Vec<LineRng>,
    /// Slots of the live paths, in the order of `lines`.
    live: Vec<u32>,
    next_live: Vec<u32>,
    lines: Vec<Line>,
    next_lines: Vec<Line>,
    hits: Vec<Option<crate::tracer::Hit>>,
    /// Per live path this step (index as `live`): its fate and reflectance.
    fate: Vec<Fate>,
    rho: Vec<Vec3A>,
    /// The diffuse vertices of this step: index into `live`; the offset
    /// vertex the next segment and the shadow ray leave from, the shading
    /// normal facing the arriving ray and the throughput times the
    /// reflectance (one push a vertex, transposed for 8 lanes where they
    /// are read); the vertex's five draws (light choice, light point,
    /// direction) as columns, one row a vertex.
    diffuse: Vec<u32>,
    vertex: Vec<[Vec3A; 3]>,
    draws: [Vec<f32>; 5],
    shadow: Vec<Line>,
    shadow_add: Vec<(u32, Vec3A)>,
    blocked: Vec<bool>,
    out: Vec<Vec3A>,
}

thread_local! {
    /// This thread's [`Scratch`], taken out while a call uses it (a call
    /// nested through the tracer's own parallelism finds none and makes
    /// its own), put back after.
    static SCRATCH: std::cell::Cell<Option<Box<Scratch>>> = const { std::cell::Cell::new(None) };
}

/// Power-heuristic weight of a strategy with density `a` against one with
/// `b`: `a² / (a² + b²)`, written so that neither square overflows f32.
#[inline]
fn power(a: f32, b: f32) -> f32 {
    if a >= b {
        if a > 0.0 {
            let r = b / a;
            1.0 / (1.0 + r * r)
        } else {
            0.0
        }
    } else {
        let r = a / b;
        let r2 = r * r;
        r2 / (1.0 + r2)
    }
}

/// [`power`] of 8 lanes: each lane's branch's operations, selected per
/// lane (one division for `r`, one for the weight), so the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn power8(a: std::arch::x86_64::__m256, b: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::{
        _CMP_GE_OQ, _CMP_GT_OQ, _mm256_add_ps, _mm256_andnot_ps, _mm256_blendv_ps, _mm256_cmp_ps, _mm256_div_ps,
        _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps,
    };
    let one = _mm256_set1_ps(1.0);
    let ge = _mm256_cmp_ps::<_CMP_GE_OQ>(a, b);
    // `a ≥ b`: `r = b / a`, weight `1 / (1 + r²)`; else `r = a / b`, weight `r² / (1 + r²)`.
    let r = _mm256_div_ps(_mm256_blendv_ps(a, b, ge), _mm256_blendv_ps(b, a, ge));
    let r2 = _mm256_mul_ps(r, r);
    let w = _mm256_div_ps(_mm256_blendv_ps(r2, one, ge), _mm256_add_ps(one, r2));
    // `a ≥ b` with `a` not above 0: weight 0.
    let zero = _mm256_andnot_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(a, _mm256_setzero_ps()), ge);
    _mm256_andnot_ps(zero, w)
}

/// A shadow ray ends this fraction of the way to the light point.
const SHADOW_SHORT: f32 = 1.0 - 1e-4;

/// What next-event estimation and the BSDF sample make of a diffuse
/// vertex ([`shade`]).
struct Shaded {
    /// The shadow ray toward the light point and the radiance it adds
    /// when unblocked; `None` where the light cannot contribute.
    light: Option<(Line, Vec3A)>,
    /// The next segment's direction (cosine-distributed about the normal).
    direction: Vec3A,
    /// Its solid-angle density, `cos / π` (0: the path ends).
    pdf: f32,
}

/// One diffuse vertex: leaving from `o` with the shading normal `nf` and
/// throughput times reflectance `weight`, its five draws `[light choice,
/// light point (2), direction (2)]`. Next-event estimation toward a point
/// of an area light (solid-angle density eq. of [`Lights::pdf32`]) weighted
/// against the cosine BSDF sample by the power heuristic ([`power`]), and
/// the cosine-distributed next direction.
#[inline(always)]
fn shade(lights: &Lights, o: Vec3A, nf: Vec3A, weight: Vec3A, [u0, l1, l2, d1, d2]: [f32; 5]) -> Shaded {
    let (li, y) = lights.sample32(u0, l1, l2);
    let to = y - o;
    let dist = to.length();
    let w = to / dist;
    let cos_x = nf.dot(w);
    let fl = &lights.fast[li];
    let cos_l = -fl.normal.dot(w);
    let mut light = None;
    if cos_x > 0.0 && cos_l > 0.0 && dist > 0.0 {
        let pdf_l = lights.pdf32(li, dist, cos_l);
        let mis = power(pdf_l, cos_x * FRAC_1_PI);
        let c = weight * fl.radiance * (FRAC_1_PI * cos_x / pdf_l * mis);
        if c.max_element() > 0.0 {
            light = Some((Line::ray32(o, w, 0.0, dist * SHADOW_SHORT), c));
        }
    }
    let d = cosine_direction32(nf, d1, d2);
    Shaded { light, direction: d, pdf: (nf.dot(d) * FRAC_1_PI).max(0.0) }
}

/// [`shade`] for whole groups of eight diffuse vertices, 8 lanes at once
/// (`vertex`: `[at, normal, weight]` each; `draws`): the same f32 operations
/// lane by lane, so the same bits; each vertex's result goes to `apply`
/// in order. Returns how many vertices it shaded (a multiple of 8).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn shade_avx2(
    lights: &Lights,
    vertex: &[[Vec3A; 3]],
    draws: &[Vec<f32>; 5],
    apply: &mut impl FnMut(usize, Shaded),
) -> usize {
    use std::arch::x86_64::{
        _CMP_GT_OQ, _mm256_and_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_max_ps, _mm256_movemask_ps, _mm256_mul_ps,
        _mm256_set1_ps, _mm256_setzero_ps, _mm256_xor_ps,
    };

    use crate::lines::{Vec3x8, cosine_direction32x8, load8f, store8f};

    let n = draws[0].len() / 8 * 8;
    let zero = _mm256_setzero_ps();
    let inv_pi = _mm256_set1_ps(FRAC_1_PI);
    for base in (0..n).step_by(8) {
        let rows = |k: usize| Vec3x8::from_rows(std::array::from_fn(|l| vertex[base + l][k]));
        let (o, nf, wt) = (rows(0), rows(1), rows(2));
        let [u0, l1, l2, d1, d2] = draws.each_ref().map(|c| load8f(c[base..base + 8].try_into().expect("eight rows")));
        let l = lights.sample32x8(u0, l1, l2);
        let to = l.point.sub(o);
        let dist = to.length();
        let w = to.div(dist);
        let cos_x = nf.dot(w);
        let cos_l = _mm256_xor_ps(l.normal.dot(w), _mm256_set1_ps(-0.0));
        let gt0 = |v| _mm256_cmp_ps::<_CMP_GT_OQ>(v, zero);
        let seen = _mm256_and_ps(_mm256_and_ps(gt0(cos_x), gt0(cos_l)), gt0(dist));
        // `Lights::pdf32`: `density · dist · dist / cos_l`.
        let pdf_l = _mm256_div_ps(_mm256_mul_ps(_mm256_mul_ps(l.density, dist), dist), cos_l);
        let mis = power8(pdf_l, _mm256_mul_ps(cos_x, inv_pi));
        let c = wt.mul(l.radiance).scale(_mm256_mul_ps(_mm256_div_ps(_mm256_mul_ps(inv_pi, cos_x), pdf_l), mis));
        // glam's `max_element`: `max(max(x, z), max(y, z))`.
        let c_max = _mm256_max_ps(_mm256_max_ps(c.x, c.z), _mm256_max_ps(c.y, c.z));
        let lit = _mm256_movemask_ps(_mm256_and_ps(seen, gt0(c_max)));
        let d = cosine_direction32x8(nf, d1, d2);
        let pdf = store8f(_mm256_max_ps(_mm256_mul_ps(nf.dot(d), inv_pi), zero));
        let [ox, oy, oz] = o.lanes();
        let [wx, wy, wz] = w.lanes();
        let [cx, cy, cz] = c.lanes();
        let [dx, dy, dz] = d.lanes();
        let dist = store8f(dist);
        for k in 0..8 {
            let light = (lit & (1 << k) != 0).then(|| {
                let (o, w) = (Vec3A::new(ox[k], oy[k], oz[k]), Vec3A::new(wx[k], wy[k], wz[k]));
                (Line::ray32(o, w, 0.0, dist[k] * SHADOW_SHORT), Vec3A::new(cx[k], cy[k], cz[k]))
            });
            apply(base + k, Shaded { light, direction: Vec3A::new(dx[k], dy[k], dz[k]), pdf: pdf[k] });
        }
    }
    n
}

impl PathTracer<'_> {
    /// Radiance along each start ray, RGB, in order.
    ///
    /// # Errors
    /// Backend failures only.
    pub fn radiance(&self, starts: &[Start]) -> Result<Vec<[f64; 3]>, BackendError> {
        self.radiance_geometry(starts, None)
    }

    /// As [`Self::radiance`]; with `geometry`, also the geometry factor
    /// `g(s) = |cos θ| / r²` of each camera ray's first hit (Part IV eq.
    /// (12), normalised units; 0 for a ray that hits nothing), in order.
    ///
    /// # Errors
    /// Backend failures only.
    pub fn radiance_geometry(
        &self,
        starts: &[Start],
        geometry: Option<&mut Vec<f64>>,
    ) -> Result<Vec<[f64; 3]>, BackendError> {
        self.radiance_strata(starts, None, geometry)
    }

    /// As [`Self::radiance_geometry`], with each start's place in its
    /// pixel's batch (`strata[i]` for `starts[i]`) stratifying its first
    /// diffuse vertex (module docs).
    ///
    /// # Errors
    /// Backend failures only.
    ///
    /// # Panics
    /// If `strata` is given with a length other than `starts`'s.
    pub fn radiance_strata(
        &self,
        starts: &[Start],
        strata: Option<&[Stratum]>,
        mut geometry: Option<&mut Vec<f64>>,
    ) -> Result<Vec<[f64; 3]>, BackendError> {
        if let Some(s) = strata {
            assert_eq!(s.len(), starts.len(), "one stratum per start");
        }
        if let Some(g) = geometry.as_deref_mut() {
            g.clear();
            g.resize(starts.len(), 0.0);
        }
        let mut scratch = SCRATCH.with(std::cell::Cell::take).unwrap_or_default();
        let result = self.wavefront(starts, strata, geometry, &mut scratch);
        SCRATCH.with(|c| c.set(Some(scratch)));
        result
    }

    /// The wavefront of [`Self::radiance_strata`] in `scratch`'s buffers.
    ///
    /// Each step runs in passes over the live paths' arrays: the hit
    /// vertices (emission, mirrors, which paths go on), the diffuse
    /// vertices' draws (integer hashing only, [`vertex_draws`]), their
    /// next-event estimation and BSDF directions ([`shade`], 8 vertices at
    /// a time where AVX2 runs: [`shade_avx2`]), then the
    /// roulette and the next segments in the live order. Per path, the
    /// arithmetic and its order are the single loop's before this split,
    /// so the images are the same bit for bit.
    fn wavefront(
        &self,
        starts: &[Start],
        strata: Option<&[Stratum]>,
        mut geometry: Option<&mut Vec<f64>>,
        scratch: &mut Scratch,
    ) -> Result<Vec<[f64; 3]>, BackendError> {
        let Scratch {
            origin,
            direction,
            beta,
            pdf,
            rng,
            live,
            next_live,
            lines,
            next_lines,
            hits,
            fate,
            rho,
            diffuse,
            vertex,
            draws,
            shadow,
            shadow_add,
            blocked,
            out,
        } = scratch;
        let n = starts.len();
        out.clear();
        out.resize(n, Vec3A::ZERO);
        origin.clear();
        direction.clear();
        beta.clear();
        beta.resize(n, Vec3A::ONE);
        pdf.clear();
        pdf.resize(n, 0.0);
        rng.clear();
        live.clear();
        lines.clear();
        for (slot, s) in starts.iter().enumerate() {
            let (o, d) = (s.origin.as_vec3a(), s.direction.as_vec3a());
            origin.push(o);
            direction.push(d);
            rng.push(s.rng);
            live.push(slot as u32);
            lines.push(Line::ray32(o, d, 0.0, FAR));
        }
        let mut depth = 0u32;
        while !live.is_empty() {
            self.tracer.closest_hit(lines, hits)?;
            fate.clear();
            rho.clear();
            diffuse.clear();
            vertex.clear();
            // Pass 1: the vertices. Emission, the depth cap, absorption,
            // mirrors; diffuse vertices listed for the passes below.
            for (j, (&p, hit)) in live.iter().zip(hits.iter()).enumerate() {
                let p = p as usize;
                fate.push(Fate::Ended);
                rho.push(Vec3A::ZERO);
                let Some(h) = hit else { continue };
                let t = h.primitive as usize;
                let [v0, v1, v2] = self.prepared.triangles[t];
                let [b1, b2] = h.barycentric;
                let x = v0 * (1.0 - b1 - b2) + v1 * b1 + v2 * b2;
                let nrm = Vec3A::from(h.normal);
                let cos_in = nrm.dot(direction[p]);
                if depth == 0
                    && let Some(g) = geometry.as_deref_mut()
                {
                    let r = (x - origin[p]).length();
                    g[p] = itgfx_core::pixel::geometry_factor(f64::from(cos_in), f64::from(r));
                }
                let m = self.surfaces.fast_of(h.primitive);
                let light = self.lights.of_triangle[t];
                if cos_in < 0.0 && light != u32::MAX {
                    let w = if pdf[p] == 0.0 {
                        1.0
                    } else {
                        let d = (x - origin[p]).length();
                        power(pdf[p], self.lights.pdf32(light as usize, d, -cos_in))
                    };
                    out[p] += beta[p] * m.emittance * w;
                }
                if depth + 1 >= self.max_depth {
                    continue;
                }
                let nf = if cos_in < 0.0 { nrm } else { -nrm };
                if m.reflectance.max_element() <= 0.0 {
                    continue;
                }
                rho[j] = m.reflectance;
                origin[p] = x + nf * EPSILON;
                fate[j] = Fate::Continues;
                if m.mirror {
                    let d = direction[p];
                    direction[p] = (d - nf * (2.0 * d.dot(nf))).normalize();
                    pdf[p] = 0.0;
                } else {
                    diffuse.push(j as u32);
                    vertex.push([origin[p], nf, beta[p] * m.reflectance]);
                }
            }
            // Pass 2: the diffuse vertices' draws.
            let k = CAMERA_DRAWS + DRAWS_PER_BOUNCE * depth;
            vertex_draws(live, diffuse, rng, strata, k, depth, draws);
            // Pass 3: next-event estimation and the BSDF direction.
            shadow.clear();
            shadow_add.clear();
            let mut apply = |i: usize, v: Shaded| {
                let j = diffuse[i] as usize;
                let p = live[j] as usize;
                if let Some((line, c)) = v.light {
                    shadow.push(line);
                    shadow_add.push((p as u32, c));
                }
                pdf[p] = v.pdf;
                direction[p] = v.direction;
                if !(v.pdf > 0.0) {
                    fate[j] = Fate::Ended;
                }
            };
            #[allow(unused_mut)]
            let mut done = 0;
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 was detected just above.
                done = unsafe { shade_avx2(self.lights, vertex, draws, &mut apply) };
            }
            for i in done..diffuse.len() {
                let d = draws.each_ref().map(|c| c[i]);
                let [o, nf, w] = vertex[i];
                apply(i, shade(self.lights, o, nf, w, d));
            }
            // Pass 4: throughput, the roulette, and the next segments, in
            // the live order.
            next_live.clear();
            next_lines.clear();
            for ((&p, &f), &r) in live.iter().zip(fate.iter()).zip(rho.iter()) {
                if f == Fate::Ended {
                    continue;
                }
                let s = p as usize;
                let mut b = beta[s] * r;
                if depth + 1 >= ROULETTE_FROM {
                    // The roulette's draw (the bounce's sixth), drawn only
                    // where the path needs it.
                    let q = b.max_element().min(0.95);
                    if rng[s].uniform32(k + 5) >= q {
                        continue;
                    }
                    b /= q;
                }
                beta[s] = b;
                next_live.push(p);
                next_lines.push(Line::ray32(origin[s], direction[s], 0.0, FAR));
            }
            if !shadow.is_empty() {
                self.tracer.occluded(shadow, blocked)?;
                for (&(slot, c), &b) in shadow_add.iter().zip(blocked.iter()) {
                    if !b {
                        out[slot as usize] += c;
                    }
                }
            }
            std::mem::swap(live, next_live);
            std::mem::swap(lines, next_lines);
            depth += 1;
        }
        Ok(out.iter().map(|c| c.as_dvec3().to_array()).collect())
    }
}

/// The five draws of each diffuse vertex of a step at `depth` (its draws
/// from `k` on): light choice, light point, BSDF direction, the two pairs
/// placed in their stratum's cell where the path has a [`Stratum`].
/// `diffuse` indexes `live`, which holds slots (of `rng` and `strata`).
/// Eight vertices at a time where AVX2 runs ([`vertex_draws_avx2`]: the
/// same integer operations lane by lane, so the same draws).
fn vertex_draws(
    live: &[u32],
    diffuse: &[u32],
    rng: &[LineRng],
    strata: Option<&[Stratum]>,
    k: u32,
    depth: u32,
    draws: &mut [Vec<f32>; 5],
) {
    for c in draws.iter_mut() {
        c.clear();
        c.resize(diffuse.len(), 0.0);
    }
    #[allow(unused_mut)]
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 was detected just above.
        done = unsafe { vertex_draws_avx2(live, diffuse, rng, strata, k, depth, draws) };
    }
    for (i, &j) in diffuse.iter().enumerate().skip(done) {
        put5(draws, i, vertex_draw(live[j as usize] as usize, rng, strata, k, which(depth)));
    }
}

/// Writes `d` as row `i` of five columns.
#[inline]
fn put5(columns: &mut [Vec<f32>; 5], i: usize, d: [f32; 5]) {
    for (c, x) in columns.iter_mut().zip(d) {
        c[i] = x;
    }
}

/// The five draws of path `p`'s vertex (see [`vertex_draws`]), `words` =
/// [`which`] of its depth.
#[inline(always)]
fn vertex_draw(p: usize, rng: &[LineRng], strata: Option<&[Stratum]>, k: u32, [wl, wd]: [u32; 2]) -> [f32; 5] {
    let r = &rng[p];
    let u = |i: u32| r.uniform32(k + i);
    let (mut l1, mut l2, mut d1, mut d2) = (u(1), u(2), u(3), u(4));
    if let Some(s) = strata {
        let s = &s[p];
        let grid = self::strata(s.count);
        (l1, l2) = s.place_hashed(grid, pcg(s.key ^ wl), l1, l2);
        (d1, d2) = s.place_hashed(grid, pcg(s.key ^ wd), d1, d2);
    }
    [u(0), l1, l2, d1, d2]
}

/// [`vertex_draws`] for whole groups of eight vertices, 8 lanes at once:
/// the draws ([`crate::lines::uniform32x8`]), the permutation keys, and,
/// where every lane's batch is a power of two (a one-round permutation,
/// [`crate::lines::permute8_pow2`]), the placement in the cell; a group
/// with another batch size takes [`vertex_draw`] lane by lane. Returns how
/// many vertices it drew (a multiple of 8).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn vertex_draws_avx2(
    live: &[u32],
    diffuse: &[u32],
    rng: &[LineRng],
    strata: Option<&[Stratum]>,
    k: u32,
    depth: u32,
    draws: &mut [Vec<f32>; 5],
) -> usize {
    use std::arch::x86_64::{
        __m256, _mm256_add_ps, _mm256_and_si256, _mm256_castsi256_ps, _mm256_cvtepi32_ps, _mm256_min_ps, _mm256_mul_ps,
        _mm256_set1_ps, _mm256_srlv_epi32, _mm256_xor_si256,
    };

    use crate::lines::{load8, pcg8, permute8_pow2, splat8, store8f, uniform32x8};

    let words = which(depth);
    let below_one = _mm256_set1_ps(1.0 - f32::EPSILON / 2.0);
    // `Stratum::place_hashed`'s power-of-two branch, 8 lanes: `cell`'s
    // column and row, each plus its jitter, times `1/a` and `1/b`.
    let place = |cell, amask, ka, inva, invb, u, v| {
        let x = _mm256_mul_ps(_mm256_add_ps(_mm256_cvtepi32_ps(_mm256_and_si256(cell, amask)), u), inva);
        let y = _mm256_mul_ps(_mm256_add_ps(_mm256_cvtepi32_ps(_mm256_srlv_epi32(cell, ka)), v), invb);
        (_mm256_min_ps(x, below_one), _mm256_min_ps(y, below_one))
    };
    let groups = diffuse.len() / 8;
    for (g, group) in diffuse.chunks_exact(8).enumerate() {
        let base = 8 * g;
        // Written out, not as array maps: their closures were left out of
        // line in some builds (docs/RENDER.md, *Camera packets on the wide
        // nodes*).
        let mut slot = [0usize; 8];
        let mut state = [[0u32; 8]; 2];
        for (l, &j) in group.iter().enumerate() {
            let p = live[j as usize] as usize;
            slot[l] = p;
            [state[0][l], state[1][l]] = rng[p].words();
        }
        let (w1, w2) = (load8(&state[0]), load8(&state[1]));
        let u: [__m256; 5] = std::array::from_fn(|i| uniform32x8(w1, w2, k + i as u32));
        let [mut l1, mut l2, mut d1, mut d2] = [u[1], u[2], u[3], u[4]];
        if let Some(s) = strata {
            let mut lanes = [s[0]; 8];
            for (x, &p) in lanes.iter_mut().zip(&slot) {
                *x = s[p];
            }
            let s = lanes;
            if !s.iter().all(|s| s.count.is_power_of_two()) {
                for (l, &p) in slot.iter().enumerate() {
                    put5(draws, base + l, vertex_draw(p, rng, strata, k, words));
                }
                continue;
            }
            let ka = s.map(|s| s.count.trailing_zeros() / 2);
            let kb = s.map(|s| s.count.trailing_zeros() - s.count.trailing_zeros() / 2);
            let inv = |k: [u32; 8]| _mm256_castsi256_ps(load8(&k.map(|k| (127 - k) << 23)));
            let (inva, invb) = (inv(ka), inv(kb));
            let amask = load8(&ka.map(|k| (1 << k) - 1));
            let ka = load8(&ka);
            let (key, index, w) =
                (load8(&s.map(|s| s.key)), load8(&s.map(|s| s.index)), load8(&s.map(|s| s.count - 1)));
            let cell = |which: u32| permute8_pow2(index, w, pcg8(_mm256_xor_si256(key, splat8(which))));
            (l1, l2) = place(cell(words[0]), amask, ka, inva, invb, l1, l2);
            (d1, d2) = place(cell(words[1]), amask, ka, inva, invb, d1, d2);
        }
        for (c, v) in draws.iter_mut().zip([u[0], l1, l2, d1, d2]) {
            c[base..base + 8].copy_from_slice(&store8f(v));
        }
    }
    groups * 8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A batch's placed draws fall one in each cell of its grid (for every
    /// permutation used), inside the unit square; batches of other keys
    /// place them in other orders.
    #[test]
    fn a_batch_covers_each_cell_once() {
        for count in [1u32, 7, 8, 60, 64, 256] {
            let grid = self::strata(count);
            for which in [0x4c49_4748u32, 0x4449_5245, 5u32.wrapping_mul(0x9E37_79B9) ^ 0x4c49_4748] {
                let mut seen = vec![false; count as usize];
                let rng = LineRng::new(3, u64::from(count));
                for index in 0..count {
                    let s = Stratum { index, count, key: 99 };
                    for (u, v) in [
                        (rng.uniform32(2 * index), rng.uniform32(2 * index + 1)),
                        (1.0 - f32::EPSILON / 2.0, 1.0 - f32::EPSILON / 2.0),
                    ] {
                        let (u, v) = s.place(grid, which, u, v);
                        assert!(u > 0.0 && u < 1.0 && v > 0.0 && v < 1.0, "{u} {v}");
                    }
                    let (u, v) = s.place(grid, which, 0.5, 0.5);
                    let cell = (v * grid.1 as f32) as u32 * grid.0 + (u * grid.0 as f32) as u32;
                    assert!(!seen[cell as usize], "count {count}: cell {cell} twice");
                    seen[cell as usize] = true;
                }
            }
        }
        let order =
            |key| (0..64).map(|index| Stratum { index, count: 64, key }.place((8, 8), 1, 0.5, 0.5)).collect::<Vec<_>>();
        assert_ne!(order(1), order(2));
    }

    /// The 8-lane power heuristic is the scalar one bit for bit, both
    /// branches, zeros, ties, infinities and NaN included.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn power8_is_power() {
        use crate::lines::{load8f, store8f};
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let values = [0.0f32, -0.0, 1e-30, 0.3, 1.0, 2.5, 1e30, f32::MAX, f32::INFINITY, -1.0, f32::NAN, 7.0];
        let pairs: Vec<(f32, f32)> = values.iter().flat_map(|&a| values.iter().map(move |&b| (a, b))).collect();
        for g in pairs.chunks(8) {
            let a: [f32; 8] = std::array::from_fn(|l| g[l % g.len()].0);
            let b: [f32; 8] = std::array::from_fn(|l| g[l % g.len()].1);
            // SAFETY: AVX2 was detected above.
            let w = unsafe { store8f(power8(load8f(&a), load8f(&b))) };
            for l in 0..8 {
                assert_eq!(w[l].to_bits(), power(a[l], b[l]).to_bits(), "{} {}", a[l], b[l]);
            }
        }
    }

    /// The 8-lane shading is the scalar [`shade`] bit for bit (shadow ray,
    /// its radiance, direction, density) on random vertices facing every
    /// way, some with zero throughput, for one, two and thirteen lights; a
    /// tail of fewer than eight is left to the scalar code.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn shade_avx2_is_shade() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        for probability in
            [&[1.0][..], &[0.5, 0.5], &[0.1, 0.05, 0.1, 0.0, 0.1, 0.05, 0.1, 0.1, 0.1, 0.05, 0.1, 0.05, 0.1]]
        {
            let lights = Lights::random(probability);
            let n = 1003;
            let mut vertex = Vec::new();
            let mut draws: [Vec<f32>; 5] = Default::default();
            for i in 0..n {
                let r = LineRng::new(6, i);
                let v = |k: u32| Vec3A::new(r.uniform32(k), r.uniform32(k + 1), r.uniform32(k + 2));
                let weight = if i % 7 == 0 { Vec3A::ZERO } else { v(10) };
                vertex.push([v(0) * 2.0 - 1.0, r.sphere_point(3).as_vec3a(), weight]);
                for (k, c) in draws.iter_mut().enumerate() {
                    c.push(r.uniform32(20 + k as u32));
                }
            }
            let mut got = Vec::new();
            // SAFETY: AVX2 was detected above.
            let done = unsafe { shade_avx2(&lights, &vertex, &draws, &mut |i, v| got.push((i, v))) };
            assert_eq!(done, 1000);
            let bits = |v: Vec3A| v.to_array().map(f32::to_bits);
            let mut lit = 0;
            for (i, v) in got {
                let d = draws.each_ref().map(|c| c[i]);
                let [o, nf, w] = vertex[i];
                let want = shade(&lights, o, nf, w, d);
                assert_eq!(
                    (bits(v.direction), v.pdf.to_bits()),
                    (bits(want.direction), want.pdf.to_bits()),
                    "vertex {i}"
                );
                let line = |l: Option<(Line, Vec3A)>| l.map(|(l, c)| (l, bits(c)));
                assert_eq!(line(v.light), line(want.light), "vertex {i}");
                lit += usize::from(v.light.is_some());
            }
            assert!(lit > 100 && lit < 900, "{lit} of 1000 vertices see the light");
        }
    }

    /// The 8-lane draws are the scalar draws bit for bit: batches of a
    /// power of two (one permutation round) and of other sizes (the scalar
    /// fallback) mixed within groups, a tail that is not a whole group,
    /// and paths with no stratum.
    #[test]
    fn vertex_draws_match_the_scalar_draws() {
        let n = 203u32;
        let rng: Vec<LineRng> = (0..n).map(|i| LineRng::new(5, u64::from(i) * 7 + 1)).collect();
        let live: Vec<u32> = (0..n).rev().collect();
        let diffuse: Vec<u32> = (0..n).filter(|j| j % 3 != 1).collect();
        for sizes in [&[64u32, 16, 1, 256, 2][..], &[64, 60, 64, 64], &[8, 32, 128]] {
            let strata: Vec<Stratum> = (0..n)
                .map(|p| {
                    let count = sizes[(p as usize / 8) % sizes.len()];
                    Stratum { index: (p * 13) % count, count, key: pcg(p / 8) }
                })
                .collect();
            for s in [Some(&strata[..]), None] {
                for depth in [0u32, 3] {
                    let k = CAMERA_DRAWS + DRAWS_PER_BOUNCE * depth;
                    let mut draws = Default::default();
                    vertex_draws(&live, &diffuse, &rng, s, k, depth, &mut draws);
                    assert!(draws.iter().all(|c| c.len() == diffuse.len()));
                    for (i, &j) in diffuse.iter().enumerate() {
                        let d = draws.each_ref().map(|c| c[i]);
                        let want = vertex_draw(live[j as usize] as usize, &rng, s, k, which(depth));
                        assert_eq!(d.map(f32::to_bits), want.map(f32::to_bits), "vertex {j}, sizes {sizes:?}");
                    }
                }
            }
        }
    }
}
