//! The viewpoint channel `V → O` of Part V: viewpoints on a sphere around an
//! object, `p(o|v)` from the solid angle each polygon subtends at `v`
//! (`a_o`, Part V eq. (2)). Two estimators build the same sparse channel:
//!
//! * [`solid_angle`] (the CLI's default): each triangle's exact solid angle
//!   times the fraction of it the viewpoint sees, that fraction sampled only
//!   where visibility changes and refined until every VMI meets a relative
//!   tolerance; exact on convex objects, with a standard error per VMI;
//! * [`ViewpointChannel::build`], the ray grid: rays through a stratified grid
//!   of directions covering the cone that contains the object's bounding
//!   sphere, each carrying `Ω_cone / N`, so `a_o ≈ Ω_cone · hits_o / N`. With
//!   many polygons smaller than the ray spacing this plug-in count is biased
//!   upwards (docs/images and BENCHMARKS.md show by how much); it stays for
//!   comparison and for the Vulkan conformance runs.
//!
//! The first surface a ray meets is the polygon seen (`Tracer::closest_hit`),
//! whichever side faces the viewpoint (as a renderer without back-face
//! culling; open meshes show their inside through holes); rays that miss see
//! the background.
//!
//! The channel is kept sparse (a viewpoint sees at most one polygon per ray),
//! so meshes of 10^6 polygons fit in memory. Its measures come from
//! `itgfx-core`'s [`itgfx_core::SparseChannel`]:
//! * [`analysis`]: viewpoint entropy, VMI, VKL, `I(V;O)`, the heuristic of
//!   eq. (1), polygonal mutual information, dissimilarity and stability;
//! * [`saliency`]: polygon adjacency, mesh saliency and viewpoint saliency;
//! * [`solid_angle`]: the default estimate of `a_o` from exact triangle
//!   solid angles and visibility sampled where it changes, with standard errors;
//! * [`selection`]: best-n views, the guided exploration path and
//!   importance-driven selection.

pub mod analysis;
mod coherent;
mod contours;
pub mod saliency;
pub mod selection;
pub mod shard_file;
pub mod shard_job;
pub mod solid_angle;
pub mod study;

pub use analysis::{ViewpointAnalysis, ViewpointMeasures, ViewpointWeights};

use glam::DVec3;
use rayon::prelude::*;

use crate::lines::Line;
use crate::tracer::{BackendError, Prepared, Tracer};

