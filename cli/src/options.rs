//! The typed command line: one options struct per command, parsed and
//! range-checked by clap before any scene is loaded, traced or written.

use std::path::PathBuf;

use clap::{ArgGroup, Args, Parser, Subcommand};
use itgfx_backends::BackendChoice;
use itgfx_core::Base;

use crate::measure::MeasureCommand;
use crate::values::{
    backend, base, best_n, blocks, capture, count, distance, explore, lines, max_subdivision, out_path, resolution,
    smooth, subdivide, threads, tolerance, viewpoint_count, vp_subdivide,
};

/// `itgfx`: information theory for computer graphics.
#[derive(Debug, Parser)]
#[command(
    name = "itgfx",
    version,
    about = "itgfx — information theory for computer graphics",
    after_help = "Every command accepts --json (one JSON object on stdout); those that report information measures take --base 2|e|10.\n\
                  Errors are one line on stderr: exit code 2 for a usage error (bad options or input, refused before any work), \
                  1 for a failure on the way (an output or standard output that could not be written). \
                  Output files are written all or none, at the end of the run.",
    arg_required_else_help = true
)]
pub struct Cli {
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

impl Cli {
    /// The command-line parser: [`Cli`]'s, with every option that takes a
    /// value also taking a negative number (`--delta -1`), so that the value's
    /// own check answers ("must be in ...") instead of "unknown option -1".
    #[must_use]
    pub fn parser() -> clap::Command {
        fn negatives(c: clap::Command) -> clap::Command {
            c.mut_args(|a| if a.get_action().takes_values() { a.allow_negative_numbers(true) } else { a })
                .mut_subcommands(negatives)
        }
        negatives(<Self as clap::CommandFactory>::command())
    }

    /// Parses `words` (the program name first) with [`Cli::parser`].
    ///
    /// # Errors
    /// clap's error for a bad command line.
    pub fn parse_words(words: &[std::ffi::OsString]) -> Result<Self, clap::Error> {
        let mut cmd = Self::parser();
        let m = cmd.try_get_matches_from_mut(words)?;
        <Self as clap::FromArgMatches>::from_arg_matches(&m).map_err(|e| e.format(&mut cmd))
    }
}

/// The commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Scene visibility channel: H_P, H_S, I_S, I_S^c (Part III)
    Complexity(ComplexityOptions),
    /// Viewpoint channel V -> O: VE, VMI, best views (Part V)
    Viewpoints(ViewpointsOptions),
    /// Path-traced image with adaptive pixel sampling (Part IV; Part III-IV §5)
    Render(crate::render::RenderOptions),
    /// RMSE, PSNR and relMSE of one EXR image against another
    Compare(crate::render::CompareOptions),
    /// Hierarchical radiosity refined by the oracles of Part III §9 and Part III-IV §4
    Radiosity(crate::radiosity::RadiosityOptions),
    /// Viewpoint channel over voxels V -> Z: VMI, VoMI, EVMI, best views of a volume (Part VI)
    Volume(crate::volume::VolumeOptions),
    /// Viewpoint-driven mesh simplification by VMI or VE (Part VII)
    Simplify(crate::simplify::SimplifyOptions),
    /// Rigid 2D registration by mutual information, multiresolution (Part 8)
    Register(crate::imaging::RegisterOptions),
    /// Image segmentation by the region-intensity information channel (Part 8)
    Segment(crate::imaging::SegmentOptions),
    /// A synthetic two-modality image pair with a known rigid transform (Part 8)
    Phantom(crate::imaging::PhantomOptions),
    /// Shape descriptors from the viewpoint channel (Part V), D2 and A3: distances and retrieval scores
    Shapes(crate::commands::shapes::args::ShapesOptions),
    /// Evaluate an information measure
    #[command(arg_required_else_help = true, subcommand_value_name = "NAME", subcommand_help_heading = "Measures")]
    Measure(MeasureCommand),
    /// Vulkan devices found, and the one --backend vulkan uses
    Devices(JsonOnly),
}

