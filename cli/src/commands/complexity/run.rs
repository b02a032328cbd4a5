//! `itgfx complexity SCENE`: the scene visibility channel of Part III.

use std::path::Path;
use std::time::Instant;

use itgfx_backends::memory::OutOfMemory;
use itgfx_backends::open;
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::{Prepared, Tracer};
use itgfx_backends::visibility::merge_job::{CountsMerge, Coverage, MergeError};
use itgfx_backends::visibility::{Complexity, LineOptions, VisibilityCounts, count_visibility};

use super::ComplexityOptions;
use crate::CliError;
use crate::progress::Progress;
use crate::report::Report;
use crate::scene::load_scene;

/// Checks everything `complexity` can check before loading or tracing: the
/// scene argument, the line range, every output path.
///
/// # Errors
/// One-line usage errors.
pub fn check(o: &ComplexityOptions) -> Result<String, CliError> {
    let spec = o
        .scene
        .clone()
        .ok_or_else(|| CliError::usage("give a scene: a built-in name (e.g. cube-enclosure:10) or an .obj file"))?;
    if o.shards.merge.is_empty() {
        line_range(o)?;
    }
    for (flag, p) in [("--export-ply", &o.export_ply), ("--image", &o.image), ("--save-counts", &o.shards.save_shard)] {
        if let Some(p) = p {
            crate::output::check(flag, p)?;
        }
    }
    Ok(spec)
}

/// Lines traced when none are given.
pub const DEFAULT_LINES: u64 = 1_000_000;

/// The first line index and the number of lines this run traces: `--offset`
/// and `--lines`, or the `--shard i/n` part of the `--lines` run.
///
/// # Errors
/// A range past the last 64-bit line index, or more shards than lines.
pub fn line_range(o: &ComplexityOptions) -> Result<(u64, u64), CliError> {
    let lines = o.lines.unwrap_or(DEFAULT_LINES);
    if let Some(s) = o.shards.shard {
        if s.count > lines {
            return Err(CliError::usage(format!(
                "--shard {s}: {} shards of {lines} lines leave some shards empty (give at most {lines} shards)",
                s.count
            )));
        }
        let r = s.range(lines);
        return Ok((r.start, r.end - r.start));
    }
    o.offset.checked_add(lines).ok_or_else(|| {
        CliError::usage(format!(
            "--offset {} + --lines {lines} passes the last line index 2^64-1 (line indices are 64-bit)",
            o.offset
        ))
    })?;
    Ok((o.offset, lines))
}

/// A refused merge in the CLI's words: the options named (`--merge`,
/// `--lines`), and the way out of a merge too large for memory.
fn merge_error(e: MergeError) -> CliError {
    let line = match e {
        MergeError::NoFiles => "--merge: no files".to_string(),
        MergeError::File { file, error } => format!("{file}: {error}"),
        MergeError::Coverage(Coverage::Missing { from, to, lines, covered }) => format!(
            "--merge: lines {from}..{to} of --lines {lines} are missing (a shard is missing?); the files cover {covered}"
        ),
        MergeError::Coverage(Coverage::Past { lines, covered }) => {
            format!("--merge: the files cover {covered}, past --lines {lines} (a shard of another run?)")
        }
        MergeError::Memory(e) => {
            let files = e.what.trim_start_matches("a merge of ");
            let e = OutOfMemory { what: format!("--merge of {files}"), ..e };
            format!(
                "{e}: merge fewer at a time (a merge tree: merge groups with --save-counts --counts-only, then the results)"
            )
        }
    };
    CliError::usage(line)
}

/// The report of a `--counts-only` run: what the saved counts cover, no
/// measures.
fn counts_report(
    o: &ComplexityOptions,
    scene: &Scene,
    backend: &str,
    counts: &VisibilityCounts,
    estimate: Option<u64>,
    t0: Instant,
) -> Report {
    let sum = |f: fn(&itgfx_backends::visibility::BlockCounts) -> u64| counts.blocks.iter().map(f).sum::<u64>();
    let mut r = Report::new();
    r.text("scene", scene.name.clone())
        .text("backend", backend)
        .text("lines_kind", if counts.local { "local" } else { "global" });
    r.count("patches", scene.patches.len() as u64)
        .count("lines", counts.lines())
        .count("segments", sum(|b| b.segments))
        .count("seed", counts.seed);
    let ranges: Vec<String> = counts.ranges.iter().map(|r| format!("{}..{}", r.0, r.1)).collect();
    r.text("ranges", ranges.join(", ")).count("pairs", sum(|b| b.pairs.len() as u64));
    if let Some(s) = o.shards.shard {
        r.text("shard", s.to_string());
    }
    if let Some(b) = estimate {
        r.real("merge_memory_estimate_MiB", b as f64 / f64::from(1u32 << 20), None);
    }
    if let Some(p) = &o.shards.save_shard {
        r.text("saved", p.display().to_string());
    }
    r.real("seconds", t0.elapsed().as_secs_f64(), Some("s"));
    r
}

/// The counts of this run: traced (lines `offset..offset + lines`), or
/// merged from `--merge`'s files (the job of
/// `itgfx_backends::visibility::merge_job`), with the merge's memory estimate.
fn counts_of(
    o: &ComplexityOptions,
    scene: &Scene,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    (offset, lines): (u64, u64),
) -> Result<(VisibilityCounts, Option<u64>), CliError> {
    if o.shards.merge.is_empty() {
        let opts = LineOptions { lines, seed: o.seed, local: o.local, blocks: o.blocks, offset };
        let mut progress = Progress::new();
        let counts = count_visibility(scene, prepared, tracer, &opts, &mut |d, t| progress.update(d, t))
            .map_err(|e| CliError::usage(e.to_string()))?;
        return Ok((counts, None));
    }
    let job = CountsMerge {
        files: &o.shards.merge,
        lines: o.lines,
        save: o.shards.save_shard.is_some(),
        measures: !o.counts_only,
    };
    job.run(scene).map_err(merge_error)
}

