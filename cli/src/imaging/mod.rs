//! `itgfx phantom`, `itgfx register` and `itgfx segment`: information theory
//! on images (syllabus Part 8), over [`itgfx_backends::imaging`].

pub mod pictures;
pub mod register;
pub mod segment;
pub mod synth;

use std::path::PathBuf;

use clap::Args;

pub use register::run_register;
pub use segment::run_segment;
pub use synth::run_phantom;

use crate::values::out_path;

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

/// `X,Y`: two finite numbers.
///
/// # Errors
/// A reason.
pub fn pair(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or("is not X,Y (two numbers and a comma)")?;
    let num =
        |v: &str| v.trim().parse::<f64>().ok().filter(|x| x.is_finite()).ok_or(format!("{v:?} is not a finite number"));
    Ok((num(a)?, num(b)?))
}

/// A finite number in `[lo, hi]`.
fn ranged(s: &str, lo: f64, hi: f64) -> Result<f64, String> {
    let v: f64 = s.parse().ok().filter(|x: &f64| x.is_finite()).ok_or("is not a finite number")?;
    if (lo..=hi).contains(&v) { Ok(v) } else { Err(format!("must be in [{lo}, {hi}]")) }
}

/// `--angle`: degrees in `[−180, 180]`.
///
/// # Errors
/// A reason.
pub fn angle(s: &str) -> Result<f64, String> {
    ranged(s, -180.0, 180.0)
}

/// `--noise`: standard deviation in `[0, 1]`.
///
/// # Errors
/// A reason.
pub fn unit(s: &str) -> Result<f64, String> {
    ranged(s, 0.0, 1.0)
}

/// `--bias`: in `[0, 0.9]` (the field stays positive).
///
/// # Errors
/// A reason.
pub fn bias(s: &str) -> Result<f64, String> {
    ranged(s, 0.0, 0.9)
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
    /// Directory for fixed.png, moving.png and transform.json (made if missing)
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: PathBuf,
    /// Image size
    #[arg(long, value_name = "W,H", default_value = "128,128", value_parser = size)]
    pub size: (usize, usize),
    /// True rotation, degrees (counter-clockwise in image axes, about the centre)
    #[arg(long, value_name = "DEG", default_value = "5", value_parser = angle, allow_hyphen_values = true)]
    pub angle: f64,
    /// True translation, pixels (fixed to moving), |X| and |Y| below the image's width and height
    #[arg(long, value_name = "X,Y", default_value = "4,-3", value_parser = pair, allow_hyphen_values = true)]
    pub shift: (f64, f64),
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
    /// The fixed (reference) image, PNG
    #[arg(value_name = "FIXED.png")]
    pub fixed: PathBuf,
    /// The moving image, PNG, same size
    #[arg(value_name = "MOVING.png")]
    pub moving: PathBuf,
    /// The true transform (transform.json from `itgfx phantom`): errors are reported
    #[arg(long, value_name = "transform.json")]
    pub truth: Option<PathBuf>,
    /// Directory for registered.png, checkerboard.png, overlay.png, joint.png, joint-initial.png, trace.png,
    /// result.json
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
    /// Starting transform: angle in degrees, then x and y shifts in pixels
    #[arg(long, value_name = "DEG,X,Y", default_value = "0,0,0", value_parser = register::start, allow_hyphen_values = true)]
    pub initial: itgfx_backends::imaging::Rigid2,
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
