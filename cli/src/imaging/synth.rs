//! `itgfx phantom`: a synthetic multimodal pair with a known rigid transform.

use itgfx_backends::imaging::Rigid2;
use itgfx_backends::imaging::phantom::{PhantomOptions as Render, render};
use itgfx_backends::imaging::rigid::centre;

use super::PhantomOptions;
use super::pictures::write_gray;
use crate::CliError;
use crate::report::Report;

/// Writes `fixed.png`, `moving.png` and `transform.json` under `--out`.
///
/// # Errors
/// Output errors, one line.
pub fn run_phantom(o: &PhantomOptions) -> Result<Report, CliError> {
    let (w, h) = o.size;
    // A shift of the whole image or more leaves nothing of the fixed image in
    // the moving one (and 1e300 was accepted and rendered as nothing).
    if !(o.shift.0.abs() < w as f64 && o.shift.1.abs() < h as f64) {
        return Err(CliError::usage(format!(
            "--shift {:?},{:?}: must be within the image, |X| < {w} and |Y| < {h} (--size)",
            o.shift.0, o.shift.1
        )));
    }
    let paths = crate::output::out_files(&o.out, &["fixed.png", "moving.png", "transform.json"])?;
    let truth = Rigid2 { angle_deg: o.angle, tx: o.shift.0, ty: o.shift.1 };
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
    let text = serde_json::to_string_pretty(&t.to_json()).unwrap_or_default();
    crate::output::write(&paths[2], format!("{text}\n").as_bytes())?;
    let mut r = t;
    r.texts("files", paths.iter().map(|p| p.display().to_string()).collect());
    Ok(r)
}
