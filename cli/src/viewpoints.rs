//! `itgfx viewpoints MESH`: the viewpoint channel of Part V.

use std::path::{Path, PathBuf};
use std::time::Instant;

use itgfx_backends::tracer::Prepared;
use itgfx_backends::viewpoint::saliency::{mesh_saliency, patch_adjacency, smooth, viewpoint_saliency};
use itgfx_backends::viewpoint::selection::{best_views, exploration, importance_information};
use itgfx_backends::viewpoint::{ViewpointAnalysis, ViewpointChannel, ViewpointWeights, icosphere};
use itgfx_backends::{BackendChoice, open};

use crate::CliError;
use crate::args::Args;
use crate::complexity::{Progress, load_scene};
use crate::export::{Faces, colours, montage, percentile_range, render_image, sphere_image, write_ply_with, write_png};
use crate::report::Report;

/// Where each picture goes: explicit paths, or standard names under `--out`.
struct Pictures {
    out: Option<PathBuf>,
}

impl Pictures {
    fn path(&self, args: &Args, flag: &str, name: &str) -> Option<PathBuf> {
        args.value(flag).map(PathBuf::from).or_else(|| self.out.as_ref().map(|d| d.join(name)))
    }
}

fn core_err(e: itgfx_core::Error) -> CliError {
    CliError::usage(format!("viewpoint channel: {e}"))
}

