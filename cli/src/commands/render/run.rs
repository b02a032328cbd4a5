//! The run of `itgfx render` (options checked before any work, the
//! render, its files and report) and of `itgfx compare`.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use itgfx_backends::open;
use itgfx_backends::render::{
    self, AdaptiveSampling, Criterion, Frame, Oracle, Sampling, Shading, Supersampling, TreeContrast, adaptive,
    criteria, supersample, tree, views,
};
use itgfx_backends::tracer::Prepared;

use super::args::{CompareOptions, MAX_SPP, RenderOptions};
use super::images::Radiance;
use super::metrics::compare_images;
use super::{export_scene, images, maps, metrics, shard};
use crate::CliError;
use crate::progress::Progress;
use crate::report::Report;
use crate::scene::load_scene;

/// Nodes of a full refinement tree of `MAX_LEVEL` = 4 levels (1 + 4 + 16 + 64).
const TREE_NODES: u64 = 85;

/// Most memory a run may plan to use.
const MEMORY_LIMIT: u64 = 4 << 30;

/// Refuses a run whose image or per-row sample buffers would pass
/// [`MEMORY_LIMIT`]: about 120 bytes a pixel (radiance, counts, display
/// values, PNG; 200 for `adaptive`), and 48 bytes a sample of the row each
/// worker holds (a tree's pixel: its 85 nodes of `N_s^r` samples).
fn memory_check(o: &RenderOptions) -> Result<(), CliError> {
    let (w, h) = (u64::from(o.size.0), u64::from(o.size.1));
    let per_pixel = match o.sampler.as_str() {
        "uniform" => u64::from(o.spp),
        "ec" | "ic" | "cc-tree" | "ec-binary" => TREE_NODES * u64::from(o.node_samples.unwrap_or(tree::NODE_SAMPLES)),
        _ => u64::from(o.max_spp.unwrap_or(o.spp.saturating_mul(16).min(MAX_SPP))),
    };
    let workers = o.tracing.threads.unwrap_or_else(rayon::current_num_threads) as u64;
    // adaptive also keeps every pixel's pilot sums, weight and share (about 80 bytes).
    let image = if o.sampler == "adaptive" { 200 } else { 120 };
    let bytes = w * h * image + workers * w * per_pixel * 48;
    if bytes > MEMORY_LIMIT {
        return Err(CliError::usage(format!(
            "{w} x {h} at up to {per_pixel} samples a pixel needs about {:.1} GiB (limit {} GiB): lower --size, --spp or --max-spp",
            bytes as f64 / f64::from(1u32 << 30),
            MEMORY_LIMIT >> 30
        )));
    }
    itgfx_backends::memory::check(|| format!("{w} x {h} at up to {per_pixel} samples a pixel"), bytes)
        .map_err(|e| CliError::usage(format!("{e}: lower --size, --spp or --max-spp")))
}

/// The output directory: must be a directory or not exist; made if missing.
/// Returns it and whether it was made here.
pub(super) fn out_dir(o: &RenderOptions) -> Result<(PathBuf, bool), CliError> {
    let d = o.out.clone().ok_or_else(|| CliError::usage("give --out DIR for the images"))?;
    let made = crate::output::out_dir(&d)?.is_some();
    Ok((d, made))
}

