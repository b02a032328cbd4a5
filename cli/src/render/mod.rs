//! `itgfx render SCENE`: path-traced images with the tutorial's adaptive
//! pixel criteria (Part IV; Part III-IV §5), and `itgfx compare A.exr B.exr`.

mod export_scene;
pub mod images;
pub mod maps;
mod metrics;
mod shard;

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use clap::Args;
use glam::DVec3;
use itgfx_backends::camera::Camera;
use itgfx_backends::open;
use itgfx_backends::render::{
    self, AdaptiveSampling, Criterion, Frame, Oracle, Sampling, Shading, Supersampling, TreeContrast, adaptive,
    criteria, supersample, tree, views,
};
use itgfx_backends::tracer::Prepared;

use crate::CliError;
use crate::options::{Common, Tracing};
use crate::progress::Progress;
use crate::report::Report;
use crate::scene::load_scene;
use crate::values::{count, finite, out_path};
use images::Radiance;
pub use metrics::compare_images;

/// Largest image side.
const MAX_SIDE: u32 = 8192;
/// Most samples per pixel (average) a run may ask for.
const MAX_SPP: u32 = 1 << 16;

/// `itgfx render SCENE`.
#[derive(Debug, Args)]
#[command(after_help = "SCENE is an .obj file with its MTL (Kd diffuse, Ke emission, Ks with illum 3/5/8 a mirror), \
                        a .ply, a .gltf/.glb (its first camera is the default camera), a Mitsuba 3 .xml, \
                        or a built-in with materials: cornell-box, mirror-room, open-blocks, open-sphere (docs/SCENES.md).\n\
                        DIR receives image.exr (linear radiance), image.png (sRGB) and density.png \
                        (samples per pixel, log scale); with --variance also variance.exr.\n\
                        Recommended: --sampler adaptive (unbiased; pays on scenes with empty or flat regions, \
                        about uniform elsewhere).",
          mut_arg("shard", |a| a.help(shard::SHARD_HELP).requires("save_shard")),
          mut_arg("save_shard", |a| a.help("Write the shard's pixels to F (for --merge)").requires("shard")),
          mut_arg("merge", |a| a.help(shard::MERGE_HELP).num_args(1..).conflicts_with_all(shard::MERGE_CONFLICTS)))]
