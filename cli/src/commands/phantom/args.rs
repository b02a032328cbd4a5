//! The options of `itgfx phantom`.

use std::path::PathBuf;

use clap::Args;

use crate::imaging::{Numbers, Size, angle, bias, numbers, sizes, unit};
use crate::values::out_path;

/// `itgfx phantom`.
#[derive(Debug, Args)]
pub struct PhantomOptions {
    /// Directory for fixed.png, moving.png and transform.json, or with --dims 3 fixed.nrrd, moving.nrrd
    /// and transform.json (made if missing)
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: PathBuf,
    /// 2: an image pair (PNG); 3: a volume pair (NRRD, float)
    #[arg(long, value_name = "2|3", default_value = "2", value_parser = clap::value_parser!(u8).range(2..=3))]
    pub dims: u8,
    /// Image size W,H (default 128,128), or with --dims 3 volume size X,Y,Z in voxels (default 64,64,64)
    #[arg(long, value_name = "W,H[,D]", value_parser = sizes)]
    pub size: Option<Size>,
    /// 2D: true rotation, degrees (counter-clockwise in image axes, about the centre) [default: 5]
    #[arg(long, value_name = "DEG", value_parser = angle, allow_hyphen_values = true)]
    pub angle: Option<f64>,
    /// 3D: true rotation, degrees about x, y and z, R = Rz Ry Rx about the volume centre, each in
    /// [-180, 180] [default: 5,-3,4]
    #[arg(long, value_name = "AX,AY,AZ", value_parser = numbers, allow_hyphen_values = true)]
    pub rotation: Option<Numbers>,
    /// True translation (fixed to moving): pixels X,Y [default: 4,-3], or with --dims 3 physical units
    /// X,Y,Z [default: 3,-2,2.5]; each below the image's extent along its axis
    #[arg(long, value_name = "X,Y[,Z]", value_parser = numbers, allow_hyphen_values = true)]
    pub shift: Option<Numbers>,
    /// 3D: voxel edge lengths X,Y,Z (written as NRRD space directions) [default: 1,1,1]
    #[arg(long, value_name = "X,Y,Z", value_parser = numbers)]
    pub spacing: Option<Numbers>,
    /// Gaussian noise standard deviation (intensities in [0, 1])
    #[arg(long, value_name = "S", default_value = "0.02", value_parser = unit)]
    pub noise: f64,
    /// Bias field strength of the moving image, in [0, 0.9]
    #[arg(long, value_name = "B", default_value = "0.1", value_parser = bias)]
    pub bias: f64,
    /// Seed of the noise
    #[arg(long, value_name = "N", default_value = "1", value_parser = crate::values::count)]
    pub seed: u64,
    /// One JSON object on stdout
    #[arg(long)]
    pub json: bool,
}
