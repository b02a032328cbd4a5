//! A render as one job (`itgfx render`), as
//! [`CountsMerge`](crate::visibility::merge_job::CountsMerge) is a merge of
//! counts: its [`Settings`], built once from the arguments (pbrt-v4's and
//! Mitsuba 3's scene description: one struct, not a dozen parameters),
//! planned before any work (the sampler chosen by name, the memory the
//! run will hold at its peak against the budget of [`crate::memory`], a
//! shard's rows), then run ([`RenderJob::run`]: the scene's lights, the
//! backend, the camera, the time-budget loop of [`super::render`], the
//! priority maps, the shard file).

use std::fmt;
use std::time::Instant;

use super::shard_file::{MeshFingerprint, RenderSettings, RenderShard, shard_rows};
use super::{
    AdaptiveSampling, Criterion, Job, Oracle, PriorityMap, RenderError, Rendered, Sampling, Shading, Supersampling,
    TreeContrast, tree, views,
};
use crate::backend::{BackendChoice, open};
use crate::camera::Camera;
use crate::memory::OutOfMemory;
use crate::scene::Scene;
use crate::shards::Place;
use crate::tracer::Prepared;

/// Most samples a pixel may take on average, and the cap of an adaptive
/// pixel's samples.
pub const MAX_SPP: u32 = 1 << 16;

/// The samples an adaptive pixel may take unless capped: 16 × the average.
const CAP_FACTOR: u32 = 16;

/// Nodes of a full refinement tree of [`tree`]'s 4 levels (1 + 4 + 16 + 64).
const TREE_NODES: u64 = 85;

/// Simmons' colour weight of the priority `p_v` (Part IV eq. (4)), unless δ is given.
const SIMMONS_DELTA: f64 = 0.9;

/// Bytes a pixel holds at the peak, a bound on the measured: the frame
/// (radiance, variance, counts: 56 B), the rows' values before they are
/// gathered into it (64 B), the EXR's and PNG's copies, and what the
/// allocator keeps of the freed ones. Peak resident memory less an 8×8
/// run's, `cornell-box --spp 1 --threads 2`: 117 B a pixel at 1024², 181 B
/// at 1448² and 160 B at 2048² (docs/RENDER.md); 224 bounds them by 24%.
const PIXEL_BYTES: u64 = 224;
/// More for `adaptive`, which keeps each pixel's pilot sums, weight and
/// share: measured 190 B a pixel in all at 1024², 162 B at 2048² (`--spp 8`).
const ADAPTIVE_PIXEL_BYTES: u64 = 80;
/// Bytes per sample of the row a worker renders at once (the samples'
/// radiance and the paths' starts): measured 36 B (`--size 2048x2 --spp 4096`).
const SAMPLE_BYTES: u64 = 48;

/// What one render is asked to do: the sampler (by name and its
/// parameters), the image, the seed, the camera, a shard, a time budget.
/// Built once from the command line; the sampler ([`Settings::sampling`]),
/// the memory estimate ([`Settings::memory`]) and the shard file's
/// settings ([`Settings::shard_settings`]) all derive from it.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The pixel sampler's name: `uniform`, `adaptive`, `es`, a tree
    /// ([`TreeContrast`]) or a batch criterion ([`Criterion`]).
    pub sampler: String,
    /// Samples a pixel (uniform), or the rays a pixel traces on average,
    /// decisions included (adaptive samplers).
    pub spp: u32,
    /// Cap on an adaptive pixel's samples (default 16 × `spp`, at most [`MAX_SPP`]).
    pub max_spp: Option<u32>,
    /// A given threshold instead of one tuned to the budget.
    pub threshold: Option<f64>,
    /// The tutorial's biased form (decision samples in the image).
    pub tutorial_form: bool,
    /// Colour weight δ against geometry (Part IV eqs. (23), (28)); with
    /// `maps`, also the priority's colour weight (eq. (4)).
    pub delta: Option<f64>,
    /// The binary colour contrast (Part IV eq. (19)) in the oracle.
    pub binary_contrast: bool,
    /// Samples per tree node `N_s^r` ([`tree::NODE_SAMPLES`] unless given).
    pub node_samples: Option<u32>,
    /// Also the quality, contrast and priority maps of an 8-spp pass.
    pub maps: bool,
    /// Image width and height in pixels.
    pub size: (u32, u32),
    /// Seed of the first pass.
    pub seed: u64,
    /// The camera in scene units; `None`: the scene's default
    /// ([`views::default_camera`]).
    pub camera: Option<Camera>,
    /// Only this shard's rows ([`shard_rows`]).
    pub shard: Option<Place>,
    /// Passes until this many seconds have passed.
    pub time_budget: Option<f64>,
}