/// Runs `itgfx render`.
///
/// # Errors
/// Usage, scene, camera and backend errors, one line each.
pub fn run(o: &RenderOptions) -> Result<Report, CliError> {
    if o.unbiased {
        return Err(CliError::usage(
            "--unbiased is gone: the unbiased form is the default now, and --spp counts its decision samples too (an old --spp N --unbiased run is --spp 2N); --tutorial-form gives the tutorial's biased form",
        ));
    }
    if o.variance && (o.out.is_none() || o.shards.shard.is_some() || !o.shards.merge.is_empty()) {
        return Err(CliError::usage(
            "--variance writes variance.exr beside image.exr: give --out DIR (and no --shard or --merge)",
        ));
    }
    if o.time_budget.is_some() && (o.shards.shard.is_some() || !o.shards.merge.is_empty()) {
        return Err(CliError::usage("--time-budget is for a single run, not --shard or --merge"));
    }
    if !o.shards.merge.is_empty() {
        return shard::run_merge(o);
    }
    let spec = o.scene.clone().ok_or_else(|| {
        CliError::usage("give a scene: cornell-box, mirror-room, open-blocks, open-sphere or a scene file")
    })?;
    if let Some(r) = &o.reference {
        crate::input::regular("--reference", r)?;
    }
    let adaptive = o.sampler != "uniform";
    if !adaptive && (o.max_spp.is_some() || o.threshold.is_some() || o.tutorial_form) {
        return Err(CliError::usage(
            "--max-spp, --threshold and --tutorial-form are for adaptive samplers (--sampler cc, kl, ...)",
        ));
    }
    let is_tree = TreeContrast::from_name(&o.sampler).is_some();
    if o.variance && (is_tree || (o.sampler == "es" && o.tutorial_form)) {
        return Err(CliError::usage(format!(
            "--variance: --sampler {}{} gives pixels that are not the mean of the samples it keeps (eq. (29) or the oracle's samples); use another sampler",
            o.sampler,
            if o.tutorial_form { " --tutorial-form" } else { "" }
        )));
    }
    if o.sampler == "adaptive" && (o.threshold.is_some() || o.tutorial_form) {
        return Err(CliError::usage(
            "--sampler adaptive has no threshold and one (unbiased) form: it spends exactly --spp on average",
        ));
    }
    if is_tree && o.max_spp.is_some() {
        return Err(CliError::usage(format!(
            "--sampler {}: the refinement tree is capped by its depth (4 levels), not --max-spp",
            o.sampler
        )));
    }
    if o.node_samples.is_some() && !is_tree {
        return Err(CliError::usage(
            "--node-samples is for the refinement trees (--sampler ec, ic, cc-tree, ec-binary)",
        ));
    }
    let oracle_maps = o.sampler == "es" || o.maps;
    if o.delta.is_some() && !(is_tree || oracle_maps) {
        return Err(CliError::usage(
            "--delta is for the contrast samplers (--sampler ec, ic, cc-tree, ec-binary, es) and --maps",
        ));
    }
    if o.binary_contrast && !oracle_maps {
        return Err(CliError::usage("--binary-contrast is for --sampler es and --maps"));
    }
    if o.sampler == "es" && o.threshold.is_some() {
        return Err(CliError::usage("--sampler es spends exactly --spp on average: no --threshold"));
    }
    if let Some(m) = o.max_spp
        && m < o.spp
    {
        return Err(CliError::usage(format!("--max-spp {m} is below --spp {}", o.spp)));
    }
    if o.sampler == "adaptive" && o.spp < adaptive::PILOT {
        return Err(CliError::usage(format!(
            "--spp {}: --sampler adaptive takes a pilot of {} a pixel; give --spp {} or more",
            o.spp,
            adaptive::PILOT,
            adaptive::PILOT
        )));
    }
    if adaptive && o.sampler != "adaptive" && o.spp < criteria::BATCH {
        return Err(CliError::usage(format!(
            "--spp {}: adaptive samplers take at least {} per pixel",
            o.spp,
            criteria::BATCH
        )));
    }
    // The unbiased form traces at least 8 samples to decide and 8 to estimate.
    let floor = 2 * criteria::BATCH;
    if adaptive
        && o.sampler != "adaptive"
        && !o.tutorial_form
        && o.spp < floor
        && (o.threshold.is_none() || o.sampler == "es")
    {
        return Err(CliError::usage(format!(
            "--spp {}: the unbiased form traces at least {floor} a pixel (8 to decide, 8 for the image): give --spp {floor} or more, or --tutorial-form",
            o.spp
        )));
    }
    shard::check(o)?;
    memory_check(o)?;
    if o.shards.shard.is_some() {
        return render_into(o, &spec, None);
    }
    let (dir, made) = out_dir(o)?;
    let result = render_into(o, &spec, Some(&dir));
    if result.is_err() && made {
        // Leave nothing behind: the directory made for --out goes again (only if still empty).
        let _ = std::fs::remove_dir(&dir);
    }
    result
}

/// The image files of a render in `dir`.
pub(super) fn image_files(dir: &Path) -> [PathBuf; 3] {
    [dir.join("image.exr"), dir.join("image.png"), dir.join("density.png")]
}

/// Reads `--reference` and checks its size against the render's.
pub(super) fn read_reference(o: &RenderOptions, size: (u32, u32)) -> Result<Option<Radiance>, CliError> {
    let reference = o.reference.as_deref().map(images::read_exr).transpose()?;
    if let Some(r) = &reference
        && (r.width, r.height) != (size.0 as usize, size.1 as usize)
    {
        return Err(CliError::usage(format!(
            "--reference is {} x {}, the render {} x {}",
            r.width, r.height, size.0, size.1
        )));
    }
    Ok(reference)
}

/// Writes `frame`'s EXR, PNG and density map into `dir`; returns the
/// image as the EXR holds it (f32 values) and the files written.
pub(super) fn write_frame(frame: &Frame, exposure: f64, dir: &Path) -> Result<(Radiance, Vec<PathBuf>), CliError> {
    let files = image_files(dir);
    // The values the EXR holds (f32), so --reference and compare agree.
    let rgb = frame.rgb.iter().map(|c| c.map(|v| f64::from(v as f32))).collect();
    let image = Radiance { width: frame.width as usize, height: frame.height as usize, rgb };
    images::write_exr(&image, &files[0])?;
    images::write_display_png(&image, exposure, &files[1])?;
    images::write_density_png(&frame.samples, image.width, image.height, &files[2])?;
    Ok((image, files.to_vec()))
}

