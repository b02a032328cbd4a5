//! `itgfx viewpoints MESH`: the viewpoint channel of Part V.

use std::path::Path;
use std::time::Instant;

use itgfx_backends::tracer::{BackendChoice, Prepared, open};
use itgfx_backends::viewpoint::{ViewpointChannel, ViewpointWeights, icosphere};

use crate::CliError;
use crate::args::Args;
use crate::complexity::load_scene;
use crate::export::{colours, render_png_from, write_ply};
use crate::report::Report;

/// Runs `itgfx viewpoints`.
///
/// # Errors
/// Usage, scene and backend errors.
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
    let weights = if args.flag("uniform-input") { ViewpointWeights::Uniform } else { ViewpointWeights::ProjectedArea };
    let choice = BackendChoice::parse(args.value("backend").unwrap_or("cpu")).map_err(CliError::usage)?;
    let scene = load_scene(&spec, args.integer("subdivide")?.unwrap_or(1) as u32)?;
    let t0 = Instant::now();
    let prepared = Prepared::new(&scene);
    let tracer = open(choice, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let dirs = icosphere(level);
    let ch = ViewpointChannel::build(&prepared, tracer.as_ref(), &dirs, distance, resolution as u32)
        .map_err(|e| CliError::usage(e.to_string()))?;
    if ch.solid_angle.iter().all(|&a| a == 0.0) {
        return Err(CliError::usage(format!(
            "{spec}: no viewpoint sees a front face (is the mesh facing inwards? viewpoints look at outward faces)"
        )));
    }
    let m = ch.measures(&scene.areas(), weights, base);
    let instability = ch.instability(&m, 6, base);
    let (poly_info, p_o) = ch.polygonal_information(weights, base);
    let seconds = t0.elapsed().as_secs_f64();
    let mut r = Report::new();
    r.text("mesh", scene.name.clone()).text("backend", tracer.name());
    r.count("polygons", scene.patches.len() as u64)
        .count("viewpoints", dirs.len() as u64)
        .count("rays_per_viewpoint", resolution * resolution);
    r.real("I_VO", m.total_mutual_information, unit).real("H_O_given_V", m.conditional_entropy, unit);
    r.count("best_view", m.best as u64).count("worst_view", m.worst as u64);
    r.reals("best_view_direction", dirs[m.best].to_array().to_vec())
        .reals("worst_view_direction", dirs[m.worst].to_array().to_vec());
    let mut views = Vec::new();
    for (v, d) in dirs.iter().enumerate() {
        let mut x = Report::new();
        x.reals("direction", d.to_array().to_vec());
        x.real("p_v", m.weight[v], None).real("VE", m.entropy[v], unit).real("VMI", m.mutual_information[v], unit);
        x.real("VKL", m.kullback_leibler[v], unit).real("HM", m.heuristic[v], None);
        x.maybe_real("instability", Some(instability[v]).filter(|x| x.is_finite()), unit);
        views.push(x);
    }
    r.records("views", views);
    r.reals("polygonal_information", poly_info.clone()).reals("p_o", p_o);
    // Pictures.
    let size = (640, 480);
    let grey: Vec<[u8; 3]> = vec![[200, 200, 205]; scene.patches.len()];
    if let Some(p) = args.value("best-image") {
        render_png_from(tracer.as_ref(), &grey, dirs[m.best] * distance, Path::new(p), size)?;
        r.text("best_image", p);
    }
    if let Some(p) = args.value("worst-image") {
        render_png_from(tracer.as_ref(), &grey, dirs[m.worst] * distance, Path::new(p), size)?;
        r.text("worst_image", p);
    }
    // Information-theoretic ambient occlusion: a grey level per polygon from
    // I(o;V); polygons seen from few viewpoints (occluded) carry the most.
    let max = poly_info.iter().copied().fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    let ao: Vec<[u8; 3]> = poly_info.iter().map(|i| [(255.0 * (1.0 - i / max)).round() as u8; 3]).collect();
    if let Some(p) = args.value("ao-image") {
        render_png_from(tracer.as_ref(), &ao, dirs[m.best] * distance, Path::new(p), size)?;
        r.text("ao_image", p);
    }
    if let Some(p) = args.value("export-ply") {
        write_ply(&scene, &poly_info, Path::new(p))?;
        r.text("ply", p);
    }
    if let Some(p) = args.value("info-image") {
        render_png_from(tracer.as_ref(), &colours(&poly_info), dirs[m.best] * distance, Path::new(p), size)?;
        r.text("info_image", p);
    }
    r.real("seconds", seconds, Some("s"));
    Ok(r)
}
