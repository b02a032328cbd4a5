//! `itgfx viewpoints --shard i/n --save-shard F` and `--merge F1,F2,...`:
//! a job array's tasks each trace a range of viewpoints and save its
//! channel rows; the merge concatenates them into the one-process channel
//! (bit for bit) and computes every measure from it.

use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;
use itgfx_backends::tracer::{Prepared, Tracer};
use itgfx_backends::viewpoint::ViewpointChannel;
use itgfx_backends::viewpoint::shard_file::{
    MeshFingerprint, ShardSettings, ViewpointShard, grid_channel, order_shards, shard_range,
};
use itgfx_backends::viewpoint::solid_angle::{Convergence, Refinement, ladder_levels};

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

/// The settings the rows depend on.
#[must_use]
pub fn settings(o: &ViewpointsOptions, viewpoints: usize, refine: &Refinement, backend: &str) -> ShardSettings {
    let grid = o.estimator == "grid";
    ShardSettings {
        viewpoints: viewpoints as u64,
        estimator: o.estimator.clone(),
        distance: o.distance,
        levels: if grid { Vec::new() } else { ladder_levels(refine.first, refine.max) },
        resolution: if grid { o.resolution.unwrap_or(128) } else { 0 },
        backend: backend.to_string(),
    }
}

/// Traces shard `s`'s viewpoints, saves their rows to `--save-shard`, and
/// reports what was saved.
///
/// # Errors
/// Backend and output errors.
pub fn save(
    o: &ViewpointsOptions,
    s: Shard,
    name: &str,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    dirs: &[DVec3],
    refine: &Refinement,
) -> Result<Report, CliError> {
    let t0 = Instant::now();
    let st = settings(o, dirs.len(), refine, tracer.name());
    let (first, end) = shard_range(s.index, s.count, dirs.len() as u64);
    let mine = &dirs[first as usize..end as usize];
    let mut progress = Progress::new();
    let mut tick = |d, t| progress.update(d, t);
    let scene = MeshFingerprint::of(name, prepared);
    let (shard, kept) = if o.estimator == "grid" {
        let ch = ViewpointChannel::build(prepared, tracer, mine, o.distance, st.resolution, &mut tick)
            .map_err(|e| CliError::usage(e.to_string()))?;
        (ViewpointShard::grid(scene, st, (s.index, s.count), &ch), None)
    } else {
        let keep = o.shard_levels.map_or(1, |k| k as usize);
        let ladders = ViewpointChannel::ladders(prepared, tracer, mine, refine, keep, &mut tick)
            .map_err(|e| CliError::usage(format!("{name}: {e}")))?;
        let kept = ladders.first().map_or(0, |l| l.fractions.len());
        (ViewpointShard::solid_angle(scene, st, (s.index, s.count), ladders), Some(kept))
    };
    let text = shard.to_json().map_err(|e| CliError::runtime(format!("--save-shard: {e}")))?;
    let path = o.shards.save_shard.as_ref().ok_or_else(|| CliError::usage("--shard needs --save-shard F"))?;
    crate::output::write(path, text.as_bytes())?;
    let mut r = Report::new();
    r.text("mesh", name).text("backend", tracer.name()).text("estimator", o.estimator.clone());
    r.text("shard", s.to_string()).count("first_viewpoint", first).count("end_viewpoint", end);
    r.count("viewpoints", dirs.len() as u64).count("shard_viewpoints", end - first);
    if let Some(k) = kept {
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
    name: &str,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    dirs: &[DVec3],
    refine: &Refinement,
) -> Result<(ViewpointChannel, Option<Convergence>), CliError> {
    let st = settings(o, dirs.len(), refine, tracer.name());
    let scene = MeshFingerprint::of(name, prepared);
    let fail = |e| CliError::usage(crate::shard::describe(&e));
    let named = itgfx_backends::shards::read_files(&o.shards.merge, MAX_SHARD_BYTES).map_err(fail)?;
    let shards = order_shards(named, &scene, &st).map_err(fail)?;
    if o.estimator == "grid" {
        return Ok((grid_channel(prepared.patches, &shards, dirs, o.distance, st.resolution), None));
    }
    let ladders: Vec<_> = shards.iter().flat_map(ViewpointShard::ladders).collect();
    for (v, (l, d)) in ladders.iter().zip(dirs).enumerate() {
        if l.eye != d.normalize() * o.distance {
            return Err(CliError::usage(format!("--merge: viewpoint {v}'s eye is not where this run puts it")));
        }
    }
    let (ch, c) = ViewpointChannel::from_ladders(prepared, tracer, &ladders, refine)
        .map_err(|e| CliError::usage(format!("{name}: {e}")))?;
    Ok((ch, Some(c)))
}