/// Runs `itgfx viewpoints`.
///
/// # Errors
/// Usage, scene and backend errors.
#[allow(clippy::too_many_lines)]
pub fn run(args: &Args) -> Result<Report, CliError> {
    let spec = args.single_positional("mesh", "give a mesh: an .obj file or a built-in scene name")?;
    let base = args.base()?;
    let unit = Some(base.unit());
    let count = args.integer("viewpoints")?.unwrap_or(42);
    let level = match count {
        12 => 0,
        42 => 1,
        162 => 2,
        642 => 3,
        2562 => 4,
        other => {
            return Err(CliError::usage(format!(
                "--viewpoints must be 12, 42, 162, 642 or 2562 (a subdivided icosahedron), got {other}"
            )));
        }
    };
    let resolution = args.integer("resolution")?.unwrap_or(128);
    if !(4..=4096).contains(&resolution) {
        return Err(CliError::usage("--resolution must be in 4..=4096 (rays per viewpoint = resolution²)"));
    }
    let distance = args.number("distance")?.unwrap_or(3.0);
    if !(distance > 1.0 && distance.is_finite()) {
        return Err(CliError::usage("--distance must be above 1 (in bounding-sphere radii)"));
    }
    let capture = args.number("capture")?.unwrap_or(0.9);
    if !(capture > 0.0 && capture <= 1.0) {
        return Err(CliError::usage("--capture must be in (0, 1]: the fraction of I(V;O) the best-n views keep"));
    }
    let max_views = args.integer("best-n")?.unwrap_or(6);
    if !(1..=64).contains(&max_views) {
        return Err(CliError::usage("--best-n must be in 1..=64"));
    }
    let steps = args.integer("explore")?.unwrap_or(12);
    if steps > 10_000 {
        return Err(CliError::usage("--explore must be at most 10000 steps"));
    }
    let weights = if args.flag("uniform-input") { ViewpointWeights::Uniform } else { ViewpointWeights::ProjectedArea };
    let rounds = args.integer("smooth")?.unwrap_or(2);
    if rounds > 100 {
        return Err(CliError::usage("--smooth must be at most 100 rounds"));
    }
    let background = args.flag("background");
    let per_polygon = args.flag("per-polygon");
    let choice =
        args.value("backend").unwrap_or("cpu").parse::<BackendChoice>().map_err(|e| CliError::usage(e.to_string()))?;
    let pictures = Pictures { out: args.value("out").map(PathBuf::from) };
    if let Some(d) = &pictures.out {
        std::fs::create_dir_all(d).map_err(|e| CliError::usage(format!("--out {}: {e}", d.display())))?;
    }
    let scene = load_scene(&spec, args.integer("subdivide")?.unwrap_or(1) as u32)?;
    let t0 = Instant::now();
    let prepared = Prepared::new(&scene);
    let tracer = open(choice, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let dirs = icosphere(level);
    let mut progress = Progress::new();
    let ch = ViewpointChannel::build(&prepared, tracer.as_ref(), &dirs, distance, resolution as u32, &mut |d, t| {
        progress.update(d, t);
    })
    .map_err(|e| CliError::usage(e.to_string()))?;
    let t_channel = t0.elapsed().as_secs_f64();
    if ch.is_blind() {
        return Err(CliError::usage(format!("{spec}: no viewpoint sees any polygon (an empty mesh?)")));
    }
    let an = ViewpointAnalysis::new(&ch, weights, background).map_err(core_err)?;
    let m = an.measures(&scene.areas(), base).map_err(core_err)?;
    let neighbours = ch.neighbours(6);
    let instability = an.instability(&neighbours, base).map_err(core_err)?;
    let poly_info = an.polygonal_information(base).map_err(core_err)?;
    let adjacency = patch_adjacency(&scene);
    let saliency = mesh_saliency(&an, &adjacency, base).map_err(core_err)?;
    let view_saliency = viewpoint_saliency(&an, &saliency);
    let importance = importance_information(&an, &saliency, base).map_err(core_err)?;
    let best_importance = argmin(&importance);
    let best_n = best_views(&an, &m, capture, max_views as usize, base).map_err(core_err)?;
    let tour = exploration(&an, &neighbours, m.best, steps as usize, base).map_err(core_err)?;
    let seconds = t0.elapsed().as_secs_f64();

    let mut r = Report::new();
    r.text("mesh", scene.name.clone()).text("backend", tracer.name());
    r.count("polygons", scene.patches.len() as u64)
        .count("viewpoints", dirs.len() as u64)
        .count("rays_per_viewpoint", ch.rays_per_viewpoint)
        .count("channel_entries", ch.patch.len() as u64);
    r.text("p_v", if weights == ViewpointWeights::Uniform { "uniform" } else { "projected area" });
    r.text("background", if background { "an extra polygon" } else { "excluded" });
    r.real("I_VO", m.total_mutual_information, unit).real("H_O_given_V", m.conditional_entropy, unit).real(
        "H_O",
        m.object_entropy,
        unit,
    );
    r.count("best_view", m.best as u64).count("worst_view", m.worst as u64);
    r.reals("best_view_direction", dirs[m.best].to_array().to_vec())
        .reals("worst_view_direction", dirs[m.worst].to_array().to_vec());
    r.count("best_importance_view", best_importance as u64);
    r.reals("best_importance_direction", dirs[best_importance].to_array().to_vec());
    r.counts("best_n_views", best_n.views.iter().map(|&v| v as u64).collect());
    r.reals("best_n_merged_VMI", best_n.merged_information.clone()).reals("best_n_captured", best_n.captured.clone());
    r.counts("exploration_path", tour.path.iter().map(|&v| v as u64).collect());
    r.reals("exploration_merged_VMI", tour.merged_information.clone());
    let mut views = Vec::new();
    for (v, d) in dirs.iter().enumerate() {
        let mut x = Report::new();
        x.reals("direction", d.to_array().to_vec());
        x.real("p_v", m.weight[v], None).real("VE", m.entropy[v], unit).real("VMI", m.mutual_information[v], unit);
        x.maybe_real("VKL", Some(m.kullback_leibler[v]).filter(|x| !x.is_nan()), unit).real("HM", m.heuristic[v], None);
        x.maybe_real("instability", Some(instability[v]).filter(|x| x.is_finite()), unit);
        x.real("saliency", view_saliency[v], unit).real("importance_VMI", importance[v], unit);
        views.push(x);
    }
    r.records("views", views);
    if per_polygon {
        r.reals("polygonal_information", poly_info[..scene.patches.len()].to_vec())
            .reals("saliency", saliency.clone())
            .reals("p_o", an.p_o[..scene.patches.len()].to_vec());
    }

    // Pictures.
    let size = (640, 480);
    let tracer = tracer.as_ref();
    let grey: Vec<[u8; 3]> = vec![[200, 200, 205]; scene.patches.len()];
    let shot = |cols: &[[u8; 3]], v: usize, size| render_image(tracer, cols, dirs[v] * distance, size, Faces::Both);
    let mut written = Vec::new();
    // Information-theoretic ambient occlusion: a grey level per polygon from
    // I(o;V); polygons seen from few viewpoints (occluded) carry the most.
    // Pictures show the fields averaged over neighbours `--smooth` times.
    let patches = scene.patches.len();
    let shown_info = smooth(&poly_info[..patches], &adjacency, rounds as u32);
    let shown_saliency = smooth(&saliency, &adjacency, rounds as u32);
    let ao = grey_levels(&shown_info);
    if let Some(p) = pictures.path(args, "best-image", "best.png") {
        save(&shot(&grey, m.best, size)?, &p, &mut written)?;
    }
    if let Some(p) = pictures.path(args, "worst-image", "worst.png") {
        save(&shot(&grey, m.worst, size)?, &p, &mut written)?;
    }
    if let Some(p) = pictures.path(args, "best-n-image", "best-n.png") {
        let imgs = best_n.views.iter().map(|&v| shot(&grey, v, (320, 240))).collect::<Result<Vec<_>, _>>()?;
        save(&montage(&imgs, 3), &p, &mut written)?;
    }
    if let Some(p) = pictures.path(args, "importance-image", "best-importance.png") {
        save(&shot(&colours(&shown_saliency), best_importance, size)?, &p, &mut written)?;
    }
    if let Some(p) = pictures.path(args, "sphere-image", "sphere.png") {
        let vmi: Vec<f64> = m.mutual_information.iter().map(|&x| if x.is_finite() { x } else { f64::NAN }).collect();
        save(&sphere_image(&dirs, &[&vmi, &m.entropy], dirs[m.best], 160), &p, &mut written)?;
    }
    if let Some(p) = pictures.path(args, "ao-image", "ao.png") {
        save(&shot(&ao, m.best, size)?, &p, &mut written)?;
    }
    if let Some(p) = pictures.path(args, "saliency-image", "saliency.png") {
        save(&shot(&colours(&shown_saliency), m.best, size)?, &p, &mut written)?;
    }
    if let Some(p) = pictures.path(args, "info-image", "info.png") {
        save(&shot(&colours(&shown_info), m.best, size)?, &p, &mut written)?;
    }
    if let Some(p) = pictures.path(args, "export-ply", "ao.ply") {
        write_ply_with(&scene, &shown_info, &ao, &p)?;
        written.push(p);
    }
    if let Some(p) = pictures.path(args, "saliency-ply", "saliency.ply") {
        write_ply_with(&scene, &shown_saliency, &colours(&shown_saliency), &p)?;
        written.push(p);
    }
    r.reals("exploration_directions", tour.path.iter().flat_map(|&v| dirs[v].to_array()).collect());
    if !written.is_empty() {
        r.texts("wrote", written.iter().map(|p| p.display().to_string()).collect());
    }
    r.real("channel_seconds", t_channel, Some("s")).real("seconds", seconds, Some("s"));
    Ok(r)
}

fn save(img: &image::RgbImage, path: &Path, written: &mut Vec<PathBuf>) -> Result<(), CliError> {
    write_png(img, path)?;
    written.push(path.to_path_buf());
    Ok(())
}

/// Grey levels for ambient occlusion: white at the 2nd percentile of
/// `I(o;V)`, black at the 98th.
fn grey_levels(info: &[f64]) -> Vec<[u8; 3]> {
    let (lo, hi) = percentile_range(info);
    info.iter().map(|&i| [(255.0 * (1.0 - (i - lo) / (hi - lo))).round().clamp(0.0, 255.0) as u8; 3]).collect()
}

/// Index of the smallest finite value (0 if none).
fn argmin(x: &[f64]) -> usize {
    (0..x.len()).filter(|&i| x[i].is_finite()).min_by(|&a, &b| x[a].total_cmp(&x[b])).unwrap_or(0)
}
