//! `itgfx volume VOLUME`: view selection for volume data (Part VI), the
//! viewpoint channel over voxels.
//!
//! * `input`: the volume, the transfer function, the focus, option parsers;
//! * `routes`: the object channel and the iso-surface route;
//! * `pictures`: the pictures of `--out DIR`;
//! * [`shard`]: `--shard i/n --save-shard F` and `--merge`;
//! * `series`: `--time SERIES`, time-varying volumes;
//! * `between`: `--path-between A,B`, the camera path between two objects.

mod between;
mod input;
mod pictures;
mod routes;
mod series;
pub mod shard;
mod study;

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use itgfx_backends::BackendChoice;
use itgfx_backends::backend::open_volume;
use itgfx_backends::viewpoint::{ViewpointWeights, icosphere};
use itgfx_backends::volume::raycast::Caster;
use itgfx_backends::volume::{TransferFunction, VolumeChannelOptions, volume_channel};

use crate::CliError;
use crate::options::Common;
use crate::progress::Progress;
use crate::report::Report;
use crate::values::{backend, distance, out_path, threads, viewpoint_count, viewpoint_level};
use input::{dims, image_side, iso_value, size, spacing, step, transfer, volume_help};
use study::{Inputs, Study};

/// `itgfx volume VOLUME`.
#[derive(Debug, Args)]
#[command(after_help = volume_help(),
          mut_arg("shard", |a| a.help(shard::SHARD_HELP).requires("save_shard")),
          mut_arg("save_shard", |a| a.help(crate::viewpoints::shard::SAVE_HELP).requires("shard")),
          mut_arg("merge", |a| a.help(shard::MERGE_HELP)))]
pub struct VolumeOptions {
    /// A built-in volume (hydrogen:3,2,0,64, phantom:64, cube:32, sphere:32), an .nrrd or a raw file
    #[arg(value_name = "VOLUME")]
    pub volume: Option<String>,
    /// Raw file size X,Y,Z in voxels
    #[arg(long, value_name = "X,Y,Z", value_parser = dims, help_heading = "Raw input")]
    pub dims: Option<[usize; 3]>,
    /// Raw value type: u8, u16 or f32 (little-endian)
    #[arg(long = "type", value_name = "u8|u16|f32", value_parser = ["u8", "u16", "f32"], help_heading = "Raw input")]
    pub value_type: Option<String>,
    /// Voxel spacing X,Y,Z (default 1,1,1)
    #[arg(long, value_name = "X,Y,Z", value_parser = spacing, help_heading = "Raw input")]
    pub spacing: Option<[f64; 3]>,
    /// Transfer function: a preset (ramp, step) or a file
    #[arg(long, value_name = "PRESET|FILE", default_value = "ramp")]
    pub tf: String,
    /// Viewpoints: 12, 42, 162, 642 or 2562 points of a subdivided icosahedron
    #[arg(long, value_name = "N", default_value = "42", value_parser = viewpoint_count, help_heading = "Channel")]
    pub viewpoints: u32,
    /// Image side of the ray caster for the channel: N x N rays per viewpoint (8..=1024;
    /// default twice the volume's largest dimension, at least 32, at most 512: under about two
    /// rays per voxel the rows alias and I(V;Z) is biased upwards)
    #[arg(long, value_name = "N", value_parser = size, help_heading = "Channel")]
    pub size: Option<u32>,
    /// Sample step along rays, in voxels (0.05..=2)
    #[arg(long, value_name = "F", default_value = "0.5", value_parser = step, help_heading = "Channel")]
    pub step: f64,
    /// Viewpoint distance in bounding-sphere radii (1.05..=1000)
    #[arg(long, value_name = "D", default_value = "3", value_parser = distance, help_heading = "Channel")]
    pub distance: f64,
    /// p(V) uniform instead of proportional to the visibility a viewpoint gathers
    #[arg(long, help_heading = "Channel")]
    pub uniform_input: bool,
    /// Focus on a labelled object (name or number; phantom): EVMI with its voxels as importance
    #[arg(long, value_name = "LABEL", help_heading = "Channel")]
    pub focus: Option<String>,
    /// Also extract the iso-surface at this normalised value (0 < F < 1) and run the polygonal
    /// viewpoint channel on it (Part VI §2.1), to compare its views with the voxels'
    #[arg(long, value_name = "F", value_parser = iso_value, help_heading = "Channel")]
    pub iso: Option<f64>,
    /// Smooth camera path from object A's characteristic view to object B's (labelled volumes;
    /// names or numbers): the great circle between them, K steps, with their measures
    #[arg(long, value_name = "A,B", help_heading = "Objects")]
    pub path_between: Option<String>,
    /// Steps of --path-between, both ends included (2..=64; default 8)
    #[arg(long, value_name = "K", value_parser = input::path_steps, help_heading = "Objects")]
    pub path_steps: Option<usize>,
    /// A time series instead of VOLUME: hydrogen-beat, hydrogen-beat:N or hydrogen-beat:N,T; a comma-separated list of
    /// volumes, or a pattern with * or ? in the file name (matches sorted by name)
    #[arg(long, value_name = "SERIES", help_heading = "Time series", conflicts_with_all = ["best_n", "explore", "capture"])]
    pub time: Option<String>,
    /// Most camera turn between two frames of the dynamic view path, in degrees (0..=180;
    /// default: one step to a neighbouring viewpoint)
    #[arg(long, value_name = "DEG", value_parser = input::turn_degrees, help_heading = "Time series")]
    pub max_turn: Option<f64>,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub selection: crate::options::Selection,
    /// Pictures and volume.json in DIR (created if missing)
    #[arg(long, value_name = "DIR", value_parser = out_path, help_heading = "Pictures")]
    pub out: Option<PathBuf>,
    /// Side of the pictures in pixels (16..=2048)
    #[arg(long, value_name = "N", default_value = "256", value_parser = image_side, help_heading = "Pictures",
          requires = "out")]
    pub image: u32,
    /// Worker threads (default: all cores)
    #[arg(long, value_name = "T", value_parser = threads)]
    pub threads: Option<usize>,
    /// Ray-casting backend for the channel: cpu or vulkan (the same rows, bit for bit)
    #[arg(long, value_name = "cpu|vulkan", default_value = "cpu", value_parser = backend)]
    pub backend: BackendChoice,
    /// Shards.
    #[command(flatten)]
    pub shards: crate::shard::ShardArgs,
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
}

