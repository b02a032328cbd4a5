//! The typed command line: one options struct per command, parsed and
//! range-checked by clap before any scene is loaded, traced or written.

use clap::{Args, Parser, Subcommand};
use itgfx_backends::BackendChoice;
use itgfx_core::Base;

use crate::measure::MeasureCommand;
use crate::values::{backend, base, best_n, capture, explore, threads};

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
    Complexity(crate::commands::complexity::ComplexityOptions),
    /// Viewpoint channel V -> O: VE, VMI, best views (Part V)
    Viewpoints(crate::commands::viewpoints::ViewpointsOptions),
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
    Register(crate::commands::register::RegisterOptions),
    /// Image segmentation by the region-intensity information channel (Part 8)
    Segment(crate::commands::segment::SegmentOptions),
    /// A synthetic two-modality image pair with a known rigid transform (Part 8)
    Phantom(crate::commands::phantom::PhantomOptions),
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

/// The options a command that traces a scene and reports measures ends
/// with: [`Tracing`] (`--backend`, `--threads`), then [`Common`] (`--json`,
/// `--base`), in that order in `--help`.
#[derive(Debug, Clone, Copy, Args)]
pub struct Traced {
    #[command(flatten)]
    #[allow(missing_docs)]
    pub tracing: Tracing,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: Common,
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
