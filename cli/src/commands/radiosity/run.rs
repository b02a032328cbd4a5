//! Running `itgfx radiosity` ([`super::RadiosityOptions`]): hierarchical
//! Monte Carlo radiosity refined by the tutorial's oracles, its pictures,
//! and an independent path-traced reference to score them against
//! (RMSE/PSNR of Part III-IV Table 2).

use std::path::{Path, PathBuf};
use std::time::Instant;

use itgfx_backends::open;
use itgfx_backends::radiosity::reference::{Reference, ReferenceJob, path_traced};
use itgfx_backends::radiosity::refine::{RadiosityError, check_scene};
use itgfx_backends::radiosity::render::{
    View, default_camera, leaf_mesh, mesh_picture, picture, tonemap, view, white_point,
};
use itgfx_backends::radiosity::search::search_epsilon;
use itgfx_backends::radiosity::{Rgb, Settings, Solution, element::Hierarchy, solve};
use itgfx_backends::tracer::Prepared;
use itgfx_core::pixel::{SRGB_LUMINANCE_WEIGHTS, image_error};

use super::RadiosityOptions;
use crate::CliError;
use crate::progress::Progress;
use crate::render::images::{Radiance, read_exr, read_pfm, write_exr, write_pfm};
use crate::report::Report;
use crate::scene::load_scene;

fn usage(e: impl std::fmt::Display) -> CliError {
    CliError::usage(e.to_string())
}

/// A solver error in the CLI's words: the element cap is `--max-elements`
/// (the engine names no flag).
fn solver(e: RadiosityError) -> CliError {
    match e {
        RadiosityError::TooLarge(m) => CliError::usage(format!("{m} (--max-elements)")),
        e => usage(e),
    }
}

/// The output files of a run, checked before any work.
fn outputs(o: &RadiosityOptions) -> Result<Vec<(&'static str, PathBuf)>, CliError> {
    let Some(dir) = &o.out else { return Ok(Vec::new()) };
    let names: &[&'static str] = if o.path_trace.is_some() {
        &[
            "reference.exr",
            "reference.pfm",
            "reference-even.pfm",
            "reference-odd.pfm",
            "reference.png",
            "reference.json",
        ]
    } else if o.check_paths.is_some() {
        &[
            "radiosity.png",
            "mesh.png",
            "radiosity.exr",
            "radiosity.pfm",
            "mesh.ply",
            "elements.csv",
            "patches.csv",
            "radiosity.json",
        ]
    } else {
        &["radiosity.png", "mesh.png", "radiosity.exr", "radiosity.pfm", "mesh.ply", "elements.csv", "radiosity.json"]
    };
    let paths = crate::output::out_files(dir, names)?;
    Ok(names.iter().copied().zip(paths).collect())
}

/// Refuses a picture whose linear values do not fit the f32 of the EXR and
/// PFM outputs (or are not finite), before any file is written: a value
/// past 3.4e38 would be written as infinity.
fn fits_f32(what: &str, px: &[Option<Rgb>]) -> Result<(), CliError> {
    match px.iter().flatten().flatten().find(|c| !(c.abs() <= f64::from(f32::MAX))) {
        Some(c) => Err(CliError::usage(format!(
            "{what}: a pixel's radiosity {c:e} does not fit the f32 of the pictures: lower the emittances (MTL Ke)"
        ))),
        None => Ok(()),
    }
}

/// A linear RGB picture as OpenEXR (f32, the renderer's writer).
fn exr(px: &[Rgb], width: u32, height: u32, path: &Path) -> Result<(), CliError> {
    write_exr(&radiance(px, width, height), path)
}

/// A linear RGB picture as PFM (the renderer's writer).
fn pfm(px: &[Rgb], width: u32, height: u32, path: &Path) -> Result<(), CliError> {
    write_pfm(&radiance(px, width, height), path)
}

fn radiance(px: &[Rgb], width: u32, height: u32) -> Radiance {
    Radiance { width: width as usize, height: height as usize, rgb: px.to_vec() }
}

