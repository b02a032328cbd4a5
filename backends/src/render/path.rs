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

use std::f64::consts::FRAC_1_PI;

use glam::DVec3;

use super::lights::{Lights, Surfaces};
use crate::lines::{Line, LineRng, cosine_direction};
use crate::tracer::{BackendError, Prepared, Tracer};

/// Offset of a new ray's origin along the shading normal (normalised
/// units; f32 hit points are good to about 1e-7).
const EPSILON: f64 = 1e-5;
/// Far end of every path segment (normalised units: the scene is within 1).
const FAR: f64 = 1e5;
/// Bounces after which Russian roulette starts.
const ROULETTE_FROM: u32 = 3;
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

struct Path {
    origin: DVec3,
    direction: DVec3,
    beta: DVec3,
    /// Solid-angle density of the BSDF sample that made this segment; 0
    /// after the camera or a mirror (emission then counts in full).
    pdf: f64,
    rng: LineRng,
    slot: usize,
    depth: u32,
}

fn rgb(c: [f64; 3]) -> DVec3 {
    DVec3::from_array(c)
}

/// Power-heuristic weight of a strategy with density `a` against one with `b`.
fn power(a: f64, b: f64) -> f64 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
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
        mut geometry: Option<&mut Vec<f64>>,
    ) -> Result<Vec<[f64; 3]>, BackendError> {
        if let Some(g) = geometry.as_deref_mut() {
            g.clear();
            g.resize(starts.len(), 0.0);
        }
        let mut out = vec![DVec3::ZERO; starts.len()];
        let mut paths: Vec<Path> = starts
            .iter()
            .enumerate()
            .map(|(slot, s)| Path {
                origin: s.origin,
                direction: s.direction,
                beta: DVec3::ONE,
                pdf: 0.0,
                rng: s.rng,
                slot,
                depth: 0,
            })
            .collect();
        let (mut lines, mut hits, mut shadow, mut shadow_add, mut blocked) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        while !paths.is_empty() {
            lines.clear();
            lines.extend(paths.iter().map(|p| Line::ray(p.origin, p.direction, 0.0, FAR)));
            self.tracer.closest_hit(&lines, &mut hits)?;
            shadow.clear();
            shadow_add.clear();
            let mut next = Vec::with_capacity(paths.len());
            for (mut p, hit) in paths.into_iter().zip(&hits) {
                let Some(h) = hit else { continue };
                let t = h.primitive as usize;
                let [v0, v1, v2] = self.prepared.triangles[t].map(|v| DVec3::from(v.to_array().map(f64::from)));
                let (b1, b2) = (f64::from(h.barycentric[0]), f64::from(h.barycentric[1]));
                let x = v0 * (1.0 - b1 - b2) + v1 * b1 + v2 * b2;
                let n = DVec3::from(h.normal.map(f64::from));
                let cos_in = n.dot(p.direction);
                if p.depth == 0
                    && let Some(g) = geometry.as_deref_mut()
                {
                    let r = (x - p.origin).length();
                    g[p.slot] = itgfx_core::pixel::geometry_factor(cos_in, r);
                }
                let m = self.surfaces.of(h.primitive);
                let light = self.lights.of_triangle[t];
                if cos_in < 0.0 && light != u32::MAX {
                    let w = if p.pdf == 0.0 {
                        1.0
                    } else {
                        let d = (x - p.origin).length();
                        power(p.pdf, self.lights.pdf(light as usize, d, -cos_in))
                    };
                    out[p.slot] += p.beta * rgb(m.emittance) * w;
                }
                if p.depth + 1 >= self.max_depth {
                    continue;
                }
                let nf = if cos_in < 0.0 { n } else { -n };
                let rho = rgb(m.reflectance);
                if rho.max_element() <= 0.0 {
                    continue;
                }
                let k = CAMERA_DRAWS + DRAWS_PER_BOUNCE * p.depth;
                let u = |i: u32| p.rng.uniform(k + i);
                let o = x + nf * EPSILON;
                if m.mirror {
                    p.direction = (p.direction - nf * (2.0 * p.direction.dot(nf))).normalize();
                    p.pdf = 0.0;
                } else {
                    // Next-event estimation.
                    let (li, y) = self.lights.sample(u(0), u(1), u(2));
                    let to = y - o;
                    let dist = to.length();
                    let w = to / dist;
                    let cos_x = nf.dot(w);
                    let cos_l = -self.lights.triangles[li].normal.dot(w);
                    if cos_x > 0.0 && cos_l > 0.0 && dist > 0.0 {
                        let pdf_l = self.lights.pdf(li, dist, cos_l);
                        let weight = power(pdf_l, cos_x * FRAC_1_PI);
                        let le = rgb(self.lights.triangles[li].radiance);
                        let c = p.beta * rho * FRAC_1_PI * le * (cos_x / pdf_l * weight);
                        if c.max_element() > 0.0 {
                            shadow.push(Line::ray(o, w, 0.0, dist * (1.0 - 1e-4)));
                            shadow_add.push((p.slot, c));
                        }
                    }
                    let d = cosine_direction(nf, u(3), u(4));
                    p.pdf = (nf.dot(d) * FRAC_1_PI).max(0.0);
                    p.direction = d;
                    if !(p.pdf > 0.0) {
                        continue;
                    }
                }
                p.beta *= rho;
                p.depth += 1;
                if p.depth >= ROULETTE_FROM {
                    let q = p.beta.max_element().min(0.95);
                    if u(5) >= q {
                        continue;
                    }
                    p.beta /= q;
                }
                p.origin = o;
                next.push(p);
            }
            if !shadow.is_empty() {
                self.tracer.occluded(&shadow, &mut blocked)?;
                for (&(slot, c), &b) in shadow_add.iter().zip(&blocked) {
                    if !b {
                        out[slot] += c;
                    }
                }
            }
            paths = next;
        }
        Ok(out.into_iter().map(|c| c.to_array()).collect())
    }
}
