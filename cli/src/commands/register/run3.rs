//! `itgfx register FIXED.nrrd MOVING.nrrd`: rigid registration of volumes
//! (6 parameters) by mutual information, over
//! [`itgfx_backends::imaging::register3()`].

use std::path::Path;
use std::time::Instant;

use itgfx_backends::imaging::register3::{joint_histogram3, resample3, working_bytes};
use itgfx_backends::imaging::{Gray3, RegisterOptions as Engine, Registration3, Rigid3, register3};
use itgfx_backends::volume::nrrd::read_nrrd;

use super::RegisterOptions;
use super::run::{Outcome, choices, level_report, trace_picture};
use crate::CliError;
use crate::commands::phantom::CONVENTION_3D;
use crate::imaging::pictures::{checkerboard, histogram_image, middle_slices, side_by_side, write_nrrd, write_rgb};
use crate::report::Report;

const FILES: [&str; 6] =
    ["registered.nrrd", "checkerboard.png", "joint.png", "joint-initial.png", "trace.png", "result.json"];

/// Rotation error (degrees) and translation error (voxels) counted as a
/// success: 1° is about half a voxel at the rim of a 64³ volume.
pub const SUCCESS: (f64, f64) = (1.0, 1.0);

/// Nanoseconds per voxel and metric evaluation (Parzen, one thread),
/// measured on the 64³ phantom: the basis of the time estimate.
const NS_PER_VOXEL: f64 = 40.0;

/// Evaluations a level typically takes (6 parameters, a few Powell
/// iterations of ~8 line searches of ~6 evaluations), for the estimate.
const EVALUATIONS_PER_LEVEL: f64 = 250.0;

/// Reads `transform.json` of `phantom --dims 3`: `rotation_deg` and `translation`.
///
/// # Errors
/// One line naming the file.
pub fn read_truth3(path: &Path) -> Result<Rigid3, CliError> {
    let fail = |e: &dyn std::fmt::Display| CliError::usage(format!("--truth {path:?}: {e}"));
    let text = itgfx_backends::files::read_regular_to_string(path).map_err(|e| fail(&e))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| fail(&e))?;
    let get = |k: &str| -> Option<[f64; 3]> {
        let a = v.get(k)?.as_array()?;
        let n: Vec<f64> = a.iter().map(|x| x.as_f64().filter(|x| x.is_finite())).collect::<Option<_>>()?;
        n.try_into().ok()
    };
    match (get("rotation_deg"), get("translation")) {
        (Some(angles_deg), Some(t)) => Ok(Rigid3 { angles_deg, t }),
        _ => Err(fail(&"needs rotation_deg and translation, three finite numbers each (a volume's transform)")),
    }
}

/// `--initial` of a volume: `AX,AY,AZ,X,Y,Z`.
fn start3(o: &RegisterOptions) -> Result<Rigid3, CliError> {
    match o.initial.as_ref().map(|n| n.0.as_slice()) {
        None => Ok(Rigid3::default()),
        Some(&[a, b, c, x, y, z]) if [a, b, c].iter().all(|v| v.abs() <= 180.0) => {
            Ok(Rigid3 { angles_deg: [a, b, c], t: [x, y, z] })
        }
        Some(&[_, _, _, _, _, _]) => Err(CliError::usage("--initial: each angle must be in [-180, 180]")),
        Some(_) => Err(CliError::usage("--initial: a volume takes AX,AY,AZ,X,Y,Z (six numbers)")),
    }
}

fn read(path: &Path) -> Result<Gray3, CliError> {
    let v = read_nrrd(path).map_err(|e| CliError::usage(e.to_string()))?;
    Ok(Gray3 { dims: v.dims, spacing: v.spacing, data: v.data })
}

/// FIXED and MOVING, read (their memory checked first) and checked: the
/// same size and grid, at least 4 voxels along each axis, neither constant.
fn read_pair3(o: &RegisterOptions) -> Result<(Gray3, Gray3), CliError> {
    // Reading holds a file's bytes and their f32 values (at most 4 per byte) at once.
    let len = |p: &Path| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
    let reading = len(&o.fixed).saturating_mul(5).saturating_add(len(&o.moving).saturating_mul(4));
    itgfx_backends::memory::check(|| "reading the two volumes".to_string(), reading)
        .map_err(|e| CliError::usage(e.to_string()))?;
    let fixed = read(&o.fixed)?;
    let moving = read(&o.moving)?;
    if fixed.dims != moving.dims {
        return Err(CliError::usage(format!(
            "the fixed volume is {:?} voxels but the moving volume is {:?}: register needs the same size",
            fixed.dims, moving.dims
        )));
    }
    if fixed.spacing != moving.spacing {
        return Err(CliError::usage(format!(
            "the fixed volume's spacing is {:?} but the moving volume's is {:?}: register needs the same grid",
            fixed.spacing, moving.spacing
        )));
    }
    if fixed.dims.iter().any(|&n| n < 4) {
        return Err(CliError::usage(format!(
            "{:?}: {:?} voxels: register needs at least 4 along each axis",
            o.fixed, fixed.dims
        )));
    }
    for (img, path) in [(&fixed, &o.fixed), (&moving, &o.moving)] {
        let (lo, hi) = img.range();
        if lo >= hi {
            return Err(CliError::usage(format!("{path:?}: the volume is constant: nothing to register")));
        }
    }
    Ok((fixed, moving))
}

