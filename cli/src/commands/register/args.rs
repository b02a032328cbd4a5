//! The options of `itgfx register`.

use std::path::PathBuf;

use clap::Args;

use super::run as register;
use crate::imaging::{Numbers, bins, numbers};
use crate::values::out_path;

/// `itgfx register`.
#[derive(Debug, Args)]
pub struct RegisterOptions {
    /// The fixed (reference) image, PNG, or volume, NRRD
    #[arg(value_name = "FIXED")]
    pub fixed: PathBuf,
    /// The moving image or volume, same kind and size
    #[arg(value_name = "MOVING")]
    pub moving: PathBuf,
    /// The true transform (transform.json from `itgfx phantom`): errors are reported
    #[arg(long, value_name = "transform.json")]
    pub truth: Option<PathBuf>,
    /// Directory for registered.png (volumes: registered.nrrd), checkerboard.png, overlay.png (images only),
    /// joint.png, joint-initial.png, trace.png, result.json
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: PathBuf,
    /// Histogram bins per axis
    #[arg(long, value_name = "N", default_value = "32", value_parser = bins)]
    pub bins: usize,
    /// Joint histogram: parzen (cubic B-spline window on the moving intensity, Mattes), binned, or pv
    /// (partial-volume interpolation, Maes)
    #[arg(long, value_name = "KIND", default_value = "parzen", value_parser = ["parzen", "binned", "pv"])]
    pub histogram: String,
    /// Metric maximised: mi, nmi (Studholme), ecc (entropy correlation), mi-over-joint [default: mi for
    /// images, nmi for volumes (MI's overlap bias misregisters volumes: docs/IMAGING.md)]
    #[arg(long, value_name = "M", value_parser = ["mi", "nmi", "ecc", "mi-over-joint"])]
    pub metric: Option<String>,
    /// Pyramid, coarse to fine: shrink:sigma per level (sigma in full-resolution pixels) [default:
    /// 4:2,2:1,1:1 for images, 4:2,2:1,1:0.5 for volumes (less smoothing at the last level lowers the
    /// median rotation error: docs/IMAGING.md)]
    #[arg(long, value_name = "S:SIGMA,...", value_parser = register::levels)]
    pub levels: Option<register::Levels>,
    /// Starting transform: DEG,X,Y (angle in degrees, shifts in pixels), or for volumes AX,AY,AZ,X,Y,Z
    /// (degrees about x, y, z as in --rotation of phantom, shifts in physical units) [default: identity]
    #[arg(long, value_name = "DEG,X,Y", value_parser = numbers, allow_hyphen_values = true)]
    pub initial: Option<Numbers>,
    /// Most Powell iterations per level
    #[arg(long, value_name = "N", default_value = "50", value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub max_iterations: u32,
    /// --json and --base (entropies and information in bits, nats or hartleys)
    #[command(flatten)]
    pub common: crate::options::Common,
}
