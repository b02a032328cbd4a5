//! The run of `itgfx simplify`: the simplification, the errors a user
//! checks it by, the pictures.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;
use itgfx_backends::simplify::job::{Evaluation, JobError, JobOutcome, Measured, SimplifyJob, Work};
use itgfx_backends::simplify::metrics::{Render, evaluation_directions};
use itgfx_backends::simplify::{IndexedMesh, Metric, Placement, Repairs, Settings};
use itgfx_backends::tracer::Prepared;
use itgfx_backends::viewpoint::icosphere;

use crate::CliError;
use crate::export::{montage, write_png};
use crate::plot::{Axis, Style, chart};
use crate::report::Report;
use crate::scene::load_scene;
use crate::values::viewpoint_level;

use super::SimplifyOptions;

/// A target for a mesh of `n` triangles: `P%` with `0 < P < 100`, or a
/// count `1 ≤ N < n`.
///
/// # Errors
/// A one-line reason naming `flag`.
pub fn parse_target(flag: &str, s: &str, n: usize) -> Result<usize, CliError> {
    let bad = |why: String| CliError::usage(format!("{flag} {s:?}: {why}"));
    let t = s.trim();
    let count = if let Some(p) = t.strip_suffix('%') {
        let p: f64 = p.trim().parse().map_err(|_| bad("is not a percentage".into()))?;
        if !(p > 0.0 && p < 100.0) {
            return Err(bad("a percentage must be above 0 and below 100".into()));
        }
        ((n as f64 * p / 100.0).round() as usize).max(1)
    } else {
        let k: i64 = t.parse().map_err(|_| bad("is neither a percentage (10%) nor a triangle count".into()))?;
        if k <= 0 {
            return Err(bad("a triangle count must be positive".into()));
        }
        k as usize
    };
    if count >= n {
        return Err(bad(format!("{count} triangles is not fewer than the mesh's {n}")));
    }
    Ok(count)
}

/// The targets asked for, largest first, without repeats.
fn targets(o: &SimplifyOptions, n: usize) -> Result<Vec<usize>, CliError> {
    let mut t = Vec::new();
    if let Some(s) = &o.target {
        t.push(parse_target("--target", s, n)?);
    }
    if let Some(s) = &o.sweep {
        for part in s.split(',') {
            t.push(parse_target("--sweep", part, n)?);
        }
    }
    t.sort_unstable_by(|a, b| b.cmp(a));
    t.dedup();
    Ok(t)
}

/// The mesh `--evaluate` measures, in the input's frame, repaired as the
/// input is ([`IndexedMesh::repair`]); an OBJ's faces with no area (other
/// simplifiers leave some) are left out by the reader instead of refused.
/// What was dropped or repaired is said in one line on stderr.
fn load_evaluated(f: &str, centre: DVec3, scale: f64) -> Result<IndexedMesh, CliError> {
    let path = Path::new(f);
    let is_obj = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    let scene = if is_obj && path.is_file() {
        let s = itgfx_backends::obj::load_obj_dropping_degenerate(path).map_err(|e| CliError::usage(e.to_string()))?;
        for w in &s.warnings {
            eprintln!("itgfx: warning: {w}");
        }
        s
    } else {
        load_scene(f, 1)?
    };
    let mut mesh = IndexedMesh::weld_any(&scene.triangles, centre, scale)
        .map_err(|e| CliError::usage(format!("--evaluate {f}: {e}")))?;
    let repairs = mesh.repair();
    if mesh.faces.is_empty() {
        return Err(CliError::usage(format!("--evaluate {f}: no triangle with an area")));
    }
    if repairs.any() {
        eprintln!("itgfx: warning: --evaluate {f}: repaired: {repairs}");
    }
    Ok(mesh)
}

/// A grey picture of one render.
fn picture(r: &Render) -> image::RgbImage {
    image::RgbImage::from_fn(r.size, r.size, |x, y| {
        let i = (y * r.size + x) as usize;
        if r.covered[i] {
            let g = (255.0 * (0.12 + 0.88 * f64::from(r.shade[i]))).round().clamp(0.0, 255.0) as u8;
            image::Rgb([g, g, g])
        } else {
            image::Rgb(itgfx_backends::preview::BACKGROUND)
        }
    })
}

