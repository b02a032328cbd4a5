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

/// The wavefront's buffers, kept per thread between calls so that a batch
/// neither allocates nor touches fresh pages (a chunk's paths are ~0.6 MB,
/// above the allocator's threshold for returning memory to the system).
#[derive(Default)]
struct Scratch {
    paths: Vec<Path>,
    next: Vec<Path>,
    lines: Vec<Line>,
    next_lines: Vec<Line>,
    hits: Vec<Option<crate::tracer::Hit>>,
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

#[derive(Clone, Copy)]
struct Path {
    origin: Vec3A,
    direction: Vec3A,
    beta: Vec3A,
    /// Solid-angle density of the BSDF sample that made this segment; 0
    /// after the camera or a mirror (emission then counts in full).
    pdf: f32,
    rng: LineRng,
    slot: u32,
    depth: u32,
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
    fn wavefront(
        &self,
        starts: &[Start],
        strata: Option<&[Stratum]>,
        mut geometry: Option<&mut Vec<f64>>,
        scratch: &mut Scratch,
    ) -> Result<Vec<[f64; 3]>, BackendError> {
        let Scratch { paths, next, lines, next_lines, hits, shadow, shadow_add, blocked, out } = scratch;
        out.clear();
        out.resize(starts.len(), Vec3A::ZERO);
        paths.clear();
        lines.clear();
        for (slot, s) in starts.iter().enumerate() {
            let (origin, direction) = (s.origin.as_vec3a(), s.direction.as_vec3a());
            paths.push(Path { origin, direction, beta: Vec3A::ONE, pdf: 0.0, rng: s.rng, slot: slot as u32, depth: 0 });
            lines.push(Line::ray32(origin, direction, 0.0, FAR));
        }
        while !paths.is_empty() {
            self.tracer.closest_hit(lines, hits)?;
            shadow.clear();
            shadow_add.clear();
            next.clear();
            next_lines.clear();
            for (p, hit) in paths.iter().zip(hits.iter()) {
                let Some(h) = hit else { continue };
                let mut p = *p;
                let t = h.primitive as usize;
                let [v0, v1, v2] = self.prepared.triangles[t];
                let [b1, b2] = h.barycentric;
                let x = v0 * (1.0 - b1 - b2) + v1 * b1 + v2 * b2;
                let n = Vec3A::from(h.normal);
                let cos_in = n.dot(p.direction);
                if p.depth == 0
                    && let Some(g) = geometry.as_deref_mut()
                {
                    let r = (x - p.origin).length();
                    g[p.slot as usize] = itgfx_core::pixel::geometry_factor(f64::from(cos_in), f64::from(r));
                }
                let m = self.surfaces.fast_of(h.primitive);
                let light = self.lights.of_triangle[t];
                if cos_in < 0.0 && light != u32::MAX {
                    let w = if p.pdf == 0.0 {
                        1.0
                    } else {
                        let d = (x - p.origin).length();
                        power(p.pdf, self.lights.pdf32(light as usize, d, -cos_in))
                    };
                    out[p.slot as usize] += p.beta * m.emittance * w;
                }
                if p.depth + 1 >= self.max_depth {
                    continue;
                }
                let nf = if cos_in < 0.0 { n } else { -n };
                let rho = m.reflectance;
                if rho.max_element() <= 0.0 {
                    continue;
                }
                let k = CAMERA_DRAWS + DRAWS_PER_BOUNCE * p.depth;
                let o = x + nf * EPSILON;
                if m.mirror {
                    p.direction = (p.direction - nf * (2.0 * p.direction.dot(nf))).normalize();
                    p.pdf = 0.0;
                } else {
                    let u = |i: u32| p.rng.uniform32(k + i);
                    let (mut l1, mut l2, mut d1, mut d2) = (u(1), u(2), u(3), u(4));
                    if let Some(s) = strata {
                        let s = &s[p.slot as usize];
                        let grid = self::strata(s.count);
                        let [wl, wd] = which(p.depth);
                        (l1, l2) = s.place_hashed(grid, pcg(s.key ^ wl), l1, l2);
                        (d1, d2) = s.place_hashed(grid, pcg(s.key ^ wd), d1, d2);
                    }
                    // Next-event estimation.
                    let (li, y) = self.lights.sample32(u(0), l1, l2);
                    let to = y - o;
                    let dist = to.length();
                    let w = to / dist;
                    let cos_x = nf.dot(w);
                    let fl = &self.lights.fast[li];
                    let cos_l = -fl.normal.dot(w);
                    if cos_x > 0.0 && cos_l > 0.0 && dist > 0.0 {
                        let pdf_l = self.lights.pdf32(li, dist, cos_l);
                        let weight = power(pdf_l, cos_x * FRAC_1_PI);
                        let c = p.beta * rho * fl.radiance * (FRAC_1_PI * cos_x / pdf_l * weight);
                        if c.max_element() > 0.0 {
                            shadow.push(Line::ray32(o, w, 0.0, dist * (1.0 - 1e-4)));
                            shadow_add.push((p.slot, c));
                        }
                    }
                    let d = cosine_direction32(nf, d1, d2);
                    p.pdf = (nf.dot(d) * FRAC_1_PI).max(0.0);
                    p.direction = d;
                    if !(p.pdf > 0.0) {
                        continue;
                    }
                }
                p.beta *= rho;
                p.depth += 1;
                if p.depth >= ROULETTE_FROM {
                    // The roulette's draw (the bounce's sixth), drawn only
                    // where the path needs it.
                    let q = p.beta.max_element().min(0.95);
                    if p.rng.uniform32(k + 5) >= q {
                        continue;
                    }
                    p.beta /= q;
                }
                p.origin = o;
                next.push(p);
                next_lines.push(Line::ray32(o, p.direction, 0.0, FAR));
            }
            if !shadow.is_empty() {
                self.tracer.occluded(shadow, blocked)?;
                for (&(slot, c), &b) in shadow_add.iter().zip(blocked.iter()) {
                    if !b {
                        out[slot as usize] += c;
                    }
                }
            }
            std::mem::swap(paths, next);
            std::mem::swap(lines, next_lines);
        }
        Ok(out.iter().map(|c| c.as_dvec3().to_array()).collect())
    }
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
}
