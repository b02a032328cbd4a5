//! Viewpoint-driven mesh simplification (tutorial Part VII; Castelló,
//! Sbert, Chover, Feixas, Computers & Graphics 2008): half-edge collapses
//! `u → v` taken greedily in the order of the smallest change of what the
//! viewpoints see, measured on the viewpoint channel `V → O` of Part V.
//!
//! * [`mesh`]: the welded, manifold [`IndexedMesh`] and its checks;
//! * [`collapse`]: the mesh under collapses, the link condition, boundary
//!   rules and the fold-over test;
//! * [`cost`]: the channel's weights with running sums, so that a collapse
//!   is priced and applied by updating the triangles around it only, the
//!   measures from `itgfx-core` ([`Metric::Vmi`]: `|ΔI(V;O)|`,
//!   [`Metric::Ve`]: the mean `|ΔH(O|v)|`, [`Metric::Vkl`]: the mean `|ΔKL_v|`);
//! * [`metrics`]: what a user checks afterwards: image RMSE over views the
//!   simplifier did not use, and the symmetric Hausdorff distance.
//!
//! The channel is traced ([`ViewpointChannel::build_solid_angle`]) on the
//! input and again each time the triangle count has fallen by
//! [`Settings::refresh`]; in between, moved triangles inherit the visible
//! fraction of the triangles they replace. Costs are recomputed for the
//! half-edges leaving the vertices around each collapse; the others keep the
//! cost of their last evaluation (the running sums have moved on since, as
//! in every greedy collapse scheme). The result does not depend on the
//! number of threads: costs are pure functions, ties are broken by vertex
//! index, and the collapses are applied in one sequence.

pub mod collapse;
pub mod cost;
pub mod mesh;
pub mod metrics;

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

pub use collapse::Dynamic;
pub use cost::{Metric, ViewState};
pub use mesh::{IndexedMesh, MeshError, Repairs};

use crate::backend::{BackendChoice, BackendError, open};
use crate::viewpoint::solid_angle::{ChannelError, Refinement};
use crate::viewpoint::{ViewpointChannel, ViewpointWeights};

/// How to simplify.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The collapse cost.
    pub metric: Metric,
    /// Viewpoint directions (unit vectors).
    pub directions: Vec<DVec3>,
    /// Viewpoint distance in bounding-sphere radii.
    pub distance: f64,
    /// Backend that traces the channel.
    pub backend: BackendChoice,
    /// Trace the channel again once the triangles fall to this fraction of
    /// their number at the last trace (in `(0, 1)`).
    pub refresh: f64,
    /// Relative VMI tolerance of each traced channel (see [`Refinement`]).
    pub tolerance: f64,
    /// Largest subdivision of triangles where visibility changes.
    pub max_subdivision: u32,
    /// Count the background as a polygon (Part V §3.1).
    pub background: bool,
}

/// The mesh when the simplification reached (or stopped short of) a target.
#[derive(Clone, Debug)]
pub struct Stage {
    /// Triangles asked for.
    pub target: usize,
    /// The simplified mesh.
    pub mesh: IndexedMesh,
    /// Seconds since the start (channel tracing included).
    pub seconds: f64,
    /// CPU seconds of the process (all threads) since the start, where the
    /// system tells them (Linux): on a loaded machine the fairer time.
    pub cpu_seconds: Option<f64>,
    /// `I(V;O)` in bits of the channel as updated (inherited visibility).
    pub mutual_information: f64,
    /// Why the target was not reached, if it was not.
    pub stalled: Option<String>,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// One stage per target, largest first.
    pub stages: Vec<Stage>,
    /// Collapses applied.
    pub collapses: u64,
    /// Channels traced.
    pub traces: u32,
    /// Seconds spent tracing channels.
    pub trace_seconds: f64,
    /// `I(V;O)` in bits of the input's traced channel.
    pub initial_mutual_information: f64,
}

