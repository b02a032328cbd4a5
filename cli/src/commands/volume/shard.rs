//! `itgfx volume --shard i/n --save-shard F` and `--merge F1,F2,...`: a job
//! array's tasks each ray-cast a range of viewpoints and save their channel
//! rows `vis(z|v)` (the viewpoint shard file of
//! `backends/src/viewpoint/shard_file.rs`, with voxels for patches); the
//! merge concatenates them into the channel one process builds, bit for
//! bit, and computes every measure from it (they need every row).

use std::time::Instant;

use glam::DVec3;
use itgfx_backends::viewpoint::ViewpointChannel;
use itgfx_backends::volume::cast::VolumeCaster;
use itgfx_backends::volume::raycast::Caster;
use itgfx_backends::volume::shard_job::VolumeShards;

use super::VolumeOptions;
use crate::CliError;
use crate::progress::Progress;
use crate::report::Report;
use crate::shard::{MAX_SHARD_BYTES, Shard};

/// `--shard`'s help.
pub const SHARD_HELP: &str =
    "Shard i of n (0-based): ray-cast viewpoints [i*V/n, (i+1)*V/n) only and save their rows (--save-shard)";
/// `--merge`'s help.
pub const MERGE_HELP: &str =
    "Build the channel from the saved shards F1,F2,... of one run (all n of them) instead of ray casting";

/// Checks the shard options before any work: a shard saves rows only, so
/// pictures, the iso-surface route and the focus belong to the merge; there
/// are at most as many shards as viewpoints.
///
/// # Errors
/// One-line usage errors.
pub(super) fn check(o: &VolumeOptions) -> Result<(), CliError> {
    let Some(s) = o.shards.shard else { return Ok(()) };
    if s.count > u64::from(o.viewpoints) {
        return Err(CliError::usage(format!(
            "--shard {s}: more shards than the {} viewpoints (give at most {})",
            o.viewpoints, o.viewpoints
        )));
    }
    let merge_only = [("--out", o.out.is_some()), ("--iso", o.iso.is_some()), ("--focus", o.focus.is_some())];
    if let Some((flag, _)) = merge_only.iter().find(|f| f.1) {
        return Err(CliError::usage(format!("{flag}: a --shard run saves channel rows only; give it to --merge")));
    }
    if let Some(p) = &o.shards.save_shard {
        crate::output::check("--save-shard", p)?;
    }
    Ok(())
}

/// The job over the run's viewpoints `dirs`: the fingerprint's name is the
/// volume, `--tf` and `--step` (as shard files have always had it).
pub(super) fn job<'a>(
    o: &VolumeOptions,
    label: &'a str,
    caster: &'a Caster<'a>,
    dirs: &'a [DVec3],
    rays: u32,
) -> VolumeShards<'a> {
    VolumeShards { label, caster, directions: dirs, distance: o.distance, rays }
}

/// The fingerprint's name of `caster`'s volume under the options.
pub(super) fn label(o: &VolumeOptions, caster: &Caster<'_>) -> String {
    format!("{} --tf {} --step {}", caster.volume.name, o.tf, o.step)
}

/// Ray-casts shard `s`'s viewpoints, saves their rows to `--save-shard`,
/// and reports what was saved.
///
/// # Errors
/// Output errors.
pub(super) fn save(
    o: &VolumeOptions,
    s: Shard,
    job: &VolumeShards,
    backend: &dyn VolumeCaster,
    memory: u64,
) -> Result<Report, CliError> {
    let t0 = Instant::now();
    let mut progress = Progress::new();
    let saved = job.save(backend, s, &mut |d, t| progress.update(d, t)).map_err(|e| CliError::usage(e.to_string()))?;
    let text = saved.shard.to_json().map_err(|e| CliError::runtime(format!("--save-shard: {e}")))?;
    let path = o.shards.save_shard.as_ref().ok_or_else(|| CliError::usage("--shard needs --save-shard F"))?;
    crate::output::write(path, text.as_bytes())?;
    let (first, end, views) = (saved.shard.first, saved.shard.end, job.directions.len() as u64);
    let mut r = Report::new();
    r.text("volume", job.caster.volume.name.clone()).text("shard", s.to_string());
    r.count("first_viewpoint", first).count("end_viewpoint", end);
    r.count("viewpoints", views).count("shard_viewpoints", end - first);
    r.count("channel_entries", saved.entries);
    r.text("saved", path.display().to_string()).count("bytes", text.len() as u64);
    r.real("memory_estimate_MiB", memory as f64 / f64::from(1u32 << 20), None);
    r.real("seconds", t0.elapsed().as_secs_f64(), Some("s"));
    Ok(r)
}

/// The channel of the run whose shards are `--merge`d: the one-process
/// channel, bit for bit.
///
/// # Errors
/// Unreadable, foreign, duplicate or missing shards: one line.
pub(super) fn merged(o: &VolumeOptions, job: &VolumeShards) -> Result<ViewpointChannel, CliError> {
    job.merge(&o.shards.merge, MAX_SHARD_BYTES).map_err(|e| CliError::usage(crate::shard::describe(&e)))
}