/// Reads `--reference`: OpenEXR (by its magic number) or the PFM of [`pfm`].
fn read_reference(path: &Path) -> Result<(u32, u32, Vec<Rgb>), CliError> {
    let mut magic = [0u8; 4];
    let is_exr = itgfx_backends::files::open_regular(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
        .is_ok_and(|()| magic == [0x76, 0x2f, 0x31, 0x01]);
    if !is_exr {
        let image = read_pfm(path, "--reference")?;
        return Ok((image.width as u32, image.height as u32, image.rgb));
    }
    let image = read_exr(path).map_err(|e| CliError::usage(format!("--reference {e}")))?;
    if let Some(bad) = image.rgb.iter().flatten().find(|v| !(v.is_finite() && **v >= 0.0)) {
        return Err(CliError::usage(format!("--reference {path:?}: a pixel value {bad} (want finite, >= 0)")));
    }
    Ok((image.width as u32, image.height as u32, image.rgb))
}

fn png(px: &[[u8; 3]], w: u32, h: u32, path: &Path) -> Result<(), CliError> {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb(px[(y * w + x) as usize]));
    crate::export::write_png(&img, path)
}

fn dense(px: &[Option<Rgb>]) -> Vec<Rgb> {
    px.iter().map(|p| p.unwrap_or([0.0; 3])).collect()
}

/// 8-bit display values, interleaved, as the tables score them.
fn display(px: &[Rgb], white: f64) -> Vec<f64> {
    px.iter().flat_map(|p| tonemap(*p, white).map(f64::from)).collect()
}

/// RMSE_a, RMSE_p, PSNR_a, PSNR_p of `a` against `b` (8-bit, Part IV §6.4).
fn scores(a: &[f64], b: &[f64]) -> Result<[f64; 4], CliError> {
    let err = |e| crate::core_err("image error", e);
    let ea = image_error(a, b, 3, &[1.0; 3], 255.0).map_err(err)?;
    let ep = image_error(a, b, 3, &SRGB_LUMINANCE_WEIGHTS, 255.0).map_err(err)?;
    Ok([ea.rmse, ep.rmse, ea.psnr, ep.psnr])
}

/// Runs `itgfx radiosity`: checks, the solution (or the path-traced
/// reference), its report, the pictures scored against `--reference`, the
/// files.
///
/// # Errors
/// Usage, scene, backend and output errors, one line.
pub fn run(o: &RadiosityOptions) -> Result<Report, CliError> {
    let spec = o.scene.clone().ok_or_else(|| CliError::usage("give a scene: an .obj file or a built-in scene name"))?;
    if let Some(n) = o.elements
        && n > o.max_elements
    {
        return Err(CliError::usage(format!("--elements {n} is above --max-elements {}", o.max_elements)));
    }
    if let Some(r) = &o.reference {
        crate::input::regular("--reference", r)?;
    }
    let scene = load_scene(&spec, o.subdivide)?;
    check_scene(&scene).map_err(usage)?;
    let h0 = Hierarchy::new(&scene);
    coarsest_check(o, &spec, &h0)?;
    let reference = reference_of(o)?;
    let files = outputs(o)?;
    let file = |name: &str| files.iter().find(|f| f.0 == name).map(|f| f.1.clone());
    let t0 = Instant::now();
    let prepared = Prepared::new(&scene);
    let tracer = open(o.run.tracing.backend, &prepared).map_err(usage)?;
    let camera = o.camera.unwrap_or_else(|| default_camera(&scene));
    let mut r = Report::new();
    r.text("scene", scene.name.clone()).text("backend", tracer.name());
    r.count("polygons", h0.roots.len() as u64).count("pixels", u64::from(o.size) * u64::from(o.size));
    if let Some(walks) = o.path_trace {
        let v = view(&scene, &prepared, tracer.as_ref(), &h0, &camera, (o.size, o.size)).map_err(usage)?;
        let (tracer, seed) = (tracer.as_ref(), o.seed);
        let job = ReferenceJob { scene: &scene, prepared: &prepared, tracer, view: &v, camera: &camera, walks, seed };
        return reference_run(r, &job, t0, &file);
    }
    let (solution, trials) = solve_or_search(o, &scene, &prepared, tracer.as_ref())?;
    solution_report(&mut r, o, &solution, trials, t0.elapsed().as_secs_f64());
    if let Some(paths) = o.check_paths {
        let csv = super::check::check(&mut r, &scene, &prepared, tracer.as_ref(), &solution, paths, o.seed)?;
        if let Some(p) = file("patches.csv") {
            crate::output::write(&p, csv.as_bytes())?;
        }
    }
    let v = view(&scene, &prepared, tracer.as_ref(), &solution.hierarchy, &camera, (o.size, o.size)).map_err(usage)?;
    let pictures = Pictures::of(&solution, &v, reference.as_ref().map(|x| x.2.as_slice()));
    fits_f32(&scene.name, &pictures.gouraud)?;
    r.real("white", pictures.white, None);
    if let Some((_, _, ref_px)) = &reference {
        pictures.score(ref_px, &mut r)?;
    }
    pictures.write(&scene.name, &solution, &file)?;
    r.real("seconds", t0.elapsed().as_secs_f64(), Some("s"));
    if let Some(p) = file("radiosity.json") {
        crate::output::write(&p, format!("{}\n", r.to_json()).as_bytes())?;
    }
    if !files.is_empty() {
        r.texts("files", files.iter().map(|f| f.1.display().to_string()).collect());
    }
    Ok(r)
}