impl Settings {
    /// Whether the sampler adapts (anything but `uniform`).
    #[must_use]
    pub fn adaptive(&self) -> bool {
        self.sampler != "uniform"
    }

    /// δ as the samplers take it: 1 (colour only) unless given.
    #[must_use]
    pub fn delta(&self) -> f64 {
        self.delta.unwrap_or(1.0)
    }

    /// The cap on an adaptive pixel's samples.
    fn cap(&self) -> u32 {
        self.max_spp.unwrap_or(self.spp.saturating_mul(CAP_FACTOR).min(MAX_SPP))
    }

    /// The oracle of `es` and of the maps.
    fn oracle(&self) -> Oracle {
        Oracle { delta: self.delta(), binary: self.binary_contrast }
    }

    /// The pixel sampler the settings name.
    #[must_use]
    pub fn sampling(&self) -> Sampling {
        let unbiased = !self.tutorial_form;
        match (Criterion::from_name(&self.sampler), TreeContrast::from_name(&self.sampler)) {
            (None, Some(contrast)) => Sampling::Tree {
                contrast,
                delta: self.delta(),
                spp: self.spp,
                unbiased,
                threshold: self.threshold,
                node_samples: self.node_samples.unwrap_or(tree::NODE_SAMPLES),
            },
            (None, None) if self.sampler == "es" => {
                Sampling::Supersample(Supersampling { oracle: self.oracle(), spp: self.spp, max: self.cap(), unbiased })
            }
            (None, None) if self.sampler == "adaptive" => {
                Sampling::Neighbours(AdaptiveSampling { spp: self.spp, max: self.cap() })
            }
            (None, None) => Sampling::Uniform(self.spp),
            (Some(criterion), _) => {
                Sampling::Adaptive { criterion, spp: self.spp, max: self.cap(), unbiased, threshold: self.threshold }
            }
        }
    }

    /// The rows `[first, end)` the run renders: a shard's, else all.
    #[must_use]
    pub fn rows(&self) -> Option<(u32, u32)> {
        self.shard.map(|s| shard_rows(s.index, s.count, self.size.1))
    }

    /// The most samples a pixel holds at once while its row is rendered:
    /// `spp` (uniform), a full tree's 85 nodes of `N_s^r` (the trees), else
    /// the cap.
    #[must_use]
    pub fn samples_held(&self) -> u64 {
        match self.sampling() {
            Sampling::Uniform(n) => u64::from(n),
            Sampling::Tree { node_samples, .. } => TREE_NODES * u64::from(node_samples),
            _ => u64::from(self.cap()),
        }
    }

    /// A bound on the memory the run holds at its peak, beyond the program
    /// and the scene, on `workers` threads: 224 bytes a pixel (304 for
    /// `adaptive`) and 48 bytes a sample of the row each worker holds at
    /// once ([`Settings::samples_held`]), each a bound on the peak resident
    /// memory measured at two sizes (see the constants).
    #[must_use]
    pub fn memory(&self, workers: usize) -> u64 {
        let (w, h) = (u64::from(self.size.0), u64::from(self.size.1));
        let pixel = PIXEL_BYTES + if self.sampler == "adaptive" { ADAPTIVE_PIXEL_BYTES } else { 0 };
        let rows = (workers as u64).min(h);
        (w * h * pixel).saturating_add(rows.saturating_mul(w).saturating_mul(self.samples_held()) * SAMPLE_BYTES)
    }