/// A progress bar on stderr counting collapses (runs past a second, when
/// stderr is a terminal or `ITGFX_PROGRESS=1`, as the other commands').
struct Collapses {
    start: Instant,
    last: f64,
    enabled: bool,
}

impl Collapses {
    fn new() -> Self {
        use std::io::IsTerminal;
        let enabled = std::io::stderr().is_terminal() || std::env::var_os("ITGFX_PROGRESS").is_some_and(|v| v == "1");
        Self { start: Instant::now(), last: 0.0, enabled }
    }

    fn update(&mut self, done: u64, total: u64) {
        let el = self.start.elapsed().as_secs_f64();
        if !self.enabled || el < 1.0 || (el - self.last < 0.2 && done < total) {
            return;
        }
        self.last = el;
        let frac = done as f64 / total.max(1) as f64;
        let fill = (frac * 30.0) as usize;
        let eta = if done > 0 { el * (total - done.min(total)) as f64 / done as f64 } else { 0.0 };
        eprint!(
            "\r[{}{}] {:5.1}%  {done}/{total} collapses  eta {eta:.0}s ",
            "#".repeat(fill),
            " ".repeat(30 - fill),
            100.0 * frac
        );
        if done >= total {
            eprintln!();
        }
    }
}

/// How many of the evaluation views go into the pictures.
const SHOWN: usize = 4;

/// Runs `itgfx simplify`: the options, the input welded, the job
/// ([`SimplifyJob`]: memory check, collapses or the mesh to evaluate,
/// measurements), the report, the outputs.
///
/// # Errors
/// Usage, mesh, backend and output errors, one line.
pub fn run(o: &SimplifyOptions) -> Result<Report, CliError> {
    let (spec, out) = required(o)?;
    // Syntax first, before any file is read; the counts once the mesh is known.
    targets(o, usize::MAX)?;
    let scene = load_scene(&spec, 1)?;
    let prepared = Prepared::new(&scene);
    let frame = (prepared.centre, prepared.scale);
    let (original, repairs) =
        IndexedMesh::weld(&scene.triangles, frame.0, frame.1).map_err(|e| CliError::usage(format!("{spec}: {e}")))?;
    if repairs.any() {
        eprintln!("itgfx: warning: {spec}: repaired: {repairs}");
    }
    let job = SimplifyJob { input: &original, work: work(o, original.triangles(), frame)?, evaluation: evaluation(o) };
    job.plan().map_err(|e| CliError::usage(format!("{spec}: {e}")))?;
    crate::output::out_files(&out, &["original.png", "compare.png"])?;
    let t0 = Instant::now();
    let mut progress = Collapses::new();
    let outcome = job.run(&mut |d, t| progress.update(d, t)).map_err(|e| match e {
        JobError::Simplify(e) => CliError::usage(format!("{spec}: {e}")),
        JobError::Render(e) => CliError::usage(e.to_string()),
    })?;
    for m in &outcome.results {
        if let Some(why) = &m.made.stalled {
            eprintln!("itgfx: warning: target {} not reached: {why}", m.made.label);
        }
    }
    let mut r = report(o, &scene.name, (&original, repairs), &outcome);
    let written = write_outputs(o, (&out, &spec, frame), &original, &outcome, &mut r)?;
    r.texts("wrote", written);
    r.real("seconds", t0.elapsed().as_secs_f64(), Some("s"));
    Ok(r)
}

/// The mesh and `--out` (required), and something to do.
fn required(o: &SimplifyOptions) -> Result<(String, PathBuf), CliError> {
    let spec = o.mesh.clone().ok_or_else(|| CliError::usage("give a mesh: an .obj file or a built-in scene name"))?;
    let out = o.out.clone().ok_or_else(|| CliError::usage("give --out DIR for the simplified meshes and pictures"))?;
    if o.target.is_none() && o.sweep.is_none() && o.evaluate.is_none() {
        return Err(CliError::usage("give --target P%|N, --sweep P%,... or --evaluate F.obj"));
    }
    if std::fs::metadata(&out).is_ok_and(|m| !m.is_dir()) {
        return Err(CliError::usage(format!("--out {out:?}: not a directory")));
    }
    Ok((spec, out))
}

/// The placement `--placement` and `--lambda` ask for.
fn placement(o: &SimplifyOptions) -> Placement {
    match o.placement.as_str() {
        "endpoint" => Placement::Endpoint,
        "best" => Placement::Best,
        "quadric" => Placement::Quadric,
        _ => Placement::Blend(o.lambda),
    }
}

