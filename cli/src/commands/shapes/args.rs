//! The options of `itgfx shapes`.

use std::path::PathBuf;

use clap::Args;

use crate::options::{JsonOnly, Tracing};
use crate::values::{out_path, positive, viewpoint_count};

/// `itgfx shapes FILE...`: shape descriptors from the viewpoint channel
/// (Part V) and the classical shape distributions D2 and A3, their distance
/// matrices and, with `--labels`, retrieval scores.
#[derive(Debug, Args)]
pub struct ShapesOptions {
    /// Meshes (any scene file the other commands read, or a built-in object)
    #[arg(value_name = "FILE")]
    pub files: Vec<String>,
    /// Descriptors, comma-separated; the first gives "distance": it (viewpoint channel), d2, a3
    #[arg(long, value_name = "it|d2|a3,...", default_value = "it,d2,a3")]
    pub descriptor: String,
    /// CSV of `file,class` rows naming every FILE: adds nearest-neighbour accuracy, mAP, precision-recall
    #[arg(long, value_name = "CSV")]
    pub labels: Option<PathBuf>,
    /// Writes descriptors.csv, descriptors.json, distance-DESCRIPTOR.csv and, with --labels, pr.png
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: Option<PathBuf>,
    /// Seed of the D2/A3 surface samples
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Point pairs (D2) and triples (A3) per mesh
    #[arg(long, value_name = "N", default_value = "262144", value_parser = positive)]
    pub samples: u64,
    /// Viewpoints of the information descriptor: 12, 42, 162, 642 or 2562
    #[arg(long, value_name = "N", default_value = "162", value_parser = viewpoint_count)]
    pub viewpoints: u32,
    /// Blocks of the information descriptor: js (default), vmi, vkl, area (comma-separated; docs/SHAPES.md)
    #[arg(long, value_name = "LIST", default_value = "js")]
    pub blocks: String,
    /// Tracing backend and threads
    #[command(flatten)]
    pub tracing: Tracing,
    /// --json
    #[command(flatten)]
    pub common: JsonOnly,
}
