//! The viewpoint shard file: the channel rows of a range of viewpoints,
//! saved as versioned JSON (serde), so that shards of one run (`--shard
//! i/n`, one per job-array task) merge into the channel the single run
//! builds, bit for bit. The measures (VE, VMI, `I(V;O)`, selection, …) are
//! computed after the merge: they need every row.
//!
//! Version 1 holds the format name and version, the scene's fingerprint
//! (name, patch and triangle counts, an FNV-1a hash of the triangles'
//! vertex bits and patch ids), the settings the rows depend on (viewpoint
//! count, estimator, distance, refinement levels or grid resolution,
//! backend), the shard `i/n` and its viewpoint range
//! `[⌊i·V/n⌋, ⌊(i+1)·V/n⌋)`, and per viewpoint either its ray-grid row
//! (patches, solid angles, background) or its solid-angle ladder
//! ([`ViewLadder`]: the visibility at every refinement level, so the merge
//! replays the refinement without tracing). Floats are written so they read
//! back exactly. Everything is checked on reading and on merging: foreign
//! (another scene or settings), duplicate and missing shards are refused
//! with one line.
//!
//! Volume runs (`itgfx volume --shard`, Part VI's channel over voxels) use
//! the same file: their rows are [`GridRow`]s with voxels for patches and
//! visibilities for solid angles, the estimator is `"volume"`, the
//! resolution is the caster's image side, and the fingerprint is the
//! volume's ([`MeshFingerprint::volume`]).

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::ViewpointChannel;
use super::solid_angle::ViewLadder;
use crate::shards::{Difference, Foreign, Setting, ShardError};
use crate::tracer::Prepared;

/// The `format` field of a viewpoint shard file.
pub const FORMAT_NAME: &str = "itgfx-viewpoint-shard";
/// The version written and read.
pub const FORMAT_VERSION: u32 = 1;

/// The estimator name of volume shards (ray-cast rows over voxels).
pub const VOLUME_ESTIMATOR: &str = "volume";

/// FNV-1a, 64 bits: the fingerprints' hash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    /// Hashes `bytes` in.
    pub fn eat(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// The hash as 16 hexadecimal digits.
    #[must_use]
    pub fn hex(self) -> String {
        format!("{:016x}", self.0)
    }
}

/// What identifies the scene: a shard of another mesh is refused.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshFingerprint {
    /// The scene's name.
    pub name: String,
    /// Patches (polygons).
    pub patches: u64,
    /// Triangles traced.
    pub triangles: u64,
    /// FNV-1a (64 bits, 16 hexadecimal digits) of every triangle's vertex
    /// bits (f32, little-endian) and patch id, in order.
    pub hash: String,
}

impl MeshFingerprint {
    /// The fingerprint of a prepared scene named `name`.
    #[must_use]
    pub fn of(name: &str, p: &Prepared) -> Self {
        let mut h = Fnv::default();
        for (t, &patch) in p.triangles.iter().zip(&p.triangle_patch) {
            for v in t {
                for c in v.to_array() {
                    h.eat(&c.to_bits().to_le_bytes());
                }
            }
            h.eat(&patch.to_le_bytes());
        }
        Self { name: name.to_string(), patches: p.patches as u64, triangles: p.triangles.len() as u64, hash: h.hex() }
    }

    /// A volume's fingerprint: `voxels` outputs, no triangles, and `hash`
    /// of everything its rows depend on besides the viewpoints (the voxels,
    /// the transfer function and the sample step: `volume::raycast::Caster::fingerprint`).
    #[must_use]
    pub fn volume(name: &str, voxels: usize, hash: Fnv) -> Self {
        Self { name: name.to_string(), patches: voxels as u64, triangles: 0, hash: hash.hex() }
    }
}

