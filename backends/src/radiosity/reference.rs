//! An independent reference: the radiosity at the surface point each pixel
//! sees, estimated by the renderer's path tracer ([`PathTracer`]:
//! next-event estimation with MIS, Russian roulette; the same one
//! `itgfx render` and the patch check use), with no mesh, no links and no
//! oracle.
//!
//! For a diffuse surface the radiance leaving `x` is the same in every
//! direction and the renderer's equation (its emittance read as radiance)
//! is the radiosity equation `B = E + ρ H` in the solver's units, so the
//! radiance arriving from `x` along the camera's ray is `B(x)`. Each walk
//! starts just in front of the point the pixel centre sees, along the
//! radiosity camera's ray (the Cornell box's camera looks through the
//! closed front wall, which the solver's pictures skip; the renderer's
//! surfaces are two-sided, so the walk starts past it). Each pixel keeps
//! the sums of its walks and of their squares (standard errors) and two
//! half-sums (even and odd walks), whose difference measures the
//! reference's own noise in the same units as an image error.

use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

use super::Rgb;
use super::render::View;
use crate::backend::BackendError;
use crate::camera::Camera;
use crate::lines::{Line, LineRng};
use crate::render::path::{PathTracer, Start};
use crate::render::{RenderError, Shading};
use crate::scene::Scene;
use crate::tracer::{CrossingBuffer, Hit, Prepared, Tracer};

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

/// Offset of each walk's origin in front of its point (normalised units),
/// as the patch check uses.
const LIFT: f64 = 1e-4;

/// Walks per renderer call (memory: one path state each).
const CHUNK: usize = 1 << 15;

/// A tracer that counts the lines it is asked about.
struct Counting<'a> {
    inner: &'a dyn Tracer,
    lines: AtomicU64,
}

impl Tracer for Counting<'_> {
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        self.lines.fetch_add(lines.len() as u64, Ordering::Relaxed);
        self.inner.trace_all(lines, out)
    }

    fn closest_hit(&self, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
        self.lines.fetch_add(lines.len() as u64, Ordering::Relaxed);
        self.inner.closest_hit(lines, out)
    }

    fn occluded(&self, lines: &[Line], out: &mut Vec<bool>) -> Result<(), BackendError> {
        self.lines.fetch_add(lines.len() as u64, Ordering::Relaxed);
        self.inner.occluded(lines, out)
    }
}

/// What a reference traces: the scene's pixels of `view` (seen with
/// `camera`), `walks` walks each, from `seed` (one settings struct, not
/// seven parameters).
#[derive(Clone, Copy)]
pub struct ReferenceJob<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its prepared geometry.
    pub prepared: &'a Prepared,
    /// The tracing backend.
    pub tracer: &'a dyn Tracer,
    /// What each pixel sees.
    pub view: &'a View,
    /// The camera of `view`, in scene units.
    pub camera: &'a Camera,
    /// Walks a pixel.
    pub walks: u32,
    /// Seed of every walk.
    pub seed: u64,
}

