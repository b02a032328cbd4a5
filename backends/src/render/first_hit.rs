//! Simmons' priority values of Part IV §2 on the oracle pass's samples:
//! the colour priority `p_c` (eq. (2)), the depth difference
//! `p_d = 1 − d_min/d_max` (eq. (3)) and their mixture
//! `p_v = δ p_c + (1 − δ) p_d` (eq. (4)), the baselines the tutorial's
//! contrast maps are shown against (Figs. 2.b, 4.d, 5.d, 6.a).
//!
//! Every pixel's samples are the oracle pass's own
//! ([`super::supersample::contrast_map`]: [`ORACLE_SAMPLES`] stratified
//! samples, indices `0..8`, the same seeds and positions), so the three maps
//! sit beside the contrast maps sample for sample. Two traces per row:
//!
//! * **colour**: the row's batches are path traced again; the same seeds
//!   give the same samples (a test compares the pixel sums with the
//!   contrast map's);
//! * **depth**: the same batches through a path tracer whose paths end at
//!   their first hit (`max_depth` 1) and whose [`Tracer`] is wrapped in a
//!   [`Recorder`]: such a path tracer asks for nothing but the camera
//!   rays' closest hits, in sample order, and the recorder keeps each
//!   hit's distance from the eye.
//!
//! A camera ray that meets nothing counts as distance 0. With the core's
//! `p_d` that gives 1 for a pixel where some rays meet a surface and others
//! nothing (the limit `d_max → ∞` of eq. (3)) and 0 where none does, as the
//! geometry factor of a miss is 0 for the contrasts of eqs. (20)–(22). The
//! formulas are the core's ([`itgfx_core::pixel`]); this module only
//! gathers the samples.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use itgfx_core::pixel::{depth_difference, priority_colour, priority_value};
use rayon::prelude::*;

use super::frame::{Batch, View, trace_geometry};
use super::path::PathTracer;
use super::supersample::ORACLE_SAMPLES;
use crate::lines::Line;
use crate::tracer::{BackendError, CrossingBuffer, Hit, NEAR, Tracer};

/// A [`Tracer`] that forwards every query and keeps the distance of each
/// closest hit it returns (0 for a miss), in order.
pub struct Recorder<'a> {
    inner: &'a dyn Tracer,
    distances: Mutex<Vec<f64>>,
}

impl<'a> Recorder<'a> {
    /// Records the closest hits `inner` finds.
    #[must_use]
    pub fn new(inner: &'a dyn Tracer) -> Self {
        Self { inner, distances: Mutex::new(Vec::new()) }
    }

    /// The distances recorded so far (the recorder is emptied).
    #[must_use]
    pub fn take(&self) -> Vec<f64> {
        self.distances.lock().map(|mut d| std::mem::take(&mut *d)).unwrap_or_default()
    }
}

impl Tracer for Recorder<'_> {
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        self.inner.trace_all(lines, out)
    }

    fn closest_hit(&self, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
        self.inner.closest_hit(lines, out)?;
        if let Ok(mut d) = self.distances.lock() {
            // Lines are backed off by NEAR from their origin (`Line::ray32`).
            d.extend(out.iter().map(|h| h.map_or(0.0, |h| f64::from(h.t - NEAR).max(0.0))));
        }
        Ok(())
    }

    fn occluded(&self, lines: &[Line], out: &mut Vec<bool>) -> Result<(), BackendError> {
        self.inner.occluded(lines, out)
    }

    fn batch_lines(&self) -> usize {
        self.inner.batch_lines()
    }
}

/// Simmons' priorities of one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Priority {
    /// `p_c` (eq. (2), Mitchell's weights); `+∞` if a sample's radiance is
    /// not finite.
    pub colour: f64,
    /// `p_d` (eq. (3)) of the first-hit distances.
    pub depth: f64,
    /// `p_v = δ p_c + (1 − δ) p_d` (eq. (4)); `+∞` with `p_c`.
    pub value: f64,
}

/// The priorities of every pixel, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct PriorityMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The colour weight `δ` of `p_v`.
    pub delta: f64,
    /// Per pixel.
    pub pixels: Vec<Priority>,
}

/// The oracle pass's batches of row `y`: [`ORACLE_SAMPLES`] samples from index 0.
fn oracle_batches(view: &View, y: u32) -> Vec<Batch> {
    let w = view.width;
    (0..w).map(|x| Batch { pixel: y * w + x, slot: x, first: 0, n: ORACLE_SAMPLES, odd: false, pilot: false }).collect()
}

