//! The run of `itgfx render` (options checked before any work, the
//! render, its files and report) and of `itgfx compare`.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use itgfx_backends::render::job::Settings;
use itgfx_backends::render::{
    self, AdaptiveSampling, Frame, JobError, Outcome, RenderJob, Sampling, adaptive, supersample,
};

use super::args::{CompareOptions, RenderOptions};
use super::images::Radiance;
use super::metrics::compare_images;
use super::{check, export_scene, images, maps, metrics, shard};
use crate::CliError;
use crate::progress::Progress;
use crate::report::Report;
use crate::scene::load_scene;

/// The output directory: must be a directory or not exist; made if missing.
/// Returns it and whether it was made here.
pub(super) fn out_dir(o: &RenderOptions) -> Result<(PathBuf, bool), CliError> {
    let d = o.out.clone().ok_or_else(|| CliError::usage("give --out DIR for the images"))?;
    let made = crate::output::out_dir(&d)?.is_some();
    Ok((d, made))
}

/// Runs `itgfx render`: the options checked, the settings built once and
/// their memory estimate checked against the budget, then the render into
/// `--out` (or a shard's file); a merge with `--merge`.
///
/// # Errors
/// Usage, scene, camera and backend errors, one line each.
pub fn run(o: &RenderOptions) -> Result<Report, CliError> {
    check::run_options(o)?;
    if !o.shards.merge.is_empty() {
        return shard::run_merge(o);
    }
    let spec = o.scene.clone().ok_or_else(|| {
        CliError::usage("give a scene: cornell-box, mirror-room, open-blocks, open-sphere or a scene file")
    })?;
    if let Some(r) = &o.reference {
        crate::input::regular("--reference", r)?;
    }
    check::sampler_options(o)?;
    check::budget(o)?;
    shard::check(o)?;
    let settings = settings(o);
    let workers = o.run.tracing.threads.unwrap_or_else(rayon::current_num_threads);
    settings.plan(workers).map_err(|e| CliError::usage(format!("{e}: lower --size, --spp or --max-spp")))?;
    if o.shards.shard.is_some() {
        return render_into(o, &spec, &settings, None);
    }
    let (dir, made) = out_dir(o)?;
    let result = render_into(o, &spec, &settings, Some(&dir));
    if result.is_err() && made {
        // Leave nothing behind: the directory made for --out goes again (only if still empty).
        let _ = std::fs::remove_dir(&dir);
    }
    result
}

