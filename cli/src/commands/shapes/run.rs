//! `itgfx shapes FILE...`: descriptors, distance matrices and retrieval
//! scores (design: docs/SHAPES.md).

use std::path::{Path, PathBuf};
use std::time::Instant;

use itgfx_backends::scene::Scene;
use itgfx_backends::shapes::information::Blocks;
use itgfx_backends::shapes::retrieval::{Scores, scores};
use itgfx_backends::shapes::{Descriptor, Kind, Settings, describe, distance_matrix};
use rayon::prelude::*;

use super::args::ShapesOptions;
use crate::CliError;
use crate::plot::{Axis, Curve, Style, Titles, titled};
use crate::report::Report;
use crate::scene::load_scene;
use crate::values::viewpoint_level;

/// Most D2/A3 samples per mesh (8 bytes each while the histogram is made).
const MAX_SAMPLES: u64 = 1 << 26;

/// Colours of the precision-recall curves, in `--descriptor` order.
const COLOURS: [[u8; 3]; 3] = [[200, 40, 40], [40, 90, 200], [40, 150, 60]];

/// The descriptors `--descriptor` names, in order, without repeats.
fn kinds(list: &str) -> Result<Vec<Kind>, CliError> {
    let mut out = Vec::new();
    for w in list.split(',') {
        let k = Kind::parse(w.trim()).ok_or_else(|| {
            CliError::usage(format!("--descriptor: unknown descriptor {:?} (expected it, d2 or a3)", w.trim()))
        })?;
        if !out.contains(&k) {
            out.push(k);
        }
    }
    Ok(out)
}

/// `file,class` rows (blank lines and `#` comments skipped, an optional
/// `file,class` header), matched to the files as given or by canonical path;
/// every file needs exactly one class and every row must name a file.
fn labels(path: &Path, files: &[String]) -> Result<Vec<String>, CliError> {
    let fail = |m: String| CliError::usage(format!("--labels {path:?}: {m}"));
    let f = itgfx_backends::files::open_regular(path).map_err(|e| fail(e.to_string()))?;
    let mut text = String::new();
    std::io::Read::read_to_string(&mut std::io::Read::take(f, 64 << 20), &mut text).map_err(|e| fail(e.to_string()))?;
    let canon = |s: &str| std::fs::canonicalize(s).ok();
    let keys: Vec<Option<PathBuf>> = files.iter().map(|f| canon(f)).collect();
    let mut class: Vec<Option<String>> = vec![None; files.len()];
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || (n == 0 && line == "file,class") {
            continue;
        }
        let (file, c) = line
            .rsplit_once(',')
            .map(|(a, b)| (a.trim(), b.trim()))
            .filter(|(a, b)| !a.is_empty() && !b.is_empty())
            .ok_or_else(|| fail(format!("line {}: expected file,class", n + 1)))?;
        let key = canon(file);
        let i = files
            .iter()
            .zip(&keys)
            .position(|(f, k)| f == file || (key.is_some() && *k == key))
            .ok_or_else(|| fail(format!("line {}: {file:?} is not one of the files given", n + 1)))?;
        if class[i].replace(c.to_string()).is_some() {
            return Err(fail(format!("line {}: {file:?} is labelled twice", n + 1)));
        }
    }
    class.into_iter().zip(files).map(|(c, f)| c.ok_or_else(|| fail(format!("{f:?} has no class")))).collect()
}

/// The memory the largest mesh needs: its viewpoint channel, and the samples.
fn memory_check(scenes: &[Scene], viewpoints: usize, samples: u64, information: bool) -> Result<(), CliError> {
    let threads = rayon::current_num_threads().max(1);
    let need = samples.saturating_mul(8).saturating_mul(threads.min(scenes.len()) as u64);
    itgfx_backends::memory::check(|| format!("{samples} samples on {threads} threads"), need)
        .map_err(|e| CliError::usage(format!("{e}: fewer --samples")))?;
    if information {
        for s in scenes {
            crate::viewpoints::memory_check(s, viewpoints)?;
        }
    }
    Ok(())
}