/// Path-traces `walks` walks from every pixel of `view` (seen with
/// `camera`), reporting `(walks done, walks)`. Walk `w` of pixel `p` draws
/// from the stream `(seed, p · walks + w)` only and the sums are made in
/// pixel and walk order, so any thread count gives the same picture.
///
/// # Errors
/// Tracing errors; a scene the renderer cannot shade (no light).
pub fn path_traced(job: &ReferenceJob, progress: &mut dyn FnMut(u64, u64)) -> Result<Reference, RenderError> {
    let ReferenceJob { scene, prepared, tracer, view, camera, walks, seed } = *job;
    let n = view.sights.len();
    let shading = Shading::new(scene, prepared)?;
    let counting = Counting { inner: tracer, lines: AtomicU64::new(0) };
    let pt = PathTracer {
        tracer: &counting,
        prepared,
        surfaces: &shading.surfaces,
        lights: &shading.lights,
        max_depth: MAX_DEPTH,
    };
    let eye = camera.normalised(prepared).eye;
    let seen: Vec<(usize, glam::DVec3, glam::DVec3)> = view
        .sights
        .iter()
        .enumerate()
        .filter_map(|(p, s)| {
            let x = prepared.to_normalised(s.as_ref()?.point);
            let d = (x - eye).normalize_or_zero();
            (d != glam::DVec3::ZERO).then_some((p, x, d))
        })
        .collect();
    let mut sum = vec![[0.0f64; 3]; n];
    let mut sq = vec![[0.0f64; 3]; n];
    let mut half = [vec![[0.0f64; 3]; n], vec![[0.0f64; 3]; n]];
    let per_round = (1u32 << 20).div_ceil(seen.len().max(1) as u32).clamp(1, walks.max(1));
    let mut done = 0u32;
    while done < walks {
        let round = per_round.min(walks - done);
        let starts: Vec<(Start, usize, u32)> = seen
            .iter()
            .flat_map(|&(p, x, d)| {
                (done..done + round).map(move |w| {
                    let id = p as u64 * u64::from(walks) + u64::from(w);
                    (Start { origin: x - d * LIFT, direction: d, rng: LineRng::new(seed, id) }, p, w)
                })
            })
            .collect();
        let values: Vec<Vec<[f64; 3]>> = starts
            .par_chunks(CHUNK)
            .map(|c| pt.radiance(&c.iter().map(|s| s.0).collect::<Vec<_>>()))
            .collect::<Result<_, _>>()?;
        for ((_, p, w), v) in starts.iter().zip(values.iter().flatten()) {
            for k in 0..3 {
                sum[*p][k] += v[k];
                sq[*p][k] += v[k] * v[k];
                half[(w % 2) as usize][*p][k] += v[k];
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
    for &(p, _, _) in &seen {
        let mut m = [0.0; 3];
        for k in 0..3 {
            let mu = sum[p][k] / wn;
            m[k] = mu;
            let var = if walks > 1 { ((sq[p][k] / wn - mu * mu) * wn / (wn - 1.0)).max(0.0) } else { 0.0 };
            stderr[p][k] = (var / wn).sqrt();
            halves[0][p][k] = if even > 0.0 { half[0][p][k] / even } else { 0.0 };
            halves[1][p][k] = if odd > 0.0 { half[1][p][k] / odd } else { 0.0 };
        }
        mean[p] = Some(m);
    }
    Ok(Reference { mean, stderr, halves, walks, rays: counting.lines.into_inner() })
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::radiosity::element::Hierarchy;
    use crate::radiosity::refine::tests::glowing_cube;
    use crate::radiosity::render::view;
    use crate::tracer::CpuTracer;

    #[test]
    fn the_reference_of_a_uniform_enclosure_is_e_over_one_minus_rho_in_every_pixel() {
        // rho = 0.5, E = 1: B = 2 everywhere, seen from inside the cube.
        let scene = glowing_cube(2, 0.5, 1.0);
        let p = Prepared::new(&scene);
        let t = CpuTracer::new(&p);
        let h = Hierarchy::new(&scene);
        let camera = Camera::look_at(DVec3::new(0.5, 0.5, 0.1), DVec3::new(0.5, 0.5, 1.0), DVec3::Y, 60.0).unwrap();
        let v = view(&scene, &p, &t, &h, &camera, (8, 8)).unwrap();
        let job =
            ReferenceJob { scene: &scene, prepared: &p, tracer: &t, view: &v, camera: &camera, walks: 256, seed: 7 };
        let r = path_traced(&job, &mut |_, _| {}).unwrap();
        assert!(r.rays > 64 * 256, "every walk traced: {} rays", r.rays);
        let (mut sum, mut n) = (0.0, 0.0);
        for (m, se) in r.mean.iter().zip(&r.stderr) {
            let m = m.expect("every pixel sees a wall");
            assert!(se[0] > 0.0 && (m[0] - 2.0).abs() < 5.0 * se[0], "{} ± {}, expected 2", m[0], se[0]);
            sum += m[0];
            n += 1.0;
        }
        assert!((sum / n - 2.0).abs() < 0.02, "mean {}", sum / n);
        // The same seed gives the same picture.
        let again = path_traced(&job, &mut |_, _| {}).unwrap();
        assert_eq!(again.mean, r.mean);
    }
}
