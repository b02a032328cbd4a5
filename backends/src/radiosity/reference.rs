//! An independent reference: the radiosity at the surface point each pixel
//! sees, estimated by random walks (path tracing of the diffuse scene
//! through [`Tracer::closest_hit`]), with no mesh, no links and no oracle.
//!
//! `B(x) = E(x) + ρ(x) (D(x) + E[B(y) − E(y)])`: the direct part `D(x)`
//! from one point `y'` sampled uniformly on the emitters' area and a shadow
//! ray ([`Tracer::occluded`]), `E(y') G(x, y') A_emit`; the rest from the
//! first front-facing surface `y` along a cosine-distributed direction
//! from `x` (so the `cos/π` of the rendering equation cancels), whose own
//! emission is left out (it is the direct part's). Walks stop by Russian
//! roulette with the survival probability `max_c ρ_c`. Each pixel keeps the sums of its
//! walks and of their squares (standard errors) and two half-sums (even
//! and odd walks), whose difference measures the reference's own noise in
//! the same units as an image error.

use glam::DVec3;
use rayon::prelude::*;

use super::Rgb;
use super::element::Hierarchy;
use super::render::{View, closest, sight};
use crate::backend::BackendError;
use crate::lines::{Line, LineRng};
use crate::scene::Scene;
use crate::tracer::{Prepared, Tracer};

/// A path-traced reference picture.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Mean radiosity per pixel (`None`: background).
    pub mean: Vec<Option<Rgb>>,
    /// Standard error of each pixel's mean, per channel.
    pub stderr: Vec<Rgb>,
    /// Means over the even and over the odd walks.
    pub halves: [Vec<Rgb>; 2],
    /// Walks per pixel.
    pub walks: u32,
    /// Rays cast.
    pub rays: u64,
}

/// Most bounces of a walk (Russian roulette ends nearly all far sooner).
const MAX_DEPTH: u32 = 256;

/// Emitting triangles with their cumulative areas, for area sampling.
struct Emitters {
    triangles: Vec<(usize, Rgb)>,
    cumulative: Vec<f64>,
    area: f64,
}

impl Emitters {
    fn new(scene: &Scene) -> Self {
        let mut triangles = Vec::new();
        let mut cumulative = Vec::new();
        let mut area = 0.0;
        for (t, tri) in scene.triangles.iter().enumerate() {
            let m = &scene.materials[scene.patches[scene.triangle_patch[t] as usize].material];
            if m.emittance.iter().any(|&e| e > 0.0) {
                area += 0.5 * (tri[1] - tri[0]).cross(tri[2] - tri[0]).length();
                triangles.push((t, m.emittance));
                cumulative.push(area);
            }
        }
        Self { triangles, cumulative, area }
    }

    /// A uniform point on the emitters: (point, unit normal, emittance).
    fn sample(&self, scene: &Scene, u0: f64, u1: f64, u2: f64) -> Option<(DVec3, DVec3, Rgb)> {
        let target = u0 * self.area;
        let k = self.cumulative.partition_point(|&c| c <= target).min(self.triangles.len().checked_sub(1)?);
        let (t, e) = self.triangles[k];
        let [a, b, c] = scene.triangles[t];
        let s = u1.sqrt();
        let p = a * (1.0 - s) + b * (s * (1.0 - u2)) + c * (s * u2);
        Some((p, (b - a).cross(c - a).normalize_or_zero(), e))
    }
}

struct Walk {
    pixel: u32,
    parity: u8,
    id: u64,
    point: DVec3,
    normal: DVec3,
    throughput: Rgb,
    value: Rgb,
    depth: u32,
}

/// Occlusion of many lines, in parallel batches.
fn occluded(tracer: &dyn Tracer, lines: &[Line]) -> Result<Vec<bool>, BackendError> {
    let parts: Vec<Vec<bool>> = lines
        .par_chunks(4096)
        .map(|c| {
            let mut out = Vec::new();
            tracer.occluded(c, &mut out).map(|()| out)
        })
        .collect::<Result<_, _>>()?;
    Ok(parts.into_iter().flatten().collect())
}

/// A cosine-distributed unit direction about `n` from two uniforms.
fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let (t, b) = n.any_orthonormal_pair();
    let r = u1.sqrt();
    let phi = std::f64::consts::TAU * u2;
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()).normalize()
}