/// Descriptor name, descriptors, distance matrix, seconds, scores.
type Outcome = (Kind, Vec<Descriptor>, Vec<f64>, f64, Option<Scores>);

/// Runs `itgfx shapes`: checks, the meshes, each descriptor of each mesh
/// and their distances, the report, the files.
///
/// # Errors
/// Usage errors (before any work), scene and backend errors.
pub fn run(o: &ShapesOptions) -> Result<Report, CliError> {
    let kinds = kinds(&o.descriptor)?;
    let blocks = Blocks::parse(&o.blocks).map_err(|e| CliError::usage(format!("--blocks: {e}")))?;
    if o.samples == 0 || o.samples > MAX_SAMPLES {
        return Err(CliError::usage(format!("--samples: must be in 1..={MAX_SAMPLES}")));
    }
    match o.files.len() {
        0 => return Err(CliError::usage("give at least two mesh files to compare")),
        1 => return Err(CliError::usage("one file only: give at least two mesh files to compare")),
        _ => {}
    }
    let labels = o.labels.as_ref().map(|p| labels(p, &o.files)).transpose()?;
    let mut names = vec!["descriptors.csv", "descriptors.json"];
    let distance_names: Vec<String> = kinds.iter().map(|k| format!("distance-{}.csv", k.name())).collect();
    names.extend(distance_names.iter().map(String::as_str));
    if labels.is_some() {
        names.push("pr.png");
    }
    let paths = o.out.as_ref().map(|d| crate::output::out_files(d, &names)).transpose()?;
    let scenes: Vec<Scene> = o.files.iter().map(|f| load_scene(f, 1)).collect::<Result<_, _>>()?;
    let settings = Settings {
        seed: o.seed,
        samples: o.samples,
        information: itgfx_backends::shapes::information::Settings {
            level: viewpoint_level(o.viewpoints),
            blocks,
            ..Default::default()
        },
    };
    memory_check(&scenes, o.viewpoints as usize, o.samples, kinds.contains(&Kind::Information))?;
    let outcomes = describe_all(o, &scenes, &kinds, &settings, labels.as_deref())?;
    let r = report(o, &kinds, labels.as_deref(), &outcomes);
    if labels.is_some() && outcomes.iter().all(|x| x.4.is_none()) {
        eprintln!("itgfx: warning: no class has two members: no retrieval scores");
    }
    if let Some(p) = paths {
        write_outputs(&p, o, &outcomes, labels.is_some())?;
    }
    Ok(r)
}

/// Each descriptor of every mesh, their distance matrix, its time and,
/// with classes, its retrieval scores.
fn describe_all(
    o: &ShapesOptions,
    scenes: &[Scene],
    kinds: &[Kind],
    settings: &Settings,
    labels: Option<&[String]>,
) -> Result<Vec<Outcome>, CliError> {
    let label_refs: Option<Vec<&str>> = labels.map(|l| l.iter().map(String::as_str).collect());
    let mut outcomes: Vec<Outcome> = Vec::new();
    for &kind in kinds {
        let t0 = Instant::now();
        let d: Vec<Descriptor> = scenes
            .par_iter()
            .zip(&o.files)
            .map(|(s, f)| {
                describe(s, kind, settings, o.tracing.backend).map_err(|e| CliError::usage(format!("{f}: {e}")))
            })
            .collect::<Result<_, _>>()?;
        let m = distance_matrix(&d).map_err(|e| crate::core_err("distance", e))?;
        let seconds = t0.elapsed().as_secs_f64();
        let sc = label_refs.as_ref().and_then(|l| scores(&m, l));
        outcomes.push((kind, d, m, seconds, sc));
    }
    Ok(outcomes)
}