/// The settings a shard's rows depend on: every shard of a run, and the
/// merging command, must agree on all of them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardSettings {
    /// Viewpoints of the whole run.
    pub viewpoints: u64,
    /// `"solid-angle"` or `"grid"`.
    pub estimator: String,
    /// Viewpoint distance in bounding-sphere radii.
    pub distance: f64,
    /// Solid angle: the refinement levels (`m` of each); empty for the grid.
    pub levels: Vec<u32>,
    /// Grid: rays per side; 0 for the solid angle.
    pub resolution: u32,
    /// The tracing backend's name.
    pub backend: String,
}

impl ShardSettings {
    /// The first setting that differs from `other`'s (a shard's).
    #[must_use]
    pub fn difference(&self, other: &Self) -> Option<Difference> {
        let d = |s: Setting, a: String, b: String| Difference::of(s, a, b, "in the shard");
        let resolution =
            if self.estimator == VOLUME_ESTIMATOR { Setting::ImageResolution } else { Setting::Resolution };
        d(Setting::Viewpoints, self.viewpoints.to_string(), other.viewpoints.to_string())
            .or_else(|| d(Setting::Estimator, self.estimator.clone(), other.estimator.clone()))
            .or_else(|| d(Setting::Distance, format!("{:?}", self.distance), format!("{:?}", other.distance)))
            .or_else(|| d(Setting::Levels, format!("{:?}", self.levels), format!("{:?}", other.levels)))
            .or_else(|| d(resolution, self.resolution.to_string(), other.resolution.to_string()))
            .or_else(|| d(Setting::Backend, self.backend.clone(), other.backend.clone()))
    }
}

/// One ray-grid row.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridRow {
    /// Patches seen, increasing.
    pub patches: Vec<u32>,
    /// Their projected solid angles (sr).
    pub solid_angles: Vec<f64>,
    /// Solid angle of the background in the cone (sr).
    pub background: f64,
}

/// The rows of a shard's viewpoints.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShardRows {
    /// Ray-grid rows.
    Grid(Vec<GridRow>),
    /// Solid-angle ladders.
    SolidAngle(Vec<SavedLadder>),
}

/// A [`ViewLadder`] as saved.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SavedLadder {
    /// The eye.
    pub eye: [f64; 3],
    /// `[patch, Ω]` of the triangles seen whole.
    pub whole: Vec<(u32, f64)>,
    /// `[triangle, Ω]` of the sampled triangles.
    pub sampled: Vec<(u32, f64)>,
    /// Rays of the centroid probes.
    pub base_rays: u64,
    /// Visible fractions per level.
    pub fractions: Vec<Vec<f64>>,
}

/// A shard: viewpoints `first..end` of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewpointShard {
    /// [`FORMAT_NAME`].
    pub format: String,
    /// [`FORMAT_VERSION`].
    pub version: u32,
    /// The scene.
    pub scene: MeshFingerprint,
    /// The settings.
    pub settings: ShardSettings,
    /// `i` of `i/n`.
    pub shard: u64,
    /// `n` of `i/n`.
    pub shards: u64,
    /// First viewpoint.
    pub first: u64,
    /// One past the last viewpoint.
    pub end: u64,
    /// The rows, one per viewpoint of the range.
    pub rows: ShardRows,
}

/// Viewpoints `[⌊i·V/n⌋, ⌊(i+1)·V/n⌋)` of shard `i` of `n`.
#[must_use]
pub fn shard_range(i: u64, n: u64, viewpoints: u64) -> (u64, u64) {
    let at = |k: u64| (u128::from(k) * u128::from(viewpoints) / u128::from(n.max(1))) as u64;
    (at(i), at(i + 1))
}

impl ViewpointShard {
    /// A shard of ray-grid rows: `ch` holds the range's viewpoints only.
    #[must_use]
    pub fn grid(scene: MeshFingerprint, settings: ShardSettings, shard: (u64, u64), ch: &ViewpointChannel) -> Self {
        let rows = (0..ch.viewpoints())
            .map(|v| {
                let (p, a) = ch.row(v);
                GridRow { patches: p.to_vec(), solid_angles: a.to_vec(), background: ch.background[v] }
            })
            .collect();
        Self::new(scene, settings, shard, ShardRows::Grid(rows))
    }

