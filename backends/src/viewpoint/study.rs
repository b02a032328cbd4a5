//! A viewpoint study: every Part V result `itgfx viewpoints` reports, from a
//! built channel. Its two independent halves run side by side when the
//! channel is small (up to [`SIDE_BY_SIDE_ENTRIES`] entries): the entries'
//! logarithms (8 bytes an entry) and the reversed channel with its own
//! (20 bytes an entry) are then held at the same time. On a larger channel
//! they run one after the other: on the 1.1M-triangle bunny (67M entries)
//! side by side raised the peak from 3.79 to 4.49 GB for no shorter run
//! (53.05 against 52.92 s wall, idle, `/usr/bin/time`). The job behind the
//! command's run; the CLI only words and writes what it holds.

use itgfx_core::{Base, Error};

use super::ViewpointChannel;
use super::analysis::{ViewpointAnalysis, ViewpointMeasures, ViewpointWeights};
use super::saliency::{mesh_saliency, patch_adjacency, viewpoint_saliency};
use super::selection::{BestViews, Exploration, best_views, exploration, importance_information};
use crate::scene::Scene;

/// The most channel entries whose study runs its two halves side by side
/// (their extra tables, 28 bytes an entry, ~450 MB here). The run's memory
/// check (`shard_job::channel_memory`, 72 bytes for every viewpoint and
/// polygon) still bounds such a run: the 69k bunny at 162 viewpoints peaks
/// at 394 MB against ~0.8 GB estimated.
pub const SIDE_BY_SIDE_ENTRIES: u64 = 1 << 24;

/// What a study asks for besides the channel.
#[derive(Clone, Copy, Debug)]
pub struct StudySettings {
    /// `p(v)`: uniform or by projected area.
    pub weights: ViewpointWeights,
    /// The background counts as an extra polygon.
    pub background: bool,
    /// Best-n views stop once they capture this fraction of `I(V;O)`.
    pub capture: f64,
    /// At most this many best views.
    pub best_n: usize,
    /// Steps of the guided exploration from the best view.
    pub explore: usize,
    /// Logarithm base of every measure.
    pub base: Base,
}

/// The results of a study.
#[derive(Debug)]
pub struct Study {
    /// The channel's analysis (`p(v)`, `p(o)`, the rows).
    pub analysis: ViewpointAnalysis,
    /// VE, VMI, VKL, the heuristic and `I(V;O)` (Part V eqs. (1)-(7)).
    pub measures: ViewpointMeasures,
    /// Each viewpoint's instability against its 6 neighbours (Part V: stability).
    pub instability: Vec<f64>,
    /// The greedy best-n views (Part V: best view selection).
    pub best_n: BestViews,
    /// `I(o;V)` per polygon, from the reversed channel (Part V §3).
    pub polygonal_information: Vec<f64>,
    /// The polygons' adjacency (shared edges).
    pub adjacency: Vec<Vec<u32>>,
    /// Mesh saliency per polygon (Part V: saliency).
    pub saliency: Vec<f64>,
    /// Viewpoint saliency per viewpoint.
    pub view_saliency: Vec<f64>,
    /// Importance-driven VMI per viewpoint (saliency as the importance).
    pub importance: Vec<f64>,
    /// The guided exploration from the best view.
    pub tour: Exploration,
    /// Rays per viewpoint of the channel (grid estimator).
    pub rays_per_viewpoint: u64,
    /// Non-zero entries of the channel.
    pub channel_entries: u64,
}

impl Study {
    /// Runs the study of `scene`'s channel `ch`.
    ///
    /// # Errors
    /// The core's errors (an empty channel, a viewpoint that sees nothing).
    pub fn run(scene: &Scene, ch: ViewpointChannel, s: &StudySettings) -> Result<Self, Error> {
        let neighbours = ch.neighbours(6);
        let (rays_per_viewpoint, channel_entries) = (ch.rays_per_viewpoint, ch.patch.len() as u64);
        // Without the background the analysis takes the channel's rows over
        // (the same numbers as `new`, without a second copy of its entries).
        let analysis = if s.background {
            ViewpointAnalysis::new(&ch, s.weights, s.background)
        } else {
            ViewpointAnalysis::from_channel(ch, s.weights)
        }?;
        // Two independent halves (each value computed as alone, so the same
        // bits whatever runs where): the measures, the instability and the
        // best-n search on one side; the polygonal information, mesh
        // saliency and importance on the other. Each half has steps that run
        // on one thread (the core's passes over every entry, the reversed
        // channel's columns, the best-n search's clustering), which the other
        // half's parallel work overlaps when they run side by side.
        let areas = scene.areas();
        let an = &analysis;
        let selection = || -> Result<_, Error> {
            // One logarithm per channel entry, taken first: the measures'
            // passes read them instead of taking their own.
            let logs = an.entry_logs();
            let measures = an.measures_logs(&areas, s.base, &logs)?;
            // One logarithm per channel entry, shared by the instability
            // and the best-n search (each row meets many others).
            let instability = an.instability_logs(&neighbours, &logs, s.base)?;
            let best_n = best_views(an, &measures, s.capture, s.best_n, s.base, Some(&logs))?;
            drop(logs);
            let tour = exploration(an, &neighbours, measures.best, s.explore, s.base)?;
            Ok((measures, instability, best_n, tour))
        };
        let per_polygon = || -> Result<_, Error> {
            let (polygonal_information, adjacency) =
                rayon::join(|| an.polygonal_information(s.base), || patch_adjacency(scene));
            let polygonal_information = polygonal_information?;
            let saliency = mesh_saliency(an, &adjacency, s.base)?;
            let view_saliency = viewpoint_saliency(an, &saliency);
            let importance = importance_information(an, &saliency, s.base)?;
            Ok((polygonal_information, adjacency, saliency, view_saliency, importance))
        };
        let (selection, per_polygon) = if channel_entries <= SIDE_BY_SIDE_ENTRIES {
            rayon::join(selection, per_polygon)
        } else {
            (selection(), per_polygon())
        };
        let (measures, instability, best_n, tour) = selection?;
        let (polygonal_information, adjacency, saliency, view_saliency, importance) = per_polygon?;
        Ok(Self {
            analysis,
            measures,
            instability,
            best_n,
            polygonal_information,
            adjacency,
            saliency,
            view_saliency,
            importance,
            tour,
            rays_per_viewpoint,
            channel_entries,
        })
    }
}