/// Runs `itgfx volume`.
///
/// # Errors
/// Usage, input and output errors; one line each.
#[allow(clippy::too_many_lines)]
pub fn run(o: &VolumeOptions) -> Result<Report, CliError> {
    check_combinations(o)?;
    let spec = o.volume.clone().or_else(|| o.time.clone()).ok_or_else(|| {
        CliError::usage(
            "give a volume: a built-in (hydrogen, phantom, cube, sphere, marschner-lobb), an .nrrd or a raw file",
        )
    })?;
    let base = o.common.base;
    let unit = Some(base.unit());
    let tf = transfer(&o.tf)?;
    let created = match &o.out {
        Some(d) => crate::output::out_dir(d)?,
        None => None,
    };
    let result = if o.time.is_some() { series::run(o, &spec, &tf, base, unit) } else { run_in(o, &spec, &tf) };
    if result.is_err()
        && let Some(d) = created
    {
        // Leave nothing behind: the directory made for --out goes again (only if still empty).
        let _ = std::fs::remove_dir(d);
    }
    result
}

/// Options that do not go together, refused before any work.
fn check_combinations(o: &VolumeOptions) -> Result<(), CliError> {
    if o.time.is_some() {
        let clash = [
            (o.volume.is_some(), "VOLUME (the series is the volume)"),
            (o.focus.is_some(), "--focus"),
            (o.iso.is_some(), "--iso"),
            (o.path_between.is_some(), "--path-between"),
            (o.shards.shard.is_some() || !o.shards.merge.is_empty(), "--shard/--merge"),
        ];
        if let Some((_, what)) = clash.iter().find(|c| c.0) {
            return Err(CliError::usage(format!("--time takes no {what}")));
        }
    } else if o.max_turn.is_some() {
        return Err(CliError::usage("--max-turn is for a time series (--time)"));
    }
    if o.path_steps.is_some() && o.path_between.is_none() {
        return Err(CliError::usage("--path-steps is for --path-between A,B"));
    }
    if o.path_between.is_some() && o.shards.shard.is_some() {
        return Err(CliError::usage("--path-between is for a whole run or --merge, not a --shard"));
    }
    Ok(())
}

