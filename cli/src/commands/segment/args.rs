//! The options of `itgfx segment`.

use std::path::PathBuf;

use clap::Args;

use crate::imaging::{bins, unit};
use crate::values::out_path;

/// `itgfx segment`.
#[derive(Debug, Args)]
pub struct SegmentOptions {
    /// The image, PNG
    #[arg(value_name = "IMAGE.png")]
    pub image: PathBuf,
    /// Directory for labels.png, means.png, curve.png, result.json
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: PathBuf,
    /// Regions kept after merging, at most the leaves of the split (default: the fewest keeping
    /// --ratio of I(R;X))
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..=512))]
    pub regions: Option<u32>,
    /// Without --regions: keep the fewest clusters with I(T;X) >= ratio * I(R;X) of the split
    #[arg(long, value_name = "R", default_value = "0.9", value_parser = unit, conflicts_with = "regions")]
    pub ratio: f64,
    /// Stop splitting once I(R;X) >= split-ratio * H(X)
    #[arg(long, value_name = "R", default_value = "1", value_parser = unit)]
    pub split_ratio: f64,
    /// Most leaves of the split (the bottleneck costs leaves^3 * bins)
    #[arg(long, value_name = "N", default_value = "128", value_parser = clap::value_parser!(u32).range(1..=512))]
    pub max_leaves: u32,
    /// Intensity bins
    #[arg(long, value_name = "N", default_value = "32", value_parser = bins)]
    pub bins: usize,
    /// --json and --base (entropies and information in bits, nats or hartleys)
    #[command(flatten)]
    pub common: crate::options::Common,
}