/// Writes `--save-counts`: binary unless the name ends in `.json` (JSON;
/// both format 4, under the one shard header).
fn save_counts(p: &Path, name: &str, counts: &VisibilityCounts) -> Result<(), CliError> {
    let bytes = if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
        let mut bytes = Vec::new();
        counts.save(name, &mut bytes).map_err(|e| CliError::usage(format!("{p:?}: {e}")))?;
        bytes
    } else {
        counts.to_binary(name)
    };
    crate::output::write(p, &bytes)
}

/// The measures' report (Part III: `H_P`, `H_S`, `H_J`, `I_S`, `I_S^c` and
/// their standard errors).
fn measures_report(
    o: &ComplexityOptions,
    scene: &Scene,
    backend: &str,
    (counts, c): (&VisibilityCounts, &Complexity),
    offset: u64,
    estimate: Option<u64>,
    seconds: f64,
) -> Report {
    let unit = Some(o.run.common.base.unit());
    let m = &c.measures;
    let mut r = Report::new();
    r.text("scene", scene.name.clone())
        .text("backend", backend)
        .text("lines_kind", if counts.local { "local" } else { "global" });
    r.count("patches", scene.patches.len() as u64)
        .count("lines", c.lines)
        .count("segments", c.segments)
        .count("seed", counts.seed);
    if let Some(s) = o.shards.shard {
        r.text("shard", s.to_string()).count("first_line", offset);
    }
    if let Some(b) = estimate {
        r.real("merge_memory_estimate_MiB", b as f64 / f64::from(1u32 << 20), None);
    }
    r.count("escaped", c.escaped).count("unsampled_patches", m.unsampled_patches as u64);
    r.real("H_P", m.positional_entropy, unit).real("H_S", m.scene_entropy, unit).real("H_J", m.joint_entropy, unit);
    r.real("I_S", m.mutual_information, unit);
    r.maybe_real("I_S_stderr", c.mutual_information_stderr, unit);
    r.maybe_real("I_S_corrected", c.mutual_information_corrected, unit);
    r.maybe_real("I_S_cont", c.continuous, unit);
    r.maybe_real("I_S_cont_stderr", c.continuous_stderr, unit);
    r.maybe_real("discretisation_accuracy", c.discretisation_accuracy, None);
    r.real("H_S_normalized", m.normalized_entropy, None).real("I_S_normalized", m.normalized_mutual_information, None);
    r.real("seconds", seconds, Some("s"));
    r
}

/// `--export-ply` and `--image`: information (or, by `--color-by delta`,
/// discretisation error) per unit area.
fn pictures(
    o: &ComplexityOptions,
    scene: &Scene,
    tracer: &dyn Tracer,
    c: &Complexity,
    r: &mut Report,
) -> Result<(), CliError> {
    let (ply, png) = (o.export_ply.as_deref(), o.image.as_deref());
    if ply.is_none() && png.is_none() {
        return Ok(());
    }
    let total = scene.total_area();
    let values: Vec<f64> = match o.color_by.as_str() {
        "information" => c.patch_information.iter().zip(&scene.patches).map(|(v, p)| v / (p.area / total)).collect(),
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
        crate::export::write_ply(scene, &values, p)?;
        r.text("ply", p.display().to_string());
    }
    if let Some(p) = png {
        crate::export::render_png(tracer, &values, p, (640, 480))?;
        r.text("image", p.display().to_string());
    }
    Ok(())
}

/// Runs `itgfx complexity`.
///
/// # Errors
/// Usage, scene and backend errors.
pub fn run(o: &ComplexityOptions) -> Result<(Report, VisibilityCounts, Scene), CliError> {
    let spec = check(o)?;
    let range = if o.shards.merge.is_empty() { line_range(o)? } else { (0, 0) };
    let scene = load_scene(&spec, o.subdivide)?;
    let t0 = Instant::now();
    let prepared = Prepared::new(&scene);
    let tracer = open(o.run.tracing.backend, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let (counts, estimate) = counts_of(o, &scene, &prepared, tracer.as_ref(), range)?;
    if let Some(p) = &o.shards.save_shard {
        save_counts(p, &scene.name, &counts)?;
    }
    if o.counts_only {
        return Ok((counts_report(o, &scene, tracer.name(), &counts, estimate, t0), counts, scene));
    }
    let c = counts.complexity(o.run.common.base);
    if c.segments == 0 && c.lines > 0 {
        // Kept, not refused: the measures of an empty channel are what the
        // scene gives; but a closed mesh wound outwards is the usual cause.
        eprintln!(
            "itgfx: warning: {}: none of {} lines joined two patches facing each other, so every measure is that of an empty channel: complexity looks at a scene from inside (faces wound inwards); an object wound outwards is seen from outside only",
            scene.name, c.lines
        );
    }
    let seconds = t0.elapsed().as_secs_f64();
    let mut r = measures_report(o, &scene, tracer.name(), (&counts, &c), range.0, estimate, seconds);
    pictures(o, &scene, tracer.as_ref(), &c, &mut r)?;
    Ok((r, counts, scene))
}
