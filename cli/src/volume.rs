//! `itgfx volume VOLUME`: view selection for volume data (Part VI), the
//! viewpoint channel over voxels.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use glam::DVec3;
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::Prepared;
use itgfx_backends::viewpoint::selection::{best_views, exploration};
use itgfx_backends::viewpoint::{ViewpointAnalysis, ViewpointChannel, ViewpointMeasures, ViewpointWeights, icosphere};
use itgfx_backends::volume::builtin::{BUILT_IN, built_in, is_built_in};
use itgfx_backends::volume::channel::{channel_memory, seeable_voxels, viewpoint_colour};
use itgfx_backends::volume::iso::iso_surface;
use itgfx_backends::volume::nrrd::read_nrrd;
use itgfx_backends::volume::objects::object_channel;
use itgfx_backends::volume::raw::{RawType, read_raw};
use itgfx_backends::volume::raycast::{Caster, View};
use itgfx_backends::volume::transfer::PRESETS;
use itgfx_backends::volume::{TransferFunction, Volume, VolumeChannelOptions, volume_channel, volume_measures};
use itgfx_backends::{BackendChoice, open};

use crate::export::{montage, percentile_range, sphere_image, viridis, write_png};
use crate::options::Common;
use crate::progress::Progress;
use crate::report::Report;
use crate::values::{
    argmin, best_n, capture, count, distance, explore, out_path, threads, viewpoint_count, viewpoint_level,
};
use crate::{CliError, core_err};

/// Most memory the channel may take (estimated before any ray is cast).
pub const MEMORY_LIMIT: u64 = 6 << 30;

fn volume_help() -> String {
    let mut s = String::from(
        "VOLUME is a built-in, an .nrrd file (one raw scalar volume, little-endian) or a raw file\n\
                      (little-endian values, x fastest; give --dims and --type):\n",
    );
    for b in BUILT_IN {
        s.push_str(&format!("  {}\n      {}\n", b.syntax, b.description));
    }
    s.push_str("--tf is a preset (");
    s.push_str(&PRESETS.iter().map(|p| format!("{}: {}", p.0, p.1)).collect::<Vec<_>>().join("; "));
    s.push_str(") or a file of lines 'value opacity r g b' over the scalar normalised to [0, 1].\n");
    s.push_str("--out DIR gets best.png, worst.png, best-n.png, sphere.png, vomi.png, colour-vomi.png, volume.json.");
    s
}

/// `itgfx volume VOLUME`.
#[derive(Debug, Args)]
#[command(after_help = volume_help())]
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
    /// At most N best views, greedy
    #[arg(long, value_name = "N", default_value = "6", value_parser = best_n, help_heading = "Selection")]
    pub best_n: usize,
    /// Stop once the views capture F of I(V;Z), F in (0, 1]
    #[arg(long, value_name = "F", default_value = "0.9", value_parser = capture, help_heading = "Selection")]
    pub capture: f64,
    /// Steps of the guided exploration path from the best view
    #[arg(long, value_name = "S", default_value = "12", value_parser = explore, help_heading = "Selection")]
    pub explore: usize,
    /// Pictures and volume.json in DIR (created if missing)
    #[arg(long, value_name = "DIR", value_parser = out_path, help_heading = "Pictures")]
    pub out: Option<PathBuf>,
    /// Side of the pictures in pixels (16..=2048)
    #[arg(long, value_name = "N", default_value = "256", value_parser = image_side, help_heading = "Pictures")]
    pub image: u32,
    /// Worker threads (default: all cores)
    #[arg(long, value_name = "T", value_parser = threads)]
    pub threads: Option<usize>,
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
}

fn ranged(s: &str, lo: u64, hi: u64) -> Result<u64, String> {
    let v = count(s)?;
    if (lo..=hi).contains(&v) { Ok(v) } else { Err(format!("must be in {lo}..={hi}")) }
}

fn size(s: &str) -> Result<u32, String> {
    ranged(s, 8, 1024).map(|v| v as u32)
}

