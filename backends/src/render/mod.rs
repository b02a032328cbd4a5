//! A path tracer driven by the pixel criteria of Part IV (adaptive
//! sampling) and Part III-IV §5 (f-divergence criteria).
//!
//! * [`path`]: the path tracer itself (next-event estimation with MIS,
//!   mirrors, Russian roulette), traced as a wavefront through the
//!   [`Tracer`] seam, so every backend renders the same way.
//! * [`criteria`]: the refinement criteria, each a call into
//!   `itgfx_core::pixel`; [`tree`]: the entropy refinement tree of Part IV
//!   §6; [`tune`]: thresholds for an equal average budget.
//! * [`frame`]: the image plane, stratified batches per pixel, rows in
//!   parallel, the same image for any thread count.
//! * [`lights`]: area lights and materials; [`views`]: default cameras and
//!   the camera-inside-an-object check; [`room`]: the `mirror-room` scene.
//!
//! Radiance is linear RGB in f64; the criteria read the luminance `Y` of
//! linear sRGB (Part III-IV §5.1) or the channels.

pub mod criteria;
pub mod frame;
pub mod lights;
pub mod path;
pub mod room;
pub mod shard_file;
pub mod supersample;
pub mod tree;
pub mod tune;
pub mod views;

use std::fmt;

use crate::camera::Camera;
use crate::scene::Scene;
use crate::tracer::{BackendError, Prepared, Tracer};
pub use criteria::{Adaptive, Criterion};
pub use frame::{Frame, Policy, Uniform, View};
pub use lights::{Lights, Surfaces};
pub use path::PathTracer;
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
    },
    /// Entropy-based supersampling of Part IV §5.
    Supersample(Supersampling),
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
}

/// Renders `scene` seen by `camera` (scene units): checks the camera, tunes
/// an adaptive sampler's threshold to its budget, then traces. With `maps`,
/// also the quality and contrast maps of an 8-spp pass (the supersampler's
/// own oracle pass, so no extra rays for `Sampling::Supersample`). With
/// `rows = (first, end)`, only those rows are traced (a shard: the frame
/// holds them alone; thresholds are tuned on the whole image's pilot, and
/// `es` traces the whole oracle, so every shard decides as the whole run).
/// `progress` gets (rows done, rows).
///
/// # Errors
/// [`RenderError`].
#[allow(clippy::too_many_arguments)]
pub fn render(
    tracer: &dyn Tracer,
    scene: &Scene,
    prepared: &Prepared,
    shading: &Shading,
    camera: &Camera,
    size: (u32, u32),
    seed: u64,
    sampling: &Sampling,
    maps: Option<Oracle>,
    rows: Option<(u32, u32)>,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Rendered, RenderError> {
    let camera = views::check_camera(tracer, scene, prepared, camera)?;
    let pt = PathTracer { tracer, prepared, surfaces: &shading.surfaces, lights: &shading.lights, max_depth: 256 };
    let view = View { camera, width: size.0, height: size.1, seed, rows: rows.unwrap_or((0, size.1)) };
    let mut rendered = trace(&pt, &view, sampling, progress)?;
    if let (None, Some(oracle)) = (&rendered.map, maps) {
        rendered.map = Some(supersample::contrast_map(&pt, &view, oracle, &|_, _| {})?);
    }
    Ok(rendered)
}

fn trace(
    pt: &PathTracer,
    view: &View,
    sampling: &Sampling,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Rendered, RenderError> {
    let view = *view;
    match *sampling {
        Sampling::Uniform(n) => Ok(Rendered {
            frame: frame::render(pt, &view, &Uniform(n), progress)?,
            threshold: None,
            tuned: None,
            map: None,
        }),
        Sampling::Adaptive { criterion, spp, max, unbiased, threshold } => {
            let tuned = match threshold {
                Some(_) => None,
                None => Some(tune::tune(pt, &view, criterion, f64::from(spp), max, unbiased)?),
            };
            let threshold = threshold.or(tuned.map(|t| t.threshold)).unwrap_or(0.0);
            let policy = Adaptive { criterion, threshold, max, unbiased };
            Ok(Rendered {
                frame: frame::render(pt, &view, &policy, progress)?,
                threshold: Some(threshold),
                tuned,
                map: None,
            })
        }
        Sampling::Tree { contrast, delta, spp, unbiased, threshold } => {
            let tuned = match threshold {
                Some(_) => None,
                None => Some(tune::tune_policy(pt, &view, f64::from(spp), &|eps| {
                    Box::new(Tree { threshold: eps, unbiased, contrast, delta })
                })?),
            };
            let threshold = threshold.or(tuned.map(|t| t.threshold)).unwrap_or(0.0);
            let frame = frame::render(pt, &view, &Tree { threshold, unbiased, contrast, delta }, progress)?;
            Ok(Rendered { frame, threshold: Some(threshold), tuned, map: None })
        }
        Sampling::Supersample(es) => {
            let (frame, map) = supersample::render(pt, &view, &es, progress)?;
            Ok(Rendered { frame, threshold: None, tuned: None, map: Some(map) })
        }
    }
}
