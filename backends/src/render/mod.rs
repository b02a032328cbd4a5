//! A path tracer driven by the pixel criteria of Part IV (adaptive
//! sampling) and Part III-IV §5 (f-divergence criteria).
//!
//! * [`path`]: the path tracer itself (next-event estimation with MIS,
//!   mirrors, Russian roulette), traced as a wavefront through the
//!   [`Tracer`] seam, so every backend renders the same way.
//! * [`criteria`]: the refinement criteria, each a call into
//!   `itgfx_core::pixel`; [`tree`]: the entropy refinement tree of Part IV
//!   §6; [`tune`]: thresholds for an equal average budget.
//! * [`sampler`]: the [`PixelSampler`] trait and the one pixel loop that
//!   drives every sampler (rows in parallel, shards, progress); its
//!   implementations are [`batch`] (`uniform` and the batch criteria),
//!   [`tree`], [`supersample`] (`es`) and [`adaptive`].
//! * [`frame`]: the image plane and the film: stratified batches per
//!   pixel, the frame their values land in, passes pooled; the same image
//!   for any thread count.
//! * [`job`]: a render as one job, [`RenderJob`]: its [`job::Settings`]
//!   (built once from the arguments: the sampler by name, the memory
//!   estimate against the budget, a shard's rows and file), then the run.
//! * [`lights`]: area lights and materials; [`views`]: default cameras and
//!   the camera-inside-an-object check; [`room`]: the `mirror-room` scene;
//!   [`open`]: the open scenes `open-blocks` and `open-sphere`.
//!
//! Radiance is linear RGB in f64; the criteria read the luminance `Y` of
//! linear sRGB (Part III-IV §5.1) or the channels.

pub mod adaptive;
pub mod batch;
pub mod criteria;
pub mod first_hit;
pub mod frame;
pub mod job;
pub mod lights;
pub mod open;
pub mod path;
pub mod room;
pub mod sampler;
pub mod shard_file;
pub mod supersample;
pub mod tree;
pub mod tune;
pub mod views;

use std::fmt;

use crate::camera::Camera;
use crate::scene::Scene;
use crate::tracer::{BackendError, Prepared, Tracer};
pub use adaptive::AdaptiveSampling;
pub use batch::{Batches, Policy, Uniform};
pub use criteria::{Adaptive, Criterion};
pub use first_hit::{Priority, PriorityMap};
pub use frame::{Frame, View};
pub use job::{JobError, Outcome, RenderJob};
pub use lights::{Lights, Surfaces};
pub use path::PathTracer;
pub use sampler::PixelSampler;
pub use supersample::{ContrastMap, Oracle, PixelMeasures};
pub use tree::{Tree, TreeContrast};
pub use tune::Tuned;

/// Why a scene cannot be rendered.
#[derive(Debug)]
pub enum RenderError {
    /// No material emits.
    NoLights(String),
    /// The analytic sphere has no triangles to shade.
    Unsupported(String),
    /// The camera is inside a closed object.
    CameraInside(String),
    /// A backend failure.
    Backend(BackendError),
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoLights(s) | Self::Unsupported(s) | Self::CameraInside(s) => f.write_str(s),
            Self::Backend(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for RenderError {}

impl From<BackendError> for RenderError {
    fn from(e: BackendError) -> Self {
        Self::Backend(e)
    }
}

/// A scene's materials and lights, checked for rendering.
pub struct Shading {
    /// Materials by triangle.
    pub surfaces: Surfaces,
    /// Area lights.
    pub lights: Lights,
}

impl Shading {
    /// Materials and lights of `scene`.
    ///
    /// # Errors
    /// [`RenderError::NoLights`] when nothing emits,
    /// [`RenderError::Unsupported`] for the analytic sphere.
    pub fn new(scene: &Scene, prepared: &Prepared) -> Result<Self, RenderError> {
        if scene.sphere.is_some() {
            return Err(RenderError::Unsupported(format!(
                "{}: the analytic sphere cannot be rendered (use geosphere or a mesh)",
                scene.name
            )));
        }
        let lights = Lights::new(scene, prepared).ok_or_else(|| {
            RenderError::NoLights(format!(
                "{}: no light: no material emits (give one a non-zero Ke in the MTL file)",
                scene.name
            ))
        })?;
        Ok(Self { surfaces: Surfaces::new(scene), lights })
    }
}

/// How pixels are sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampling {
    /// The same number of stratified samples in every pixel.
    Uniform(u32),
    /// Batches of 8 while a criterion asks for more.
    Adaptive {
        /// The criterion.
        criterion: Criterion,
        /// Average rays per pixel to trace, decision samples included (the
        /// threshold is tuned to it).
        spp: u32,
        /// Most samples one pixel takes.
        max: u32,
        /// Decide on a separate pilot set, estimate from fresh samples (the
        /// default); false: the tutorial's form, biased.
        unbiased: bool,
        /// A given threshold instead of tuning one.
        threshold: Option<f64>,
    },
    /// The refinement tree of Part IV §6 (`ec`, `ic`, `cc-tree`).
    Tree {
        /// The node contrast.
        contrast: TreeContrast,
        /// Colour weight `δ` against geometry (eq. (28)); 1 is colour only.
        delta: f64,
        /// Average rays per pixel to trace, the pilot tree's included (the
        /// threshold is tuned to it).
        spp: u32,
        /// Pilot tree decides, fresh leaf samples estimate (the default);
        /// false: the tutorial's form, biased.
        unbiased: bool,
        /// A given threshold instead of tuning one.
        threshold: Option<f64>,
        /// Samples per node `N_s^r` ([`tree::valid_node_samples`]).
        node_samples: u32,
    },
    /// Entropy-based supersampling of Part IV §5.
    Supersample(Supersampling),
    /// The recommended sampler: a pilot in every pixel, the rest shared by
    /// the neighbours' display-space spread ([`adaptive`]).
    Neighbours(AdaptiveSampling),
}

/// Entropy-based supersampling (Part IV §5): the contrast map of 8 spp
/// shares out the rest of the budget.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Supersampling {
    /// How the oracle's contrast is formed.
    pub oracle: Oracle,
    /// Average rays per pixel, the oracle's included (exact: no threshold is tuned).
    pub spp: u32,
    /// Most samples one pixel takes in its estimate.
    pub max: u32,
    /// The oracle's samples only decide (the default); false: they are
    /// averaged into the image too, the tutorial's form, biased.
    pub unbiased: bool,
}

