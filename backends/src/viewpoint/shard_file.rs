//! The viewpoint shard file: the channel rows of a range of viewpoints,
//! saved as versioned JSON (serde), so that shards of one run (`--shard
//! i/n`, one per job-array task) merge into the channel the single run
//! builds, bit for bit. The measures (VE, VMI, `I(V;O)`, selection, …) are
//! computed after the merge: they need every row.
//!
//! Version 2 (version 1, with its own header, is refused as "written by an
//! older itgfx") holds the shard header of [`crate::shards::header`]:
//! format, version, the shard `i/n`, a fingerprint, the scene's
//! fingerprint (name, patch and triangle counts, an FNV-1a hash of the
//! triangles' vertex bits and patch ids) and the settings the rows depend
//! on (viewpoint count, estimator, distance, refinement levels or grid
//! resolution, backend); then its viewpoint range
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
use crate::shards::{Difference, Header, Kind, Place, Setting, ShardError, ShardFile};
pub use crate::shards::{Fnv, MeshFingerprint};

/// The `format` field of a viewpoint shard file.
pub const FORMAT_NAME: &str = "itgfx-viewpoint-shard";
/// The version written and read.
pub const FORMAT_VERSION: u32 = 2;

/// The kind of file.
const KIND: Kind = Kind { format: FORMAT_NAME, version: FORMAT_VERSION, noun: "viewpoint shard file" };

/// The estimator name of volume shards (ray-cast rows over voxels).
pub const VOLUME_ESTIMATOR: &str = "volume";

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

impl crate::shards::Settings for ShardSettings {
    /// The first setting that differs from `other`'s (a shard's).
    fn difference(&self, other: &Self) -> Option<Difference> {
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
    /// Format, version, place, fingerprint, scene and settings.
    pub header: Header<ShardSettings>,
    /// First viewpoint.
    pub first: u64,
    /// One past the last viewpoint.
    pub end: u64,
    /// The rows, one per viewpoint of the range.
    pub rows: ShardRows,
}

/// Viewpoints `[⌊i·V/n⌋, ⌊(i+1)·V/n⌋)` of shard `i` of `n` ([`crate::shards::range`]).
#[must_use]
pub fn shard_range(i: u64, n: u64, viewpoints: u64) -> (u64, u64) {
    let r = crate::shards::range(i, n, viewpoints);
    (r.start, r.end)
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
        Self { header: Header::new(KIND, Place { index: shard, count: shards }, scene, settings), first, end, rows }
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
    /// As [`crate::shards::to_json`].
    pub fn to_json(&self) -> Result<String, ShardError> {
        crate::shards::to_json(self)
    }

    /// Reads and checks a shard file's text.
    ///
    /// # Errors
    /// One line naming what is wrong ([`crate::shards::from_json`]).
    pub fn from_json(text: &str) -> Result<Self, ShardError> {
        crate::shards::from_json(text)
    }

    /// Checks the invariants the merge relies on.
    ///
    /// # Errors
    /// [`ShardError::Invalid`] naming the first violation.
    pub fn validate(&self) -> Result<(), ShardError> {
        crate::shards::validate(self)
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

impl ShardFile for ViewpointShard {
    type Settings = ShardSettings;
    const KIND: Kind = KIND;

    fn header(&self) -> &Header<ShardSettings> {
        &self.header
    }

    fn violation(&self) -> Option<String> {
        let (h, st) = (&self.header, &self.header.settings);
        if h.shards > st.viewpoints {
            return Some(format!("shard {}/{} of {} viewpoints is not a shard", h.shard, h.shards, st.viewpoints));
        }
        if (self.first, self.end) != shard_range(h.shard, h.shards, st.viewpoints) {
            return Some(format!("shard {}/{} holds the wrong viewpoint range", h.shard, h.shards));
        }
        if self.len() as u64 != self.end - self.first {
            return Some(format!("{} rows for viewpoints {}..{}", self.len(), self.first, self.end));
        }
        let patches = h.scene.patches;
        let finite = |x: f64| x.is_finite() && x >= 0.0;
        match &self.rows {
            ShardRows::Grid(rows) => {
                let grid = st.estimator == "grid" || st.estimator == VOLUME_ESTIMATOR;
                if !grid || st.resolution == 0 || !st.levels.is_empty() {
                    return Some("grid rows with solid-angle settings".into());
                }
                for r in rows {
                    let sorted = r.patches.windows(2).all(|w| w[0] < w[1]);
                    if !sorted || r.patches.iter().any(|&p| u64::from(p) >= patches) {
                        return Some("a grid row's patches are out of range or not increasing".into());
                    }
                    if r.patches.len() != r.solid_angles.len()
                        || !r.solid_angles.iter().all(|&a| finite(a))
                        || !finite(r.background)
                    {
                        return Some("a grid row's solid angles are not finite and non-negative".into());
                    }
                }
            }
            ShardRows::SolidAngle(rows) => {
                if st.estimator != "solid-angle" || st.levels.is_empty() || st.resolution != 0 {
                    return Some("solid-angle rows with grid settings".into());
                }
                for r in rows {
                    if r.whole.iter().any(|&(p, a)| u64::from(p) >= patches || !finite(a))
                        || r.sampled.iter().any(|&(t, a)| u64::from(t) >= h.scene.triangles || !finite(a))
                    {
                        return Some("a ladder's patches or triangles are out of range".into());
                    }
                    if !(1..=st.levels.len()).contains(&r.fractions.len())
                        || r.fractions
                            .iter()
                            .any(|f| f.len() != r.sampled.len() || !f.iter().all(|x| (0.0..=1.0).contains(x)))
                    {
                        return Some("a ladder's fractions do not match its levels and triangles".into());
                    }
                    if !r.eye.iter().all(|x| x.is_finite()) {
                        return Some("a ladder's eye is not finite".into());
                    }
                }
            }
        }
        None
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
    let run = Header::new(KIND, Place { index: 0, count: 1 }, scene.clone(), settings.clone());
    crate::shards::order_run(named, &run, |_| None)
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