/// Each oracle sample of row `y`: its radiance and its first-hit distance
/// from the eye (normalised units, 0 for a miss), pixel by pixel.
///
/// # Errors
/// Backend failures only.
pub fn row_samples(pt: &PathTracer, view: &View, y: u32) -> Result<(Vec<[f64; 3]>, Vec<f64>), BackendError> {
    let batches = oracle_batches(view, y);
    let rgb = trace_geometry(pt, view, &batches, None)?;
    let recorder = Recorder::new(pt.tracer);
    let first =
        PathTracer { tracer: &recorder, prepared: pt.prepared, surfaces: pt.surfaces, lights: pt.lights, max_depth: 1 };
    trace_geometry(&first, view, &batches, None)?;
    let distances = recorder.take();
    debug_assert_eq!(distances.len(), rgb.len(), "one closest hit per camera ray");
    Ok((rgb, distances))
}

/// The priorities of one pixel's samples.
#[must_use]
pub fn priority(rgb: &[[f64; 3]], distances: &[f64], delta: f64) -> Priority {
    let ch: [Vec<f64>; 3] = std::array::from_fn(|c| rgb.iter().map(|s| s[c]).collect());
    let depth = depth_difference(distances).unwrap_or(0.0);
    match priority_colour(&ch[0], &ch[1], &ch[2]) {
        Ok(colour) => Priority { colour, depth, value: priority_value(delta, colour, depth).unwrap_or(f64::INFINITY) },
        Err(_) => Priority { colour: f64::INFINITY, depth, value: f64::INFINITY },
    }
}