fn image_side(s: &str) -> Result<u32, String> {
    ranged(s, 16, 2048).map(|v| v as u32)
}

fn step(s: &str) -> Result<f64, String> {
    let x: f64 = s.parse().ok().filter(|x: &f64| x.is_finite()).ok_or("is not a finite number")?;
    if (0.05..=2.0).contains(&x) { Ok(x) } else { Err("must be in 0.05..=2 voxels".into()) }
}

fn iso_value(s: &str) -> Result<f64, String> {
    let x: f64 = s.parse().ok().filter(|x: &f64| x.is_finite()).ok_or("is not a finite number")?;
    if x > 0.0 && x < 1.0 { Ok(x) } else { Err("must be in (0, 1): a value of the scalar normalised to [0, 1]".into()) }
}

fn triple<T: std::str::FromStr>(s: &str, what: &str) -> Result<[T; 3], String> {
    let v: Vec<T> = s
        .split(',')
        .map(|x| x.trim().parse::<T>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("want three {what} X,Y,Z"))?;
    <[T; 3]>::try_from(v).map_err(|_| format!("want three {what} X,Y,Z"))
}

fn dims(s: &str) -> Result<[usize; 3], String> {
    let d: [usize; 3] = triple(s, "sizes")?;
    if d.iter().any(|&x| x == 0 || x > 4096) {
        return Err("every size must be in 1..=4096".into());
    }
    Ok(d)
}

fn spacing(s: &str) -> Result<[f64; 3], String> {
    let d: [f64; 3] = triple(s, "numbers")?;
    if d.iter().any(|x| !x.is_finite() || *x <= 0.0 || *x > 1e6) {
        return Err("every spacing must be in (0, 1e6]".into());
    }
    Ok(d)
}

/// The pictures under `--out`, in order.
const PICTURES: [&str; 7] =
    ["best.png", "worst.png", "best-n.png", "sphere.png", "vomi.png", "colour-vomi.png", "volume.json"];

fn load(o: &VolumeOptions, spec: &str) -> Result<Volume, CliError> {
    let usage = |e: itgfx_backends::volume::VolumeError| CliError::usage(e.to_string());
    let path = Path::new(spec);
    if is_built_in(spec) && !path.exists() {
        if o.dims.is_some() || o.value_type.is_some() || o.spacing.is_some() {
            return Err(CliError::usage("--dims, --type and --spacing are for raw files, not built-in volumes"));
        }
        return built_in(spec).map_err(usage);
    }
    if !path.exists() {
        // Not a file: report it as a built-in (the message lists them) or a missing file.
        if spec.contains(['/', '.']) {
            return Err(CliError::usage(format!("{spec:?}: no such file")));
        }
        return built_in(spec).map_err(usage);
    }
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("nrrd")) {
        if o.dims.is_some() || o.value_type.is_some() || o.spacing.is_some() {
            return Err(CliError::usage("--dims, --type and --spacing are for raw files: an NRRD header has them"));
        }
        return read_nrrd(path).map_err(usage);
    }
    let d = o.dims.ok_or_else(|| CliError::usage(format!("{spec:?}: a raw file needs --dims X,Y,Z")))?;
    let ty = RawType::parse(o.value_type.as_deref().unwrap_or("u8")).map_err(usage)?;
    read_raw(path, d, ty, o.spacing.unwrap_or([1.0; 3])).map_err(usage)
}

fn transfer(spec: &str) -> Result<TransferFunction, CliError> {
    if PRESETS.iter().any(|p| p.0 == spec) {
        return TransferFunction::preset(spec).map_err(|e| CliError::usage(e.to_string()));
    }
    let meta = std::fs::metadata(spec)
        .map_err(|e| CliError::usage(format!("--tf {spec:?}: not a preset ({}) and {e}", preset_names())))?;
    if meta.len() > 1 << 20 {
        return Err(CliError::usage(format!("--tf {spec:?}: larger than 1 MiB")));
    }
    let text = std::fs::read_to_string(spec).map_err(|e| CliError::usage(format!("--tf {spec:?}: {e}")))?;
    TransferFunction::parse(&text).map_err(|e| CliError::usage(format!("--tf {spec:?}: {e}")))
}