/// What the job does to a mesh of `n` triangles in the frame `(centre,
/// scale)`: the targets asked for, or `--evaluate`'s mesh.
fn work(o: &SimplifyOptions, n: usize, (centre, scale): (DVec3, f64)) -> Result<Work, CliError> {
    let targets = targets(o, n)?;
    if let Some(f) = &o.evaluate {
        let mesh = load_evaluated(f, centre, scale)?;
        let label = Path::new(f).file_stem().map_or_else(|| "evaluated".into(), |s| s.to_string_lossy().into_owned());
        return Ok(Work::Evaluate { label, mesh });
    }
    let metric = match o.metric.as_str() {
        "ve" => Metric::Ve,
        "ivo" => Metric::Ivo,
        "vkl" => Metric::Vkl,
        _ => Metric::Vmi,
    };
    let settings = Settings {
        metric,
        placement: placement(o),
        directions: icosphere(viewpoint_level(o.viewpoints)),
        distance: o.distance,
        backend: o.run.tracing.backend,
        refresh: 0.5,
        tolerance: o.tolerance,
        max_subdivision: o.max_subdivision,
        background: !o.no_background,
        lazy: true,
    };
    Ok(Work::Simplify { targets, settings })
}

/// The evaluation views, render size and samples asked for.
fn evaluation(o: &SimplifyOptions) -> Evaluation {
    Evaluation {
        eyes: evaluation_directions(o.eval_views).into_iter().map(|d| d * o.distance).collect(),
        image_size: o.image_size,
        samples: o.samples,
        kept: SHOWN,
        backend: o.run.tracing.backend,
    }
}

/// The report: the input, the mode and its settings, the collapses, one
/// record per result (its file names are added by [`write_outputs`]).
fn report(o: &SimplifyOptions, name: &str, (original, repairs): (&IndexedMesh, Repairs), job: &JobOutcome) -> Report {
    let unit = Some(o.run.common.base.unit());
    // The simplifier measures in bits; reports follow --base.
    let in_base = |bits: f64| bits * std::f64::consts::LN_2 * o.run.common.base.per_nat();
    let mut r = Report::new();
    r.text("mesh", name).count("triangles", original.triangles() as u64);
    r.count("vertices", original.positions.len() as u64);
    r.count("evaluation_views", o.eval_views as u64).count("image_size", u64::from(o.image_size));
    r.count("hausdorff_samples", o.samples as u64);
    r.count("repaired_degenerate", repairs.degenerate as u64)
        .count("repaired_duplicates", repairs.duplicates as u64)
        .count("repaired_detached", repairs.detached as u64)
        .count("repaired_split_vertices", repairs.split_vertices as u64);
    r.text("distance_unit", "bounding-box half diagonal");
    if let Some(c) = &job.collapsed {
        r.text("mode", "simplify")
            .text("metric", o.metric.clone())
            .text("placement", o.placement.clone())
            .maybe_real("lambda", matches!(placement(o), Placement::Blend(_)).then_some(o.lambda), None)
            .flag("background", !o.no_background)
            .count("viewpoints", u64::from(o.viewpoints));
        r.real("I_VO", in_base(c.initial_mutual_information), unit);
        r.count("collapses", c.collapses).count("channel_traces", u64::from(c.traces));
        r.real("channel_seconds", c.trace_seconds, Some("s"));
    } else {
        r.text("mode", "evaluate");
    }
    let summary = job.results.iter().map(|m| {
        format!(
            "{} triangles: image RMSE {:.4}, silhouette RMSE {:.4}, Hausdorff {:.4}, {:.2} s",
            m.made.mesh.triangles(),
            m.error.shading,
            m.error.silhouette,
            m.distance.hausdorff,
            m.made.seconds
        )
    });
    r.texts("summary", summary.collect());
    r
}