/// A rendered frame and how its sampler was set.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    /// The image.
    pub frame: Frame,
    /// The threshold used by an adaptive sampler.
    pub threshold: Option<f64>,
    /// The tuning pilot, when the threshold was tuned.
    pub tuned: Option<Tuned>,
    /// The pixel quality and contrast maps of 8 spp (Part IV §3–§4): the
    /// supersampler's oracle, or a separate pass when asked for.
    pub map: Option<ContrastMap>,
    /// Passes pooled in the frame (more than 1 only with a time budget).
    pub passes: u64,
}

/// What to render and how: the settings of one [`render`] call.
#[derive(Clone, Copy)]
pub struct Job<'a> {
    /// The tracing backend.
    pub tracer: &'a dyn Tracer,
    /// The scene.
    pub scene: &'a Scene,
    /// Its prepared geometry.
    pub prepared: &'a Prepared,
    /// Its materials and lights.
    pub shading: &'a Shading,
    /// The camera, in scene units.
    pub camera: &'a Camera,
    /// Image width and height in pixels.
    pub size: (u32, u32),
    /// Seed of the first pass (every pass's with [`time_budget`](Self::time_budget)).
    pub seed: u64,
    /// How pixels are sampled.
    pub sampling: &'a Sampling,
    /// Also the quality and contrast maps of an 8-spp pass, with this oracle.
    pub maps: Option<Oracle>,
    /// Only the rows `[first, end)` (a shard).
    pub rows: Option<(u32, u32)>,
    /// Render passes of the sampler's budget until this many seconds have
    /// passed (at least one pass); the image is the mean of all their samples.
    pub time_budget: Option<f64>,
}