fn preset_names() -> String {
    PRESETS.iter().map(|p| p.0).collect::<Vec<_>>().join(", ")
}

/// The focus importance: 1 on the voxels of the named label, 0 elsewhere.
fn focus(v: &Volume, name: &str) -> Result<(Vec<f64>, String), CliError> {
    let Some(labels) = &v.labels else {
        return Err(CliError::usage(format!("--focus {name:?}: {} has no labelled objects", v.name)));
    };
    let k = v
        .label_names
        .iter()
        .position(|n| n == name)
        .map(|k| k + 1)
        .or_else(|| name.parse::<usize>().ok().filter(|&k| (1..=v.label_names.len()).contains(&k)))
        .ok_or_else(|| {
            CliError::usage(format!("--focus {name:?}: not a label of {} ({})", v.name, v.label_names.join(", ")))
        })?;
    Ok((labels.iter().map(|&l| f64::from(u8::from(usize::from(l) == k))).collect(), v.label_names[k - 1].clone()))
}

/// Runs `itgfx volume`.
///
/// # Errors
/// Usage, input and output errors; one line each.
#[allow(clippy::too_many_lines)]
pub fn run(o: &VolumeOptions) -> Result<Report, CliError> {
    let spec = o
        .volume
        .clone()
        .ok_or_else(|| CliError::usage("give a volume: a built-in (hydrogen, phantom, cube, sphere) or a raw file"))?;
    let base = o.common.base;
    let unit = Some(base.unit());
    let tf = transfer(&o.tf)?;
    let mut created = None;
    if let Some(d) = &o.out {
        if std::fs::metadata(d).is_ok_and(|m| !m.is_dir()) {
            return Err(CliError::usage(format!("--out {d:?}: not a directory")));
        }
        if !d.exists() {
            std::fs::create_dir_all(d).map_err(|e| CliError::usage(format!("--out {d:?}: {e}")))?;
            created = Some(d.clone());
        }
    }
    let result = run_in(o, &spec, &tf, base, unit);
    if result.is_err()
        && let Some(d) = created
    {
        // Leave nothing behind: the directory made for --out goes again (only if still empty).
        let _ = std::fs::remove_dir(d);
    }
    result
}