/// `n` unit directions on a Fibonacci spiral: golden-angle steps in
/// longitude, `z = 1 − (2i + 1)/n` from `1 − 1/n` to `−1 + 1/n`, so every
/// direction stands for the same area of the sphere. None is a vertex of the
/// subdivided icosahedra of [`icosphere`].
#[must_use]
pub fn fibonacci_sphere(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// Unit directions of a subdivided icosahedron: 12, 42, 162, 642, 2562
/// points for `level` 0..=4 (see [`crate::meshes::icosphere_mesh`]).
#[must_use]
pub fn icosphere(level: u32) -> Vec<DVec3> {
    crate::meshes::icosphere_mesh(level).0
}

/// The sampled channel: projected solid angles `a_o` per viewpoint, kept as
/// compressed rows (only the polygons each viewpoint sees).
#[derive(Clone, Debug, PartialEq)]
pub struct ViewpointChannel {
    /// Viewpoint positions (normalised scene coordinates).
    pub positions: Vec<DVec3>,
    /// Row `v` is `patch[starts[v]..starts[v + 1]]` (increasing).
    pub starts: Vec<usize>,
    /// Patches seen, row by row.
    pub patch: Vec<u32>,
    /// Projected solid angle `a_o` (steradians) of each stored patch.
    pub solid_angle: Vec<f64>,
    /// Solid angle of the background inside the sampled cone, per viewpoint.
    pub background: Vec<f64>,
    /// Patches in the scene.
    pub patches: usize,
    /// Rays cast per viewpoint.
    pub rays_per_viewpoint: u64,
}

impl ViewpointChannel {
    /// Casts `resolution²` rays from each viewpoint at `distance` (in
    /// bounding-sphere radii, > 1) in each direction of `directions`.
    /// `progress(rays_done, rays_total)` is called between waves of viewpoints.
    ///
    /// # Errors
    /// Backend errors.
    pub fn build(
        prepared: &Prepared,
        tracer: &dyn Tracer,
        directions: &[DVec3],
        distance: f64,
        resolution: u32,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, BackendError> {
        let r = resolution.max(1);
        let per_view = u64::from(r) * u64::from(r);
        let total = per_view * directions.len() as u64;
        let wave = (rayon::current_num_threads() * 2).max(2);
        let mut starts = vec![0];
        let (mut patch, mut solid_angle, mut background) = (Vec::new(), Vec::new(), Vec::new());
        for (w, dirs) in directions.chunks(wave).enumerate() {
            let rows: Vec<Result<Row, BackendError>> =
                dirs.par_iter().map(|&dir| view_row(tracer, dir, distance, r)).collect();
            for row in rows {
                let (p, a, bg) = row?;
                patch.extend(p);
                solid_angle.extend(a);
                background.push(bg);
                starts.push(patch.len());
            }
            progress(((w * wave + dirs.len()) as u64) * per_view, total);
        }
        Ok(Self {
            positions: directions.iter().map(|d| d.normalize() * distance).collect(),
            starts,
            patch,
            solid_angle,
            background,
            patches: prepared.patches,
            rays_per_viewpoint: per_view,
        })
    }

    /// Viewpoints.
    #[must_use]
    pub fn viewpoints(&self) -> usize {
        self.positions.len()
    }

    /// Row `v`: the patches it sees and their projected solid angles.
    #[must_use]
    pub fn row(&self, v: usize) -> (&[u32], &[f64]) {
        let (a, b) = (self.starts[v], self.starts[v + 1]);
        (&self.patch[a..b], &self.solid_angle[a..b])
    }

    /// Projected solid angle of the whole object at `v`.
    #[must_use]
    pub fn seen(&self, v: usize) -> f64 {
        self.row(v).1.iter().sum()
    }

    /// Whether no viewpoint sees any patch.
    #[must_use]
    pub fn is_blind(&self) -> bool {
        self.patch.is_empty()
    }

    /// The `k` nearest other viewpoints of each viewpoint on the sphere
    /// (ties broken by index, so the lists are deterministic).
    #[must_use]
    pub fn neighbours(&self, k: usize) -> Vec<Vec<usize>> {
        let n = self.positions.len();
        (0..n)
            .map(|a| {
                let mut near: Vec<(f64, usize)> = (0..n)
                    .filter(|&b| b != a)
                    .map(|b| ((self.positions[a] - self.positions[b]).length_squared(), b))
                    .collect();
                near.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                near.into_iter().take(k).map(|(_, b)| b).collect()
            })
            .collect()
    }
}

/// Patches seen, their solid angles, and the background's solid angle.
type Row = (Vec<u32>, Vec<f64>, f64);

/// One viewpoint's row: the patches hit first by a stratified, equal-solid-
/// angle grid of `r²` rays over the cone around the unit bounding sphere.
fn view_row(tracer: &dyn Tracer, dir: DVec3, distance: f64, r: u32) -> Result<Row, BackendError> {
    let eye = dir.normalize() * distance;
    let axis = -eye.normalize();
    let cos_a = (1.0 - 1.0 / (distance * distance)).max(0.0).sqrt();
    let cone = std::f64::consts::TAU * (1.0 - cos_a);
    let (t, b) = axis.any_orthonormal_pair();
    let per = cone / f64::from(r * r);
    let mut lines = Vec::with_capacity((r * r) as usize);
    for i in 0..r {
        for j in 0..r {
            // Stratified, equal solid angle: cos θ uniform in [cos α, 1].
            let ct = 1.0 - (f64::from(i) + 0.5) / f64::from(r) * (1.0 - cos_a);
            let st = (1.0 - ct * ct).max(0.0).sqrt();
            let ph = std::f64::consts::TAU * (f64::from(j) + 0.5) / f64::from(r);
            let d = axis * ct + (t * ph.cos() + b * ph.sin()) * st;
            lines.push(Line {
                origin: eye.as_vec3().to_array(),
                tmin: 0.0,
                direction: d.as_vec3().to_array(),
                tmax: 4.0 * distance as f32,
            });
        }
    }
    let mut first = Vec::with_capacity(lines.len());
    tracer.closest_hit(&lines, &mut first)?;
    let mut hits: Vec<u32> = first.iter().flatten().map(|h| h.patch).collect();
    let bg = (lines.len() - hits.len()) as f64 * per;
    hits.sort_unstable();
    let (mut patch, mut angle) = (Vec::new(), Vec::new());
    for run in hits.chunk_by(|a, b| a == b) {
        patch.push(run[0]);
        angle.push(run.len() as f64 * per);
    }
    Ok((patch, angle, bg))
}
