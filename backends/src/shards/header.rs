//! The one header of every shard file (render rows, viewpoint rows, volume
//! rows), written and read here: the format name and version, the place
//! `i/n`, a fingerprint of the scene and settings, the scene, and the
//! settings themselves. A file is `{"header": {...}, ...the engine's rows}`
//! (JSON, serde; floats read back exactly).
//!
//! Reading checks the format and version first, so that a file of another
//! kind, an earlier format ("written by an older itgfx (format N); re-run the
//! shard") or a later one gets one line that says so rather than a serde
//! message; then the header (the place, the fingerprint against the scene and
//! settings it holds), then the engine's own invariants ([`ShardFile::violation`]).

use std::path::PathBuf;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::error::{Difference, ShardError};
use super::fingerprint::{Fnv, MeshFingerprint};
use super::order::{Foreign, order};
use super::place::Place;

/// A kind of shard file: its format name, the version written and read,
/// and its name in errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kind {
    /// The header's `format`.
    pub format: &'static str,
    /// The version written and read.
    pub version: u32,
    /// The file in words ("render shard file").
    pub noun: &'static str,
}

/// The settings a shard's numbers depend on: every shard of a run must
/// agree on all of them.
pub trait Settings: Clone + PartialEq + Serialize + DeserializeOwned {
    /// The first setting that differs between `self` (the run, or the
    /// first shard) and `other` (a shard).
    fn difference(&self, other: &Self) -> Option<Difference>;
}

/// The header of a shard file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header<S> {
    /// [`Kind::format`].
    pub format: String,
    /// [`Kind::version`].
    pub version: u32,
    /// `i` of `i/n`.
    pub shard: u64,
    /// `n` of `i/n`.
    pub shards: u64,
    /// [`Header::stamp`] of `scene` and `settings`: equal for every shard of
    /// one run.
    pub fingerprint: String,
    /// The scene (or volume).
    pub scene: MeshFingerprint,
    /// The settings.
    pub settings: S,
}

impl<S: Settings> Header<S> {
    /// The header of shard `place` of a `kind` run.
    #[must_use]
    pub fn new(kind: Kind, place: Place, scene: MeshFingerprint, settings: S) -> Self {
        Self {
            format: kind.format.into(),
            version: kind.version,
            shard: place.index,
            shards: place.count,
            fingerprint: Self::stamp(&scene, &settings),
            scene,
            settings,
        }
    }

    /// The run's fingerprint: FNV-1a ([`Fnv`]) of the scene's and the
    /// settings' JSON text (which holds every float's bits exactly).
    #[must_use]
    pub fn stamp(scene: &MeshFingerprint, settings: &S) -> String {
        let mut h = Fnv::default();
        // Serialising these structs cannot fail (no maps, no non-string
        // keys); an empty text would still fingerprint deterministically.
        h.eat(&serde_json::to_vec(scene).unwrap_or_default());
        h.eat(&serde_json::to_vec(settings).unwrap_or_default());
        h.hex()
    }

    /// The shard's place.
    #[must_use]
    pub fn place(&self) -> Place {
        Place { index: self.shard, count: self.shards }
    }

    /// Why the header cannot be a shard's: a place that is not one, or a
    /// fingerprint that does not match the scene and settings.
    fn violation(&self) -> Option<String> {
        if self.shards == 0 || self.shard >= self.shards {
            return Some(format!("shard {}/{} is not a shard", self.shard, self.shards));
        }
        let stamp = Self::stamp(&self.scene, &self.settings);
        (self.fingerprint != stamp).then(|| {
            format!(
                "fingerprint {:?} does not match the scene and settings ({stamp}): an edited file?",
                self.fingerprint
            )
        })
    }

    /// Why a shard with header `other` is not of the run `self` describes
    /// (the merging run's, or the first shard's): another scene, or a
    /// setting that differs.
    #[must_use]
    pub fn foreign(&self, other: &Self) -> Option<Foreign> {
        if other.fingerprint == self.fingerprint {
            return None;
        }
        let (s, o) = (&self.scene, &other.scene);
        if o != s {
            return Some(Foreign::Other(format!(
                "a shard of another scene ({:?}, {} patches, hash {}), not of {:?} ({} patches, hash {})",
                o.name, o.patches, o.hash, s.name, s.patches, s.hash
            )));
        }
        Some(self.settings.difference(&other.settings).map_or_else(
            || {
                Foreign::Other(format!(
                    "a shard of another run (fingerprint {}, not {})",
                    other.fingerprint, self.fingerprint
                ))
            },
            Foreign::Run,
        ))
    }
}

/// A shard file: a [`Header`] and the engine's rows.
pub trait ShardFile: Serialize + DeserializeOwned {
    /// The settings in the header.
    type Settings: Settings;
    /// The kind of file.
    const KIND: Kind;

    /// The header.
    fn header(&self) -> &Header<Self::Settings>;

    /// The first invariant of the rows that the merge relies on and that
    /// does not hold, in words (the header is checked already).
    fn violation(&self) -> Option<String>;
}

