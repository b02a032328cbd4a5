//! The options of `itgfx complexity SCENE`.

use std::path::PathBuf;

use clap::{ArgGroup, Args};

use crate::options::{Traced, scene_list};
use crate::values::{blocks, count, lines, out_path, subdivide};

/// `itgfx complexity SCENE`.
#[derive(Debug, Args)]
#[command(after_help = scene_list(), group(ArgGroup::new("picture").multiple(true).args(["export_ply", "image"])),
          mut_arg("shard", |a| a.help("Shard i of n (0-based) of the --lines run: lines [i*N/n, (i+1)*N/n), for job arrays")
              .conflicts_with("offset").help_heading(None)),
          mut_arg("save_shard", |a| a.long("save-counts").help("Write the counts to F (binary; JSON if F ends in .json)")
              .help_heading(None)),
          mut_arg("merge", |a| a.help("Evaluate saved shards together instead of tracing: F1,F2,... (with --lines N: they must cover 0..N)")
              .conflicts_with_all(["offset", "local", "seed", "blocks"]).help_heading(None)))]
pub struct ComplexityOptions {
    /// A built-in scene name (e.g. cube-enclosure:10) or an .obj file
    #[arg(value_name = "SCENE")]
    pub scene: Option<String>,
    /// Lines to cast (global lines that miss count; default 1e6); 1e7-style counts accepted. With
    /// --shard, the whole run's lines; with --merge, the shards must cover exactly lines 0..N
    #[arg(long, value_name = "N", value_parser = lines)]
    pub lines: Option<u64>,
    /// Seed; same seed, same numbers, any thread count
    #[arg(long, value_name = "S", default_value = "1", value_parser = count)]
    pub seed: u64,
    /// Local lines from the patches instead of global lines
    #[arg(long)]
    pub local: bool,
    /// Split every patch into K x K cells
    #[arg(long, value_name = "K", default_value = "1", value_parser = subdivide)]
    pub subdivide: u32,
    /// Jackknife blocks for standard errors (1 = none)
    #[arg(long, value_name = "B", default_value = "8", value_parser = blocks)]
    pub blocks: u32,
    /// Mesh coloured by information per unit area, as PLY
    #[arg(long, value_name = "F", value_parser = out_path)]
    pub export_ply: Option<PathBuf>,
    /// The same, rendered from a default camera, as PNG
    #[arg(long, value_name = "F.png", value_parser = out_path)]
    pub image: Option<PathBuf>,
    /// Colour by information per unit area, or by I_i^c - I_i (delta)
    #[arg(long, value_name = "information|delta", default_value = "information",
          value_parser = ["information", "delta"], requires = "picture")]
    pub color_by: String,
    /// First line index (shards of one run: same seed, disjoint ranges)
    #[arg(long, value_name = "K", default_value = "0", value_parser = count)]
    pub offset: u64,
    /// Save the counts (--save-counts) and report what they cover, without the measures: the inner
    /// steps of a merge tree (over half a partial merge's time is the measures' evaluation)
    #[arg(long, requires = "save_shard", conflicts_with_all = ["export_ply", "image"])]
    pub counts_only: bool,
    /// `--shard`, `--save-counts` (the shard's counts, or any run's) and `--merge`
    #[command(flatten)]
    pub shards: crate::shard::ShardArgs,
    /// `--backend`, `--threads`, `--json`, `--base`
    #[command(flatten)]
    pub run: Traced,
}