/// The render's settings, built once from the options.
fn settings(o: &RenderOptions) -> Settings {
    Settings {
        sampler: o.sampler.clone(),
        spp: o.spp,
        max_spp: o.max_spp,
        threshold: o.threshold,
        tutorial_form: o.tutorial_form,
        delta: o.delta,
        binary_contrast: o.binary_contrast,
        node_samples: o.node_samples,
        maps: o.maps,
        size: o.size,
        seed: o.seed,
        camera: o.camera,
        shard: o.shards.shard,
        time_budget: o.time_budget,
    }
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

/// Renders into `dir` (or a shard's file): the outputs checked, the
/// reference read, the job run with a progress bar, the files written, the
/// report.
fn render_into(o: &RenderOptions, spec: &str, settings: &Settings, dir: Option<&Path>) -> Result<Report, CliError> {
    if let Some(dir) = dir {
        check_outputs(o, dir)?;
    }
    let reference = read_reference(o, o.size)?;
    let scene = load_scene(spec, 1)?;
    let job = RenderJob { settings, scene: &scene, backend: o.run.tracing.backend };
    let progress = Mutex::new(Progress::new());
    let tick = |d: u64, t: u64| {
        if let Ok(mut p) = progress.lock() {
            p.update(d, t);
        }
    };
    let done = job.run(&tick).map_err(|e| match e {
        JobError::Setup(e) => CliError::usage(e.to_string()),
        JobError::Render(e) => CliError::usage(format!("{spec}: {e}")),
    })?;
    let mut r = Report::new();
    let (image, wrote) = write_outputs(o, &scene, &done, dir, &mut r)?;
    report_settings(&mut r, o, &scene.name, &done);
    frame_stats(&mut r, &done.rendered.frame, image.as_ref(), reference.as_ref(), o.exposure)?;
    let frame = &done.rendered.frame;
    let traced: f64 = frame.samples.iter().chain(&frame.pilot_samples).map(|&s| f64::from(s)).sum();
    r.real("seconds", done.seconds, Some("s")).real("Msamples_per_s", traced / done.seconds.max(1e-9) / 1e6, None);
    r.texts("wrote", wrote.iter().map(|p| p.display().to_string()).collect());
    Ok(r)
}

/// Checks every file `--out` will receive, before any work.
fn check_outputs(o: &RenderOptions, dir: &Path) -> Result<(), CliError> {
    let variance = if o.variance { vec![dir.join("variance.exr")] } else { Vec::new() };
    let maps = if o.maps { maps::files(dir) } else { Vec::new() };
    for f in image_files(dir).iter().chain(&maps).chain(&variance) {
        crate::output::check("--out", f)?;
    }
    Ok(())
}

/// Writes a shard's file, or the images, maps, exported scene and variance
/// into `dir`; returns the image as the EXR holds it and the files written.
fn write_outputs(
    o: &RenderOptions,
    scene: &itgfx_backends::scene::Scene,
    done: &Outcome,
    dir: Option<&Path>,
    r: &mut Report,
) -> Result<(Option<Radiance>, Vec<PathBuf>), CliError> {
    let frame = &done.rendered.frame;
    if let (Some(file), Some(path)) = (&done.shard, &o.shards.save_shard) {
        shard::save(path, file, r)?;
        return Ok((None, vec![path.clone()]));
    }
    let dir = dir.ok_or_else(|| CliError::usage("give --out DIR for the images"))?;
    let (image, mut wrote) = write_frame(frame, o.exposure, dir)?;
    if let (Some(map), Some(priority)) = (&done.rendered.map, &done.priority) {
        maps::write_maps(map, priority, dir)?;
        wrote.extend(maps::files(dir));
    }
    if o.export_scene {
        wrote.extend(export_scene::export_scene(scene, &done.camera, o.size, o.spp, dir)?);
    }
    if o.variance {
        wrote.push(write_variance(frame, dir)?);
    }
    Ok((Some(image), wrote))
}

/// The report's settings: the scene, backend, sampler and its parameters,
/// the image, the camera, and what the sampler decided.
fn report_settings(r: &mut Report, o: &RenderOptions, scene: &str, done: &Outcome) {
    let (frame, camera, sampling) = (&done.rendered.frame, &done.camera, done.sampling);
    r.text("scene", scene.to_string()).text("backend", done.backend).text("sampler", o.sampler.clone());
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
        r.real("time_budget", b, Some("s")).count("passes", done.rendered.passes);
    }
    if o.sampler != "uniform" {
        // Which form ran: decisions kept out of the image, or the tutorial's shared samples.
        r.text("form", if o.tutorial_form { "tutorial" } else { "unbiased" }).flag("unbiased", !o.tutorial_form);
    }
    if let Sampling::Supersample(es) = sampling {
        r.count("max_spp", u64::from(es.max)).count("oracle_spp", u64::from(supersample::ORACLE_SAMPLES));
    }
    if matches!(sampling, Sampling::Tree { .. } | Sampling::Supersample(_)) || o.maps {
        r.real("delta", o.delta.unwrap_or(1.0), None);
    }
    if let Sampling::Tree { node_samples, .. } = sampling {
        r.count("node_samples", u64::from(node_samples));
    }
    if let Some(map) = &done.rendered.map {
        let mean = |g: fn(&render::PixelMeasures) -> f64| {
            map.measures.iter().map(g).sum::<f64>() / map.measures.len().max(1) as f64
        };
        r.real("mean_colour_quality", mean(|m| m.colour_quality), None)
            .real("mean_geometry_quality", mean(|m| m.geometry_quality), None)
            .real("mean_contrast", mean(|m| m.contrast), None);
    }
    if o.sampler != "uniform" {
        r.maybe_real("threshold", done.rendered.threshold, None);
        if let Some(t) = done.rendered.tuned {
            r.count("pilot_pixels", u64::from(t.pilot_pixels)).real("pilot_spp_mean", t.pilot_mean, None);
        }
    }
    r.count("spp_requested", u64::from(o.spp));
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