/// Checks a shard: its format and version, its header, its rows.
///
/// # Errors
/// [`ShardError::Format`] for another format or version,
/// [`ShardError::Invalid`] naming the first violation.
pub fn validate<T: ShardFile>(file: &T) -> Result<(), ShardError> {
    let h = file.header();
    let kind = T::KIND;
    if h.format != kind.format || h.version != kind.version {
        return Err(ShardError::Format {
            why: format!("{} {:?} version {}: not this itgfx's ({})", kind.noun, h.format, h.version, kind.version),
        });
    }
    match h.violation().or_else(|| file.violation()) {
        Some(why) => Err(ShardError::Invalid(why)),
        None => Ok(()),
    }
}

/// The file's text.
///
/// # Errors
/// [`ShardError::Invalid`] if serde refuses (it does not for these files).
pub fn to_json<T: ShardFile>(file: &T) -> Result<String, ShardError> {
    serde_json::to_string(file).map_err(|e| ShardError::Invalid(format!("{}: {e}", T::KIND.noun)))
}

/// Reads and checks a shard file's text ([`validate`]).
///
/// # Errors
/// [`ShardError::Format`] (not JSON, another format, a later version, a
/// field serde rejects), [`ShardError::Older`] (an earlier version),
/// [`ShardError::Invalid`].
pub fn from_json<T: ShardFile>(text: &str) -> Result<T, ShardError> {
    #[derive(Deserialize)]
    struct Head {
        format: Option<String>,
        version: Option<u32>,
    }
    #[derive(Deserialize)]
    struct Top {
        header: Option<Head>,
        format: Option<String>,
        version: Option<u32>,
    }
    let kind = T::KIND;
    let noun = kind.noun;
    let bad = |why: String| ShardError::Format { why };
    let top: Top = serde_json::from_str(text).map_err(|_| bad(format!("not a {noun} (JSON)")))?;
    // Formats before this header kept the name and version at the top.
    let (format, version) = match top.header {
        Some(h) => (h.format, h.version),
        None => (top.format, top.version),
    };
    if format.as_deref() != Some(kind.format) {
        return Err(bad(format!("not a {noun} (format {:?})", format.unwrap_or_default())));
    }
    match version {
        Some(v) if v == kind.version => {}
        Some(v) if v < kind.version => return Err(ShardError::Older { kind: noun, version: v }),
        v => {
            return Err(bad(format!(
                "{noun} version {}: this itgfx reads version {}",
                v.map_or("none".into(), |v| v.to_string()),
                kind.version
            )));
        }
    }
    let file: T = serde_json::from_str(text).map_err(|e| bad(format!("{noun}: {e}")))?;
    validate(&file)?;
    Ok(file)
}

/// Bytes of memory per byte of shard file that reading may take: the
/// text, and the parsed rows (a number of at least 2 bytes of text becomes
/// at most 8 bytes, twice that while its vector grows).
pub const BYTES_PER_FILE_BYTE: u64 = 9;

/// The text of shard file `path`: a regular file of at most `max_bytes`,
/// refused before reading if its parsed form would not fit in the memory
/// available ([`BYTES_PER_FILE_BYTE`]).
fn read_text(path: &std::path::Path, max_bytes: u64) -> Result<String, ShardError> {
    use std::io::Read;
    let unreadable = |why: String| ShardError::Unreadable(why);
    let file = crate::files::open_regular(path).map_err(|e| unreadable(e.to_string()))?;
    let len = file.metadata().map_err(|e| unreadable(e.to_string()))?.len();
    if len > max_bytes {
        return Err(unreadable(format!("file is {len} bytes, over the limit of {max_bytes} bytes")));
    }
    crate::memory::check(|| format!("reading {}", path.display()), len.saturating_mul(BYTES_PER_FILE_BYTE))
        .map_err(|e| unreadable(e.to_string()))?;
    let mut bytes = Vec::new();
    file.take(max_bytes + 1).read_to_end(&mut bytes).map_err(|e| unreadable(e.to_string()))?;
    if bytes.len() as u64 > max_bytes {
        return Err(unreadable(format!("more than {max_bytes} bytes (still growing); refusing to read on")));
    }
    String::from_utf8(bytes).map_err(|_| unreadable("not UTF-8 text".into()))
}

/// Reads and checks the shard files `paths` (regular files of at most
/// `max_bytes`), each named in errors and in the result as `{path:?}`.
///
/// # Errors
/// [`ShardError::InFile`]: the first file that cannot be read or is not a
/// valid shard file, with why.
pub fn read_files<T: ShardFile>(paths: &[PathBuf], max_bytes: u64) -> Result<Vec<(String, T)>, ShardError> {
    let mut named = Vec::with_capacity(paths.len());
    for f in paths {
        let name = format!("{f:?}");
        let file = read_text(f, max_bytes)
            .and_then(|text| from_json::<T>(&text))
            .map_err(|error| ShardError::InFile { file: name.clone(), error: Box::new(error) })?;
        named.push((name, file));
    }
    Ok(named)
}

/// Puts the shards of the run `run` describes in order ([`order`]),
/// refusing any of another scene or settings ([`Header::foreign`]) or that
/// `extra` refuses, duplicates and missing ones.
///
/// # Errors
/// One line naming the offending file(s).
pub fn order_run<T: ShardFile>(
    named: Vec<(String, T)>,
    run: &Header<T::Settings>,
    extra: impl Fn(&T) -> Option<Foreign>,
) -> Result<Vec<T>, ShardError> {
    order(named, |s| (s.header().shard, s.header().shards), |s| run.foreign(s.header()).or_else(|| extra(s)))
}
