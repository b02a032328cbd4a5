//! `itgfx viewpoints MESH`: the viewpoint channel of Part V.

use std::path::{Path, PathBuf};
use std::time::Instant;

use itgfx_backends::open;
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::{Prepared, Tracer};
use itgfx_backends::viewpoint::saliency::smooth;
use itgfx_backends::viewpoint::shard_job::{Estimator, ViewpointShards, check_channel_memory};
use itgfx_backends::viewpoint::solid_angle::{Convergence, Refinement};
use itgfx_backends::viewpoint::study::{Study, StudySettings};
use itgfx_backends::viewpoint::{ViewpointChannel, ViewpointWeights, icosphere};
use itgfx_core::Base;

use super::ViewpointsOptions;
use crate::CliError;
use crate::export::{Faces, colours, montage, percentile_range, render_image, sphere_image, write_ply_with, write_png};
use crate::progress::Progress;
use crate::report::Report;
use crate::scene::load_scene;
use crate::values::{argmin, viewpoint_level};

/// A picture: its flag, its name under `--out`, and where it goes if asked for.
type Picture = (&'static str, &'static str, Option<PathBuf>);

/// Where each picture goes: explicit paths, or standard names under `--out`.
fn pictures(o: &ViewpointsOptions) -> Vec<Picture> {
    let list = [
        ("--best-image", "best.png", &o.best_image),
        ("--worst-image", "worst.png", &o.worst_image),
        ("--best-n-image", "best-n.png", &o.best_n_image),
        ("--importance-image", "best-importance.png", &o.importance_image),
        ("--sphere-image", "sphere.png", &o.sphere_image),
        ("--ao-image", "ao.png", &o.ao_image),
        ("--saliency-image", "saliency.png", &o.saliency_image),
        ("--info-image", "info.png", &o.info_image),
        ("--export-ply", "ao.ply", &o.export_ply),
        ("--saliency-ply", "saliency.ply", &o.saliency_ply),
    ];
    list.into_iter()
        .map(|(flag, name, p)| (flag, name, p.clone().or_else(|| o.out.as_ref().map(|d| d.join(name)))))
        .collect()
}

fn core_err(e: itgfx_core::Error) -> CliError {
    CliError::usage(format!("viewpoint channel: {e}"))
}