/// Why a simplification failed.
#[derive(Debug, Clone, PartialEq)]
pub enum SimplifyError {
    /// Opening a backend or tracing failed.
    Backend(BackendError),
    /// The viewpoint channel could not be built (nothing seen).
    Channel(ChannelError),
    /// The channel's weights would not fit in memory.
    TooLarge {
        /// Bytes needed.
        bytes: u64,
    },
    /// The channel's weights are over what the process may use ([`crate::memory`]).
    Memory(crate::memory::OutOfMemory),
}

impl std::fmt::Display for SimplifyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SimplifyError::Backend(e) => e.fmt(f),
            SimplifyError::Channel(e) => e.fmt(f),
            SimplifyError::TooLarge { bytes } => write!(
                f,
                "the viewpoint weights need {:.1} GiB (more than {} GiB): fewer viewpoints need less",
                *bytes as f64 / f64::from(1u32 << 30),
                MAX_BYTES >> 30
            ),
            SimplifyError::Memory(e) => write!(f, "{e}: fewer viewpoints need less"),
        }
    }
}

impl std::error::Error for SimplifyError {}

/// Most bytes the channel's weights may take.
pub const MAX_BYTES: u64 = 2 << 30;

/// A half-edge `u → v` in the queue, cheapest first, then by vertices.
#[derive(Clone, Copy, Debug)]
struct Entry {
    cost: f64,
    u: u32,
    v: u32,
    stamp: u32,
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    /// Reversed, so the standard max-heap pops the cheapest.
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost.total_cmp(&self.cost).then(o.u.cmp(&self.u)).then(o.v.cmp(&self.v)).then(o.stamp.cmp(&self.stamp))
    }
}

/// Checks, before any work, that the channel's weights for `triangles`
/// triangles and `views` viewpoints fit in [`MAX_BYTES`] and in the memory
/// the process may use.
///
/// # Errors
/// [`SimplifyError::TooLarge`], [`SimplifyError::Memory`].
pub fn check_memory(triangles: usize, views: usize) -> Result<(), SimplifyError> {
    let bytes = ViewState::bytes(triangles, views);
    if bytes > MAX_BYTES {
        return Err(SimplifyError::TooLarge { bytes });
    }
    crate::memory::check(|| format!("the viewpoint weights of {triangles} triangles x {views} views"), bytes)
        .map_err(SimplifyError::Memory)
}

/// User and system CPU seconds of this process, all threads (Linux's
/// `/proc/self/stat`, in its fixed 100 Hz ticks); `None` elsewhere.
#[must_use]
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which may hold spaces) in parentheses.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let (user, system): (f64, f64) = (f.get(11)?.parse().ok()?, f.get(12)?.parse().ok()?);
    Some((user + system) / 100.0)
}

/// Traces the channel of the living triangles.
pub(crate) fn trace(d: &Dynamic, s: &Settings) -> Result<ViewState, SimplifyError> {
    let live: Vec<u32> = (0..d.faces.len() as u32).filter(|&f| d.alive[f as usize]).collect();
    check_memory(d.faces.len(), s.directions.len())?;
    let mesh =
        IndexedMesh { positions: d.positions.clone(), faces: live.iter().map(|&f| d.faces[f as usize]).collect() };
    let prepared = mesh.prepared();
    let tracer = open(s.backend, &prepared).map_err(SimplifyError::Backend)?;
    let refine = Refinement {
        distance: s.distance,
        tolerance: s.tolerance,
        first: Refinement::default().first.min(s.max_subdivision),
        max: s.max_subdivision,
        weights: ViewpointWeights::ProjectedArea,
        background: false,
    };
    let (ch, _) =
        ViewpointChannel::build_solid_angle(&prepared, tracer.as_ref(), &s.directions, &refine, &mut |_, _| {})
            .map_err(SimplifyError::Channel)?;
    Ok(ViewState::from_channel(&ch, d, &live, s.background))
}

/// Evaluates every valid half-edge leaving the vertices `from`.
fn evaluate(d: &Dynamic, state: &ViewState, metric: Metric, from: &[u32], stamps: &[u32]) -> Vec<Entry> {
    from.par_iter()
        .flat_map_iter(|&u| {
            d.neighbours(u).into_iter().filter_map(move |v| {
                let change = d.check(u, v)?;
                let p = state.propose(d, u, v, &change, metric);
                p.cost.is_finite().then_some(Entry { cost: p.cost, u, v, stamp: stamps[u as usize] })
            })
        })
        .collect()
}