/// Refuses `--elements` below the coarsest mesh: every polygon at
/// `--base-level`.
fn coarsest_check(o: &RadiosityOptions, spec: &str, h0: &Hierarchy) -> Result<(), CliError> {
    let coarsest = h0.roots.len().saturating_mul(4usize.saturating_pow(o.base_level));
    match o.elements {
        Some(n) if n < coarsest => Err(CliError::usage(format!(
            "--elements {n}: {spec} already has {} polygons, {coarsest} elements at --base-level {} (the coarsest mesh)",
            h0.roots.len(),
            o.base_level
        ))),
        _ => Ok(()),
    }
}

/// `--reference`, read and checked against `--size` before any work.
fn reference_of(o: &RadiosityOptions) -> Result<Option<(u32, u32, Vec<Rgb>)>, CliError> {
    let reference = o.reference.as_ref().map(|p| read_reference(p)).transpose()?;
    if let Some((w, hh, _)) = &reference
        && (*w != o.size || *hh != o.size)
    {
        return Err(CliError::usage(format!(
            "--reference is {w} x {hh} pixels but --size is {}: make both with the same --size",
            o.size
        )));
    }
    Ok(reference)
}

/// The solution at `--epsilon`, or, with `--elements N`, at the epsilon the
/// search finds for about N elements (with its trials).
fn solve_or_search(
    o: &RadiosityOptions,
    scene: &itgfx_backends::scene::Scene,
    prepared: &Prepared,
    tracer: &dyn itgfx_backends::tracer::Tracer,
) -> Result<(Solution, usize), CliError> {
    let settings = Settings {
        oracle: o.oracle,
        epsilon: o.epsilon.unwrap_or(1e-3),
        samples: o.samples,
        transport_samples: o.transport_samples.unwrap_or(o.samples),
        shares: o.shares,
        seed: o.seed,
        min_area: o.min_area,
        max_elements: o.max_elements,
        base_level: o.base_level,
        ..Settings::default()
    };
    let Some(n) = o.elements else {
        return Ok((solve(scene, prepared, tracer, &settings).map_err(solver)?, 0));
    };
    let verbose = std::env::var_os("ITGFX_PROGRESS").is_some_and(|v| v == "1");
    let s = search_epsilon(scene, prepared, tracer, &settings, n, o.count_tolerance, o.max_trials, &mut |t, e, k| {
        if verbose {
            eprintln!("itgfx: trial {t}: epsilon {e:.4e} -> {k} elements");
        }
    })
    .map_err(solver)?;
    Ok((s.solution, s.trials.len()))
}