/// The report: the first descriptor's distances, then each descriptor's
/// blocks, time, scores and distances.
fn report(o: &ShapesOptions, kinds: &[Kind], labels: Option<&[String]>, outcomes: &[Outcome]) -> Report {
    let n = o.files.len();
    let rows = |m: &[f64]| -> Vec<Vec<f64>> { m.chunks(n).map(<[f64]>::to_vec).collect() };
    let mut r = Report::new();
    r.texts("files", o.files.clone());
    r.text("descriptor", kinds[0].name());
    r.matrix("distance", rows(&outcomes[0].2));
    if let Some(l) = labels {
        r.texts("classes", l.to_vec());
    }
    let mut each = Vec::new();
    for (kind, d, m, seconds, sc) in outcomes {
        let mut x = Report::new();
        x.text("descriptor", kind.name());
        x.texts("blocks", d[0].blocks.iter().map(|b| b.name.to_string()).collect());
        x.count("bins", d[0].blocks.iter().map(|b| b.p.len() as u64).sum());
        x.real("seconds", *seconds, Some("s"));
        if let Some(s) = sc {
            x.real("nearest_neighbour_accuracy", s.nearest_neighbour, None)
                .real("mean_average_precision", s.mean_average_precision, None)
                .reals("precision_at_recall", s.precision_at_recall.clone())
                .count("queries", s.queries as u64);
        }
        x.matrix("distance", rows(m));
        each.push(x);
        if let Some(s) = sc {
            r.real(&format!("{}_accuracy", kind.name()), s.nearest_neighbour, None);
            r.real(&format!("{}_mAP", kind.name()), s.mean_average_precision, None);
        }
        r.real(&format!("{}_seconds", kind.name()), *seconds, Some("s"));
    }
    r.records("descriptors", each);
    r
}

/// `--out`: the descriptors (CSV: one row per file and descriptor, bins of
/// every block in order; JSON: the blocks by name), each distance matrix, and
/// the precision-recall plot.
fn write_outputs(paths: &[PathBuf], o: &ShapesOptions, outcomes: &[Outcome], plot: bool) -> Result<(), CliError> {
    let mut csv = String::from("file,descriptor,bins...\n");
    let mut json = Vec::new();
    for (kind, d, _, _, _) in outcomes {
        for (f, x) in o.files.iter().zip(d) {
            let bins: Vec<String> = x.blocks.iter().flat_map(|b| b.p.iter().map(|v| format!("{v:e}"))).collect();
            csv += &format!("{},{},{}\n", csv_field(f), kind.name(), bins.join(","));
            let blocks: serde_json::Map<String, serde_json::Value> =
                x.blocks.iter().map(|b| (b.name.to_string(), serde_json::json!(b.p))).collect();
            json.push(serde_json::json!({"file": f, "descriptor": kind.name(), "blocks": blocks}));
        }
    }
    crate::output::write(&paths[0], csv.as_bytes())?;
    crate::output::write(&paths[1], format!("{}\n", serde_json::Value::Array(json)).as_bytes())?;
    let n = o.files.len();
    for (k, (_, _, m, _, _)) in outcomes.iter().enumerate() {
        let mut t = String::from("file");
        for f in &o.files {
            t += &format!(",{}", csv_field(f));
        }
        t.push('\n');
        for (f, row) in o.files.iter().zip(m.chunks(n)) {
            let v: Vec<String> = row.iter().map(|x| format!("{x:e}")).collect();
            t += &format!("{},{}\n", csv_field(f), v.join(","));
        }
        crate::output::write(&paths[2 + k], t.as_bytes())?;
    }
    if plot {
        let mut titles = Titles { x: "recall".into(), y: "precision".into(), legend: Vec::new() };
        let curves: Vec<Curve> = outcomes
            .iter()
            .zip(COLOURS.iter().cycle())
            .filter_map(|((kind, _, _, _, s), c)| {
                let s = s.as_ref()?;
                titles.legend.push((format!("{} (map {:.3})", kind.name(), s.mean_average_precision), *c));
                let n = s.precision_at_recall.len().saturating_sub(1).max(1) as f64;
                Some((s.precision_at_recall.iter().enumerate().map(|(i, &p)| (i as f64 / n, p)).collect(), *c))
            })
            .collect();
        let unit = Axis::linear(0.0, 1.0);
        let img = titled(&curves, unit, unit, (480, 360), &Style::LIGHT, &titles);
        crate::export::write_png(&img, &paths[paths.len() - 1])?;
    }
    Ok(())
}

/// A CSV field, quoted when it holds a comma or a quote.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}
