//! The options of `itgfx simplify`.

use std::path::PathBuf;

use clap::Args;

use crate::options::{Common, Tracing};
use crate::values::{distance, max_subdivision, out_path, tolerance, viewpoint_count};

/// `itgfx simplify MESH`.
#[derive(Debug, Args)]
#[command(after_help = "MESH is an .obj file (or a built-in scene) that welds into a manifold triangle mesh.\n\
                        Writes DIR/input.obj (welded, repaired), DIR/simplified_N.obj per target, DIR/original.png, DIR/simplified_N.png and\n\
                        DIR/compare.png (rows: original, then each target; columns: evaluation views); with two targets or more,\n\
                        DIR/errors.png: image RMSE (white) and silhouette RMSE (orange) against triangles (log axis).")]
pub struct SimplifyOptions {
    /// An .obj file or a built-in scene name
    #[arg(value_name = "MESH")]
    pub mesh: Option<String>,
    /// Triangles to keep: a percentage (10%) or a count (500)
    #[arg(long, value_name = "P%|N", conflicts_with = "evaluate", allow_negative_numbers = true)]
    pub target: Option<String>,
    /// Several targets in one run, each written: 50%,10%,2% (or counts)
    #[arg(long, value_name = "P%,...", conflicts_with = "evaluate", allow_negative_numbers = true)]
    pub sweep: Option<String>,
    /// Output directory (created if missing)
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: Option<PathBuf>,
    /// Collapse cost: vmi = mean |change of each viewpoint's I(v;O)|, ve = mean |change of viewpoint
    /// entropy|, ivo = |change of the channel's I(V;O)|, vkl = mean |change of each viewpoint's
    /// Kullback-Leibler distance to the actual areas|
    #[arg(long, value_name = "vmi|ve|ivo|vkl", default_value = "vmi", value_parser = ["vmi", "ve", "ivo", "vkl"],
          conflicts_with = "evaluate")]
    pub metric: String,
    /// Where a collapse puts the vertex it keeps: blend = at the quadric error's minimiser
    /// (Garland-Heckbert), collapses ordered by the viewpoint cost + LAMBDA x the quadric error
    /// per unit of surface area; quadric = the same vertex, ordered by the viewpoint cost alone;
    /// best = the position of least viewpoint cost among that minimiser, the midpoint and the two
    /// ends; endpoint = half-edge collapses (the vertex stays where it was, the papers' form)
    #[arg(long, value_name = "blend|quadric|best|endpoint", default_value = "blend",
          value_parser = ["blend", "quadric", "best", "endpoint"], conflicts_with = "evaluate")]
    pub placement: String,
    /// Weight of the quadric error in --placement blend's order (chosen on a torus and a
    /// reduced bunny, docs/SIMPLIFY.md)
    #[arg(long, value_name = "LAMBDA", default_value = "10000", value_parser = lambda, conflicts_with = "evaluate")]
    pub lambda: f64,
    /// Viewpoints of the channel: 12, 42, 162, 642 or 2562 (a subdivided icosahedron)
    #[arg(long, value_name = "N", default_value = "42", value_parser = viewpoint_count)]
    pub viewpoints: u32,
    /// Viewpoint distance in bounding-sphere radii
    #[arg(long, value_name = "D", default_value = "3", value_parser = distance)]
    pub distance: f64,
    /// Relative VMI tolerance of each traced channel
    #[arg(long, value_name = "F", default_value = "0.05", value_parser = tolerance)]
    pub tolerance: f64,
    /// Largest subdivision M of triangles where visibility changes
    #[arg(long, value_name = "M", default_value = "8", value_parser = max_subdivision)]
    pub max_subdivision: u32,
    /// Leave the background out of the channel (by default it is an extra polygon, Part V §3.1,
    /// so that a shrinking silhouette changes the channel)
    #[arg(long)]
    pub no_background: bool,
    /// Measure this already simplified OBJ against MESH instead of simplifying (e.g. QEM's output)
    #[arg(long, value_name = "F.obj")]
    pub evaluate: Option<String>,
    /// Evaluation views (a Fibonacci spiral, none of them a channel viewpoint)
    #[arg(long, value_name = "N", default_value = "24", value_parser = eval_views)]
    pub eval_views: usize,
    /// Pixels per side of each evaluation render
    #[arg(long, value_name = "PX", default_value = "128", value_parser = image_size)]
    pub image_size: u32,
    /// Points sampled on each surface for the Hausdorff distance
    #[arg(long, value_name = "N", default_value = "20000", value_parser = samples)]
    pub samples: usize,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub tracing: Tracing,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: Common,
}

fn lambda(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err("must be a finite number >= 0".into()),
    }
}

fn eval_views(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=1000).contains(&n) => Ok(n),
        _ => Err("must be an integer in 1..=1000".into()),
    }
}

fn image_size(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n) if (8..=2048).contains(&n) => Ok(n),
        _ => Err("must be an integer in 8..=2048".into()),
    }
}

fn samples(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (100..=10_000_000).contains(&n) => Ok(n),
        _ => Err("must be an integer in 100..=10000000".into()),
    }
}
