//! `itgfx viewpoints --shard i/n --save-shard F` and `--merge F1,F2,...`:
//! a job array's tasks each trace a range of viewpoints and save its
//! channel rows; the merge concatenates them into the one-process channel
//! (bit for bit) and computes every measure from it.

use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;
use itgfx_backends::tracer::{Prepared, Tracer};
use itgfx_backends::viewpoint::ViewpointChannel;
use itgfx_backends::viewpoint::shard_job::{Estimator, ViewpointShardError, ViewpointShards};
use itgfx_backends::viewpoint::solid_angle::{Convergence, Refinement};

use super::ViewpointsOptions;
use crate::CliError;
use crate::progress::Progress;
use crate::report::Report;
use crate::shard::{MAX_SHARD_BYTES, Shard};

/// `--shard`'s help.
pub const SHARD_HELP: &str =
    "Shard i of n (0-based): trace viewpoints [i*V/n, (i+1)*V/n) only and save their rows (--save-shard)";
/// `--save-shard`'s help (`volume`'s too).
pub const SAVE_HELP: &str = "Write the shard's channel rows to F (for --merge)";
/// `--merge`'s help.
pub const MERGE_HELP: &str =
    "Build the channel from the saved shards F1,F2,... of one run (all n of them) instead of tracing";

/// Checks the shard options before any work: a shard saves rows only, so
/// pictures and per-polygon output belong to the merge; there are at most
/// as many shards as viewpoints.
///
/// # Errors
/// One-line usage errors.
pub fn check(
    o: &ViewpointsOptions,
    pictures: &[(&'static str, &'static str, Option<PathBuf>)],
) -> Result<(), CliError> {
    if let Some(s) = o.shards.shard {
        if s.count > u64::from(o.viewpoints) {
            return Err(CliError::usage(format!(
                "--shard {s}: more shards than the {} viewpoints (give at most {})",
                o.viewpoints, o.viewpoints
            )));
        }
        if let Some((flag, _, _)) = pictures.iter().find(|p| p.2.is_some()) {
            let flag = if o.out.is_some() { "--out" } else { flag };
            return Err(CliError::usage(format!(
                "{flag}: a --shard run saves channel rows only; ask for pictures in the --merge run"
            )));
        }
        if o.per_polygon {
            return Err(CliError::usage("--per-polygon: a --shard run saves channel rows only; give it to --merge"));
        }
    }
    if o.shard_levels.is_some() && o.estimator == "grid" {
        return Err(CliError::usage("--shard-levels: the grid estimator has no refinement levels"));
    }
    if let Some(p) = &o.shards.save_shard {
        crate::output::check("--save-shard", p)?;
    }
    Ok(())
}

/// The job over the run's viewpoints `dirs`, estimated as the options say.
pub fn job<'a>(
    o: &ViewpointsOptions,
    name: &'a str,
    prepared: &'a Prepared,
    tracer: &'a dyn Tracer,
    dirs: &'a [DVec3],
    refine: &'a Refinement,
) -> ViewpointShards<'a> {
    let estimator = if o.estimator == "grid" {
        Estimator::Grid { resolution: o.resolution.unwrap_or(128) }
    } else {
        Estimator::SolidAngle { refine, keep: o.shard_levels.map_or(1, |k| k as usize) }
    };
    ViewpointShards { name, prepared, tracer, directions: dirs, distance: o.distance, estimator }
}

/// A job error in the CLI's words.
fn job_error(e: ViewpointShardError) -> CliError {
    match e {
        ViewpointShardError::Shard(e) => CliError::usage(crate::shard::describe(&e)),
        ViewpointShardError::Eye { .. } => CliError::usage(format!("--merge: {e}")),
        e => CliError::usage(e.to_string()),
    }
}

/// Traces shard `s`'s viewpoints, saves their rows to `--save-shard`, and
/// reports what was saved.
///
/// # Errors
/// Backend and output errors.
pub fn save(o: &ViewpointsOptions, s: Shard, job: &ViewpointShards) -> Result<Report, CliError> {
    let t0 = Instant::now();
    let mut progress = Progress::new();
    let saved = job.save(s, &mut |d, t| progress.update(d, t)).map_err(job_error)?;
    let text = saved.shard.to_json().map_err(|e| CliError::runtime(format!("--save-shard: {e}")))?;
    let path = o.shards.save_shard.as_ref().ok_or_else(|| CliError::usage("--shard needs --save-shard F"))?;
    crate::output::write(path, text.as_bytes())?;
    let (first, end, views) = (saved.shard.first, saved.shard.end, job.directions.len() as u64);
    let mut r = Report::new();
    r.text("mesh", job.name).text("backend", job.tracer.name()).text("estimator", o.estimator.clone());
    r.text("shard", s.to_string()).count("first_viewpoint", first).count("end_viewpoint", end);
    r.count("viewpoints", views).count("shard_viewpoints", end - first);
    if let Some(k) = saved.levels_saved {
        r.count("levels_saved", k as u64);
    }
    r.text("saved", path.display().to_string()).count("bytes", text.len() as u64);
    r.real("seconds", t0.elapsed().as_secs_f64(), Some("s"));
    Ok(r)
}

/// The channel (and, for the solid angle, its convergence) of the run
/// whose shards are `--merge`d: the one-process result, bit for bit.
///
/// # Errors
/// Unreadable, foreign, duplicate or missing shards: one line.
pub fn merged(
    o: &ViewpointsOptions,
    job: &ViewpointShards,
) -> Result<(ViewpointChannel, Option<Convergence>), CliError> {
    job.merge(&o.shards.merge, MAX_SHARD_BYTES).map_err(job_error)
}