/// Runs `itgfx viewpoints`: checks, the channel (traced, merged from shards,
/// or a shard saved), the study ([`Study`]), the report, the pictures.
///
/// # Errors
/// Usage, scene and backend errors.
pub fn run(o: &ViewpointsOptions) -> Result<Report, CliError> {
    let spec = o.mesh.clone().ok_or_else(|| CliError::usage("give a mesh: an .obj file or a built-in scene name"))?;
    if o.estimator != "grid" && o.resolution.is_some() {
        return Err(CliError::usage("--resolution sets the ray grid: give it with --estimator grid"));
    }
    super::shard::check(o, &pictures(o))?;
    let outputs = checked_pictures(o)?;
    let scene = load_scene(&spec, o.subdivide)?;
    let dirs = icosphere(viewpoint_level(o.viewpoints));
    memory_check(&scene, dirs.len())?;
    let t0 = Instant::now();
    let prepared = Prepared::new(&scene);
    let tracer = open(o.tracing.backend, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let refine = Refinement {
        distance: o.distance,
        tolerance: o.tolerance,
        max: o.max_subdivision,
        first: Refinement::default().first.min(o.max_subdivision),
        weights: weights(o),
        background: o.background,
    };
    let job = super::shard::job(o, &scene.name, &prepared, tracer.as_ref(), &dirs, &refine);
    if let Some(s) = o.shards.shard {
        return super::shard::save(o, s, &job);
    }
    let (ch, convergence) = channel(o, &spec, &job)?;
    let t_channel = t0.elapsed().as_secs_f64();
    if ch.is_blind() {
        return Err(CliError::usage(format!("{spec}: no viewpoint sees any polygon (an empty mesh?)")));
    }
    let settings = StudySettings {
        weights: weights(o),
        background: o.background,
        capture: o.selection.capture,
        best_n: o.selection.best_n,
        explore: o.selection.explore,
        base: o.common.base,
    };
    let study = Study::run(&scene, ch, &settings).map_err(core_err)?;
    let seconds = t0.elapsed().as_secs_f64();
    let mut r = report(o, (&scene, tracer.name(), &dirs), &study, convergence.as_ref());
    let written = write_pictures(o, &outputs, (&scene, tracer.as_ref(), &dirs), &study)?;
    r.reals("exploration_directions", study.tour.path.iter().flat_map(|&v| dirs[v].to_array()).collect());
    if !written.is_empty() {
        r.texts("wrote", written.iter().map(|p| p.display().to_string()).collect());
    }
    r.real("channel_seconds", t_channel, Some("s")).real("seconds", seconds, Some("s"));
    Ok(r)
}

/// `p(V)`: uniform with `--uniform-input`, else by projected area.
fn weights(o: &ViewpointsOptions) -> ViewpointWeights {
    if o.uniform_input { ViewpointWeights::Uniform } else { ViewpointWeights::ProjectedArea }
}

/// The pictures asked for, every path checked (and `--out` made) before any work.
fn checked_pictures(o: &ViewpointsOptions) -> Result<Vec<Picture>, CliError> {
    let outputs = pictures(o);
    let checked =
        || outputs.iter().try_for_each(|(flag, _, p)| p.as_ref().map_or(Ok(()), |p| crate::output::check(flag, p)));
    match &o.out {
        Some(d) => crate::output::out_dir_checked(d, checked).map(|_| ())?,
        None => checked()?,
    }
    Ok(outputs)
}

/// The channel: merged from `--merge`'s shards, or traced by the grid or
/// the solid-angle estimator (with its convergence).
fn channel(
    o: &ViewpointsOptions,
    spec: &str,
    job: &ViewpointShards,
) -> Result<(ViewpointChannel, Option<Convergence>), CliError> {
    if !o.shards.merge.is_empty() {
        return super::shard::merged(o, job);
    }
    let mut progress = Progress::new();
    let mut tick = |d, t| progress.update(d, t);
    let (prepared, tracer, dirs) = (job.prepared, job.tracer, job.directions);
    match job.estimator {
        Estimator::Grid { resolution } => {
            let ch = ViewpointChannel::build(prepared, tracer, dirs, o.distance, resolution, &mut tick)
                .map_err(|e| CliError::usage(e.to_string()))?;
            Ok((ch, None))
        }
        Estimator::SolidAngle { refine, .. } => {
            let (ch, c) = ViewpointChannel::build_solid_angle(prepared, tracer, dirs, refine, &mut tick)
                .map_err(|e| CliError::usage(format!("{spec}: {e}")))?;
            Ok((ch, Some(c)))
        }
    }
}

/// The report: the channel, its estimator's convergence, the measures, the
/// selections, one record per viewpoint, and per polygon with `--per-polygon`.
fn report(
    o: &ViewpointsOptions,
    (scene, backend, dirs): (&Scene, &str, &[glam::DVec3]),
    study: &Study,
    convergence: Option<&Convergence>,
) -> Report {
    let base = o.common.base;
    let unit = Some(base.unit());
    let (m, best_n, tour) = (&study.measures, &study.best_n, &study.tour);
    let best_importance = argmin(&study.importance);
    let mut r = Report::new();
    r.text("mesh", scene.name.clone()).text("backend", backend);
    r.count("polygons", scene.patches.len() as u64).count("viewpoints", dirs.len() as u64);
    r.text("estimator", if convergence.is_none() { "grid" } else { "solid-angle" });
    match convergence {
        Some(c) => convergence_report(o, c, &mut r),
        None => {
            r.count("rays_per_viewpoint", study.rays_per_viewpoint);
        }
    }
    r.count("channel_entries", study.channel_entries);
    r.text("p_v", if weights(o) == ViewpointWeights::Uniform { "uniform" } else { "projected area" });
    r.text("background", if o.background { "an extra polygon" } else { "excluded" });
    r.real("I_VO", m.total_mutual_information, unit).real("H_O_given_V", m.conditional_entropy, unit);
    r.real("H_O", m.object_entropy, unit);
    r.count("best_view", m.best as u64).count("worst_view", m.worst as u64);
    r.reals("best_view_direction", dirs[m.best].to_array().to_vec())
        .reals("worst_view_direction", dirs[m.worst].to_array().to_vec());
    r.count("best_importance_view", best_importance as u64);
    r.reals("best_importance_direction", dirs[best_importance].to_array().to_vec());
    r.counts("best_n_views", best_n.views.iter().map(|&v| v as u64).collect());
    r.reals("best_n_merged_VMI", best_n.merged_information.clone()).reals("best_n_captured", best_n.captured.clone());
    r.counts("exploration_path", tour.path.iter().map(|&v| v as u64).collect());
    r.reals("exploration_merged_VMI", tour.merged_information.clone());
    let views = (0..dirs.len()).map(|v| view_record(v, dirs[v], study, convergence, base)).collect();
    r.records("views", views);
    if o.per_polygon {
        let n = scene.patches.len();
        r.reals("polygonal_information", study.polygonal_information[..n].to_vec())
            .reals("saliency", study.saliency.clone())
            .reals("p_o", study.analysis.p_o[..n].to_vec());
    }
    r
}

/// The solid-angle estimator's convergence, with a warning when some
/// viewpoint missed `--tolerance`.
fn convergence_report(o: &ViewpointsOptions, c: &Convergence, r: &mut Report) {
    let met = c.met.iter().filter(|&&m| m).count();
    r.real("tolerance", o.tolerance, None)
        .flag("tolerance_met", met == c.met.len())
        .count("views_meeting_tolerance", met as u64)
        .count("visibility_rays", c.rays)
        .count("boundary_triangles", c.boundary_triangles)
        .count("max_subdivision_used", u64::from(c.subdivision.iter().copied().max().unwrap_or(0)));
    if met < c.met.len() {
        eprintln!(
            "itgfx: warning: {} of {} viewpoints missed --tolerance {} at --max-subdivision {} (see VMI_stderr)",
            c.met.len() - met,
            c.met.len(),
            o.tolerance,
            o.max_subdivision
        );
    }
}

/// One viewpoint's record.
fn view_record(v: usize, d: glam::DVec3, study: &Study, convergence: Option<&Convergence>, base: Base) -> Report {
    let unit = Some(base.unit());
    let m = &study.measures;
    let mut x = Report::new();
    x.reals("direction", d.to_array().to_vec());
    x.real("p_v", m.weight[v], None).real("VE", m.entropy[v], unit).real("VMI", m.mutual_information[v], unit);
    if let Some(c) = convergence {
        // The builder's standard errors are in nats.
        x.real("VMI_stderr", c.vmi_stderr[v] * base.per_nat(), unit).flag("tolerance_met", c.met[v]);
    }
    x.maybe_real("VKL", Some(m.kullback_leibler[v]).filter(|x| !x.is_nan()), unit).real("HM", m.heuristic[v], None);
    x.maybe_real("instability", Some(study.instability[v]).filter(|x| x.is_finite()), unit);
    x.real("saliency", study.view_saliency[v], unit).real("importance_VMI", study.importance[v], unit);
    x
}

/// Writes the pictures asked for; returns the paths written.
fn write_pictures(
    o: &ViewpointsOptions,
    outputs: &[Picture],
    (scene, tracer, dirs): (&Scene, &dyn Tracer, &[glam::DVec3]),
    study: &Study,
) -> Result<Vec<PathBuf>, CliError> {
    let path = |flag: &str| outputs.iter().find(|x| x.0 == flag).and_then(|x| x.2.clone());
    let (m, size) = (&study.measures, (640, 480));
    let grey: Vec<[u8; 3]> = vec![[200, 200, 205]; scene.patches.len()];
    let shot = |cols: &[[u8; 3]], v: usize, size| render_image(tracer, cols, dirs[v] * o.distance, size, Faces::Both);
    let mut written = Vec::new();
    // Information-theoretic ambient occlusion: a grey level per polygon from
    // I(o;V); polygons seen from few viewpoints (occluded) carry the most.
    // Pictures show the fields averaged over neighbours `--smooth` times.
    let patches = scene.patches.len();
    let shown_info = smooth(&study.polygonal_information[..patches], &study.adjacency, o.smooth);
    let shown_saliency = smooth(&study.saliency, &study.adjacency, o.smooth);
    let ao = grey_levels(&shown_info);
    if let Some(p) = path("--best-image") {
        save(&shot(&grey, m.best, size)?, &p, &mut written)?;
    }
    if let Some(p) = path("--worst-image") {
        save(&shot(&grey, m.worst, size)?, &p, &mut written)?;
    }
    if let Some(p) = path("--best-n-image") {
        let imgs = study.best_n.views.iter().map(|&v| shot(&grey, v, (320, 240))).collect::<Result<Vec<_>, _>>()?;
        save(&montage(&imgs, 3), &p, &mut written)?;
    }
    if let Some(p) = path("--importance-image") {
        save(&shot(&colours(&shown_saliency), argmin(&study.importance), size)?, &p, &mut written)?;
    }
    if let Some(p) = path("--sphere-image") {
        let vmi: Vec<f64> = m.mutual_information.iter().map(|&x| if x.is_finite() { x } else { f64::NAN }).collect();
        save(&sphere_image(dirs, &[&vmi, &m.entropy], dirs[m.best], 160), &p, &mut written)?;
    }
    if let Some(p) = path("--ao-image") {
        save(&shot(&ao, m.best, size)?, &p, &mut written)?;
    }
    if let Some(p) = path("--saliency-image") {
        save(&shot(&colours(&shown_saliency), m.best, size)?, &p, &mut written)?;
    }
    if let Some(p) = path("--info-image") {
        save(&shot(&colours(&shown_info), m.best, size)?, &p, &mut written)?;
    }
    if let Some(p) = path("--export-ply") {
        write_ply_with(scene, &shown_info, &ao, &p)?;
        written.push(p);
    }
    if let Some(p) = path("--saliency-ply") {
        write_ply_with(scene, &shown_saliency, &colours(&shown_saliency), &p)?;
        written.push(p);
    }
    Ok(written)
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

/// Refuses, before the tracer and its BVH are built, a run whose memory
/// ([`check_channel_memory`]) is over what the process may use
/// (`viewpoints`, and `shapes` for each mesh).
pub fn memory_check(scene: &itgfx_backends::scene::Scene, views: usize) -> Result<(), CliError> {
    check_channel_memory(scene, views)
        .map(|_| ())
        .map_err(|e| CliError::usage(format!("{e}: fewer --viewpoints or a smaller scene")))
}
