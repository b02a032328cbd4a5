//! The options of `itgfx viewpoints MESH`.

use std::path::PathBuf;

use clap::{ArgGroup, Args};

use crate::options::{Common, Selection, Tracing};
use crate::values::{
    distance, max_subdivision, out_path, resolution, smooth, tolerance, viewpoint_count, vp_subdivide,
};

/// `itgfx viewpoints MESH`.
#[derive(Debug, Args)]
#[command(after_help = "MESH is an .obj file or a built-in (see itgfx complexity --help). \
                        The first surface a ray meets is what it sees.\n\
                        Pictures are PNG renders and PLY with vertex colours.",
          group(ArgGroup::new("smoothed").multiple(true).args([
              "out", "importance_image", "ao_image", "saliency_image", "info_image", "export_ply", "saliency_ply",
          ])),
          mut_arg("shard", |a| a.help(super::shard::SHARD_HELP).requires("save_shard")),
          mut_arg("save_shard", |a| a.help(super::shard::SAVE_HELP).requires("shard")),
          mut_arg("merge", |a| a.help(super::shard::MERGE_HELP)))]
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
