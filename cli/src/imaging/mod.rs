//! `itgfx phantom`, `itgfx register` and `itgfx segment`: information theory
//! on images (syllabus Part 8), over [`itgfx_backends::imaging`].

pub mod pictures;
pub mod register;
pub mod register3;
pub mod segment;
pub mod synth;

use std::path::PathBuf;

use clap::Args;

pub use register::run_register;
pub use segment::run_segment;
pub use synth::run_phantom;

use crate::values::{out_path, real, real_in};

/// One of several numbers: [`real`], its refusal naming the text (`"x" is not a finite number`).
fn finite(v: &str) -> Result<f64, String> {
    real(v.trim()).map_err(|e| format!("{v:?} {e}"))
}

/// Largest width or height of a generated phantom.
pub const MAX_SIDE: usize = 8192;

/// `W,H`: two sides in `4..=8192`, at most [`pictures::MAX_PIXELS`] pixels.
///
/// # Errors
/// A reason.
pub fn size(s: &str) -> Result<(usize, usize), String> {
    let (w, h) = s.split_once(',').ok_or("is not W,H (two integers and a comma)")?;
    let side = |v: &str| -> Result<usize, String> {
        let n: usize = v.trim().parse().map_err(|_| format!("{v:?} is not a whole number"))?;
        if (4..=MAX_SIDE).contains(&n) { Ok(n) } else { Err(format!("each side must be in 4..={MAX_SIDE}, not {n}")) }
    };
    let (w, h) = (side(w)?, side(h)?);
    if (w * h) as u64 > pictures::MAX_PIXELS {
        return Err(format!("{w} x {h} is more than {} pixels", pictures::MAX_PIXELS));
    }
    Ok((w, h))
}

/// A comma-separated list of 1 to 8 finite numbers (the length is checked
/// where the dimension is known: 2D or 3D).
#[derive(Clone, Debug, PartialEq)]
pub struct Numbers(pub Vec<f64>);

/// Parses [`Numbers`].
///
/// # Errors
/// A reason.
pub fn numbers(s: &str) -> Result<Numbers, String> {
    let v: Vec<f64> = s.split(',').map(finite).collect::<Result<_, _>>()?;
    if v.len() > 8 { Err("give at most 8 numbers".into()) } else { Ok(Numbers(v)) }
}

/// Largest side of a generated phantom volume.
pub const MAX_SIDE_3D: usize = 1024;

/// `--size` of `phantom`: `W,H` ([`size`]) or `X,Y,Z` (sides in `4..=1024`,
/// at most [`pictures::MAX_PIXELS`] voxels).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// An image.
    Two(usize, usize),
    /// A volume.
    Three([usize; 3]),
}

/// Parses [`Size`].
///
/// # Errors
/// A reason.
pub fn sizes(s: &str) -> Result<Size, String> {
    if s.split(',').count() != 3 {
        return size(s).map(|(w, h)| Size::Two(w, h));
    }
    let mut d = [0usize; 3];
    for (k, v) in s.split(',').enumerate() {
        let n: usize = v.trim().parse().map_err(|_| format!("{v:?} is not a whole number"))?;
        if !(4..=MAX_SIDE_3D).contains(&n) {
            return Err(format!("each side must be in 4..={MAX_SIDE_3D}, not {n}"));
        }
        d[k] = n;
    }
    if (d[0] * d[1] * d[2]) as u64 > pictures::MAX_PIXELS {
        return Err(format!("{} x {} x {} is more than {} voxels", d[0], d[1], d[2], pictures::MAX_PIXELS));
    }
    Ok(Size::Three(d))
}

/// `X,Y`: two finite numbers.
///
/// # Errors
/// A reason.
pub fn pair(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or("is not X,Y (two numbers and a comma)")?;
    Ok((finite(a)?, finite(b)?))
}

/// `--angle`: degrees in `[−180, 180]`.
///
/// # Errors
/// A reason.
pub fn angle(s: &str) -> Result<f64, String> {
    real_in(s, -180.0, 180.0)
}

/// `--noise`: standard deviation in `[0, 1]`.
///
/// # Errors
/// A reason.
pub fn unit(s: &str) -> Result<f64, String> {
    real_in(s, 0.0, 1.0)
}

/// `--bias`: in `[0, 0.9]` (the field stays positive).
///
/// # Errors
/// A reason.
pub fn bias(s: &str) -> Result<f64, String> {
    real_in(s, 0.0, 0.9)
}

/// `--bins`: 2..=256.
///
/// # Errors
/// A reason.
pub fn bins(s: &str) -> Result<usize, String> {
    let n: usize = s.parse().map_err(|_| "is not a whole number".to_string())?;
    if (2..=256).contains(&n) { Ok(n) } else { Err("must be in 2..=256".into()) }
}

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
    /// Metric maximised: mi, nmi (Studholme), ecc (entropy correlation), mi-over-joint
    #[arg(long, value_name = "M", default_value = "mi", value_parser = ["mi", "nmi", "ecc", "mi-over-joint"])]
    pub metric: String,
    /// Pyramid, coarse to fine: shrink:sigma per level (sigma in full-resolution pixels)
    #[arg(long, value_name = "S:SIGMA,...", default_value = "4:2,2:1,1:1", value_parser = register::levels)]
    pub levels: register::Levels,
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

/// Progress lines on stderr when it is a terminal or `ITGFX_PROGRESS=1`.
pub fn say(msg: &str) {
    use std::io::IsTerminal;
    if std::io::stderr().is_terminal() || std::env::var_os("ITGFX_PROGRESS").is_some_and(|v| v == "1") {
        eprintln!("{msg}");
    }
}