    /// A shard of solid-angle ladders.
    #[must_use]
    pub fn solid_angle(
        scene: MeshFingerprint,
        settings: ShardSettings,
        shard: (u64, u64),
        ladders: Vec<ViewLadder>,
    ) -> Self {
        let rows = ladders
            .into_iter()
            .map(|l| SavedLadder {
                eye: l.eye.to_array(),
                whole: l.whole,
                sampled: l.sampled,
                base_rays: l.base_rays,
                fractions: l.fractions,
            })
            .collect();
        Self::new(scene, settings, shard, ShardRows::SolidAngle(rows))
    }

    fn new(scene: MeshFingerprint, settings: ShardSettings, (shard, shards): (u64, u64), rows: ShardRows) -> Self {
        let (first, end) = shard_range(shard, shards, settings.viewpoints);
        Self { format: FORMAT_NAME.into(), version: FORMAT_VERSION, scene, settings, shard, shards, first, end, rows }
    }

    /// Viewpoints held.
    #[must_use]
    pub fn len(&self) -> usize {
        match &self.rows {
            ShardRows::Grid(r) => r.len(),
            ShardRows::SolidAngle(r) => r.len(),
        }
    }

    /// Whether no viewpoint is held (never, for a valid shard).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The file's text.
    ///
    /// # Errors
    /// Serialisation errors (none for finite values).
    pub fn to_json(&self) -> Result<String, String> {
        serde_json::to_string(self).map_err(|e| e.to_string())
    }

    /// Reads and checks a shard file's text.
    ///
    /// # Errors
    /// One line naming what is wrong.
    pub fn from_json(text: &str) -> Result<Self, ShardError> {
        let s: Self = crate::shards::read_json(text, "viewpoint shard file", FORMAT_NAME, FORMAT_VERSION)?;
        s.validate()?;
        Ok(s)
    }

    /// Checks the invariants the merge relies on.
    ///
    /// # Errors
    /// [`ShardError::Invalid`] naming the first violation.
    pub fn validate(&self) -> Result<(), ShardError> {
        self.violation().map_err(ShardError::Invalid)
    }

    fn violation(&self) -> Result<(), String> {
        let st = &self.settings;
        if self.shards == 0 || self.shard >= self.shards || self.shards > st.viewpoints {
            return Err(format!("shard {}/{} of {} viewpoints is not a shard", self.shard, self.shards, st.viewpoints));
        }
        if (self.first, self.end) != shard_range(self.shard, self.shards, st.viewpoints) {
            return Err(format!("shard {}/{} holds the wrong viewpoint range", self.shard, self.shards));
        }
        if self.len() as u64 != self.end - self.first {
            return Err(format!("{} rows for viewpoints {}..{}", self.len(), self.first, self.end));
        }
        let patches = self.scene.patches;
        let finite = |x: f64| x.is_finite() && x >= 0.0;
        match &self.rows {
            ShardRows::Grid(rows) => {
                let grid = st.estimator == "grid" || st.estimator == VOLUME_ESTIMATOR;
                if !grid || st.resolution == 0 || !st.levels.is_empty() {
                    return Err("grid rows with solid-angle settings".into());
                }
                for r in rows {
                    let sorted = r.patches.windows(2).all(|w| w[0] < w[1]);
                    if !sorted || r.patches.iter().any(|&p| u64::from(p) >= patches) {
                        return Err("a grid row's patches are out of range or not increasing".into());
                    }
                    if r.patches.len() != r.solid_angles.len()
                        || !r.solid_angles.iter().all(|&a| finite(a))
                        || !finite(r.background)
                    {
                        return Err("a grid row's solid angles are not finite and non-negative".into());
                    }
                }
            }
            ShardRows::SolidAngle(rows) => {
                if st.estimator != "solid-angle" || st.levels.is_empty() || st.resolution != 0 {
                    return Err("solid-angle rows with grid settings".into());
                }
                for r in rows {
                    if r.whole.iter().any(|&(p, a)| u64::from(p) >= patches || !finite(a))
                        || r.sampled.iter().any(|&(t, a)| u64::from(t) >= self.scene.triangles || !finite(a))
                    {
                        return Err("a ladder's patches or triangles are out of range".into());
                    }
                    if !(1..=st.levels.len()).contains(&r.fractions.len())
                        || r.fractions
                            .iter()
                            .any(|f| f.len() != r.sampled.len() || !f.iter().all(|x| (0.0..=1.0).contains(x)))
                    {
                        return Err("a ladder's fractions do not match its levels and triangles".into());
                    }
                    if !r.eye.iter().all(|x| x.is_finite()) {
                        return Err("a ladder's eye is not finite".into());
                    }
                }
            }
        }
        Ok(())
    }