#[allow(clippy::too_many_lines)]
fn run_in(
    o: &VolumeOptions,
    spec: &str,
    tf: &TransferFunction,
    base: itgfx_core::Base,
    unit: Option<&'static str>,
) -> Result<Report, CliError> {
    let outputs: Vec<PathBuf> = o.out.as_ref().map_or_else(Vec::new, |d| PICTURES.iter().map(|n| d.join(n)).collect());
    for p in &outputs {
        crate::output::check("--out", p)?;
    }
    let volume = load(o, spec)?;
    let focus = o.focus.as_deref().map(|f| focus(&volume, f)).transpose()?;
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
    let need = channel_memory(&caster, seeable_voxels(&caster), dirs.len());
    if need > MEMORY_LIMIT {
        return Err(CliError::usage(format!(
            "{}: the channel may need {:.1} GiB (limit {} GiB): fewer --viewpoints or a smaller volume",
            volume.name,
            need as f64 / f64::from(1u32 << 30),
            MEMORY_LIMIT >> 30
        )));
    }
    let mut progress = Progress::new();
    let largest = volume.dims.iter().copied().max().unwrap_or(1) as u32;
    let rays = o.size.unwrap_or((2 * largest).clamp(32, 512));
    let copts = VolumeChannelOptions { directions: dirs.clone(), distance: o.distance, size: rays };
    let ch = volume_channel(&caster, &copts, &mut |d, t| progress.update(d, t));
    let t_channel = t0.elapsed().as_secs_f64();
    if ch.is_blind() {
        return Err(CliError::usage(format!("{}: no viewpoint sees any voxel", volume.name)));
    }
    let weights = if o.uniform_input { ViewpointWeights::Uniform } else { ViewpointWeights::ProjectedArea };
    let err = |e| core_err("volume channel", e);
    // What needs the raw rows comes first: the measures normalise them in place.
    let (entries, rays_per_viewpoint, neighbours) = (ch.patch.len() as u64, ch.rays_per_viewpoint, ch.neighbours(6));
    let objects =
        volume.labels.as_ref().map(|l| object_measures(&ch, l, &volume.label_names, weights, base)).transpose()?;
    let m = volume_measures(ch, &dirs, &caster.voxel_opacity, focus.as_ref().map(|f| f.0.as_slice()), weights, base)
        .map_err(err)?;
    let v = &m.views;
    let t_measures = t0.elapsed().as_secs_f64() - t_channel;
    let best_n = best_views(&m.analysis, v, o.capture, o.best_n, base).map_err(err)?;
    let tour = exploration(&m.analysis, &neighbours, v.best, o.explore, base).map_err(err)?;
    let instability = m.analysis.instability(&neighbours, base).map_err(err)?;
    let seen = m.analysis.expand(&m.analysis.seen_angle, 0.0);
    let iso = o.iso.map(|f| iso_route(&volume, f, &dirs, o.distance, rays, base)).transpose()?;
    let seconds = t0.elapsed().as_secs_f64();

    let mut r = Report::new();
    r.text("volume", volume.name.clone());
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

    if let Some(dir) = &o.out {
        let side = o.image;
        let radius = caster.content_radius();
        let shot = |k: usize, tint: Option<&[[f32; 3]]>, s: u32| {
            let px = caster.render(&View::framed(dirs[k], o.distance, radius), s, tint);
            image::RgbImage::from_fn(s, s, |x, y| image::Rgb(px[(y * s + x) as usize]))
        };
        write_png(&shot(v.best, None, side), &dir.join(PICTURES[0]))?;
        write_png(&shot(v.worst, None, side), &dir.join(PICTURES[1]))?;
        let half = (side / 2).max(16);
        let imgs: Vec<_> = best_n.views.iter().map(|&k| shot(k, None, half)).collect();
        write_png(&montage(&imgs, 3), &dir.join(PICTURES[2]))?;
        let vmi: Vec<f64> = v.mutual_information.iter().map(|&x| if x.is_finite() { x } else { f64::NAN }).collect();
        let evmi: Vec<f64> = m.evmi_opacity.iter().map(|&x| if x.is_finite() { x } else { f64::NAN }).collect();
        write_png(&sphere_image(&dirs, &[&vmi, &v.entropy, &evmi], dirs[v.best], side / 2), &dir.join(PICTURES[3]))?;
        // VoMI: the middle y slice, its p(z)-weighted mean along y, and the volume shaded by VoMI from the best view.
        let (vlo, vhi) = percentile_range(&m.vomi);
        let vomi_tint: Vec<[f32; 3]> = m
            .vomi
            .iter()
            .map(|&x| viridis((x - vlo) / (vhi - vlo)).map(|c| (f32::from(c) / 255.0).powf(2.2)))
            .collect();
        let slices = vomi_planes(&volume, &m.vomi, &m.analysis.p_o[..volume.voxels()], side, (vlo, vhi));
        write_png(&montage(&[slices.0, slices.1, shot(v.best, Some(&vomi_tint), side)], 3), &dir.join(PICTURES[4]))?;
        // Colour VoMI: each voxel the colour of the viewpoints most informative about it.
        let scale = if vhi > 0.0 { vhi } else { 1.0 };
        let colour_tint: Vec<[f32; 3]> =
            m.colour_vomi.iter().map(|c| c.map(|x| (x / scale).clamp(0.0, 1.0) as f32)).collect();
        let palette = sphere_palette(&dirs, side / 2);
        write_png(&beside(&[shot(v.best, Some(&colour_tint), side), palette]), &dir.join(PICTURES[5]))?;
        let files: Vec<String> = outputs.iter().map(|p| p.display().to_string()).collect();
        r.texts("wrote", files);
        let json = r.to_json().to_string();
        crate::output::write(&dir.join(PICTURES[6]), json.as_bytes())?;
    }
    Ok(r)
}

