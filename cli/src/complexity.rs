//! `itgfx complexity SCENE`: the scene visibility channel of Part III.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::time::Instant;

use itgfx_backends::obj::load_obj;
use itgfx_backends::scene::{Scene, built_in};
use itgfx_backends::tracer::Prepared;
use itgfx_backends::visibility::{LineOptions, VisibilityCounts, count_visibility};
use itgfx_backends::{BackendChoice, open};

use crate::CliError;
use crate::args::Args;
use crate::report::Report;

/// Loads a scene spec: an existing `.obj` path or a built-in name, then
/// `--subdivide K`.
///
/// # Errors
/// Scene errors, one line.
pub fn load_scene(spec: &str, subdivide: u32) -> Result<Scene, CliError> {
    let scene = if Path::new(spec).is_file() || spec.ends_with(".obj") {
        load_obj(Path::new(spec)).map_err(|e| CliError::usage(e.to_string()))?
    } else {
        built_in(spec).map_err(|e| CliError::usage(e.to_string()))?
    };
    let scene = scene.subdivided(subdivide).map_err(|e| CliError::usage(e.to_string()))?;
    for w in &scene.warnings {
        eprintln!("itgfx: warning: {w}");
    }
    scene.validate().map_err(|e| CliError::usage(e.to_string()))?;
    Ok(scene)
}

/// A progress bar on stderr for runs longer than a second, when stderr is a terminal
/// or `ITGFX_PROGRESS=1`.
pub struct Progress {
    start: Instant,
    last: f64,
    enabled: bool,
}

impl Progress {
    /// A new progress reporter.
    #[must_use]
    pub fn new() -> Self {
        let enabled = std::io::stderr().is_terminal() || std::env::var_os("ITGFX_PROGRESS").is_some_and(|v| v == "1");
        Self { start: Instant::now(), last: 0.0, enabled }
    }

    /// Reports `done` of `total` lines.
    pub fn update(&mut self, done: u64, total: u64) {
        let el = self.start.elapsed().as_secs_f64();
        if !self.enabled || el < 1.0 || (el - self.last < 0.2 && done < total) {
            return;
        }
        self.last = el;
        let frac = done as f64 / total.max(1) as f64;
        let width = 30;
        let fill = (frac * width as f64) as usize;
        let rate = done as f64 / el / 1e6;
        let eta = if done > 0 { el * (total - done) as f64 / done as f64 } else { 0.0 };
        let mut e = std::io::stderr().lock();
        let _ = write!(
            e,
            "\r[{}{}] {:5.1}%  {:.2} Mlines/s  eta {:.0}s ",
            "#".repeat(fill),
            " ".repeat(width - fill),
            frac * 100.0,
            rate,
            eta
        );
        if done >= total {
            let _ = writeln!(e);
        }
    }
}

impl Default for Progress {
    fn default() -> Self {
        Self::new()
    }
}

