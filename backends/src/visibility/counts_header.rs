//! The header of both counts files (JSON and binary): the one shard header
//! of [`crate::shards::header`], with the counts' settings. Its format is
//! `itgfx-counts`, its version [`FORMAT_VERSION`] for both forms; an
//! earlier file (JSON version 2, binary version 3, the line-based version 1)
//! is refused as "written by an older itgfx (format N); re-run".
//!
//! Counts hold line ranges, not a place (any `--offset` run merges with
//! any other of its run), so the header's place is `0/1` and the ranges
//! follow it in the file. The header's scene is the counts' scene
//! fingerprint ([`SceneFingerprint`]): its name, its patches, and as its
//! hash the FNV-1a of the patch areas (no triangles: what the counts depend
//! on is the areas).

use serde::{Deserialize, Serialize};

use super::counts_valid::{SceneFingerprint, invalid};
use super::{CountsError, MAX_BLOCKS, VisibilityCounts};
use crate::shards::{Difference, Header, Kind, MeshFingerprint, Place, Setting, ShardError, ShardFile};

/// The `format` of a counts file's header.
pub const FORMAT_NAME: &str = "itgfx-counts";
/// The version written and read, JSON and binary alike (JSON was version 2
/// and binary version 3 before the one header).
pub const FORMAT_VERSION: u32 = 4;
/// The counts files' kind.
pub const KIND: Kind = Kind { format: FORMAT_NAME, version: FORMAT_VERSION, noun: "counts file" };
/// The block assignment written and read.
pub const ASSIGNMENT: &str = "line index mod blocks";

/// What every counts file of one run agrees on besides the scene.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CountsSettings {
    /// `"global"` or `"local"` lines.
    pub lines: String,
    /// The run's seed.
    pub seed: u64,
    /// Jackknife blocks.
    pub blocks: u32,
    /// How lines are assigned to blocks ([`ASSIGNMENT`]).
    pub assignment: String,
}

impl crate::shards::Settings for CountsSettings {
    fn difference(&self, other: &Self) -> Option<Difference> {
        let d = |s, a: String, b: String| Difference::of(s, a, b, "there");
        d(Setting::LineKind, self.lines.clone(), other.lines.clone())
            .or_else(|| d(Setting::Seed, self.seed.to_string(), other.seed.to_string()))
            .or_else(|| d(Setting::Blocks, self.blocks.to_string(), other.blocks.to_string()))
    }
}

/// The header of counts of the scene `name`.
#[must_use]
pub fn header_of(name: &str, c: &VisibilityCounts) -> Header<CountsSettings> {
    let scene = MeshFingerprint {
        name: name.into(),
        patches: c.scene.patches,
        triangles: 0,
        hash: format!("{:016x}", c.scene.areas_hash),
    };
    let settings = CountsSettings {
        lines: if c.local { "local" } else { "global" }.into(),
        seed: c.seed,
        blocks: c.blocks.len() as u32,
        assignment: ASSIGNMENT.into(),
    };
    Header::new(KIND, Place { index: 0, count: 1 }, scene, settings)
}

/// The run a checked header describes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Run {
    /// The scene counted.
    pub scene: SceneFingerprint,
    /// Local lines (else global).
    pub local: bool,
    /// The seed.
    pub seed: u64,
    /// Jackknife blocks, `1..=MAX_BLOCKS`.
    pub blocks: u32,
}

/// The run of a header whose format, version and fingerprint are checked.
///
/// # Errors
/// [`CountsError::Invalid`] for a line kind, assignment, block count or
/// hash that is not one, or a place other than `0/1`.
pub fn run_of(h: &Header<CountsSettings>) -> Result<Run, CountsError> {
    let s = &h.settings;
    let local = match s.lines.as_str() {
        "global" => false,
        "local" => true,
        other => return Err(invalid(format!("lines {other:?}: expected \"global\" or \"local\""))),
    };
    if s.assignment != ASSIGNMENT || !(1..=MAX_BLOCKS).contains(&s.blocks) {
        return Err(invalid(format!(
            "jackknife: {} blocks assigned by {:?}: expected 1..={MAX_BLOCKS} blocks assigned by {ASSIGNMENT:?}",
            s.blocks, s.assignment
        )));
    }
    if (h.shard, h.shards) != (0, 1) {
        return Err(invalid(format!("place {}/{}: a counts file's is 0/1 (it holds line ranges)", h.shard, h.shards)));
    }
    let hash = &h.scene.hash;
    let areas_hash = u64::from_str_radix(hash, 16)
        .ok()
        .filter(|_| hash.len() == 16 && h.scene.triangles == 0)
        .ok_or_else(|| invalid("scene: expected the areas' hash (16 hexadecimal digits) and no triangles"))?;
    let scene = SceneFingerprint { name: h.scene.name.clone(), patches: h.scene.patches, areas_hash };
    Ok(Run { scene, local, seed: s.seed, blocks: s.blocks })
}

/// A counts file's error from the shard header's: an older format is
/// refused with the way out.
#[must_use]
pub fn header_error(e: ShardError) -> CountsError {
    match e {
        ShardError::Older { version, .. } => older(version),
        e => CountsError::Format(e.to_string()),
    }
}

/// The error for a counts file of an earlier format `version`.
#[must_use]
pub fn older(version: u32) -> CountsError {
    CountsError::Format(format!(
        "counts file written by an older itgfx (format {version}); re-run the count to save them in format {FORMAT_VERSION}"
    ))
}

/// The binary file's header: the JSON object `{"header": {...}}`, read
/// and checked by [`crate::shards::from_json`] as any shard file's.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeaderOnly {
    /// The header.
    pub header: Header<CountsSettings>,
}

impl ShardFile for HeaderOnly {
    type Settings = CountsSettings;
    const KIND: Kind = KIND;

    fn header(&self) -> &Header<CountsSettings> {
        &self.header
    }

    fn violation(&self) -> Option<String> {
        None
    }
}

/// Reads and checks a binary file's header text.
///
/// # Errors
/// As [`header_error`] and [`run_of`].
pub fn read_header(text: &str) -> Result<Run, CountsError> {
    let h: HeaderOnly = crate::shards::from_json(text).map_err(header_error)?;
    run_of(&h.header)
}

/// A binary file's header text.
#[must_use]
pub fn header_text(name: &str, c: &VisibilityCounts) -> String {
    // Serialising the header cannot fail (no maps, no non-string keys).
    serde_json::to_string(&HeaderOnly { header: header_of(name, c) }).unwrap_or_default()
}