/// Simplifies `mesh` (welded, manifold, normalised frame) down to each of
/// `targets` triangles in turn (largest first), greedily by the cost of
/// [`Settings::metric`]. `progress(done, total)` counts collapses.
///
/// # Errors
/// [`SimplifyError`] from tracing the channel.
pub fn simplify(
    mesh: &IndexedMesh,
    targets: &[usize],
    s: &Settings,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Outcome, SimplifyError> {
    let t0 = Instant::now();
    let cpu0 = process_cpu_seconds();
    let cpu = || Some(process_cpu_seconds()? - cpu0?);
    let mut targets = targets.to_vec();
    targets.sort_unstable_by(|a, b| b.cmp(a));
    let mut d = Dynamic::new(mesh);
    let mut stamps = vec![0u32; d.positions.len()];
    let all: Vec<u32> = (0..d.positions.len() as u32).collect();
    let total = (d.live - targets.last().copied().unwrap_or(d.live).min(d.live)) as u64;
    let start = d.live;
    let t_trace = Instant::now();
    let mut state = trace(&d, s)?;
    let mut trace_seconds = t_trace.elapsed().as_secs_f64();
    let mut traces = 1;
    let initial = state.mutual_information();
    let mut heap: BinaryHeap<Entry> = evaluate(&d, &state, s.metric, &all, &stamps).into();
    let mut last_trace = d.live;
    let mut stages = Vec::new();
    let mut collapses = 0u64;
    let mut refilled = false;
    let mut ti = 0;
    while ti < targets.len() {
        if d.live <= targets[ti] {
            stages.push(Stage {
                target: targets[ti],
                mesh: d.snapshot(),
                seconds: t0.elapsed().as_secs_f64(),
                cpu_seconds: cpu(),
                mutual_information: state.mutual_information(),
                stalled: None,
            });
            ti += 1;
            continue;
        }
        if (d.live as f64) <= s.refresh * last_trace as f64 {
            let t = Instant::now();
            state = trace(&d, s)?;
            trace_seconds += t.elapsed().as_secs_f64();
            traces += 1;
            stamps.iter_mut().for_each(|x| *x = x.wrapping_add(1));
            heap = evaluate(&d, &state, s.metric, &all, &stamps).into();
            last_trace = d.live;
        }
        let Some(e) = heap.pop() else {
            if refilled {
                let why = format!(
                    "stopped at {} triangles: no collapse keeps the surface manifold without folding a triangle over",
                    d.live
                );
                for &target in &targets[ti..] {
                    stages.push(Stage {
                        target,
                        mesh: d.snapshot(),
                        seconds: t0.elapsed().as_secs_f64(),
                        cpu_seconds: cpu(),
                        mutual_information: state.mutual_information(),
                        stalled: Some(why.clone()),
                    });
                }
                break;
            }
            refilled = true;
            heap = evaluate(&d, &state, s.metric, &all, &stamps).into();
            continue;
        };
        if stamps[e.u as usize] != e.stamp {
            continue;
        }
        let Some(change) = d.check(e.u, e.v) else { continue };
        let p = state.propose(&d, e.u, e.v, &change, s.metric);
        state.apply(&change, &p);
        d.apply(e.u, e.v, &change);
        collapses += 1;
        refilled = false;
        let mut ring = d.neighbours(e.v);
        ring.push(e.v);
        for &w in &ring {
            stamps[w as usize] = stamps[w as usize].wrapping_add(1);
        }
        stamps[e.u as usize] = stamps[e.u as usize].wrapping_add(1);
        heap.extend(evaluate(&d, &state, s.metric, &ring, &stamps));
        if collapses.is_multiple_of(256) {
            progress((start - d.live) as u64, total);
        }
    }
    progress(total, total);
    Ok(Outcome { stages, collapses, traces, trace_seconds, initial_mutual_information: initial })
}