/// Traces the oracle pass of `view` again (rows in parallel, every row of
/// the image) and gives each pixel's priorities with colour weight `delta`
/// (`δ = 0.9` in the tutorial); `progress` gets (rows done, rows).
///
/// # Errors
/// Backend failures only.
pub fn priority_map(
    pt: &PathTracer,
    view: &View,
    delta: f64,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<PriorityMap, BackendError> {
    let (w, h) = (view.width, view.height);
    let n = ORACLE_SAMPLES as usize;
    let done = AtomicU64::new(0);
    let rows: Vec<Vec<Priority>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let (rgb, d) = row_samples(pt, view, y)?;
            let row = (0..w as usize).map(|x| priority(&rgb[x * n..(x + 1) * n], &d[x * n..(x + 1) * n], delta));
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, u64::from(h));
            Ok(row.collect())
        })
        .collect::<Result<_, BackendError>>()?;
    Ok(PriorityMap { width: w, height: h, delta, pixels: rows.into_iter().flatten().collect() })
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::super::supersample::{ContrastMap, contrast_map};
    use super::super::{Oracle, Shading};
    use super::*;
    use crate::camera::Camera;
    use crate::scene::{Material, Scene};
    use crate::tracer::CpuTracer;
    use crate::tracer::Prepared;

    /// A grey wall `z = 0` spanning `[−half, half]²`, a glowing square
    /// behind the camera lighting it, and optionally a box in front.
    fn scene(half: f64, block: bool) -> Scene {
        let d = DVec3::new;
        let mut s = Scene::named("wall");
        s.materials = vec![
            Material { name: "wall".into(), reflectance: [0.7; 3], ..Material::default() },
            Material { name: "light".into(), reflectance: [0.0; 3], emittance: [5.0; 3], mirror: false },
            Material { name: "red".into(), reflectance: [0.8, 0.1, 0.1], ..Material::default() },
        ];
        // Facing +z (towards the camera): counter-clockwise seen from +z.
        s.add_polygon("wall", &[d(-half, -half, 0.0), d(half, -half, 0.0), d(half, half, 0.0), d(-half, half, 0.0)], 0);
        // A light at z = 6 facing −z, out of the camera's view.
        s.add_polygon("light", &[d(-1.0, 3.0, 6.0), d(-1.0, 4.0, 6.0), d(1.0, 4.0, 6.0), d(1.0, 3.0, 6.0)], 1);
        if block {
            s.add_box("block", d(-0.5, -0.5, 0.0), d(0.5, 0.5, 2.0), 1, false, 2);
        }
        s
    }

    struct Setup {
        scene: Scene,
        prepared: Prepared,
        tracer: CpuTracer,
        shading: Shading,
    }

    fn setup(scene: Scene) -> Setup {
        let prepared = Prepared::new(&scene);
        let tracer = CpuTracer::new(&prepared);
        let shading = Shading::new(&scene, &prepared).unwrap();
        Setup { scene, prepared, tracer, shading }
    }

    fn view(s: &Setup, eye: DVec3, target: DVec3, side: u32) -> View {
        let c = Camera::look_at(eye, target, DVec3::Y, 40.0).unwrap().normalised(&s.prepared);
        assert!(s.scene.sphere.is_none());
        View { camera: c, width: side, height: side, seed: 7, rows: (0, side) }
    }

    fn tracer(s: &Setup) -> PathTracer<'_> {
        PathTracer {
            tracer: &s.tracer,
            prepared: &s.prepared,
            surfaces: &s.shading.surfaces,
            lights: &s.shading.lights,
            max_depth: 8,
        }
    }

    /// A wall facing the camera and filling the view: every distance is the
    /// ray's distance to the plane, `D / cos`, so within a pixel the
    /// distances span at most the pixel's corners' range and `p_d` stays
    /// below `1 − D/d_corner` (under 0.03 here: the corner pixels' spread of
    /// `1/cos`, 20° off the axis at 2.5° a pixel).
    #[test]
    fn a_wall_facing_the_camera_has_almost_uniform_depth() {
        let s = setup(scene(20.0, false));
        let (eye, side) = (DVec3::new(0.0, 0.0, 5.0), 16);
        let v = view(&s, eye, DVec3::ZERO, side);
        let pt = tracer(&s);
        // The eye's distance to the wall's plane, in the tracer's normalised units.
        let axis = (v.camera.eye - s.prepared.to_normalised(DVec3::ZERO)).z;
        let map = priority_map(&pt, &v, 0.9, &|_, _| {}).unwrap();
        for y in 0..side {
            let (_, d) = row_samples(&pt, &v, y).unwrap();
            for x in 0..side {
                let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
                let far = corners
                    .iter()
                    .map(|&(a, b)| {
                        let dir = v.camera.direction(f64::from(x) + a, f64::from(y) + b, side, side);
                        axis / dir.dot(v.camera.forward)
                    })
                    .fold(0.0, f64::max);
                let p = &d[(x * ORACLE_SAMPLES) as usize..((x + 1) * ORACLE_SAMPLES) as usize];
                assert!(p.iter().all(|&t| t >= axis * (1.0 - 1e-5) && t <= far * (1.0 + 1e-5)), "{p:?}: {axis}..{far}");
                let pd = map.pixels[(y * side + x) as usize].depth;
                assert!(pd >= 0.0 && pd <= 1.0 - axis / far + 1e-5, "({x}, {y}): p_d {pd}");
                assert!(pd < 0.03, "({x}, {y}): p_d {pd}");
            }
        }
    }

    /// A box 2 units in front of the wall: only its outline's pixels see
    /// both depths, and there `p_d` reaches about `1 − 3/5`; elsewhere it is
    /// below 0.03 (one surface's spread of `1/cos` in a pixel). A wall ending inside the view gives `p_d = 1` on its edge
    /// (a ray meeting nothing) and 0 beyond it.
    #[test]
    fn depth_edges_and_misses() {
        let s = setup(scene(20.0, true));
        let side = 24;
        let v = view(&s, DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, side);
        let map = priority_map(&tracer(&s), &v, 0.9, &|_, _| {}).unwrap();
        let edge: Vec<f64> = map.pixels.iter().map(|p| p.depth).filter(|&d| d > 0.1).collect();
        let top = edge.iter().copied().fold(0.0, f64::max);
        assert!(!edge.is_empty() && edge.len() < 4 * side as usize, "{} edge pixels", edge.len());
        assert!((top - 0.4).abs() < 0.05, "largest p_d {top}, expected about 1 - 3/5");
        assert!(map.pixels.iter().filter(|p| p.depth <= 0.1).all(|p| p.depth < 0.03));

        let s = setup(scene(1.0, false));
        let v = view(&s, DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, side);
        let map = priority_map(&tracer(&s), &v, 0.9, &|_, _| {}).unwrap();
        let ones = map.pixels.iter().filter(|p| p.depth == 1.0).count();
        let zeros = map.pixels.iter().filter(|p| p.depth == 0.0).count();
        assert!(ones > 0 && zeros > 0 && ones < 4 * side as usize, "{ones} edge pixels, {zeros} empty");
        // p_v mixes the two (eq. (4)).
        for p in &map.pixels {
            assert!((p.value - (0.9 * p.colour + 0.1 * p.depth)).abs() < 1e-12);
        }
    }

    /// The colour samples are the oracle pass's: the same pixel sums as the
    /// contrast map, to the bit.
    #[test]
    fn colour_samples_are_the_oracle_pass() {
        let s = setup(scene(20.0, true));
        let v = view(&s, DVec3::new(1.0, 0.5, 5.0), DVec3::ZERO, 12);
        let pt = tracer(&s);
        let map: ContrastMap = contrast_map(&pt, &v, Oracle { delta: 1.0, binary: false }, &|_, _| {}).unwrap();
        let n = ORACLE_SAMPLES as usize;
        for y in 0..v.height {
            let (rgb, _) = row_samples(&pt, &v, y).unwrap();
            for x in 0..v.width as usize {
                let sum = rgb[x * n..(x + 1) * n].iter().fold([0.0; 3], |a, c| [a[0] + c[0], a[1] + c[1], a[2] + c[2]]);
                assert_eq!(sum, map.sums[y as usize * v.width as usize + x]);
            }
        }
        let p = priority_map(&pt, &v, 0.9, &|_, _| {}).unwrap();
        assert!(p.pixels.iter().any(|q| q.colour > 0.0), "the red block's edges have colour priority");
    }
}
