//! The viewpoint channel's jobs behind `itgfx viewpoints`: the memory a
//! run needs ([`channel_memory`], checked against the budget before the
//! tracer is built), a shard's rows traced and made into a
//! [`ViewpointShard`] ([`ViewpointShards::save`]), and the shards of a run
//! merged into the channel one process builds, bit for bit
//! ([`ViewpointShards::merge`]). The CLI parses the options, writes the
//! file and words the errors with its flags.

use std::fmt;
use std::path::PathBuf;

use glam::DVec3;

use super::ViewpointChannel;
use super::shard_file::{MeshFingerprint, ShardSettings, ViewpointShard, grid_channel, order_shards, shard_range};
use super::solid_angle::{ChannelError, Convergence, Refinement, ladder_levels};
use crate::memory::OutOfMemory;
use crate::scene::{Limits, Scene};
use crate::shards::{Place, ShardError};
use crate::tracer::{BackendError, Prepared, Tracer};

/// Bytes a channel entry (one viewpoint, one polygon seen) takes with the
/// per-view data behind it, at most: 72 (measured 66 between 42 and 162
/// viewpoints of `torus:512,256`, 6.4 M more entries for 399 MiB more
/// maximum RSS).
pub const BYTES_PER_ENTRY: u64 = 72;

/// Bytes a viewpoint run over `scene` from `views` viewpoints may need: the
/// scene's estimate ([`Limits::estimate_bytes`]) plus a channel entry
/// ([`BYTES_PER_ENTRY`]) for every viewpoint and polygon. A bound: at 42
/// viewpoints `torus:512,256` peaks at 320 MiB against 602 MiB estimated,
/// `torus:1024,256` at 560 MiB against 1.11 GiB (`/usr/bin/time -v`).
#[must_use]
pub fn channel_memory(scene: &Scene, views: usize) -> u64 {
    let (t, p) = (scene.triangles.len() as u64, scene.patches.len() as u64);
    Limits::estimate_bytes(t, p).saturating_add((views as u64).saturating_mul(p).saturating_mul(BYTES_PER_ENTRY))
}

/// Refuses, before the tracer and its BVH are built, a run whose
/// [`channel_memory`] is over what the process may use ([`crate::memory`]).
///
/// # Errors
/// [`OutOfMemory`] naming the scene and the viewpoints.
pub fn check_channel_memory(scene: &Scene, views: usize) -> Result<u64, OutOfMemory> {
    let need = channel_memory(scene, views);
    crate::memory::check(|| format!("{} at {views} viewpoints", scene.name), need)?;
    Ok(need)
}

/// How the rows are estimated.
#[derive(Clone, Copy, Debug)]
pub enum Estimator<'a> {
    /// The ray grid, `resolution²` rays per viewpoint.
    Grid {
        /// Rays per side.
        resolution: u32,
    },
    /// The solid angle, refined as `refine` says; a shard keeps the first
    /// `keep` levels of each ladder.
    SolidAngle {
        /// The refinement.
        refine: &'a Refinement,
        /// Levels a shard keeps.
        keep: usize,
    },
}

/// The channel of a viewpoint run over a scene, as shards.
#[derive(Clone, Copy)]
pub struct ViewpointShards<'a> {
    /// The scene's name.
    pub name: &'a str,
    /// The scene.
    pub prepared: &'a Prepared,
    /// What traces it.
    pub tracer: &'a dyn Tracer,
    /// Every viewpoint direction of the run.
    pub directions: &'a [DVec3],
    /// Viewpoint distance in bounding-sphere radii.
    pub distance: f64,
    /// The estimator.
    pub estimator: Estimator<'a>,
}

/// A shard made by [`ViewpointShards::save`].
#[derive(Clone, Debug)]
pub struct Saved {
    /// The shard, to be written.
    pub shard: ViewpointShard,
    /// Levels kept of each ladder (solid angle only).
    pub levels_saved: Option<usize>,
}

/// Why a shard could not be made or merged.
#[derive(Debug)]
pub enum ViewpointShardError {
    /// The ray grid's tracing failed.
    Trace(BackendError),
    /// The solid angle's tracing failed on the scene named.
    Ladders {
        /// The scene.
        scene: String,
        /// Why.
        error: BackendError,
    },
    /// The merged ladders make no channel.
    Channel {
        /// The scene.
        scene: String,
        /// Why.
        error: ChannelError,
    },
    /// A shard file is unreadable, foreign, duplicated or missing.
    Shard(ShardError),
    /// A merged viewpoint's eye is not where this run puts it.
    Eye {
        /// The viewpoint.
        viewpoint: usize,
    },
}