    /// Solid-angle ladders, for [`ViewpointChannel::from_ladders`].
    #[must_use]
    pub fn ladders(&self) -> Vec<ViewLadder> {
        match &self.rows {
            ShardRows::Grid(_) => Vec::new(),
            ShardRows::SolidAngle(rows) => rows
                .iter()
                .map(|r| ViewLadder {
                    eye: DVec3::from_array(r.eye),
                    whole: r.whole.clone(),
                    sampled: r.sampled.clone(),
                    base_rays: r.base_rays,
                    fractions: r.fractions.clone(),
                })
                .collect(),
        }
    }
}

/// Puts shards of one run in viewpoint order, refusing foreign ones
/// (another scene or settings, or another shard count), duplicates and
/// missing ones. `named` pairs each shard with the name used in errors.
///
/// # Errors
/// One line naming the offending file(s).
pub fn order_shards(
    named: Vec<(String, ViewpointShard)>,
    scene: &MeshFingerprint,
    settings: &ShardSettings,
) -> Result<Vec<ViewpointShard>, ShardError> {
    crate::shards::order(
        named,
        |s| (s.shard, s.shards),
        |s| {
            if s.scene != *scene {
                return Some(Foreign::Other(format!(
                    "a shard of another scene ({:?}, {} patches, hash {}), not of {:?} ({} patches, hash {})",
                    s.scene.name, s.scene.patches, s.scene.hash, scene.name, scene.patches, scene.hash
                )));
            }
            settings.difference(&s.settings).map(Foreign::Run)
        },
    )
}

/// The ray-grid channel of shards in order (from [`order_shards`]) over
/// `patches` outputs: rows concatenated, positions `directions[v]` at
/// `distance` — the channel [`ViewpointChannel::build`] (or, for volumes,
/// `volume::volume_channel`) returns for the whole run.
#[must_use]
pub fn grid_channel(
    patches: usize,
    shards: &[ViewpointShard],
    directions: &[DVec3],
    distance: f64,
    resolution: u32,
) -> ViewpointChannel {
    let mut starts = vec![0];
    let (mut patch, mut solid_angle, mut background) = (Vec::new(), Vec::new(), Vec::new());
    for s in shards {
        if let ShardRows::Grid(rows) = &s.rows {
            for r in rows {
                patch.extend_from_slice(&r.patches);
                solid_angle.extend_from_slice(&r.solid_angles);
                background.push(r.background);
                starts.push(patch.len());
            }
        }
    }
    let r = u64::from(resolution.max(1));
    ViewpointChannel {
        positions: directions.iter().map(|d| d.normalize() * distance).collect(),
        starts,
        patch,
        solid_angle,
        background,
        patches,
        rays_per_viewpoint: r * r,
    }
}
