//! `--shard i/n`: one of `n` disjoint, contiguous pieces of a run (line
//! ranges of `complexity`, viewpoint ranges of `viewpoints`), so that a job
//! array's task `i` runs `--shard $i/$n` and never computes offsets.

use std::path::PathBuf;

use clap::Args;
pub use itgfx_backends::shards::{MAX_SHARDS, Place as Shard, PlaceError};

use crate::values::out_path;

/// `--shard i/n`: `0 <= i < n <= 2^32`.
///
/// # Errors
/// A [`PlaceError`], for clap to show beside the option.
pub fn parse(s: &str) -> Result<Shard, PlaceError> {
    s.parse()
}

/// The shard options every sharded command flattens: `--shard i/n`,
/// `--save-shard F` and `--merge F1,F2,...`. What a shard holds differs, so
/// each command words the help and adds its own rules with `mut_arg`
/// (`render`, `viewpoints` and `volume`: `--shard` and `--save-shard`
/// require each other; `complexity` calls `--save-shard` `--save-counts`,
/// which any run may give).
#[derive(Debug, Args)]
pub struct ShardArgs {
    /// Shard i of n (0-based): one contiguous part of the run
    #[arg(long, value_name = "i/n", value_parser = parse, help_heading = "Shards")]
    pub shard: Option<Shard>,
    /// Write the shard to F (for --merge)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Shards")]
    pub save_shard: Option<PathBuf>,
    /// Merge the saved shards F1,F2,... of one run (all n of them) instead of computing
    #[arg(long, value_name = "F1,F2,...", value_delimiter = ',', conflicts_with = "shard", help_heading = "Shards")]
    pub merge: Vec<PathBuf>,
}

/// Largest shard file read by `--merge`.
pub const MAX_SHARD_BYTES: u64 = 4 << 30;

/// A shard-file error in the CLI's words: each run setting named by the flag
/// that sets it, and the merge's own refusals prefixed with `--merge`.
#[must_use]
pub fn describe(e: &itgfx_backends::shards::ShardError) -> String {
    use itgfx_backends::shards::ShardError;
    let line = e.describe(&|s| flag(s).to_string());
    match e {
        ShardError::NoShards | ShardError::Missing { .. } => format!("--merge: {line}"),
        ShardError::InFile { .. } => format!("--merge {line}"),
        _ => line,
    }
}

/// The flag that sets a run setting.
fn flag(s: itgfx_backends::shards::Setting) -> &'static str {
    use itgfx_backends::shards::Setting;
    match s {
        Setting::Sampler => "--sampler",
        Setting::SamplesPerPixel => "--spp",
        Setting::MaxSamplesPerPixel => "--max-spp",
        Setting::Threshold => "--threshold",
        Setting::TutorialForm => "--tutorial-form",
        Setting::Delta => "--delta",
        Setting::BinaryContrast => "--binary-contrast",
        Setting::ImageSize | Setting::ImageResolution => "--size",
        Setting::Seed => "--seed",
        Setting::Camera => "--camera",
        Setting::Backend => "--backend",
        Setting::Viewpoints => "--viewpoints",
        Setting::Estimator => "--estimator",
        Setting::Distance => "--distance",
        Setting::Levels => "subdivision levels",
        Setting::Resolution => "--resolution",
        Setting::LineKind => "--local",
        Setting::Blocks => "--blocks",
    }
}
