//! An independent check of a radiosity solution, patch by patch: each
//! input patch's mean radiosity estimated by the renderer's path tracer
//! ([`PathTracer`], next-event estimation with MIS, no mesh, no link), to
//! be set against the solution's area-weighted mean over the patch's leaves.
//!
//! For a diffuse surface the radiance leaving `x` is the same in every
//! direction and the renderer's equation `L = L_e + (ρ/π) ∫ L cos dω` (its
//! emittance read as radiance) is the radiosity equation `B = E + ρ H` in
//! the solver's units, so the radiance seen at `x` is `B(x)`. Sample `k` of
//! patch `p` takes a point `x_k` uniform on the patch (a root chosen by area,
//! then a uniform point of it) and one path from a ray arriving at `x_k`
//! about 7° off its normal: the sample mean is an unbiased estimate of the patch's
//! mean radiosity `(1/A_p) ∫_p B`, its standard error the samples' standard
//! deviation over `√n`. Samples whose first hit is not the patch (a point
//! where another surface coincides with it) are counted and reported.

use rayon::prelude::*;

use super::Rgb;
use super::element::Hierarchy;
use crate::lines::{Line, LineRng};
use crate::render::path::{PathTracer, Start};
use crate::render::{RenderError, Shading};
use crate::scene::Scene;
use crate::tracer::{Prepared, Tracer};

/// One patch's path-traced mean radiosity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracedPatch {
    /// Scene patch.
    pub patch: u32,
    /// Its area (scene units).
    pub area: f64,
    /// Mean radiosity over the patch, RGB.
    pub mean: Rgb,
    /// Standard error of `mean`, per channel.
    pub stderr: Rgb,
    /// Samples whose first hit was another patch (their value still counts).
    pub strays: u32,
    /// Rays' first hits asked for the `strays` count.
    pub samples: u32,
}

/// Offset of each sample's ray origin in front of its point (normalised
/// units: the scene is within the unit ball, f32 hits good to ~1e-7).
const LIFT: f64 = 1e-4;

/// Paths per renderer call (memory: one path state each).
const CHUNK: usize = 1 << 15;

/// Every patch's mean radiosity from `samples` paths, each from its own
/// uniform point (patches without area are left out).
///
/// # Errors
/// Tracing errors; a scene the renderer cannot shade (no light, a sphere).
pub fn traced_patch_means(
    scene: &Scene,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    h: &Hierarchy,
    samples: u32,
    seed: u64,
) -> Result<Vec<TracedPatch>, RenderError> {
    let shading = Shading::new(scene, prepared)?;
    let pt = PathTracer { tracer, prepared, surfaces: &shading.surfaces, lights: &shading.lights, max_depth: 256 };
    let mut roots: Vec<Vec<(u32, f64)>> = vec![Vec::new(); scene.patches.len()];
    for (r, root) in h.roots.iter().enumerate() {
        let a = h.elements[root.element as usize].area;
        if a > 0.0 {
            roots[root.patch as usize].push((r as u32, a));
        }
    }
    let n = samples as usize;
    let mut out = Vec::new();
    for (patch, rs) in roots.iter().enumerate() {
        let area: f64 = rs.iter().map(|r| r.1).sum();
        if rs.is_empty() || !(area > 0.0) {
            continue;
        }
        // Sample k: draws 0-2 of its point stream choose the point, its
        // path stream (seed, id) the path; ids are unique per patch and k.
        let starts: Vec<(Start, u32)> = (0..n)
            .into_par_iter()
            .map(|k| {
                let id = (patch as u64) << 32 | k as u64;
                let u = LineRng::new(seed ^ POINT_STREAM, id);
                let mut pick = u.uniform(0) * area;
                let mut root = rs[rs.len() - 1].0;
                for &(r, a) in rs {
                    if pick < a {
                        root = r;
                        break;
                    }
                    pick -= a;
                }
                let el = &h.elements[h.roots[root as usize].element as usize];
                let x = prepared.to_normalised(el.sample(u.uniform(1), u.uniform(2)));
                // Slightly off the normal (a diffuse patch looks the same from any
                // side). It began as a workaround for rays with a -0.0 component
                // missing axis-aligned walls on the CPU backend, fixed since in the
                // tracer (tests/tests/backends.rs, `head_on_rays`); kept so that the
                // figures in docs/RADIOSITY.md stay those of this code.
                let (t1, t2) = el.normal.any_orthonormal_pair();
                let direction = -(el.normal + t1 * 0.1 + t2 * 0.07).normalize();
                (Start { origin: x - direction * LIFT, direction, rng: LineRng::new(seed, id) }, patch as u32)
            })
            .collect();
        let mut sum = [0.0f64; 3];
        let mut sq = [0.0f64; 3];
        let mut strays = 0u32;
        for chunk in starts.chunks(CHUNK) {
            let s: Vec<Start> = chunk.iter().map(|c| c.0).collect();
            let lines: Vec<Line> = s.iter().map(|s| Line::ray(s.origin, s.direction, 0.0, 2.0 * LIFT)).collect();
            let mut hits = Vec::new();
            tracer.closest_hit(&lines, &mut hits)?;
            strays += hits.iter().filter(|h| h.is_none_or(|h| h.patch != patch as u32)).count() as u32;
            for v in pt.radiance(&s)? {
                for c in 0..3 {
                    sum[c] += v[c];
                    sq[c] += v[c] * v[c];
                }
            }
        }
        let nf = n as f64;
        let mean = sum.map(|s| s / nf);
        let stderr = std::array::from_fn(|c| {
            let var = if n > 1 { ((sq[c] / nf - mean[c] * mean[c]) * nf / (nf - 1.0)).max(0.0) } else { 0.0 };
            (var / nf).sqrt()
        });
        out.push(TracedPatch { patch: patch as u32, area, mean, stderr, strays, samples });
    }
    Ok(out)
}