/// Options every command has.
#[derive(Debug, Clone, Copy, Args)]
pub struct Common {
    /// One JSON object on stdout (infinities as "inf")
    #[arg(long)]
    pub json: bool,
    /// Logarithm base: 2 (bits), e (nats) or 10 (hartleys)
    #[arg(long, value_name = "2|e|10", default_value = "2", value_parser = base)]
    pub base: Base,
}

/// `--json` alone, for the commands that report no information measure
/// (`--base` would be accepted and ignored there).
#[derive(Debug, Clone, Copy, Args)]
pub struct JsonOnly {
    /// One JSON object on stdout
    #[arg(long)]
    pub json: bool,
}

/// Options of every command that traces: the backend and the worker threads.
#[derive(Debug, Clone, Copy, Args)]
pub struct Tracing {
    /// Tracing backend: cpu, reference or vulkan
    #[arg(long, value_name = "cpu|reference|vulkan", default_value = "cpu", value_parser = backend)]
    pub backend: BackendChoice,
    /// Worker threads (default: all cores)
    #[arg(long, value_name = "T", value_parser = threads)]
    pub threads: Option<usize>,
}

/// Best views and guided exploration (Part V §4), shared by `viewpoints`
/// (channel V -> O) and `volume` (channel V -> Z).
#[derive(Debug, Clone, Copy, Args)]
pub struct Selection {
    /// At most N best views, greedy
    #[arg(long, value_name = "N", default_value = "6", value_parser = best_n, help_heading = "Selection")]
    pub best_n: usize,
    /// Stop once the views capture F of the channel's I(V;O) or I(V;Z), F in (0, 1]
    #[arg(long, value_name = "F", default_value = "0.9", value_parser = capture, help_heading = "Selection")]
    pub capture: f64,
    /// Steps of the guided exploration path from the best view
    #[arg(long, value_name = "S", default_value = "12", value_parser = explore, help_heading = "Selection")]
    pub explore: usize,
}

/// The built-in scenes, one per line with its description (the registry of backends).
#[must_use]
pub fn scene_list() -> String {
    let mut s = String::from("SCENE is an .obj file (one patch per polygon) or a built-in:\n");
    for b in itgfx_backends::scene::BUILT_IN {
        s.push_str(&format!("  {}\n      {}\n", b.syntax, b.description));
    }
    s
}

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
    #[command(flatten)]
    #[allow(missing_docs)]
    pub tracing: Tracing,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: Common,
}

/// `itgfx viewpoints MESH`.
#[derive(Debug, Args)]
#[command(after_help = "MESH is an .obj file or a built-in (see itgfx complexity --help). \
                        The first surface a ray meets is what it sees.\n\
                        Pictures are PNG renders and PLY with vertex colours.",
          group(ArgGroup::new("smoothed").multiple(true).args([
              "out", "importance_image", "ao_image", "saliency_image", "info_image", "export_ply", "saliency_ply",
          ])),
          mut_arg("shard", |a| a.help(crate::viewpoint_shard::SHARD_HELP).requires("save_shard")),
          mut_arg("save_shard", |a| a.help(crate::viewpoint_shard::SAVE_HELP).requires("shard")),
          mut_arg("merge", |a| a.help(crate::viewpoint_shard::MERGE_HELP)))]