/// The files `names` in `--out` (none without it), each checked writable
/// before any work; `run` removes the folder it made if the run then fails,
/// so this does not use `output::out_files` (which only undoes failed checks).
fn out_paths(o: &VolumeOptions, names: &[&str]) -> Result<Vec<PathBuf>, CliError> {
    let paths: Vec<PathBuf> = o.out.as_ref().map_or_else(Vec::new, |d| names.iter().map(|n| d.join(n)).collect());
    paths.iter().try_for_each(|p| crate::output::check("--out", p))?;
    Ok(paths)
}

/// One volume's run: its inputs, the caster, the memory the channel needs,
/// the channel (cast, merged, or a shard saved), the study, the report and
/// the pictures.
fn run_in(o: &VolumeOptions, spec: &str, tf: &TransferFunction) -> Result<Report, CliError> {
    let inputs = Inputs::read(o, spec)?;
    let volume = &inputs.volume;
    let t0 = Instant::now();
    let caster = Caster::new(volume, tf, o.step);
    if caster.voxel_opacity.iter().all(|&a| a <= 0.0) {
        return Err(CliError::usage(format!("{}: the transfer function makes every voxel transparent", volume.name)));
    }
    let dirs = icosphere(viewpoint_level(o.viewpoints));
    let largest = volume.dims.iter().copied().max().unwrap_or(1) as u32;
    let rays = o.size.unwrap_or((2 * largest).clamp(32, 512));
    let label = shard::label(o, &caster);
    let job = shard::job(o, &label, &caster, &dirs, rays);
    let need = job
        .check_memory(o.backend, job.range(o.shards.shard), o.shards.merge.is_empty())
        .map_err(|e| CliError::usage(format!("{e}: fewer --viewpoints or a smaller volume")))?;
    let backend_err = |e: itgfx_backends::BackendError| CliError::usage(e.to_string());
    if let Some(s) = o.shards.shard {
        return shard::save(o, s, &job, &*open_volume(o.backend, &caster).map_err(backend_err)?, need);
    }
    // Rays a device handed back to the host (reported for vulkan only).
    let mut host_rays = None;
    let ch = if o.shards.merge.is_empty() {
        let backend = open_volume(o.backend, &caster).map_err(backend_err)?;
        let mut progress = Progress::new();
        let copts = VolumeChannelOptions { directions: dirs.clone(), distance: o.distance, size: rays };
        let ch = volume_channel(&*backend, &copts, &mut |d, t| progress.update(d, t)).map_err(backend_err)?;
        host_rays = (o.backend == BackendChoice::Vulkan).then(|| backend.rays_finished_on_host());
        ch
    } else {
        shard::merged(o, &job)?
    };
    let t_channel = t0.elapsed().as_secs_f64();
    if ch.is_blind() {
        return Err(CliError::usage(format!("{}: no viewpoint sees any voxel", volume.name)));
    }
    let study = Study::run(o, &inputs, &caster, ch, (&dirs, rays))?;
    let seconds = t0.elapsed().as_secs_f64();
    let mut r = study.report(o, &inputs, &dirs);
    r.real("channel_seconds", t_channel, Some("s")).real("measures_seconds", study.measures_seconds, Some("s"));
    r.real("seconds", seconds, Some("s"));
    r.real("memory_estimate_MiB", need as f64 / f64::from(1u32 << 20), None);
    if let Some(n) = host_rays {
        r.count("vulkan_rays_finished_on_host", n);
    }
    if let Some(dir) = &o.out {
        study.write(o, dir, &inputs, &caster, &dirs, &mut r)?;
    }
    Ok(r)
}

/// `p(V)`: uniform with `--uniform-input`, else by the visibility gathered.
fn weights(o: &VolumeOptions) -> ViewpointWeights {
    if o.uniform_input { ViewpointWeights::Uniform } else { ViewpointWeights::ProjectedArea }
}