/// The solution's part of the report: its settings, size, rays, passes and
/// power balance.
fn solution_report(r: &mut Report, o: &RadiosityOptions, solution: &Solution, trials: usize, seconds: f64) {
    let (emitted, absorbed) = solution.power_balance();
    r.text("oracle", o.oracle.name()).real("epsilon", solution.settings.epsilon, None);
    r.count("elements", solution.leaves().len() as u64).count("links", solution.links.len() as u64);
    r.count("link_shares", solution.shares.len() as u64);
    r.count("base_level", u64::from(o.base_level));
    r.count("samples_per_link", u64::from(o.samples)).count("link_evaluations", solution.evaluations);
    r.count("transport_samples_per_link", u64::from(o.transport_samples.unwrap_or(o.samples)));
    r.count("rays", solution.rays).count("transport_rays", solution.transport_rays);
    r.count("oracle_only_rays", solution.rays - solution.transport_rays);
    r.count("passes", u64::from(solution.passes)).count("iterations", u64::from(solution.sweeps));
    r.flag("capped", solution.capped);
    if trials > 0 {
        r.count("search_trials", trials as u64);
    }
    let lum = |x: Rgb| SRGB_LUMINANCE_WEIGHTS.iter().zip(x).map(|(w, v)| w * v).sum::<f64>();
    r.real("power_emitted", lum(emitted), None).real("power_absorbed", lum(absorbed), None);
    r.real("balance", if lum(emitted) > 0.0 { lum(absorbed) / lum(emitted) } else { 0.0 }, None);
    r.real("solve_seconds", seconds, Some("s"));
}

/// The solution's pictures from the camera: Gouraud-shaded and flat, the
/// leaf element of each pixel, and the white point that maps them to
/// 8 bits (the reference's when one is given, so that both are scored alike).
struct Pictures {
    gouraud: Vec<Option<Rgb>>,
    flat: Vec<Option<Rgb>>,
    leaf: Vec<Option<itgfx_backends::radiosity::element::ElementId>>,
    white: f64,
    size: u32,
}

impl Pictures {
    fn of(solution: &Solution, v: &View, reference: Option<&[Rgb]>) -> Self {
        let h = &solution.hierarchy;
        let (gouraud, leaf) = picture(h, &solution.radiosity, v, true);
        let (flat, _) = picture(h, &solution.radiosity, v, false);
        let reference_white = reference
            .map(|px| white_point(&px.iter().map(|p| (p.iter().sum::<f64>() > 0.0).then_some(*p)).collect::<Vec<_>>()));
        let white = reference_white.unwrap_or_else(|| white_point(&gouraud));
        Self { gouraud, flat, leaf, white, size: v.width }
    }

    /// RMSE and PSNR of the Gouraud and flat pictures against the reference.
    fn score(&self, ref_px: &[Rgb], r: &mut Report) -> Result<(), CliError> {
        let a = display(&dense(&self.gouraud), self.white);
        let b = display(ref_px, self.white);
        let [ra, rp, pa, pp] = scores(&a, &b)?;
        r.real("RMSE_a", ra, None).real("RMSE_p", rp, None);
        r.real("PSNR_a", pa, Some("dB")).real("PSNR_p", pp, Some("dB"));
        let fl = display(&dense(&self.flat), self.white);
        let [fa, _, fpa, _] = scores(&fl, &b)?;
        r.real("RMSE_a_flat", fa, None).real("PSNR_a_flat", fpa, Some("dB"));
        Ok(())
    }

    /// The pictures and files `--out` asks for (all but the JSON report).
    fn write(&self, name: &str, solution: &Solution, file: &dyn Fn(&str) -> Option<PathBuf>) -> Result<(), CliError> {
        let (size, white, h) = (self.size, self.white, &solution.hierarchy);
        if let Some(p) = file("radiosity.png") {
            let px: Vec<[u8; 3]> = self
                .gouraud
                .iter()
                .map(|c| c.map_or(itgfx_backends::preview::BACKGROUND, |c| tonemap(c, white)))
                .collect();
            png(&px, size, size, &p)?;
        }
        if let Some(p) = file("mesh.png") {
            png(&mesh_picture(&self.flat, &self.leaf, size, white), size, size, &p)?;
        }
        if let Some(p) = file("radiosity.exr") {
            exr(&dense(&self.gouraud), size, size, &p)?;
        }
        if let Some(p) = file("radiosity.pfm") {
            pfm(&dense(&self.gouraud), size, size, &p)?;
        }
        if let Some(p) = file("mesh.ply") {
            super::mesh::write(&leaf_mesh(h, &solution.radiosity), name, white, &p)?;
        }
        if let Some(p) = file("elements.csv") {
            crate::output::write(&p, elements_csv(solution).as_bytes())?;
        }
        Ok(())
    }
}