pub struct ViewpointsOptions {
    /// An .obj file or a built-in scene name
    #[arg(value_name = "MESH")]
    pub mesh: Option<String>,
    /// Points of a subdivided icosahedron: 12, 42, 162, 642 or 2562
    #[arg(long, value_name = "N", default_value = "42", value_parser = viewpoint_count, help_heading = "Channel")]
    pub viewpoints: u32,
    /// solid-angle: exact triangle solid angles, visibility sampled where it changes, refined to
    /// --tolerance (converged, with standard errors); grid: R x R rays per viewpoint (plug-in counts,
    /// biased upwards when polygons are smaller than the ray spacing)
    #[arg(long, value_name = "solid-angle|grid", default_value = "solid-angle",
          value_parser = ["solid-angle", "grid"], help_heading = "Channel")]
    pub estimator: String,
    /// Relative tolerance on every VMI (solid-angle): met when 2 standard errors <= F * VMI
    #[arg(long, value_name = "F", default_value = "0.01", value_parser = tolerance, help_heading = "Channel")]
    pub tolerance: f64,
    /// Largest subdivision M (M x M visibility samples) of a triangle where visibility changes
    #[arg(long, value_name = "M", default_value = "32", value_parser = max_subdivision, help_heading = "Channel")]
    pub max_subdivision: u32,
    /// R x R rays per viewpoint over the cone around the object (grid only; default 128)
    #[arg(long, value_name = "R", value_parser = resolution, help_heading = "Channel")]
    pub resolution: Option<u32>,
    /// Viewpoint distance in bounding-sphere radii (1.05..=1000: f32 tracing stays exact enough)
    #[arg(long, value_name = "D", default_value = "3", value_parser = distance, help_heading = "Channel")]
    pub distance: f64,
    /// p(V) uniform instead of the projected area
    #[arg(long, help_heading = "Channel")]
    pub uniform_input: bool,
    /// Count the background as an extra polygon
    #[arg(long, help_heading = "Channel")]
    pub background: bool,
    /// Split every polygon into K x K cells (1..=64)
    #[arg(long, value_name = "K", default_value = "1", value_parser = vp_subdivide, help_heading = "Channel")]
    pub subdivide: u32,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub tracing: Tracing,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub selection: Selection,
    /// Every picture below under its default name in DIR
    #[arg(long, value_name = "DIR", value_parser = out_path, help_heading = "Pictures")]
    pub out: Option<PathBuf>,
    /// The best view (best.png)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub best_image: Option<PathBuf>,
    /// The worst view (worst.png)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub worst_image: Option<PathBuf>,
    /// The best-n views side by side (best-n.png)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub best_n_image: Option<PathBuf>,
    /// Saliency from the best importance-driven view (best-importance.png)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub importance_image: Option<PathBuf>,
    /// The viewpoint sphere coloured by VMI (top) and VE (bottom), best view red (sphere.png)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub sphere_image: Option<PathBuf>,
    /// Mesh saliency from the best view (saliency.png)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub saliency_image: Option<PathBuf>,
    /// Information-theoretic ambient occlusion from the best view (ao.png)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub ao_image: Option<PathBuf>,
    /// I(o;V) per polygon from the best view (info.png)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub info_image: Option<PathBuf>,
    /// Ambient occlusion as PLY (ao.ply)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub export_ply: Option<PathBuf>,
    /// Mesh saliency as PLY (saliency.ply)
    #[arg(long, value_name = "F", value_parser = out_path, help_heading = "Pictures")]
    pub saliency_ply: Option<PathBuf>,
    /// Pictures average each polygon with its neighbours K times; JSON values are never smoothed
    #[arg(long, value_name = "K", default_value = "2", value_parser = smooth, help_heading = "Pictures",
          requires = "smoothed")]
    pub smooth: u32,
    /// I(o;V), saliency and p(o) per polygon in the output
    #[arg(long)]
    pub per_polygon: bool,
    /// --shard, --save-shard, --merge (boxed: the options stay small)
    #[command(flatten)]
    pub shards: Box<crate::shard::ShardArgs>,
    /// Solid angle: refinement levels a shard saves per viewpoint (default 1: the first pass); the
    /// merge traces any further level a viewpoint needs. 16 keeps them all: the merge traces nothing
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..=16), requires = "shard",
          help_heading = "Shards")]
    pub shard_levels: Option<u32>,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: Common,
}