/// The middle y slice (x across, z up) of a per-voxel field and its mean
/// along y weighted by `weight` (`p(z)`: the field where the channel looks),
/// each `side × side` (nearest voxel), viridis between `range`.
fn vomi_planes(
    v: &Volume,
    field: &[f64],
    weight: &[f64],
    side: u32,
    range: (f64, f64),
) -> (image::RgbImage, image::RgbImage) {
    let [nx, ny, nz] = v.dims;
    let at = |x: u32, y: u32| {
        let i = ((f64::from(x) + 0.5) / f64::from(side) * nx as f64) as usize;
        let k = ((f64::from(y) + 0.5) / f64::from(side) * nz as f64) as usize;
        (i.min(nx - 1), nz - 1 - k.min(nz - 1))
    };
    let colour = |x: f64| image::Rgb(viridis((x - range.0) / (range.1 - range.0)));
    let slice = image::RgbImage::from_fn(side, side, |x, y| {
        let (i, k) = at(x, y);
        colour(field[v.index(i, ny / 2, k)])
    });
    let mip = image::RgbImage::from_fn(side, side, |x, y| {
        let (i, k) = at(x, y);
        let (a, w) =
            (0..ny).map(|j| v.index(i, j, k)).fold((0.0, 0.0), |(a, w), z| (a + weight[z] * field[z], w + weight[z]));
        if w > 0.0 { colour(a / w) } else { image::Rgb(itgfx_backends::preview::BACKGROUND) }
    });
    (slice, mip)
}

/// The viewpoint sphere coloured by each viewpoint's colour (the key of colour VoMI).
fn sphere_palette(dirs: &[DVec3], radius: u32) -> image::RgbImage {
    let side = 2 * radius;
    image::RgbImage::from_fn(side * 2, side, |x, y| {
        let (half, px) = (x / side, x % side);
        let u = (f64::from(px) + 0.5) / f64::from(radius) - 1.0;
        let w = 1.0 - (f64::from(y) + 0.5) / f64::from(radius);
        let r2 = u * u + w * w;
        if r2 > 1.0 {
            return image::Rgb(itgfx_backends::preview::BACKGROUND);
        }
        let s = if half == 0 { 1.0 } else { -1.0 };
        let p = DVec3::new(u * s, w, s * (1.0 - r2).sqrt());
        let k = (0..dirs.len()).max_by(|&a, &b| p.dot(dirs[a]).total_cmp(&p.dot(dirs[b]))).unwrap_or(0);
        image::Rgb(viewpoint_colour(dirs[k]).map(|c| (c * 255.0).round() as u8))
    })
}

/// The object channel's measures (Part VI §3.1).
struct ObjectMeasures {
    measures: ViewpointMeasures,
    p_o: Vec<f64>,
    /// `I(o;V)` per object.
    information: Vec<f64>,
    /// Per object, the viewpoint with the largest `p(v|o) ∝ p(v) p(o|v)`: the one
    /// that sees most of it relative to the rest.
    characteristic: Vec<Option<usize>>,
}

fn object_measures(
    ch: &ViewpointChannel,
    labels: &[u8],
    names: &[String],
    weights: ViewpointWeights,
    base: itgfx_core::Base,
) -> Result<ObjectMeasures, CliError> {
    let err = |e| core_err("object channel", e);
    let och = object_channel(ch, labels, names.len());
    let an = ViewpointAnalysis::new(&och, weights, false).map_err(err)?;
    let measures = an.measures(&vec![1.0; names.len()], base).map_err(err)?;
    let information = an.polygonal_information(base).map_err(err)?;
    let mut best = vec![(0.0, None); names.len()];
    for (x, &v) in an.seen.iter().enumerate() {
        let (cols, p) = an.row(x);
        for (&o, &q) in cols.iter().zip(p) {
            let w = an.p_v[x] * q;
            if w > best[o as usize].0 {
                best[o as usize] = (w, Some(v));
            }
        }
    }
    Ok(ObjectMeasures {
        measures,
        p_o: an.p_o.clone(),
        information,
        characteristic: best.into_iter().map(|b| b.1).collect(),
    })
}