/// Path-traces `walks` walks from every pixel of `view`, `per_round`
/// walks per pixel at a time (memory), reporting `(walks done, walks)`.
///
/// # Errors
/// Tracing errors.
#[allow(clippy::too_many_arguments)]
pub fn path_traced(
    scene: &Scene,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    h: &Hierarchy,
    view: &View,
    walks: u32,
    seed: u64,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Reference, BackendError> {
    let n = view.sights.len();
    let emitters = Emitters::new(scene);
    let material = |patch: u32| &scene.materials[scene.patches[patch as usize].material];
    let mut sum = vec![[0.0f64; 3]; n];
    let mut sq = vec![[0.0f64; 3]; n];
    let mut half = [vec![[0.0f64; 3]; n], vec![[0.0f64; 3]; n]];
    let mut rays = 0u64;
    let per_round = (1u32 << 20).div_ceil(n.max(1) as u32).clamp(1, walks.max(1));
    let mut done = 0u32;
    while done < walks {
        let round = per_round.min(walks - done);
        let mut active: Vec<Walk> = Vec::new();
        for (p, s) in view.sights.iter().enumerate() {
            let Some(s) = s else { continue };
            let rho = material(s.patch).reflectance;
            for w in done..done + round {
                active.push(Walk {
                    pixel: p as u32,
                    parity: (w % 2) as u8,
                    id: p as u64 * u64::from(walks) + u64::from(w),
                    point: s.point,
                    normal: s.normal,
                    throughput: rho,
                    value: [0.0; 3],
                    depth: 0,
                });
            }
        }
        let mut finished: Vec<Walk> = Vec::with_capacity(active.len());
        while !active.is_empty() {
            // Direct light at every vertex: one emitter point, one shadow ray.
            let mut shadow = Vec::new();
            let mut owner = Vec::new();
            for (k, w) in active.iter().enumerate() {
                let rng = LineRng::new(seed, w.id);
                let d = 6 * w.depth;
                let Some((y, ny, e)) =
                    emitters.sample(scene, rng.uniform(d + 3), rng.uniform(d + 4), rng.uniform(d + 5))
                else {
                    continue;
                };
                let v = y - w.point;
                let r2 = v.length_squared();
                if r2 <= 0.0 {
                    continue;
                }
                let r = r2.sqrt();
                let (cx, cy) = (w.normal.dot(v) / r, -ny.dot(v) / r);
                if cx <= 0.0 || cy <= 0.0 {
                    continue;
                }
                let g = cx * cy / (std::f64::consts::PI * r2) * emitters.area;
                let (a, b) = (prepared.to_normalised(w.point), prepared.to_normalised(y));
                let len = (b - a).length();
                shadow.push(Line::ray(a, (b - a) / len, 2e-4, (len - 2e-4).max(2e-4)));
                owner.push((k, [e[0] * g, e[1] * g, e[2] * g]));
            }
            rays += shadow.len() as u64;
            let blocked = occluded(tracer, &shadow)?;
            for ((k, c), b) in owner.into_iter().zip(blocked) {
                if !b {
                    let w = &mut active[k];
                    for ((v, t), ci) in w.value.iter_mut().zip(w.throughput).zip(c) {
                        *v += t * ci;
                    }
                }
            }
            let lines: Vec<Line> = active
                .iter()
                .map(|w| {
                    let rng = LineRng::new(seed, w.id);
                    let d = cosine_direction(w.normal, rng.uniform(6 * w.depth), rng.uniform(6 * w.depth + 1));
                    Line::ray(prepared.to_normalised(w.point), d, 2e-4, 4.0)
                })
                .collect();
            rays += lines.len() as u64;
            let hits = closest(tracer, &lines)?;
            let mut next = Vec::with_capacity(active.len());
            for (mut w, hit) in active.into_iter().zip(hits) {
                let Some(c) = hit.filter(|c| c.cos < 0.0) else {
                    finished.push(w);
                    continue;
                };
                let s = sight(scene, h, &c);
                let m = material(s.patch);
                let q = m.reflectance.iter().fold(0.0f64, |a, &b| a.max(b));
                let rng = LineRng::new(seed, w.id);
                let survive = rng.uniform(6 * w.depth + 2);
                w.depth += 1;
                if q <= 0.0 || survive >= q || w.depth >= MAX_DEPTH {
                    finished.push(w);
                    continue;
                }
                for k in 0..3 {
                    w.throughput[k] *= m.reflectance[k] / q;
                }
                w.point = s.point;
                w.normal = s.normal;
                next.push(w);
            }
            active = next;
        }
        // A fixed order of accumulation: any thread count, same sums.
        finished.sort_unstable_by_key(|w| w.id);
        for w in &finished {
            let p = w.pixel as usize;
            for k in 0..3 {
                sum[p][k] += w.value[k];
                sq[p][k] += w.value[k] * w.value[k];
                half[usize::from(w.parity)][p][k] += w.value[k];
            }
        }
        done += round;
        progress(u64::from(done), u64::from(walks));
    }
    let wn = f64::from(walks);
    let (even, odd) = (f64::from(walks.div_ceil(2)), f64::from(walks / 2));
    let mut mean = vec![None; n];
    let mut stderr = vec![[0.0; 3]; n];
    let mut halves = [vec![[0.0; 3]; n], vec![[0.0; 3]; n]];
    for (p, s) in view.sights.iter().enumerate() {
        let Some(s) = s else { continue };
        let e = material(s.patch).emittance;
        let mut m = [0.0; 3];
        for k in 0..3 {
            let mu = sum[p][k] / wn;
            m[k] = e[k] + mu;
            let var = if walks > 1 { ((sq[p][k] / wn - mu * mu) * wn / (wn - 1.0)).max(0.0) } else { 0.0 };
            stderr[p][k] = (var / wn).sqrt();
            halves[0][p][k] = e[k] + if even > 0.0 { half[0][p][k] / even } else { 0.0 };
            halves[1][p][k] = e[k] + if odd > 0.0 { half[1][p][k] / odd } else { 0.0 };
        }
        mean[p] = Some(m);
    }
    Ok(Reference { mean, stderr, halves, walks, rays })
}
