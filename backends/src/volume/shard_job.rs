//! The volume channel's jobs behind `itgfx volume`: the memory a run
//! needs ([`VolumeShards::memory`], checked against the budget of
//! [`crate::memory`] before any ray is cast), a shard's rows cast and made
//! into a viewpoint shard file ([`VolumeShards::save`]; the file of
//! [`crate::viewpoint::shard_file`], with voxels for patches), and the
//! shards of a run merged into the channel one process casts, bit for bit
//! ([`VolumeShards::merge`]). The CLI parses the options, writes the file
//! and words the errors with its flags.

use std::path::PathBuf;

use glam::DVec3;

use super::cast::VolumeCaster;
use super::channel::{VolumeChannelOptions, channel_memory, seeable_voxels, volume_channel};
use super::raycast::Caster;
use crate::backend::{BackendChoice, volume_memory};
use crate::memory::OutOfMemory;
use crate::shards::{Fnv, Place, ShardError};
use crate::tracer::BackendError;
use crate::viewpoint::ViewpointChannel;
use crate::viewpoint::shard_file::{
    MeshFingerprint, ShardSettings, VOLUME_ESTIMATOR, ViewpointShard, grid_channel, order_shards, shard_range,
};

/// Memory of the process before any volume: `itgfx volume sphere:4
/// --viewpoints 12` peaks at 7,136 KiB (`/usr/bin/time -v`).
pub const PROCESS_BYTES: u64 = 16 << 20;

/// Bytes a volume's voxel holds while it is studied: its `f32` value and a
/// byte of label.
pub const HELD_BYTES_PER_VOXEL: u64 = 5;

/// Bytes the channel of `views` viewpoints over `caster`'s volume and its
/// measures may need ([`channel_memory`]), with the buffers `backend`
/// allocates to cast `rays` rays a view ([`volume_memory`]; none for 0
/// rays: the rows come from shards).
#[must_use]
pub fn cast_memory(caster: &Caster<'_>, backend: BackendChoice, views: usize, rays: u64) -> u64 {
    let buffers = if rays > 0 { volume_memory(backend, caster, rays) } else { 0 };
    channel_memory(caster, seeable_voxels(caster), views) + buffers
}

/// The viewpoint channel of a volume, as shards.
#[derive(Clone, Copy)]
pub struct VolumeShards<'a> {
    /// The volume, transfer function and step in words: the shard files'
    /// scene name.
    pub label: &'a str,
    /// The caster (the volume and its transfer function).
    pub caster: &'a Caster<'a>,
    /// Every viewpoint direction of the run.
    pub directions: &'a [DVec3],
    /// Viewpoint distance in bounding-sphere radii.
    pub distance: f64,
    /// Image side: `rays²` rays per viewpoint.
    pub rays: u32,
}

/// A shard made by [`VolumeShards::save`].
#[derive(Clone, Debug)]
pub struct Saved {
    /// The shard, to be written.
    pub shard: ViewpointShard,
    /// Entries of its rows.
    pub entries: u64,
}

impl VolumeShards<'_> {
    /// Viewpoints `[first, end)` of `place` (all of them without one).
    #[must_use]
    pub fn range(&self, place: Option<Place>) -> (usize, usize) {
        let n = self.directions.len();
        place.map_or((0, n), |s| {
            let (a, b) = shard_range(s.index, s.count, n as u64);
            (a as usize, b as usize)
        })
    }

    /// Bytes a run over viewpoints `first..end` may need at its peak: the
    /// process and the volume it holds ([`PROCESS_BYTES`],
    /// [`HELD_BYTES_PER_VOXEL`]) and the channel ([`cast_memory`]; without
    /// the backend's buffers when it does not `casts`, a merge). A bound on
    /// the measured peak: `hydrogen:3,2,0,64` at 162 views peaks at 112.4
    /// MiB against 127.5 estimated, `hydrogen:3,2,0,128` at 774.3 MiB
    /// against 823.5 (release, `/usr/bin/time -v`, maximum RSS; debug
    /// build 117.9 and 779.9 MiB), and
    /// `hydrogen:3,2,0,256` at 5,597 MiB against 6,074 (docs/VOLUME.md).
    #[must_use]
    pub fn memory(&self, backend: BackendChoice, (first, end): (usize, usize), casts: bool) -> u64 {
        let rays = if casts { u64::from(self.rays) * u64::from(self.rays) } else { 0 };
        PROCESS_BYTES
            + self.caster.volume.voxels() as u64 * HELD_BYTES_PER_VOXEL
            + cast_memory(self.caster, backend, end - first, rays)
    }

    /// [`VolumeShards::memory`] checked against what the process may use.
    ///
    /// # Errors
    /// [`OutOfMemory`] naming the volume's channel.
    pub fn check_memory(&self, backend: BackendChoice, range: (usize, usize), casts: bool) -> Result<u64, OutOfMemory> {
        let need = self.memory(backend, range, casts);
        crate::memory::check(|| format!("{}: the channel", self.caster.volume.name), need)?;
        Ok(need)
    }

    /// What the rows depend on: the volume, transfer function and step
    /// (the fingerprint) and the viewpoints, distance and rays (the
    /// settings).
    fn identity(&self) -> (MeshFingerprint, ShardSettings) {
        let mut h = Fnv::default();
        self.caster.fingerprint(&mut h);
        let settings = ShardSettings {
            viewpoints: self.directions.len() as u64,
            estimator: VOLUME_ESTIMATOR.into(),
            distance: self.distance,
            levels: Vec::new(),
            resolution: self.rays,
            backend: "cpu".into(),
        };
        (MeshFingerprint::volume(self.label, self.caster.volume.voxels(), h), settings)
    }

    /// Casts shard `place`'s viewpoints with `backend` (`progress(done,
    /// total)`) and makes their shard.
    ///
    /// # Errors
    /// The backend's.
    pub fn save(
        &self,
        backend: &dyn VolumeCaster,
        place: Place,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Saved, BackendError> {
        let (first, end) = self.range(Some(place));
        let (scene, settings) = self.identity();
        let copts = VolumeChannelOptions {
            directions: self.directions[first..end].to_vec(),
            distance: self.distance,
            size: self.rays,
        };
        let ch = volume_channel(backend, &copts, progress)?;
        let shard = ViewpointShard::grid(scene, settings, (place.index, place.count), &ch);
        Ok(Saved { shard, entries: ch.patch.len() as u64 })
    }

    /// The channel of the run whose shards are `files` (each at most
    /// `max_bytes`): the one-process channel, bit for bit.
    ///
    /// # Errors
    /// Unreadable, foreign, duplicate or missing shards.
    pub fn merge(&self, files: &[PathBuf], max_bytes: u64) -> Result<ViewpointChannel, ShardError> {
        let (scene, settings) = self.identity();
        let named = crate::shards::read_files(files, max_bytes)?;
        let shards = order_shards(named, &scene, &settings)?;
        Ok(grid_channel(self.caster.volume.voxels(), &shards, self.directions, self.distance, self.rays))
    }
}
