//! `itgfx phantom`: a synthetic multimodal pair with a known rigid transform,
//! images (PNG) or volumes (NRRD).

use itgfx_backends::imaging::phantom::{Phantom3Options, PhantomOptions as Render, render, render3};
use itgfx_backends::imaging::rigid::centre;
use itgfx_backends::imaging::{Rigid2, Rigid3};

use super::PhantomOptions;
use crate::CliError;
use crate::imaging::Size;
use crate::imaging::pictures::{write_gray, write_nrrd};
use crate::report::Report;

/// The rotation convention of 3D transforms, for `transform.json` and `result.json`.
pub const CONVENTION_3D: &str = "fixed point p (physical units, voxel i at i * spacing) maps to moving point \
    T(p) = R (p - centre) + centre + translation, R = Rz(rotation_deg[2]) Ry(rotation_deg[1]) Rx(rotation_deg[0]) \
    (rotate about x first; ITK Euler3DTransform with ComputeZYX on)";

/// Writes `fixed.png`, `moving.png` and `transform.json` under `--out`, or
/// with `--dims 3` `fixed.nrrd`, `moving.nrrd` and `transform.json`.
///
/// # Errors
/// Bad options and output errors, one line.
pub fn run_phantom(o: &PhantomOptions) -> Result<Report, CliError> {
    if o.dims == 3 {
        return run_phantom3(o);
    }
    let only3 = [("--rotation", o.rotation.is_some()), ("--spacing", o.spacing.is_some())];
    if let Some((flag, _)) = only3.iter().find(|f| f.1) {
        return Err(CliError::usage(format!("{flag} is for volumes (--dims 3); images take --angle")));
    }
    let (w, h) = match o.size {
        None => (128, 128),
        Some(Size::Two(w, h)) => (w, h),
        Some(Size::Three(_)) => return Err(CliError::usage("--size X,Y,Z is for volumes: add --dims 3")),
    };
    let shift = match o.shift.as_ref().map(|s| s.0.as_slice()) {
        None => (4.0, -3.0),
        Some(&[x, y]) => (x, y),
        Some(_) => return Err(CliError::usage("--shift: an image takes X,Y (two numbers)")),
    };
    // A shift of the whole image or more leaves nothing of the fixed image in
    // the moving one (and 1e300 was accepted and rendered as nothing).
    if !(shift.0.abs() < w as f64 && shift.1.abs() < h as f64) {
        return Err(CliError::usage(format!(
            "--shift {:?},{:?}: must be within the image, |X| < {w} and |Y| < {h} (--size)",
            shift.0, shift.1
        )));
    }
    let paths = crate::output::out_files(&o.out, &["fixed.png", "moving.png", "transform.json"])?;
    let truth = Rigid2 { angle_deg: o.angle.unwrap_or(5.0), tx: shift.0, ty: shift.1 };
    let (fixed, moving) = render(&Render { width: w, height: h, truth, noise: o.noise, bias: o.bias, seed: o.seed });
    write_gray(&fixed, &paths[0])?;
    write_gray(&moving, &paths[1])?;
    let c = centre(w, h);
    let mut t = Report::new();
    t.real("angle_deg", truth.angle_deg, Some("deg"))
        .real("tx", truth.tx, Some("px"))
        .real("ty", truth.ty, Some("px"))
        .reals("centre", vec![c.0, c.1])
        .text("convention", "fixed pixel x maps to moving pixel T(x) = R(angle)(x - centre) + centre + (tx, ty)")
        .counts("size", vec![w as u64, h as u64])
        .real("noise", o.noise, None)
        .real("bias", o.bias, None)
        .count("seed", o.seed);
    finish(t, &paths)
}

fn finish(t: Report, paths: &[std::path::PathBuf]) -> Result<Report, CliError> {
    let text = serde_json::to_string_pretty(&t.to_json()).unwrap_or_default();
    crate::output::write(&paths[2], format!("{text}\n").as_bytes())?;
    let mut r = t;
    r.texts("files", paths.iter().map(|p| p.display().to_string()).collect());
    Ok(r)
}

/// Three numbers of a 3D option, or its default.
fn triple(v: Option<&crate::imaging::Numbers>, default: [f64; 3], flag: &str) -> Result<[f64; 3], CliError> {
    match v.map(|n| n.0.as_slice()) {
        None => Ok(default),
        Some(&[a, b, c]) => Ok([a, b, c]),
        Some(_) => Err(CliError::usage(format!("{flag}: a volume takes three numbers X,Y,Z"))),
    }
}

/// `phantom --dims 3`.
fn run_phantom3(o: &PhantomOptions) -> Result<Report, CliError> {
    if o.angle.is_some() {
        return Err(CliError::usage("--angle is for images; volumes take --rotation AX,AY,AZ"));
    }
    let dims = match o.size {
        None => [64, 64, 64],
        Some(Size::Three(d)) => d,
        Some(Size::Two(..)) => return Err(CliError::usage("--size W,H is for images: a volume takes X,Y,Z")),
    };
    let angles = triple(o.rotation.as_ref(), [5.0, -3.0, 4.0], "--rotation")?;
    if angles.iter().any(|a| a.abs() > 180.0) {
        return Err(CliError::usage(format!("--rotation {angles:?}: each angle must be in [-180, 180]")));
    }
    let shift = triple(o.shift.as_ref(), [3.0, -2.0, 2.5], "--shift")?;
    let spacing = triple(o.spacing.as_ref(), [1.0; 3], "--spacing")?;
    if spacing.iter().any(|s| !(1e-6..=1e6).contains(s)) {
        return Err(CliError::usage(format!("--spacing {spacing:?}: each spacing must be in [1e-6, 1e6]")));
    }
    let extent: [f64; 3] = core::array::from_fn(|a| dims[a] as f64 * spacing[a]);
    if (0..3).any(|a| shift[a].abs() >= extent[a]) {
        return Err(CliError::usage(format!(
            "--shift {shift:?}: must be within the volume, below its extent {extent:?} (--size times --spacing)"
        )));
    }
    let voxels = dims[0] * dims[1] * dims[2];
    // Two f32 volumes and the NRRD bytes of one.
    itgfx_backends::memory::check(|| format!("a {}x{}x{} phantom", dims[0], dims[1], dims[2]), voxels as u64 * 12)
        .map_err(|e| CliError::usage(e.to_string()))?;
    let paths = crate::output::out_files(&o.out, &["fixed.nrrd", "moving.nrrd", "transform.json"])?;
    let truth = Rigid3 { angles_deg: angles, t: shift };
    let (fixed, moving) =
        render3(&Phantom3Options { dims, spacing, truth, noise: o.noise, bias: o.bias, seed: o.seed });
    write_nrrd(&fixed, &paths[0])?;
    write_nrrd(&moving, &paths[1])?;
    let centre = fixed.centre().to_vec();
    let mut t = Report::new();
    t.count("dims", 3)
        .reals("rotation_deg", angles.to_vec())
        .reals("translation", shift.to_vec())
        .reals("translation_voxels", (0..3).map(|a| shift[a] / spacing[a]).collect())
        .reals("centre", centre)
        .text("convention", CONVENTION_3D)
        .counts("size", dims.iter().map(|&n| n as u64).collect())
        .reals("spacing", spacing.to_vec())
        .real("noise", o.noise, None)
        .real("bias", o.bias, None)
        .count("seed", o.seed);
    finish(t, &paths)
}