/// `elements.csv`: one row per leaf element, its patch, level, area,
/// centre and radiosity.
fn elements_csv(solution: &Solution) -> String {
    let h = &solution.hierarchy;
    let mut s = String::from("element,patch,level,area,x,y,z,B_r,B_g,B_b\n");
    for e in solution.leaves() {
        let el = &h.elements[e as usize];
        let c = el.centre();
        let b = solution.radiosity[e as usize];
        s.push_str(&format!(
            "{e},{},{},{:e},{},{},{},{:e},{:e},{:e}\n",
            h.patch(e),
            el.level,
            el.area,
            c.x,
            c.y,
            c.z,
            b[0],
            b[1],
            b[2]
        ));
    }
    s
}

/// The path-traced reference of `job` (with a progress bar), its report and files.
fn reference_run(
    r: Report,
    job: &ReferenceJob,
    t0: Instant,
    file: &dyn Fn(&str) -> Option<PathBuf>,
) -> Result<Report, CliError> {
    let mut progress = Progress::new();
    let reference = path_traced(job, &mut |d, t| progress.update(d, t)).map_err(usage)?;
    reference_report(r, &reference, job.view, job.walks, t0, file)
}

fn reference_report(
    mut r: Report,
    reference: &Reference,
    v: &View,
    walks: u32,
    t0: Instant,
    file: &dyn Fn(&str) -> Option<PathBuf>,
) -> Result<Report, CliError> {
    fits_f32("the path-traced reference", &reference.mean)?;
    let white = white_point(&reference.mean);
    let mean = dense(&reference.mean);
    let [na, np, _, _] = scores(&display(&reference.halves[0], white), &display(&reference.halves[1], white))?;
    // The halves differ by twice the variance of one half; the full mean
    // has half a half's variance: its own RMSE is about RMSE(halves) / 2.
    let seen: Vec<&Rgb> =
        reference.mean.iter().zip(&reference.stderr).filter(|(m, _)| m.is_some()).map(|x| x.1).collect();
    let mean_rel = {
        let mut acc = 0.0;
        let mut n = 0.0;
        for (m, s) in reference.mean.iter().zip(&reference.stderr) {
            if let Some(m) = m {
                for c in 0..3 {
                    if m[c] > 0.0 {
                        acc += s[c] / m[c];
                        n += 1.0;
                    }
                }
            }
        }
        if n > 0.0 { acc / n } else { 0.0 }
    };
    r.text(
        "method",
        "path-traced reference (the renderer's path tracer: next-event estimation with MIS, Russian roulette)",
    );
    r.count("walks_per_pixel", u64::from(walks)).count("rays", reference.rays).count("seen_pixels", seen.len() as u64);
    r.real("white", white, None);
    r.real("mean_relative_stderr", mean_rel, None);
    r.real("noise_RMSE_a", na / 2.0, None).real("noise_RMSE_p", np / 2.0, None);
    r.real("seconds", t0.elapsed().as_secs_f64(), Some("s"));
    let (w, h) = (v.width, v.height);
    if let Some(p) = file("reference.exr") {
        exr(&mean, w, h, &p)?;
    }
    if let Some(p) = file("reference.pfm") {
        pfm(&mean, w, h, &p)?;
    }
    if let Some(p) = file("reference-even.pfm") {
        pfm(&reference.halves[0], w, h, &p)?;
    }
    if let Some(p) = file("reference-odd.pfm") {
        pfm(&reference.halves[1], w, h, &p)?;
    }
    if let Some(p) = file("reference.png") {
        let px: Vec<[u8; 3]> = reference
            .mean
            .iter()
            .map(|c| c.map_or(itgfx_backends::preview::BACKGROUND, |c| tonemap(c, white)))
            .collect();
        png(&px, w, h, &p)?;
    }
    if let Some(p) = file("reference.json") {
        crate::output::write(&p, format!("{}\n", r.to_json()).as_bytes())?;
    }
    Ok(r)
}