/// Registers two volumes, writes `registered.nrrd`, the pictures and
/// `result.json`, returns the report.
///
/// # Errors
/// Bad inputs and output errors, one line.
pub fn run_register3(o: &RegisterOptions) -> Result<Report, CliError> {
    let initial = start3(o)?;
    let truth = o.truth.as_deref().map(read_truth3).transpose()?;
    let (fixed, moving) = read_pair3(o)?;
    let voxels = fixed.data.len();
    let [nx, ny, nz] = fixed.dims;
    itgfx_backends::memory::check(|| format!("registering {nx}x{ny}x{nz} volumes"), working_bytes(voxels))
        .map_err(|e| CliError::usage(e.to_string()))?;
    let (kind, metric) = choices(o, true);
    let engine = Engine::<Rigid3> {
        bins: o.bins,
        kind,
        metric,
        levels: super::run::pyramid(o, true),
        initial,
        max_iterations: o.max_iterations as usize,
        ..Engine::default()
    };
    let estimate: f64 = engine
        .levels
        .iter()
        .map(|l| voxels as f64 / (l.shrink as f64).powi(3) * EVALUATIONS_PER_LEVEL * NS_PER_VOXEL * 1e-9)
        .sum();
    crate::imaging::say(&format!("register: {nx}x{ny}x{nz} volumes, about {estimate:.0} s (estimate)"));
    let paths = crate::output::out_files(&o.out, &FILES)?;
    let t0 = Instant::now();
    let r = register3(&fixed, &moving, &engine, |k, n| {
        let l = engine.levels[k];
        crate::imaging::say(&format!("register: level {}/{n} (shrink {}, sigma {})", k + 1, l.shrink, l.sigma));
    })
    .map_err(|e| CliError::usage(e.to_string()))?;
    let seconds = t0.elapsed().as_secs_f64();
    let t = r.transform;
    write_pictures3((&fixed, &moving), &engine, &r, &paths)?;
    let k = std::f64::consts::LN_2 * o.common.base.per_nat();
    let sp = fixed.spacing;
    let mut rep = Report::new();
    rep.count("dims", 3)
        .reals("rotation_deg", t.angles_deg.to_vec())
        .reals("translation", t.t.to_vec())
        .reals("translation_voxels", (0..3).map(|a| t.t[a] / sp[a]).collect())
        .text("convention", CONVENTION_3D);
    let levels = r.levels.iter().map(|l| {
        let counts = (l.iterations, l.evaluations);
        level_report(l.level, &l.size, counts, &l.transform.params(), &l.trace, metric, k)
    });
    let counts = r.levels.iter().map(|l| (l.iterations, l.evaluations));
    let outcome = Outcome { entropies: &r.entropies, initial: r.initial_entropies.as_ref(), overlap: r.overlap };
    outcome.report(&mut rep, o, metric, (counts, levels.collect()), (Some(estimate), seconds));
    if let Some(truth) = truth {
        truth_report(&mut rep, &t, &truth, (fixed.dims, sp));
    }
    rep.write_result(&paths)
}

/// The errors against `--truth`: rotation, translation (in voxels too) and
/// the corners' distance, and whether they make a success ([`SUCCESS`]).
fn truth_report(rep: &mut Report, t: &Rigid3, truth: &Rigid3, (dims, sp): ([usize; 3], [f64; 3])) {
    let rot = t.rotation_distance_deg(truth);
    let d: [f64; 3] = core::array::from_fn(|a| t.t[a] - truth.t[a]);
    let trans = d.iter().map(|v| v * v).sum::<f64>().sqrt();
    let voxels_off = (0..3).map(|a| (d[a] / sp[a]).powi(2)).sum::<f64>().sqrt();
    rep.real("rotation_error_deg", rot, Some("deg"))
        .real("translation_error", trans, None)
        .real("translation_error_voxels", voxels_off, Some("voxels"))
        .real("corner_error", t.corner_distance(truth, dims, sp), None)
        .flag("success", rot < SUCCESS.0 && voxels_off < SUCCESS.1);
}

/// The registered volume, the middle slices' checkerboards, the joint
/// histograms after and before, and the metric's trace.
fn write_pictures3(
    (fixed, moving): (&Gray3, &Gray3),
    engine: &Engine<Rigid3>,
    r: &Registration3,
    paths: &[std::path::PathBuf],
) -> Result<(), CliError> {
    let t = r.transform;
    let registered = resample3(moving, &t, 0.0);
    write_nrrd(&registered, &paths[0])?;
    let (a, b) = (middle_slices(fixed), middle_slices(&registered));
    let boards: Vec<_> = (0..3)
        .map(|k| {
            let tile = (a[k].width.max(a[k].height) / 8).max(2);
            checkerboard(&a[k], &b[k], tile)
        })
        .collect();
    write_rgb(&side_by_side(&boards), &paths[1])?;
    let scale = (256 / engine.bins as u32).max(1);
    let hist = joint_histogram3(fixed, moving, &t, engine.bins, engine.kind);
    write_rgb(&histogram_image(&hist.counts, engine.bins, scale), &paths[2])?;
    let before = joint_histogram3(fixed, moving, &engine.initial, engine.bins, engine.kind);
    write_rgb(&histogram_image(&before.counts, engine.bins, scale), &paths[3])?;
    let traces: Vec<&[f64]> = r.levels.iter().map(|l| l.trace.as_slice()).collect();
    write_rgb(&trace_picture(&traces), &paths[4])?;
    Ok(())
}
