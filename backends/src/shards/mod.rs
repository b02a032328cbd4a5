//! The one shard module: every engine that splits a run into shards
//! (`render` pixel rows, `viewpoints` and `volume` viewpoint rows,
//! `complexity` line ranges) writes and reads its files' header through here.
//!
//! * [`place`]: a shard's place `i/n` and the part of the run it covers;
//! * [`fingerprint`]: the one hash (FNV-1a) and what identifies a scene;
//! * [`header`]: the one header (format, version, place, fingerprint of the
//!   scene and settings, the settings), JSON reading with the format and
//!   version checked first, reading several files, and ordering a run's
//!   shards;
//! * [`order`](mod@order): ordering with foreign, duplicate and missing shards refused;
//! * [`error`]: [`ShardError`], typed; a setting two shards disagree on is a
//!   [`Setting`], which a front end names its own way ([`ShardError::describe`]).
//!
//! Counts files (`complexity --save-counts`) carry this header too
//! (`visibility::counts_header`), with place `0/1`: they hold line ranges
//! rather than a place (any `--offset` run merges), after the header, in
//! `visibility::counts_file` (JSON) and `visibility::counts_binary`; their
//! scene hash is [`Fnv`] of the patch areas.

pub mod error;
pub mod fingerprint;
pub mod header;
pub mod order;
pub mod place;

pub use error::{Difference, Setting, ShardError};
pub use fingerprint::{Fnv, MeshFingerprint};
pub use header::{Header, Kind, Settings, ShardFile, from_json, order_run, read_files, to_json, validate};
pub use order::{Foreign, order};
pub use place::{MAX_SHARDS, Place, PlaceError, range};