/// Writes `frame`'s per-pixel sample variance as `variance.exr` in `dir`.
fn write_variance(frame: &Frame, dir: &Path) -> Result<PathBuf, CliError> {
    if frame.variance.len() != frame.rgb.len() {
        return Err(CliError::usage("--variance: this run kept no per-pixel variance"));
    }
    let path = dir.join("variance.exr");
    let image = Radiance { width: frame.width as usize, height: frame.height as usize, rgb: frame.variance.clone() };
    images::write_exr(&image, &path)?;
    Ok(path)
}

/// The samples spent, the image's mean and the metrics against `reference`.
pub(super) fn frame_stats(
    r: &mut Report,
    frame: &Frame,
    image: Option<&Radiance>,
    reference: Option<&Radiance>,
    exposure: f64,
) -> Result<(), CliError> {
    r.real("spp_mean", frame.mean_samples(), None)
        .real("spp_traced_mean", frame.mean_traced(), None)
        .count("spp_min", u64::from(frame.samples.iter().copied().min().unwrap_or(0)))
        .count("spp_max", u64::from(frame.samples.iter().copied().max().unwrap_or(0)));
    let mean = metrics::mean_rgb(image.map_or(&frame.rgb, |i| &i.rgb));
    r.reals("mean_radiance", mean.to_vec()).real("mean_luminance", itgfx_core::pixel::luminance(mean), None);
    if let (Some(image), Some(reference)) = (image, reference) {
        compare_images(image, reference, exposure)?.report(r);
    }
    Ok(())
}