/// One result's record, without its files.
fn result_record(o: &SimplifyOptions, m: &Measured) -> Report {
    let unit = Some(o.run.common.base.unit());
    let in_base = |bits: f64| bits * std::f64::consts::LN_2 * o.run.common.base.per_nat();
    let mut x = Report::new();
    x.text("name", m.made.label.clone()).count("triangles", m.made.mesh.triangles() as u64);
    x.real("seconds", m.made.seconds, Some("s")).maybe_real("cpu_seconds", m.made.cpu_seconds, Some("s"));
    x.real("image_rmse", m.error.shading, None).real("silhouette_rmse", m.error.silhouette, None);
    x.real("hausdorff", m.distance.hausdorff, None).real("mean_distance", m.distance.mean, None);
    x.maybe_real("I_VO", m.made.mutual_information.map(in_base), unit);
    if let Some(why) = &m.made.stalled {
        x.text("stalled", why.clone());
    }
    x
}

/// Writes `--out`'s files (the welded input and each simplified mesh when
/// simplifying, the pictures, the error plot of a sweep), adds the results
/// with their files to `r`, and returns the paths written.
fn write_outputs(
    o: &SimplifyOptions,
    (out, spec, (centre, scale)): (&Path, &str, (DVec3, f64)),
    original: &IndexedMesh,
    job: &JobOutcome,
    r: &mut Report,
) -> Result<Vec<String>, CliError> {
    let n = original.triangles();
    let simplified = job.collapsed.is_some();
    let mut written = Vec::new();
    if simplified {
        // The welded, repaired mesh the collapses started from (the input of any peer to compare with).
        let input = out.join("input.obj");
        let comment = format!("itgfx simplify: {spec} welded and repaired, {n} triangles");
        crate::output::write(&input, original.to_obj(centre, scale, &comment).as_bytes())?;
        written.push(input.display().to_string());
    }
    let mut rows = vec![job.reference.iter().map(picture).collect::<Vec<_>>()];
    write_png(&montage(&rows[0], SHOWN), &out.join("original.png"))?;
    written.push(out.join("original.png").display().to_string());
    let mut records = Vec::new();
    for m in &job.results {
        let mut x = result_record(o, m);
        let label = &m.made.label;
        let stem = if simplified { format!("simplified_{label}") } else { label.clone() };
        if simplified {
            let obj = out.join(format!("{stem}.obj"));
            let comment = format!(
                "itgfx simplify --metric {} --placement {} --viewpoints {}: {} of {n} triangles",
                o.metric,
                o.placement,
                o.viewpoints,
                m.made.mesh.triangles(),
            );
            crate::output::write(&obj, m.made.mesh.to_obj(centre, scale, &comment).as_bytes())?;
            written.push(obj.display().to_string());
            x.text("obj", obj.display().to_string());
        }
        let row: Vec<image::RgbImage> = m.renders.iter().map(picture).collect();
        let png = out.join(format!("{stem}.png"));
        write_png(&montage(&row, SHOWN), &png)?;
        written.push(png.display().to_string());
        rows.push(row);
        records.push(x);
    }
    if job.results.len() >= 2 {
        let plotted: Vec<_> =
            job.results.iter().map(|m| (m.made.mesh.triangles(), m.error.shading, m.error.silhouette)).collect();
        let plot = out.join("errors.png");
        write_png(&error_plot(&plotted, n), &plot)?;
        written.push(plot.display().to_string());
    }
    let all: Vec<image::RgbImage> = rows.concat();
    write_png(&montage(&all, SHOWN), &out.join("compare.png"))?;
    written.push(out.join("compare.png").display().to_string());
    r.records("results", records);
    Ok(written)
}

/// Error against triangles for a sweep: image RMSE (white) and silhouette
/// RMSE (orange) on a logarithmic triangle axis from the fewest triangles
/// to the input's (which has no error: both curves end at zero there).
fn error_plot(points: &[(usize, f64, f64)], input: usize) -> image::RgbImage {
    let lo = points.iter().map(|p| p.0).min().unwrap_or(1).max(1) as f64;
    let hi = (input as f64).max(lo * 1.01);
    let top = points.iter().map(|p| p.1.max(p.2)).fold(0.0, f64::max).max(1e-6) * 1.1;
    let mut all = points.to_vec();
    all.push((input, 0.0, 0.0));
    all.sort_by_key(|p| p.0);
    let curve =
        |pick: fn(&(usize, f64, f64)) -> f64, colour| (all.iter().map(|p| (p.0 as f64, pick(p))).collect(), colour);
    let curves = [curve(|p| p.1, [235, 235, 235]), curve(|p| p.2, [255, 150, 40])];
    chart(&curves, Axis::log(lo, hi), Axis::linear(0.0, top), (480, 300), &Style::DARK)
}