    /// [`Settings::memory`] checked against the budget, before anything is
    /// loaded or traced; returns the estimate.
    ///
    /// # Errors
    /// [`OutOfMemory`] naming the image and its samples.
    pub fn plan(&self, workers: usize) -> Result<u64, OutOfMemory> {
        let need = self.memory(workers);
        let (w, h, n) = (self.size.0, self.size.1, self.samples_held());
        crate::memory::check(|| format!("{w} x {h} at up to {n} samples a pixel"), need)?;
        Ok(need)
    }

    /// The settings a shard's pixels depend on, for the shard file: the
    /// camera in scene units, and the backend's name.
    #[must_use]
    pub fn shard_settings(&self, camera: &Camera, backend: &str) -> RenderSettings {
        let sampling = self.sampling();
        let max_spp = match sampling {
            Sampling::Adaptive { max, .. } | Sampling::Neighbours(AdaptiveSampling { max, .. }) => max,
            Sampling::Supersample(es) => es.max,
            _ => 0,
        };
        let (e, f, u) = (camera.eye, camera.forward, camera.up);
        RenderSettings {
            sampler: self.sampler.clone(),
            spp: self.spp,
            max_spp,
            threshold: self.threshold,
            unbiased: self.adaptive() && !self.tutorial_form,
            delta: self.delta(),
            binary_contrast: self.binary_contrast,
            node_samples: if let Sampling::Tree { node_samples, .. } = sampling { node_samples } else { 0 },
            width: self.size.0,
            height: self.size.1,
            seed: self.seed,
            camera: [e.x, e.y, e.z, f.x, f.y, f.z, u.x, u.y, u.z, camera.fov_y],
            backend: backend.to_string(),
        }
    }
}

/// One render of a scene with a backend.
#[derive(Clone, Copy)]
pub struct RenderJob<'a> {
    /// What to render and how.
    pub settings: &'a Settings,
    /// The scene.
    pub scene: &'a Scene,
    /// The tracing backend.
    pub backend: BackendChoice,
}

/// A finished render.
pub struct Outcome {
    /// The frame and how its sampler was set.
    pub rendered: Rendered,
    /// The sampler that ran.
    pub sampling: Sampling,
    /// The camera, in scene units.
    pub camera: Camera,
    /// The backend's name.
    pub backend: &'static str,
    /// Simmons' priorities of the maps' pass (with `maps`).
    pub priority: Option<PriorityMap>,
    /// The shard file of the rows (with `shard`).
    pub shard: Option<RenderShard>,
    /// Seconds the render took (not the maps' priorities).
    pub seconds: f64,
}

/// Why a render job stopped.
#[derive(Debug)]
pub enum JobError {
    /// Before tracing: the scene's lights and materials, or the backend
    /// (the messages name the scene or backend).
    Setup(RenderError),
    /// While tracing (the camera's check, the backend).
    Render(RenderError),
}