/// Runs `itgfx complexity`.
///
/// # Errors
/// Usage, scene and backend errors.
pub fn run(args: &Args) -> Result<(Report, VisibilityCounts, Scene), CliError> {
    let spec =
        args.single_positional("scene", "give a scene: a built-in name (e.g. cube-enclosure:10) or an .obj file")?;
    let base = args.base()?;
    let unit = Some(base.unit());
    let lines = args.integer("lines")?.unwrap_or(1_000_000);
    if lines == 0 {
        return Err(CliError::usage("--lines must be positive"));
    }
    let seed = args.integer("seed")?.unwrap_or(1);
    let blocks = args.integer("blocks")?.unwrap_or(8);
    if !(1..=1024).contains(&blocks) {
        return Err(CliError::usage("--blocks must be in 1..=1024"));
    }
    let subdivide = args.integer("subdivide")?.unwrap_or(1);
    if !(1..=1024).contains(&subdivide) {
        return Err(CliError::usage("--subdivide must be in 1..=1024"));
    }
    let choice =
        args.value("backend").unwrap_or("cpu").parse::<BackendChoice>().map_err(|e| CliError::usage(e.to_string()))?;
    let local = args.flag("local");
    let scene = load_scene(&spec, subdivide as u32)?;
    let t0 = Instant::now();
    let prepared = Prepared::new(&scene);
    let tracer = open(choice, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let offset = args.integer("offset")?.unwrap_or(0);
    let opts = LineOptions { lines, seed, local, blocks: blocks as u32, offset };
    let counts = if let Some(list) = args.value("merge") {
        // Evaluate saved shards instead of tracing.
        let mut merged: Option<VisibilityCounts> = None;
        for f in list.split(',') {
            let text = std::fs::read_to_string(f).map_err(|e| CliError::usage(format!("{f}: {e}")))?;
            let (_, c) = VisibilityCounts::load(&text).map_err(|e| CliError::usage(format!("{f}: {e}")))?;
            match &mut merged {
                None => merged = Some(c),
                Some(m) => m.merge(c).map_err(|e| CliError::usage(format!("{f}: {e}")))?,
            }
        }
        merged.ok_or_else(|| CliError::usage("--merge: no files"))?
    } else {
        let mut progress = Progress::new();
        count_visibility(&scene, &prepared, tracer.as_ref(), &opts, &mut |d, t| progress.update(d, t))
            .map_err(|e| CliError::usage(e.to_string()))?
    };
    if counts.areas.len() != scene.patches.len() {
        return Err(CliError::usage(format!(
            "--merge: the counts have {} patches, the scene {}",
            counts.areas.len(),
            scene.patches.len()
        )));
    }
    if let Some(p) = args.value("save-counts") {
        let mut bytes = Vec::new();
        counts.save(&scene.name, &mut bytes).map_err(|e| CliError::usage(format!("{p}: {e}")))?;
        crate::export::atomic_write(Path::new(p), &bytes)?;
    }
    let c = counts.complexity(base);
    let seconds = t0.elapsed().as_secs_f64();
    let m = &c.measures;
    let mut r = Report::new();
    r.text("scene", scene.name.clone())
        .text("backend", tracer.name())
        .text("lines_kind", if local { "local" } else { "global" });
    r.count("patches", scene.patches.len() as u64)
        .count("lines", c.lines)
        .count("segments", c.segments)
        .count("seed", seed);
    r.count("escaped", c.escaped).count("unsampled_patches", m.unsampled_patches as u64);
    r.real("H_P", m.positional_entropy, unit).real("H_S", m.scene_entropy, unit).real("H_J", m.joint_entropy, unit);
    r.real("I_S", m.mutual_information, unit);
    r.maybe_real("I_S_stderr", c.mutual_information_stderr, unit);
    r.maybe_real("I_S_corrected", c.mutual_information_corrected, unit);
    r.maybe_real("I_S_cont", c.continuous, unit);
    r.maybe_real("I_S_cont_stderr", c.continuous_stderr, unit);
    r.maybe_real(
        "discretisation_accuracy",
        c.continuous.filter(|&ic| ic > 0.0).map(|ic| m.mutual_information / ic),
        None,
    );
    r.real("H_S_normalized", m.normalized_entropy, None).real("I_S_normalized", m.normalized_mutual_information, None);
    r.real("seconds", seconds, Some("s"));
    // Pictures: information (or discretisation error) per unit area.
    let by = args.value("color-by").unwrap_or("information");
    let ply = args.value("export-ply");
    let png = args.value("image");
    if ply.is_some() || png.is_some() {
        let total = scene.total_area();
        let values: Vec<f64> = match by {
            "information" => {
                c.patch_information.iter().zip(&scene.patches).map(|(v, p)| v / (p.area / total)).collect()
            }
            "delta" => c
                .patch_continuous
                .iter()
                .zip(&c.patch_information)
                .zip(&scene.patches)
                .map(|((ic, i), p)| (ic - i) / (p.area / total))
                .collect(),
            other => return Err(CliError::usage(format!("--color-by: expected information or delta, got {other:?}"))),
        };
        if let Some(p) = ply {
            crate::export::write_ply(&scene, &values, Path::new(p))?;
            r.text("ply", p);
        }
        if let Some(p) = png {
            crate::export::render_png(tracer.as_ref(), &values, Path::new(p), (640, 480))?;
            r.text("image", p);
        }
    }
    Ok((r, counts, scene))
}
