//! A simplification as one job (`itgfx simplify`): planned before any
//! work (the channel's weights, [`ViewState::bytes`](super::ViewState::bytes), checked against
//! [`MAX_BYTES`](super::MAX_BYTES) and the memory budget by
//! [`check_memory`]), then run: the input rendered from the evaluation
//! views, the collapses down to every target ([`simplify`]) or the mesh
//! given to evaluate, and each resulting mesh measured against the input
//! ([`image_error`], [`surface_distance`]). The CLI words and writes what
//! it returns.

use std::fmt;

use glam::DVec3;

use super::metrics::{ImageError, Render, SurfaceDistance, image_error, render, surface_distance};
use super::{IndexedMesh, Settings, SimplifyError, check_memory, simplify};
use crate::backend::{BackendChoice, BackendError};

/// What the job makes of the input.
#[derive(Clone, Debug)]
pub enum Work {
    /// Simplify down to each of `targets` triangles (largest first).
    Simplify {
        /// Triangle counts, each below the input's.
        targets: Vec<usize>,
        /// The collapses' cost, placement and channel.
        settings: Settings,
    },
    /// Measure a mesh simplified elsewhere, named `label`.
    Evaluate {
        /// Its name in the results.
        label: String,
        /// The mesh, in the input's normalised frame.
        mesh: IndexedMesh,
    },
}

/// How each result is measured against the input.
#[derive(Clone, Debug)]
pub struct Evaluation {
    /// Eyes of the renders, in the input's normalised frame (none a
    /// channel viewpoint: [`super::metrics::evaluation_directions`]).
    pub eyes: Vec<DVec3>,
    /// Pixels per side of each render.
    pub image_size: u32,
    /// Points sampled on each surface for the distances.
    pub samples: usize,
    /// Renders of each result kept in it (the first ones), for pictures.
    pub kept: usize,
    /// The backend that renders.
    pub backend: BackendChoice,
}

/// A simplification job over `input` (welded, repaired, normalised frame).
#[derive(Clone, Debug)]
pub struct SimplifyJob<'a> {
    /// The mesh the collapses start from and results are measured against.
    pub input: &'a IndexedMesh,
    /// Simplify or evaluate.
    pub work: Work,
    /// The measurements.
    pub evaluation: Evaluation,
}

/// A mesh the job made (a target's stage) or was given (to evaluate).
#[derive(Clone, Debug)]
pub struct Made {
    /// The target's triangle count, or the evaluated mesh's label.
    pub label: String,
    /// The mesh.
    pub mesh: IndexedMesh,
    /// Seconds from the start of the collapses (0 when evaluated).
    pub seconds: f64,
    /// CPU seconds of the process from the start of the collapses.
    pub cpu_seconds: Option<f64>,
    /// `I(V;O)` in bits of the channel as updated (none when evaluated).
    pub mutual_information: Option<f64>,
    /// Why the target was not reached, if it was not.
    pub stalled: Option<String>,
}

/// One mesh measured against the input.
#[derive(Clone, Debug)]
pub struct Measured {
    /// The mesh and how it was made.
    pub made: Made,
    /// Image RMSE against the input's renders.
    pub error: ImageError,
    /// Surface distances to the input.
    pub distance: SurfaceDistance,
    /// The first [`Evaluation::kept`] renders.
    pub renders: Vec<Render>,
}

/// What the collapses did (none when a mesh is evaluated).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collapsed {
    /// `I(V;O)` in bits of the input's traced channel.
    pub initial_mutual_information: f64,
    /// Collapses applied.
    pub collapses: u64,
    /// Channels traced.
    pub traces: u32,
    /// Seconds spent tracing channels.
    pub trace_seconds: f64,
}

/// What a job returns.
#[derive(Clone, Debug)]
pub struct JobOutcome {
    /// The input's first [`Evaluation::kept`] renders.
    pub reference: Vec<Render>,
    /// The collapses, when simplifying.
    pub collapsed: Option<Collapsed>,
    /// Each result, largest first.
    pub results: Vec<Measured>,
}

/// Why a job failed.
#[derive(Debug, Clone, PartialEq)]
pub enum JobError {
    /// Rendering for the evaluation failed.
    Render(BackendError),
    /// The simplification failed (or its memory check refused it).
    Simplify(SimplifyError),
}

impl fmt::Display for JobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            JobError::Render(e) => e.fmt(f),
            JobError::Simplify(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for JobError {}

impl SimplifyJob<'_> {
    /// Checks, before any work, that the channel's weights fit
    /// ([`check_memory`]); an evaluation traces no channel.
    ///
    /// # Errors
    /// [`SimplifyError::TooLarge`] or [`SimplifyError::Memory`].
    pub fn plan(&self) -> Result<(), SimplifyError> {
        match &self.work {
            Work::Simplify { settings, .. } => check_memory(self.input.triangles(), settings.directions.len()),
            Work::Evaluate { .. } => Ok(()),
        }
    }

    /// Plans ([`SimplifyJob::plan`]), renders the input, makes the results
    /// (`progress(done, total)` counts collapses) and measures each.
    ///
    /// # Errors
    /// The first failure.
    pub fn run(self, progress: &mut dyn FnMut(u64, u64)) -> Result<JobOutcome, JobError> {
        self.plan().map_err(JobError::Simplify)?;
        let ev = &self.evaluation;
        let reference = render(self.input, ev.backend, &ev.eyes, ev.image_size).map_err(JobError::Render)?;
        let (collapsed, made) = match self.work {
            Work::Evaluate { label, mesh } => {
                let m = Made { label, mesh, seconds: 0.0, cpu_seconds: None, mutual_information: None, stalled: None };
                (None, vec![m])
            }
            Work::Simplify { targets, settings } => {
                let o = simplify(self.input, &targets, &settings, progress).map_err(JobError::Simplify)?;
                let c = Collapsed {
                    initial_mutual_information: o.initial_mutual_information,
                    collapses: o.collapses,
                    traces: o.traces,
                    trace_seconds: o.trace_seconds,
                };
                let stages = o.stages.into_iter().map(|s| Made {
                    label: s.target.to_string(),
                    mesh: s.mesh,
                    seconds: s.seconds,
                    cpu_seconds: s.cpu_seconds,
                    mutual_information: Some(s.mutual_information),
                    stalled: s.stalled,
                });
                (Some(c), stages.collect::<Vec<_>>())
            }
        };
        let mut results = Vec::with_capacity(made.len());
        for made in made {
            let mut renders = render(&made.mesh, ev.backend, &ev.eyes, ev.image_size).map_err(JobError::Render)?;
            let error = image_error(&reference, &renders);
            let distance = surface_distance(self.input, &made.mesh, ev.samples, 1);
            renders.truncate(ev.kept);
            results.push(Measured { made, error, distance, renders });
        }
        let mut reference = reference;
        reference.truncate(ev.kept);
        Ok(JobOutcome { reference, collapsed, results })
    }
}