impl fmt::Display for JobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Setup(e) | Self::Render(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for JobError {}

impl RenderJob<'_> {
    /// Renders: the scene's lights, the backend, the camera (the
    /// settings' or the scene's default), then [`super::render`] (a tuned
    /// threshold, the passes of a time budget); with `maps`, Simmons'
    /// priorities of the maps' pass (colour weight δ, else Simmons' 0.9 of
    /// eq. (4)); with `shard`, the shard file. `progress` gets (rows done,
    /// rows).
    ///
    /// # Errors
    /// [`JobError`].
    pub fn run(&self, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<Outcome, JobError> {
        let (st, scene) = (self.settings, self.scene);
        let prepared = Prepared::new(scene);
        let shading = Shading::new(scene, &prepared).map_err(JobError::Setup)?;
        let tracer = open(self.backend, &prepared).map_err(|e| JobError::Setup(RenderError::Backend(e)))?;
        let camera = st.camera.unwrap_or_else(|| views::default_camera(scene));
        let sampling = st.sampling();
        let job = Job {
            tracer: tracer.as_ref(),
            scene,
            prepared: &prepared,
            shading: &shading,
            camera: &camera,
            size: st.size,
            seed: st.seed,
            sampling: &sampling,
            maps: st.maps.then(|| st.oracle()),
            rows: st.rows(),
            time_budget: st.time_budget,
        };
        let t0 = Instant::now();
        let rendered = super::render(&job, progress).map_err(JobError::Render)?;
        let seconds = t0.elapsed().as_secs_f64();
        let priority = match (&rendered.map, st.maps) {
            (Some(_), true) => {
                Some(super::priority_map(&job, st.delta.unwrap_or(SIMMONS_DELTA)).map_err(JobError::Render)?)
            }
            _ => None,
        };
        let backend = tracer.name();
        let shard = st.shard.map(|s| {
            let fingerprint = MeshFingerprint::of(&scene.name, &prepared);
            let place = (s.index, s.count);
            RenderShard::new(
                fingerprint,
                st.shard_settings(&camera, backend),
                place,
                rendered.threshold,
                &rendered.frame,
            )
        });
        Ok(Outcome { rendered, sampling, camera, backend, priority, shard, seconds })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(sampler: &str, spp: u32) -> Settings {
        Settings {
            sampler: sampler.into(),
            spp,
            max_spp: None,
            threshold: None,
            tutorial_form: false,
            delta: None,
            binary_contrast: false,
            node_samples: None,
            maps: false,
            size: (1024, 512),
            seed: 1,
            camera: None,
            shard: None,
            time_budget: None,
        }
    }

    #[test]
    fn the_sampler_is_chosen_by_name_with_its_cap() {
        assert_eq!(settings("uniform", 64).sampling(), Sampling::Uniform(64));
        let Sampling::Adaptive { max, unbiased, threshold: None, .. } = settings("kl", 64).sampling() else {
            panic!("kl is a batch criterion")
        };
        assert_eq!((max, unbiased), (1024, true));
        assert_eq!(
            settings("adaptive", 8192).sampling(),
            Sampling::Neighbours(AdaptiveSampling { spp: 8192, max: MAX_SPP })
        );
        let Sampling::Supersample(es) = settings("es", 16).sampling() else { panic!("es supersamples") };
        assert_eq!((es.max, es.oracle.delta), (256, 1.0));
        let Sampling::Tree { node_samples, .. } = settings("ec", 16).sampling() else { panic!("ec is a tree") };
        assert_eq!(node_samples, tree::NODE_SAMPLES);
    }

    #[test]
    fn the_estimate_counts_every_pixel_and_each_worker_s_row_of_samples() {
        let (w, h) = (1024, 512);
        assert_eq!(settings("uniform", 4).memory(2), w * h * 224 + 2 * w * 4 * 48);
        assert_eq!(settings("adaptive", 8).memory(2), w * h * 304 + 2 * w * 128 * 48);
        assert_eq!(settings("ec", 16).memory(1), w * h * 224 + w * 85 * u64::from(tree::NODE_SAMPLES) * 48);
        // No more rows at once than the image has.
        let thin = Settings { size: (1024, 1), ..settings("uniform", 4) };
        assert_eq!(thin.memory(16), thin.memory(1));
        let st = Settings { shard: Some(Place { index: 1, count: 2 }), ..settings("uniform", 4) };
        assert_eq!(st.rows(), Some((256, 512)));
    }
}
