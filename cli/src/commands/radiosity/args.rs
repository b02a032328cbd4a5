//! The options of `itgfx radiosity` and their value parsers: every value is
//! checked by clap before any work.

use std::path::PathBuf;

use clap::Args;
use itgfx_backends::radiosity::Oracle;

use crate::options::Traced;
use crate::values::{count, out_path, ranged, real};

/// `itgfx radiosity SCENE`.
#[derive(Debug, Args)]
#[command(after_help = "SCENE is an .obj file (with MTL Kd/Ke) or a built-in (see itgfx complexity --help); \
                        cornell-box's light emits.\n\
                        --out DIR gets radiosity.png (Gouraud), mesh.png, radiosity.exr and radiosity.pfm (linear), \
                        mesh.ply (leaf elements, vertex radiosities), elements.csv (+ patches.csv with \
                        --check-paths) and radiosity.json; with --path-trace W it gets reference.exr and \
                        reference.pfm (+ -even/-odd halves, PFM), \
                        reference.png and reference.json instead.")]
pub struct RadiosityOptions {
    /// A built-in scene name (e.g. cornell-box) or an .obj file
    #[arg(value_name = "SCENE")]
    pub scene: Option<String>,
    /// Refinement oracle: power, ks, ks-avg, mi, kl, cs, hl or variance (vt)
    #[arg(long, value_name = "NAME", default_value = "power", value_parser = oracle)]
    pub oracle: Oracle,
    /// Bisect epsilon until the mesh has about N elements (equal-element-count protocol)
    #[arg(long, value_name = "N", value_parser = elements, conflicts_with = "epsilon")]
    pub elements: Option<usize>,
    /// Refinement threshold (dimensionless; default 1e-3 without --elements)
    #[arg(long, value_name = "E", value_parser = epsilon, allow_hyphen_values = true)]
    pub epsilon: Option<f64>,
    /// Relative tolerance on the element count of --elements
    #[arg(long, value_name = "F", default_value = "0.03", value_parser = fraction)]
    pub count_tolerance: f64,
    /// Most solves of the epsilon search
    #[arg(long, value_name = "K", default_value = "30", value_parser = trials)]
    pub max_trials: u32,
    /// Random point pairs (lines) per link evaluation, N_s (tutorial: 10)
    #[arg(long, value_name = "N", default_value = "10", value_parser = samples)]
    pub samples: u32,
    /// Samples per final link's transport estimate (default: --samples); the mesh is unchanged by it
    #[arg(long, value_name = "N", value_parser = samples)]
    pub transport_samples: Option<u32>,
    /// Final links gather the radiosity of the source leaf each transport sample lands on (fine meshes)
    #[arg(long)]
    pub shares: bool,
    /// Smallest element as a fraction of the total area (RenderPark: 1e-6)
    #[arg(long, value_name = "F", default_value = "1e-6", value_parser = min_area)]
    pub min_area: f64,
    /// Split every polygon L times (4^L elements each) before the first links
    #[arg(long, value_name = "L", default_value = "0", value_parser = base_level)]
    pub base_level: u32,
    /// Stop refining at this many elements (memory grows with the links: 0.44 GiB measured at 67k elements, 1.05 GiB at 114k, default samples, no --shares; --shares adds 8 bytes per share, at most min(transport samples, source leaves) per link)
    #[arg(long, value_name = "N", default_value = "200000", value_parser = max_elements)]
    pub max_elements: usize,
    /// Seed; same seed, same mesh and numbers, any thread count
    #[arg(long, value_name = "S", default_value = "1", value_parser = count)]
    pub seed: u64,
    /// Split every patch into K x K cells first
    #[arg(long, value_name = "K", default_value = "1", value_parser = subdivide)]
    pub subdivide: u32,
    /// Picture width and height in pixels (8..=2048)
    #[arg(long, value_name = "W", default_value = "256", value_parser = size)]
    pub size: u32,
    /// Camera of the pictures in scene units: eye, target, up (3 numbers each) and vertical field of
    /// view in degrees (default: the scene file's camera, else the scene's default view)
    #[arg(long, value_name = "EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOV", value_parser = crate::render::camera)]
    pub camera: Option<itgfx_backends::camera::Camera>,
    /// Score the solution against a path-traced reference (reference.exr or .pfm of --path-trace)
    #[arg(long, value_name = "R.exr", value_parser = out_path, conflicts_with = "path_trace")]
    pub reference: Option<PathBuf>,
    /// Make the reference instead: W random walks per pixel (no mesh, no oracle)
    #[arg(long, value_name = "W", value_parser = walks, conflicts_with_all = [
        "elements", "epsilon", "shares", "oracle", "samples", "base_level", "transport_samples", "min_area",
        "count_tolerance", "max_trials",
    ])]
    pub path_trace: Option<u32>,
    /// Check the solution patch by patch: N paths of the renderer's path tracer per patch
    #[arg(long, value_name = "N", value_parser = walks, conflicts_with = "path_trace")]
    pub check_paths: Option<u32>,
    /// Write the pictures and files into DIR
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: Option<PathBuf>,
    /// `--backend`, `--threads`, `--json`, `--base`
    #[command(flatten)]
    pub run: Traced,
}

fn oracle(s: &str) -> Result<Oracle, String> {
    s.parse().map_err(|e: itgfx_backends::radiosity::UnknownOracle| e.to_string())
}

fn elements(s: &str) -> Result<usize, String> {
    ranged(s, 1, 2_000_000).map(|v| v as usize)
}

fn max_elements(s: &str) -> Result<usize, String> {
    ranged(s, 16, 2_000_000).map(|v| v as usize)
}

fn epsilon(s: &str) -> Result<f64, String> {
    let e = real(s)?;
    if e > 0.0 && e <= 1e6 { Ok(e) } else { Err("must be in (0, 1e6]".into()) }
}

fn fraction(s: &str) -> Result<f64, String> {
    let e = real(s)?;
    if (1e-4..=0.5).contains(&e) { Ok(e) } else { Err("must be in 1e-4..=0.5".into()) }
}

fn min_area(s: &str) -> Result<f64, String> {
    let e = real(s)?;
    if (1e-12..=0.25).contains(&e) { Ok(e) } else { Err("must be in 1e-12..=0.25 of the total area".into()) }
}

fn base_level(s: &str) -> Result<u32, String> {
    ranged(s, 0, 8).map(|v| v as u32)
}

fn trials(s: &str) -> Result<u32, String> {
    ranged(s, 1, 200).map(|v| v as u32)
}

fn samples(s: &str) -> Result<u32, String> {
    ranged(s, 2, 1000).map(|v| v as u32)
}

fn subdivide(s: &str) -> Result<u32, String> {
    ranged(s, 1, 64).map(|v| v as u32)
}

/// Up to 2048 x 2048 pixels: a pixel's ray, hit and sight take about 120 bytes.
fn size(s: &str) -> Result<u32, String> {
    ranged(s, 8, 2048).map(|v| v as u32)
}

fn walks(s: &str) -> Result<u32, String> {
    ranged(s, 2, 1 << 20).map(|v| v as u32)
}