/// The seed of pass `k` of a progressive render: pass 0 is the run's seed,
/// so a one-pass run is the plain render.
#[must_use]
pub fn pass_seed(seed: u64, k: u64) -> u64 {
    seed.wrapping_add(k.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// Renders `job.scene` seen by `job.camera`: checks the camera, tunes an
/// adaptive sampler's threshold to its budget, then traces. With `maps`,
/// also the quality and contrast maps of an 8-spp pass (the supersampler's
/// own oracle pass, so no extra rays for `Sampling::Supersample`). With
/// `rows = (first, end)`, only those rows are traced (a shard: the frame
/// holds them alone; thresholds are tuned on the whole image's pilot, and
/// `es` and `adaptive` trace the whole pilot, so every shard decides as the
/// whole run). With `time_budget`, passes of the sampler's budget (seeds
/// [`pass_seed`], a tuned threshold reused) are rendered until the time is
/// spent and their samples pooled: each pixel's value is the mean of all
/// its samples, weighted by count, which stays unbiased since no pass's
/// counts depend on the pixel's own samples in that pass. `progress` gets
/// (rows done, rows) of the first pass.
///
/// # Errors
/// [`RenderError`].
pub fn render(job: &Job, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<Rendered, RenderError> {
    let (pt, view) = tracer_and_view(job)?;
    let start = std::time::Instant::now();
    let mut rendered = trace(&pt, &view, job.sampling, progress)?;
    if let Some(budget) = job.time_budget {
        // Later passes reuse the first pass's threshold (tuning is not repeated).
        let sampling = with_threshold(job.sampling, rendered.threshold);
        // Another pass starts only if it is expected to end within the budget
        // (as long as the last one took): the image is the complete passes'.
        let mut last = start.elapsed().as_secs_f64();
        let mut k = 1;
        while start.elapsed().as_secs_f64() + last <= budget {
            let t = std::time::Instant::now();
            let v = View { seed: pass_seed(job.seed, k), ..view };
            let next = trace(&pt, &v, &sampling, &|_, _| {})?;
            rendered.frame.pool(&next.frame);
            last = t.elapsed().as_secs_f64();
            k += 1;
        }
        rendered.passes = k;
    }
    if let (None, Some(oracle)) = (&rendered.map, job.maps) {
        rendered.map = Some(supersample::contrast_map(&pt, &view, oracle, &|_, _| {})?);
    }
    Ok(rendered)
}

/// The path tracer and the first pass's view of `job`, its camera checked.
fn tracer_and_view<'a>(job: &Job<'a>) -> Result<(PathTracer<'a>, View), RenderError> {
    let camera = views::check_camera(job.tracer, job.scene, job.prepared, job.camera)?;
    let sh = job.shading;
    let pt = PathTracer {
        tracer: job.tracer,
        prepared: job.prepared,
        surfaces: &sh.surfaces,
        lights: &sh.lights,
        max_depth: 256,
    };
    let (w, h) = job.size;
    Ok((pt, View { camera, width: w, height: h, seed: job.seed, rows: job.rows.unwrap_or((0, h)) }))
}

/// Simmons' priority values `p_c`, `p_d`, `p_v` (Part IV eqs. (2)–(4),
/// colour weight `delta`) of the 8-spp oracle pass that [`render`]'s maps
/// come from (`job.seed`, every row): see [`first_hit`].
///
/// # Errors
/// [`RenderError`].
pub fn priority_map(job: &Job, delta: f64) -> Result<PriorityMap, RenderError> {
    let (pt, view) = tracer_and_view(job)?;
    Ok(first_hit::priority_map(&pt, &view, delta, &|_, _| {})?)
}

/// `sampling` with its threshold fixed to `t` (samplers that tune one).
fn with_threshold(sampling: &Sampling, t: Option<f64>) -> Sampling {
    match *sampling {
        Sampling::Adaptive { criterion, spp, max, unbiased, threshold } => {
            Sampling::Adaptive { criterion, spp, max, unbiased, threshold: threshold.or(t) }
        }
        Sampling::Tree { contrast, delta, spp, unbiased, threshold, node_samples } => {
            Sampling::Tree { contrast, delta, spp, unbiased, threshold: threshold.or(t), node_samples }
        }
        other => other,
    }
}

/// One pass of `sampling` over `view`: a threshold tuned first where the
/// sampler needs one, then the pixel loop ([`sampler::render`]).
fn trace(
    pt: &PathTracer,
    view: &View,
    sampling: &Sampling,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Rendered, RenderError> {
    let plain = |frame| Rendered { frame, threshold: None, tuned: None, map: None, passes: 1 };
    match *sampling {
        Sampling::Uniform(n) => Ok(plain(sampler::render(pt, view, &Batches(Uniform(n)), progress)?.0)),
        Sampling::Neighbours(a) => Ok(plain(sampler::render(pt, view, &a, progress)?.0)),
        Sampling::Adaptive { criterion, spp, max, unbiased, threshold } => {
            let make = |eps| Batches(Adaptive { criterion, threshold: eps, max, unbiased });
            let (threshold, tuned) = tuned(pt, view, threshold, spp, make)?;
            let (frame, ()) = sampler::render(pt, view, &make(threshold), progress)?;
            Ok(Rendered { threshold: Some(threshold), tuned, ..plain(frame) })
        }
        Sampling::Tree { contrast, delta, spp, unbiased, threshold, node_samples } => {
            let make = |eps| Tree { threshold: eps, unbiased, contrast, delta, node_samples };
            let (threshold, tuned) = tuned(pt, view, threshold, spp, make)?;
            let (frame, ()) = sampler::render(pt, view, &make(threshold), progress)?;
            Ok(Rendered { threshold: Some(threshold), tuned, ..plain(frame) })
        }
        Sampling::Supersample(es) => {
            let (frame, plan) = sampler::render(pt, view, &es, progress)?;
            Ok(Rendered { map: Some(plan.map), ..plain(frame) })
        }
    }
}

/// The threshold `given`, or one tuned so that `make(ε)` spends `spp` rays
/// a pixel on average, with the tuning run.
fn tuned<S: PixelSampler>(
    pt: &PathTracer,
    view: &View,
    given: Option<f64>,
    spp: u32,
    make: impl Fn(f64) -> S,
) -> Result<(f64, Option<Tuned>), RenderError> {
    match given {
        Some(t) => Ok((t, None)),
        None => {
            let t = tune::tune(pt, view, f64::from(spp), make)?;
            Ok((t.threshold, Some(t)))
        }
    }
}
