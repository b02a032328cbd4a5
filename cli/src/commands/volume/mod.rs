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

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use itgfx_backends::BackendChoice;
use itgfx_backends::backend::{open_volume, volume_memory};
use itgfx_backends::viewpoint::selection::{best_views, exploration};
use itgfx_backends::viewpoint::{ViewpointWeights, icosphere};
use itgfx_backends::volume::channel::{channel_memory, seeable_voxels};
use itgfx_backends::volume::raycast::Caster;
use itgfx_backends::volume::{TransferFunction, VolumeChannelOptions, volume_channel, volume_measures};

use crate::options::Common;
use crate::progress::Progress;
use crate::report::Report;
use crate::values::{argmin, backend, distance, out_path, threads, viewpoint_count, viewpoint_level};
use crate::{CliError, core_err};
use input::{dims, focus, image_side, iso_value, load, size, spacing, step, transfer, volume_help};
use pictures::{PICTURES, Shots};
use routes::{correlation, iso_route, object_measures};

/// Most memory the channel may take (estimated before any ray is cast).
pub const MEMORY_LIMIT: u64 = 6 << 30;

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
    let result =
        if o.time.is_some() { series::run(o, &spec, &tf, base, unit) } else { run_in(o, &spec, &tf, base, unit) };
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

#[allow(clippy::too_many_lines)]
fn run_in(
    o: &VolumeOptions,
    spec: &str,
    tf: &TransferFunction,
    base: itgfx_core::Base,
    unit: Option<&'static str>,
) -> Result<Report, CliError> {
    shard::check(o)?;
    let outputs = out_paths(o, &PICTURES)?;
    let volume = load(o, spec)?;
    let focus = o.focus.as_deref().map(|f| focus(&volume, f)).transpose()?;
    let between =
        o.path_between.as_deref().map(|s| between::labels(&volume, s, o.path_steps.unwrap_or(8))).transpose()?;
    let between_png = o.out.as_ref().filter(|_| between.is_some()).map(|d| d.join(between::PICTURE));
    // The guided tour's montage, and each object's characteristic view for a labelled volume.
    let tour_png = o.out.as_ref().map(|d| d.join(pictures::TOUR));
    let objects_png = o.out.as_ref().filter(|_| volume.labels.is_some()).map(|d| d.join(pictures::OBJECTS));
    for p in [&between_png, &tour_png, &objects_png].into_iter().flatten() {
        crate::output::check("--out", p)?;
    }
    let (lo, hi) = volume.range();
    if lo >= hi {
        return Err(CliError::usage(format!("{}: constant volume (every voxel is {lo}): nothing to see", volume.name)));
    }
    let t0 = Instant::now();
    let caster = Caster::new(&volume, tf, o.step);
    if caster.voxel_opacity.iter().all(|&a| a <= 0.0) {
        return Err(CliError::usage(format!("{}: the transfer function makes every voxel transparent", volume.name)));
    }
    let dirs = icosphere(viewpoint_level(o.viewpoints));
    let (first, end) = shard::range(o, dirs.len());
    let largest = volume.dims.iter().copied().max().unwrap_or(1) as u32;
    let rays = o.size.unwrap_or((2 * largest).clamp(32, 512));
    // The device's buffers too when it casts: on lavapipe they are host memory.
    let casting = if o.shards.merge.is_empty() { u64::from(rays) * u64::from(rays) } else { 0 };
    let need = channel_memory(&caster, seeable_voxels(&caster), end - first)
        + if casting > 0 { volume_memory(o.backend, &caster, casting) } else { 0 };
    if need > MEMORY_LIMIT {
        return Err(CliError::usage(format!(
            "{}: the channel may need {:.1} GiB (limit {} GiB): fewer --viewpoints or a smaller volume",
            volume.name,
            need as f64 / f64::from(1u32 << 30),
            MEMORY_LIMIT >> 30
        )));
    }
    itgfx_backends::memory::check(|| format!("{}: the channel", volume.name), need)
        .map_err(|e| CliError::usage(format!("{e}: fewer --viewpoints or a smaller volume")))?;
    let backend_err = |e: itgfx_backends::BackendError| CliError::usage(e.to_string());
    if let Some(s) = o.shards.shard {
        return shard::save(o, s, &*open_volume(o.backend, &caster).map_err(backend_err)?, &dirs, rays, need);
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
        shard::merged(o, &caster, &dirs, rays)?
    };
    let t_channel = t0.elapsed().as_secs_f64();
    if ch.is_blind() {
        return Err(CliError::usage(format!("{}: no viewpoint sees any voxel", volume.name)));
    }
    let weights = if o.uniform_input { ViewpointWeights::Uniform } else { ViewpointWeights::ProjectedArea };
    let err = |e| core_err("volume channel", e);
    // What needs the raw rows comes first: the measures normalise them in place.
    let (entries, rays_per_viewpoint, neighbours) = (ch.patch.len() as u64, ch.rays_per_viewpoint, ch.neighbours(6));
    let objects = volume
        .labels
        .as_ref()
        .map(|l| object_measures(&ch, &volume, l, &volume.label_names, weights, base))
        .transpose()?;
    let m = volume_measures(ch, &dirs, &caster.voxel_opacity, focus.as_ref().map(|f| f.0.as_slice()), weights, base)
        .map_err(err)?;
    let v = &m.views;
    let t_measures = t0.elapsed().as_secs_f64() - t_channel;
    let best_n = best_views(&m.analysis, v, o.selection.capture, o.selection.best_n, base, None).map_err(err)?;
    let tour = exploration(&m.analysis, &neighbours, v.best, o.selection.explore, base).map_err(err)?;
    // Without a logarithm held per entry: the memory estimate counts 12 bytes an entry.
    let instability = m.analysis.instability_lean(&neighbours, base).map_err(err)?;
    let seen = m.analysis.expand(&m.analysis.seen_angle, 0.0);
    let iso = o.iso.map(|f| iso_route(&volume, f, &dirs, o.distance, rays, base)).transpose()?;
    let path_between = match (&between, &objects) {
        (Some(b), Some(ob)) => {
            let backend = open_volume(o.backend, &caster).map_err(backend_err)?;
            Some(between::path(b, &volume, &*backend, &dirs, ob, &m.analysis.p_o, (o.distance, rays), base)?)
        }
        _ => None,
    };
    let seconds = t0.elapsed().as_secs_f64();

    let mut r = Report::new();
    r.text("volume", volume.name.clone()).text("backend", o.backend.name());
    r.counts("dims", volume.dims.iter().map(|&d| d as u64).collect());
    r.count("voxels", volume.voxels() as u64).count("viewpoints", dirs.len() as u64);
    r.count("rays_per_viewpoint", rays_per_viewpoint).real("step_voxels", o.step, None);
    r.count("channel_entries", entries);
    r.count("voxels_seen", m.analysis.p_o.iter().filter(|&&p| p > 0.0).count() as u64);
    r.text("p_v", if o.uniform_input { "uniform" } else { "visibility gathered" });
    r.real("H_V", m.h_v, unit).real("H_Z", v.object_entropy, unit).real("H_Z_given_V", v.conditional_entropy, unit);
    r.real("I_VZ", v.total_mutual_information, unit);
    r.count("best_view", v.best as u64).count("worst_view", v.worst as u64);
    r.reals("best_view_direction", dirs[v.best].to_array().to_vec());
    r.reals("worst_view_direction", dirs[v.worst].to_array().to_vec());
    let best_evmi = argmin(&m.evmi_opacity);
    r.count("best_EVMI_opacity_view", best_evmi as u64);
    r.count("best_EVMI_VoMI_view", argmin(&m.evmi_vomi) as u64);
    let nw = &m.noteworthiness_entropy;
    let best_nw = (0..nw.len()).max_by(|&a, &b| nw[a].total_cmp(&nw[b]).then(b.cmp(&a))).unwrap_or(0);
    r.count("best_noteworthiness_VE_view", best_nw as u64);
    if let (Some(f), Some((_, name))) = (&m.evmi_focus, &focus) {
        r.text("focus", name.clone()).count("best_focus_view", argmin(f) as u64);
        r.reals("best_focus_direction", dirs[argmin(f)].to_array().to_vec());
    }
    let vomi_max = m.vomi.iter().copied().fold(0.0, f64::max);
    let vomi_mean: f64 = m.vomi.iter().zip(&m.analysis.p_o).map(|(i, p)| i * p).sum();
    r.real("VoMI_max", vomi_max, unit).real("VoMI_mean_pz", vomi_mean, unit);
    r.counts("best_n_views", best_n.views.iter().map(|&x| x as u64).collect());
    r.reals("best_n_merged_VMI", best_n.merged_information.clone()).reals("best_n_captured", best_n.captured.clone());
    r.counts("exploration_path", tour.path.iter().map(|&x| x as u64).collect());
    if let Some(iso) = &iso {
        r.real("iso", iso.value, None).count("iso_triangles", iso.triangles as u64);
        r.real("iso_I_VO", iso.measures.total_mutual_information, unit);
        r.count("iso_best_view", iso.measures.best as u64).count("iso_worst_view", iso.measures.worst as u64);
        r.reals("iso_best_direction", dirs[iso.measures.best].to_array().to_vec());
        let angle = dirs[iso.measures.best].angle_between(dirs[v.best]).to_degrees();
        r.real("iso_best_angle_to_voxel_best_deg", angle, None);
        // Symmetric volumes have many equally good views: the rank of the
        // iso-surface's best view among the voxel route's VMIs says more than the angle.
        let b = v.mutual_information[iso.measures.best];
        let rank = v.mutual_information.iter().filter(|&&x| x < b - 1e-9 * b.abs()).count();
        r.count("iso_best_voxel_rank", rank as u64);
        r.maybe_real(
            "iso_voxel_VMI_correlation",
            correlation(&iso.measures.mutual_information, &v.mutual_information),
            None,
        );
    }
    if let Some(ob) = &objects {
        r.real("object_I_VO", ob.measures.total_mutual_information, unit);
        r.count("object_best_view", ob.measures.best as u64);
        r.reals("object_best_direction", dirs[ob.measures.best].to_array().to_vec());
        let recs = volume
            .label_names
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let mut x = Report::new();
                x.text("name", name.clone()).real("p_o", ob.p_o[k], None).real("I_o_V", ob.information[k], unit);
                if let Some(c) = ob.characteristic[k] {
                    x.count("characteristic_view", c as u64)
                        .reals("characteristic_direction", dirs[c].to_array().to_vec());
                }
                x
            })
            .collect();
        r.records("objects", recs);
    }
    if let Some(p) = &path_between {
        r.records("path_between", vec![p.report.clone()]);
    }
    let mut views = Vec::new();
    for (k, d) in dirs.iter().enumerate() {
        let mut x = Report::new();
        x.reals("direction", d.to_array().to_vec());
        x.real("p_v", v.weight[k], None).real("H_Z_given_v", v.entropy[k], unit).real(
            "VMI",
            v.mutual_information[k],
            unit,
        );
        x.real("EVMI_opacity", m.evmi_opacity[k], unit).real("EVMI_VoMI", m.evmi_vomi[k], unit);
        x.real("VE_noteworthiness", m.noteworthiness_entropy[k], unit);
        if let Some(f) = &m.evmi_focus {
            x.real("EVMI_focus", f[k], unit);
        }
        if let Some(iso) = &iso {
            x.real("iso_VMI", iso.measures.mutual_information[k], unit);
        }
        if let Some(ob) = &objects {
            x.real("object_VMI", ob.measures.mutual_information[k], unit);
        }
        x.maybe_real("instability", Some(instability[k]).filter(|x| x.is_finite()), unit);
        x.real("visibility", seen[k] / rays_per_viewpoint as f64, None);
        views.push(x);
    }
    r.records("views", views);
    r.real("channel_seconds", t_channel, Some("s")).real("measures_seconds", t_measures, Some("s"));
    r.real("seconds", seconds, Some("s"));
    r.real("memory_estimate_MiB", need as f64 / f64::from(1u32 << 20), None);
    if let Some(n) = host_rays {
        r.count("vulkan_rays_finished_on_host", n);
    }

    if let Some(dir) = &o.out {
        let shots = Shots {
            caster: &caster,
            dirs: &dirs,
            distance: o.distance,
            side: o.image,
            radius: caster.content_radius(),
        };
        shots.write(dir, &m, &best_n.views)?;
        let mut files: Vec<String> = outputs.iter().map(|p| p.display().to_string()).collect();
        let mut montages: Vec<(&PathBuf, Vec<glam::DVec3>)> = Vec::new();
        if let (Some(p), Some(png)) = (&path_between, &between_png) {
            montages.push((png, p.directions.clone()));
        }
        if let Some(png) = &tour_png {
            montages.push((png, tour.path.iter().map(|&v| dirs[v]).collect()));
        }
        if let (Some(ob), Some(png)) = (&objects, &objects_png) {
            montages.push((png, ob.characteristic.iter().flatten().map(|&v| dirs[v]).collect()));
        }
        for (png, directions) in montages {
            pictures::montage_of(&caster, &directions, o.distance, shots.radius, o.image, png)?;
            files.push(png.display().to_string());
        }
        r.texts("wrote", files);
        let json = r.to_json().to_string();
        crate::output::write(&dir.join(PICTURES[6]), json.as_bytes())?;
    }
    Ok(r)
}