impl fmt::Display for ViewpointShardError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ViewpointShardError::Trace(e) => e.fmt(f),
            ViewpointShardError::Ladders { scene, error } => write!(f, "{scene}: {error}"),
            ViewpointShardError::Channel { scene, error } => write!(f, "{scene}: {error}"),
            ViewpointShardError::Shard(e) => e.fmt(f),
            ViewpointShardError::Eye { viewpoint } => {
                write!(f, "viewpoint {viewpoint}'s eye is not where this run puts it")
            }
        }
    }
}

impl std::error::Error for ViewpointShardError {}

impl ViewpointShards<'_> {
    /// The settings the rows depend on.
    #[must_use]
    pub fn settings(&self) -> ShardSettings {
        let (estimator, levels, resolution) = match self.estimator {
            Estimator::Grid { resolution } => ("grid", Vec::new(), resolution),
            Estimator::SolidAngle { refine, .. } => ("solid-angle", ladder_levels(refine.first, refine.max), 0),
        };
        ShardSettings {
            viewpoints: self.directions.len() as u64,
            estimator: estimator.into(),
            distance: self.distance,
            levels,
            resolution,
            backend: self.tracer.name().to_string(),
        }
    }

    /// Traces shard `place`'s viewpoints (`progress(done, total)`) and
    /// makes their shard.
    ///
    /// # Errors
    /// The tracer's.
    pub fn save(&self, place: Place, progress: &mut dyn FnMut(u64, u64)) -> Result<Saved, ViewpointShardError> {
        let st = self.settings();
        let (first, end) = shard_range(place.index, place.count, self.directions.len() as u64);
        let mine = &self.directions[first as usize..end as usize];
        let scene = MeshFingerprint::of(self.name, self.prepared);
        let at = (place.index, place.count);
        match self.estimator {
            Estimator::Grid { resolution } => {
                let ch = ViewpointChannel::build(self.prepared, self.tracer, mine, self.distance, resolution, progress)
                    .map_err(ViewpointShardError::Trace)?;
                Ok(Saved { shard: ViewpointShard::grid(scene, st, at, &ch), levels_saved: None })
            }
            Estimator::SolidAngle { refine, keep } => {
                let ladders = ViewpointChannel::ladders(self.prepared, self.tracer, mine, refine, keep, progress)
                    .map_err(|error| ViewpointShardError::Ladders { scene: self.name.into(), error })?;
                let kept = ladders.first().map_or(0, |l| l.fractions.len());
                Ok(Saved { shard: ViewpointShard::solid_angle(scene, st, at, ladders), levels_saved: Some(kept) })
            }
        }
    }

    /// The channel (and, for the solid angle, its convergence) of the run
    /// whose shards are `files` (each at most `max_bytes`): the
    /// one-process result, bit for bit.
    ///
    /// # Errors
    /// Unreadable, foreign, duplicate or missing shards; eyes not this
    /// run's.
    pub fn merge(
        &self,
        files: &[PathBuf],
        max_bytes: u64,
    ) -> Result<(ViewpointChannel, Option<Convergence>), ViewpointShardError> {
        let st = self.settings();
        let scene = MeshFingerprint::of(self.name, self.prepared);
        let named = crate::shards::read_files(files, max_bytes).map_err(ViewpointShardError::Shard)?;
        let shards = order_shards(named, &scene, &st).map_err(ViewpointShardError::Shard)?;
        let refine = match self.estimator {
            Estimator::Grid { resolution } => {
                let ch = grid_channel(self.prepared.patches, &shards, self.directions, self.distance, resolution);
                return Ok((ch, None));
            }
            Estimator::SolidAngle { refine, .. } => refine,
        };
        let ladders: Vec<_> = shards.iter().flat_map(ViewpointShard::ladders).collect();
        for (viewpoint, (l, d)) in ladders.iter().zip(self.directions).enumerate() {
            if l.eye != d.normalize() * self.distance {
                return Err(ViewpointShardError::Eye { viewpoint });
            }
        }
        let (ch, c) = ViewpointChannel::from_ladders(self.prepared, self.tracer, &ladders, refine)
            .map_err(|error| ViewpointShardError::Channel { scene: self.name.into(), error })?;
        Ok((ch, Some(c)))
    }
}