/// The iso-surface route: the surface and its polygonal viewpoint measures.
struct IsoRoute {
    value: f64,
    triangles: usize,
    measures: ViewpointMeasures,
}

/// Most triangles of an iso-surface.
const MAX_ISO_TRIANGLES: usize = 4_000_000;

/// Extracts the iso-surface at `value`, one patch per triangle, and runs the
/// viewpoint channel of Part V on it (the ray grid of `rays²` rays per
/// viewpoint, as many as the voxel route casts).
fn iso_route(
    v: &Volume,
    value: f64,
    dirs: &[DVec3],
    distance: f64,
    rays: u32,
    base: itgfx_core::Base,
) -> Result<IsoRoute, CliError> {
    let tris = iso_surface(v, value, MAX_ISO_TRIANGLES).ok_or_else(|| {
        CliError::usage(format!("--iso {value}: more than {MAX_ISO_TRIANGLES} triangles; a coarser volume"))
    })?;
    if tris.is_empty() {
        return Err(CliError::usage(format!("--iso {value}: {} has no surface at that value", v.name)));
    }
    let mut scene = Scene::named(&format!("{} iso {value}", v.name));
    for t in &tris {
        scene.add_triangles(String::new(), std::slice::from_ref(t), 0);
    }
    scene.validate().map_err(|e| CliError::usage(format!("--iso {value}: {e}")))?;
    let prepared = Prepared::new(&scene);
    let tracer = open(BackendChoice::Cpu, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let mut progress = Progress::new();
    let ch = ViewpointChannel::build(&prepared, tracer.as_ref(), dirs, distance, rays, &mut |d, t| {
        progress.update(d, t);
    })
    .map_err(|e| CliError::usage(e.to_string()))?;
    let an = ViewpointAnalysis::new(&ch, ViewpointWeights::ProjectedArea, false)
        .map_err(|e| core_err("iso-surface channel", e))?;
    let measures = an.measures(&scene.areas(), base).map_err(|e| core_err("iso-surface channel", e))?;
    Ok(IsoRoute { value, triangles: tris.len(), measures })
}

/// Pearson correlation of two per-view series over the views finite in both.
fn correlation(a: &[f64], b: &[f64]) -> Option<f64> {
    let pairs: Vec<(f64, f64)> =
        a.iter().zip(b).filter(|(x, y)| x.is_finite() && y.is_finite()).map(|(x, y)| (*x, *y)).collect();
    let n = pairs.len() as f64;
    if n < 3.0 {
        return None;
    }
    let (ma, mb) = (pairs.iter().map(|p| p.0).sum::<f64>() / n, pairs.iter().map(|p| p.1).sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in pairs {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    (saa > 0.0 && sbb > 0.0).then(|| sab / (saa * sbb).sqrt())
}

/// Images of any size side by side, top-aligned, on the dark background.
fn beside(images: &[image::RgbImage]) -> image::RgbImage {
    let w = images.iter().map(image::RgbImage::width).sum::<u32>().max(1);
    let h = images.iter().map(image::RgbImage::height).max().unwrap_or(1).max(1);
    let mut out = image::RgbImage::from_pixel(w, h, image::Rgb(itgfx_backends::preview::BACKGROUND));
    let mut x0 = 0;
    for img in images {
        for (x, y, p) in img.enumerate_pixels() {
            out.put_pixel(x0 + x, y, *p);
        }
        x0 += img.width();
    }
    out
}