pub struct RenderOptions {
    /// A built-in scene name (cornell-box, mirror-room, open-blocks, open-sphere) or a scene file
    /// (.obj, .ply, .gltf, .glb, Mitsuba .xml)
    #[arg(value_name = "SCENE")]
    pub scene: Option<String>,
    /// Directory for image.exr, image.png and density.png (made if missing)
    #[arg(long, value_name = "DIR", value_parser = out_path)]
    pub out: Option<PathBuf>,
    /// Samples per pixel (uniform), or the average rays per pixel every adaptive sampler traces
    /// (the samples it decides on included)
    #[arg(long, value_name = "N", default_value = "16", value_parser = spp)]
    pub spp: u32,
    /// Pixel sampler: uniform (stratified); adaptive (RECOMMENDED: unbiased, every ray in the image, an
    /// 8-spp pilot in each pixel and the rest shared by its neighbours' display-space noise); or an
    /// adaptive criterion of the tutorial: cc (classic contrast), ct
    /// (confidence test), kl cs hl (f-divergences), kl-sqrt cs-sqrt hl-sqrt (their square roots), ec
    /// (entropy refinement tree, Part IV §6), ic (importance-weighted classic contrast tree), cc-tree
    /// (classic contrast tree), ec-binary (the entropy tree with binary contrasts in colour and
    /// geometry, Part IV eqs. 19, 21), ec-batch (entropy contrast in batches), rel (relative confidence
    /// half-width, beyond the tutorial), es (entropy-based supersampling, Part IV §5: a contrast map
    /// of 8 spp decides where the rest of the budget goes); see docs/RENDER.md
    #[arg(long, value_name = "NAME", default_value = "uniform", value_parser = sampler_name)]
    pub sampler: String,
    /// ec, ic, cc-tree, ec-binary, es: weight of the colour contrast against the geometry contrast of the
    /// rays' first hits (Part IV eqs. (23), (28)); 1 is colour only. With --maps, also p_v's colour
    /// weight (eq. (4); 0.9 when not given)
    #[arg(long, value_name = "D", value_parser = delta)]
    pub delta: Option<f64>,
    /// es and --maps: the binary colour contrast C_b (Part IV eq. (19)) instead of the entropy
    /// contrast (eq. (18)) in the oracle's contrast
    #[arg(long)]
    pub binary_contrast: bool,
    /// Also write the pixel quality and contrast maps of an 8-spp pass (Part IV §3-4, Figs. 1-6):
    /// quality.png, geometry-quality.png, contrast.png, colour-contrast.png, binary-contrast.png,
    /// geometry-contrast.png, geometry-binary-contrast.png (eq. 21), geometry-log-contrast.png
    /// (eq. 22), quality.exr, contrast.exr, geometry-contrast.exr; and Simmons' priorities of the
    /// same samples (§2 eqs. 2-4, a second trace of the pass): priority-colour.png,
    /// depth-difference.png, priority-value.png, priority.exr
    #[arg(long)]
    pub maps: bool,
    /// Also write variance.exr: each pixel's sample variance per channel (of the samples averaged
    /// into its value; not for the trees ec ic cc-tree nor es --tutorial-form). Needs --out
    #[arg(long)]
    pub variance: bool,
    /// Render passes of the sampler's budget (--spp) until S seconds have passed, then write the mean
    /// of the complete passes' samples, to compare renderers at equal time. Each pass's seed derives
    /// from --seed, but how many passes fit depends on the machine: the image depends on timing
    #[arg(long, value_name = "S", value_parser = time_budget)]
    pub time_budget: Option<f64>,
    /// Adaptive: most samples one pixel may take (default 16 x --spp)
    #[arg(long, value_name = "N", value_parser = spp)]
    pub max_spp: Option<u32>,
    /// Adaptive: this threshold instead of one tuned to spend --spp on average
    #[arg(long, value_name = "EPS", value_parser = threshold)]
    pub threshold: Option<f64>,
    /// Adaptive: the tutorial's form, BIASED: the samples a criterion decides on are averaged into
    /// the image (3.5-17% dark on mirror-room, docs/RENDER.md). Default: decisions on samples that
    /// are kept out of the image (a pilot set, the tree's pilot, es's oracle), unbiased
    #[arg(long)]
    pub tutorial_form: bool,
    /// Gone: the unbiased form is the default now (and --spp counts its decision samples)
    #[arg(long, hide = true)]
    pub unbiased: bool,
    /// Image size in pixels
    #[arg(long, value_name = "WxH", default_value = "256x256", value_parser = size)]
    pub size: (u32, u32),
    /// Camera in scene units: eye, target, up (3 numbers each) and vertical field of view in degrees
    #[arg(long, value_name = "EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOV", value_parser = camera)]
    pub camera: Option<Camera>,
    /// Seed; same seed, same image, any thread count
    #[arg(long, value_name = "S", default_value = "1", value_parser = count)]
    pub seed: u64,
    /// PNG exposure in stops (the EXR is never scaled)
    #[arg(long, value_name = "STOPS", default_value = "0", value_parser = exposure)]
    pub exposure: f64,
    /// Add RMSE/PSNR/relMSE against this reference EXR to the output
    #[arg(long, value_name = "R.exr")]
    pub reference: Option<PathBuf>,
    /// Also write the scene for other renderers in DIR: one OBJ per material, scene.xml (Mitsuba 3:
    /// `mitsuba scene.xml` renders it as is, and itgfx reads it back) and scene.json
    #[arg(long)]
    pub export_scene: bool,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub tracing: Tracing,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub shards: crate::shard::ShardArgs,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: Common,
}