fn render_into(o: &RenderOptions, spec: &str, dir: Option<&Path>) -> Result<Report, CliError> {
    if let Some(dir) = dir {
        let variance = if o.variance { vec![dir.join("variance.exr")] } else { Vec::new() };
        let maps = if o.maps { maps::files(dir) } else { Vec::new() };
        for f in image_files(dir).iter().chain(&maps).chain(&variance) {
            crate::output::check("--out", f)?;
        }
    }
    let reference = read_reference(o, o.size)?;
    let scene = load_scene(spec, 1)?;
    let prepared = Prepared::new(&scene);
    let shading = Shading::new(&scene, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let tracer = open(o.tracing.backend, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let camera = o.camera.unwrap_or_else(|| views::default_camera(&scene));
    let delta = o.delta.unwrap_or(1.0);
    let sampling = match (Criterion::from_name(&o.sampler), TreeContrast::from_name(&o.sampler)) {
        (None, Some(contrast)) => Sampling::Tree {
            contrast,
            delta,
            spp: o.spp,
            unbiased: !o.tutorial_form,
            threshold: o.threshold,
            node_samples: o.node_samples.unwrap_or(tree::NODE_SAMPLES),
        },
        (None, None) if o.sampler == "es" => Sampling::Supersample(Supersampling {
            oracle: Oracle { delta, binary: o.binary_contrast },
            spp: o.spp,
            max: o.max_spp.unwrap_or(o.spp.saturating_mul(16).min(MAX_SPP)),
            unbiased: !o.tutorial_form,
        }),
        (None, None) if o.sampler == "adaptive" => Sampling::Neighbours(AdaptiveSampling {
            spp: o.spp,
            max: o.max_spp.unwrap_or(o.spp.saturating_mul(16).min(MAX_SPP)),
        }),
        (None, None) => Sampling::Uniform(o.spp),
        (Some(criterion), _) => Sampling::Adaptive {
            criterion,
            spp: o.spp,
            max: o.max_spp.unwrap_or(o.spp.saturating_mul(16).min(MAX_SPP)),
            unbiased: !o.tutorial_form,
            threshold: o.threshold,
        },
    };
    let t0 = Instant::now();
    let progress = Mutex::new(Progress::new());
    let tick = |d: u64, t: u64| {
        if let Ok(mut p) = progress.lock() {
            p.update(d, t);
        }
    };
    let job = render::Job {
        tracer: tracer.as_ref(),
        scene: &scene,
        prepared: &prepared,
        shading: &shading,
        camera: &camera,
        size: o.size,
        seed: o.seed,
        sampling: &sampling,
        maps: o.maps.then_some(Oracle { delta, binary: o.binary_contrast }),
        rows: o.shards.shard.map(|s| shard::rows(s, o.size.1)),
        time_budget: o.time_budget,
    };
    let rendered = render::render(&job, &tick).map_err(|e| CliError::usage(format!("{spec}: {e}")))?;
    let frame = &rendered.frame;
    let seconds = t0.elapsed().as_secs_f64();
    let mut r = Report::new();
    let (image, wrote) = match (dir, o.shards.shard, &o.shards.save_shard) {
        (_, Some(s), Some(path)) => {
            let st = shard::settings(o, &sampling, delta, &camera, tracer.name());
            shard::save(path, &scene.name, &prepared, st, s, rendered.threshold, frame, &mut r)?;
            (None, vec![path.clone()])
        }
        (Some(dir), _, _) => {
            let (image, mut wrote) = write_frame(frame, o.exposure, dir)?;
            if o.maps
                && let Some(map) = &rendered.map
            {
                // p_v's colour weight: --delta, else Simmons' 0.9 (eq. (4)).
                let priority = render::priority_map(&job, o.delta.unwrap_or(0.9))
                    .map_err(|e| CliError::usage(format!("{spec}: {e}")))?;
                maps::write_maps(map, &priority, dir)?;
                wrote.extend(maps::files(dir));
            }
            if o.export_scene {
                wrote.extend(export_scene::export_scene(&scene, &camera, o.size, o.spp, dir)?);
            }
            if o.variance {
                wrote.push(write_variance(frame, dir)?);
            }
            (Some(image), wrote)
        }
        _ => return Err(CliError::usage("give --out DIR for the images")),
    };

    let adaptive = o.sampler != "uniform";
    r.text("scene", scene.name.clone()).text("backend", tracer.name()).text("sampler", o.sampler.clone());
    r.count("width", u64::from(frame.width)).count("height", u64::from(frame.height)).count("seed", o.seed);
    r.reals("camera_eye", camera.eye.to_array().to_vec())
        .reals("camera_forward", camera.forward.to_array().to_vec())
        .real("camera_fov_y", camera.fov_y.to_degrees(), Some("deg"));
    if let Sampling::Adaptive { max, .. } | Sampling::Neighbours(AdaptiveSampling { max, .. }) = sampling {
        r.count("max_spp", u64::from(max));
    }
    if let Sampling::Neighbours(_) = sampling {
        r.count("pilot_spp", u64::from(adaptive::PILOT));
    }
    if let Some(b) = o.time_budget {
        r.real("time_budget", b, Some("s")).count("passes", rendered.passes);
    }
    if adaptive {
        // Which form ran: decisions kept out of the image, or the tutorial's shared samples.
        r.text("form", if o.tutorial_form { "tutorial" } else { "unbiased" }).flag("unbiased", !o.tutorial_form);
    }
    if let Sampling::Supersample(es) = sampling {
        r.count("max_spp", u64::from(es.max)).count("oracle_spp", u64::from(supersample::ORACLE_SAMPLES));
    }
    if matches!(sampling, Sampling::Tree { .. } | Sampling::Supersample(_)) || o.maps {
        r.real("delta", delta, None);
    }
    if let Sampling::Tree { node_samples, .. } = sampling {
        r.count("node_samples", u64::from(node_samples));
    }
    if let Some(map) = &rendered.map {
        let mean = |g: fn(&render::PixelMeasures) -> f64| {
            map.measures.iter().map(g).sum::<f64>() / map.measures.len().max(1) as f64
        };
        r.real("mean_colour_quality", mean(|m| m.colour_quality), None)
            .real("mean_geometry_quality", mean(|m| m.geometry_quality), None)
            .real("mean_contrast", mean(|m| m.contrast), None);
    }
    if o.sampler != "uniform" {
        r.maybe_real("threshold", rendered.threshold, None);
        if let Some(t) = rendered.tuned {
            r.count("pilot_pixels", u64::from(t.pilot_pixels)).real("pilot_spp_mean", t.pilot_mean, None);
        }
    }
    r.count("spp_requested", u64::from(o.spp));
    frame_stats(&mut r, frame, image.as_ref(), reference.as_ref(), o.exposure)?;
    let traced: f64 = frame.samples.iter().chain(&frame.pilot_samples).map(|&s| f64::from(s)).sum();
    r.real("seconds", seconds, Some("s")).real("Msamples_per_s", traced / seconds.max(1e-9) / 1e6, None);
    r.texts("wrote", wrote.iter().map(|p| p.display().to_string()).collect());
    Ok(r)
}

/// Runs `itgfx compare`.
///
/// # Errors
/// Unreadable or mismatched images.
pub fn run_compare(o: &CompareOptions) -> Result<Report, CliError> {
    let a = images::read_exr(&o.a)?;
    let b = images::read_exr(&o.b)?;
    let m = compare_images(&a, &b, o.exposure)?;
    let mut r = Report::new();
    r.count("width", a.width as u64).count("height", a.height as u64);
    m.report(&mut r);
    Ok(r)
}