/// The stream of the sample points, apart from the paths' own.
const POINT_STREAM: u64 = 0x5851_F42D_4C95_7F2D;

/// A solution's mean radiosity over every patch: the area-weighted mean of
/// its leaves (RGB), by patch index (`None`: no area).
#[must_use]
pub fn solved_patch_means(h: &Hierarchy, radiosity: &[Rgb], patches: usize) -> Vec<Option<Rgb>> {
    let mut acc = vec![([0.0f64; 3], 0.0f64); patches];
    for e in h.leaves() {
        let el = &h.elements[e as usize];
        let a = &mut acc[h.patch(e) as usize];
        for (s, b) in a.0.iter_mut().zip(radiosity[e as usize]) {
            *s += el.area * b;
        }
        a.1 += el.area;
    }
    acc.into_iter().map(|(s, a)| (a > 0.0).then(|| s.map(|x| x / a))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::radiosity::refine::tests::glowing_cube;
    use crate::tracer::CpuTracer;

    #[test]
    fn the_path_traced_patch_means_of_a_uniform_enclosure_are_e_over_one_minus_rho() {
        // rho = 0.5, E = 1: B = 2 on every face; the samples land on their
        // own patch (but for a point within ~1e-5 of an edge, whose ray may
        // first meet the neighbour: at most 1 in 1000).
        let scene = glowing_cube(2, 0.5, 1.0);
        let p = Prepared::new(&scene);
        let t = CpuTracer::new(&p);
        let h = Hierarchy::new(&scene);
        let traced = traced_patch_means(&scene, &p, &t, &h, 4096, 3).unwrap();
        assert_eq!(traced.len(), scene.patches.len());
        for tp in &traced {
            assert!(tp.strays * 1000 <= tp.samples, "patch {}: {} strays", tp.patch, tp.strays);
            for c in 0..3 {
                let (m, se) = (tp.mean[c], tp.stderr[c]);
                assert!(se > 0.0 && se < 0.02, "patch {}: stderr {se}", tp.patch);
                assert!((m - 2.0).abs() < 4.0 * se, "patch {}: {m} ± {se}, expected 2", tp.patch);
            }
        }
        // The solver's patch means of the same scene, unrefined, are 2 too.
        let s = solved_patch_means(&h, &vec![[2.0; 3]; h.elements.len()], scene.patches.len());
        assert!(s.iter().all(|b| b.is_some_and(|b| b == [2.0; 3])));
    }
}