/// `itgfx compare A.exr B.exr`.
#[derive(Debug, Args)]
pub struct CompareOptions {
    /// The image to score
    #[arg(value_name = "A.exr")]
    pub a: PathBuf,
    /// The reference
    #[arg(value_name = "B.exr")]
    pub b: PathBuf,
    /// Exposure in stops of the 8-bit display values that RMSE and PSNR are taken on
    #[arg(long, value_name = "STOPS", default_value = "0", value_parser = exposure)]
    pub exposure: f64,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub common: crate::options::JsonOnly,
}

fn spp(s: &str) -> Result<u32, String> {
    match count(s)? {
        n @ 1..=65_536 => Ok(n as u32),
        _ => Err(format!("must be in 1..={MAX_SPP}")),
    }
}

fn sampler_name(s: &str) -> Result<String, String> {
    if s == "uniform"
        || s == "es"
        || s == "adaptive"
        || TreeContrast::from_name(s).is_some()
        || Criterion::from_name(s).is_some()
    {
        Ok(s.to_string())
    } else {
        Err(format!(
            "unknown sampler {s:?}: uniform, adaptive, es, {}, {}",
            tree::NAMES.join(", "),
            criteria::NAMES.join(", ")
        ))
    }
}

/// Longest time budget: a week.
const MAX_TIME_BUDGET: f64 = 7.0 * 86_400.0;

fn time_budget(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x > 0.0 && x <= MAX_TIME_BUDGET {
        Ok(x)
    } else {
        Err(format!("must be seconds in (0, {MAX_TIME_BUDGET}] (a week)"))
    }
}

fn delta(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if (0.0..=1.0).contains(&x) { Ok(x) } else { Err("must be in 0..=1".into()) }
}

fn threshold(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x >= 0.0 { Ok(x) } else { Err("must be a finite number >= 0".into()) }
}

fn exposure(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if (-64.0..=64.0).contains(&x) { Ok(x) } else { Err("must be in -64..=64 stops".into()) }
}

fn size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("must be WxH, e.g. 256x256")?;
    let side = |v: &str| match v.parse::<u32>() {
        Ok(n @ 1..=MAX_SIDE) => Ok(n),
        _ => Err(format!("{v:?}: each side must be an integer in 1..={MAX_SIDE}")),
    };
    Ok((side(w)?, side(h)?))
}

/// Parses `--camera EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOV`.
pub(crate) fn camera(s: &str) -> Result<Camera, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or("must be 10 finite numbers: eye, target, up (x,y,z each) and fov")?;
    if v.len() != 10 {
        return Err(format!("must be 10 numbers (eye, target, up, fov), got {}", v.len()));
    }
    let d = |i: usize| DVec3::new(v[i], v[i + 1], v[i + 2]);
    Camera::look_at(d(0), d(3), d(6), v[9]).map_err(|e| e.to_string())
}

/// Most memory a run may plan to use.
const MEMORY_LIMIT: u64 = 4 << 30;

/// Refuses a run whose image or per-row sample buffers would pass
/// [`MEMORY_LIMIT`]: about 120 bytes a pixel (radiance, counts, display
/// values, PNG; 200 for `adaptive`), and 48 bytes a sample of the row each worker holds.
fn memory_check(o: &RenderOptions) -> Result<(), CliError> {
    let (w, h) = (u64::from(o.size.0), u64::from(o.size.1));
    let per_pixel = match o.sampler.as_str() {
        "uniform" => u64::from(o.spp),
        "ec" | "ic" | "cc-tree" | "ec-binary" => 680,
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
fn out_dir(o: &RenderOptions) -> Result<(PathBuf, bool), CliError> {
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
fn image_files(dir: &Path) -> [PathBuf; 3] {
    [dir.join("image.exr"), dir.join("image.png"), dir.join("density.png")]
}

/// Reads `--reference` and checks its size against the render's.
fn read_reference(o: &RenderOptions, size: (u32, u32)) -> Result<Option<Radiance>, CliError> {
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
fn write_frame(frame: &Frame, exposure: f64, dir: &Path) -> Result<(Radiance, Vec<PathBuf>), CliError> {
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
fn frame_stats(
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
        (None, Some(contrast)) => {
            Sampling::Tree { contrast, delta, spp: o.spp, unbiased: !o.tutorial_form, threshold: o.threshold }
        }
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
