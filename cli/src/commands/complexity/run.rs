//! `itgfx complexity SCENE`: the scene visibility channel of Part III.

use std::time::Instant;

use itgfx_backends::open;
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::Prepared;
use itgfx_backends::visibility::merge::{join_ranges, merge_memory};
use itgfx_backends::visibility::{LineOptions, VisibilityCounts, count_visibility};

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

/// With `--merge` and `--lines N`: the merged shards must cover exactly
/// lines `0..N` (a missing shard leaves a gap, a shard of a larger run
/// passes `N`).
fn check_coverage(ranges: &[(u64, u64)], lines: u64) -> Result<(), CliError> {
    if ranges == [(0, lines)] {
        return Ok(());
    }
    let covered = ranges.iter().map(|r| format!("{}..{}", r.0, r.1)).collect::<Vec<_>>().join(", ");
    let mut at = 0;
    for r in ranges {
        if r.0 > at && at < lines {
            let to = r.0.min(lines);
            return Err(CliError::usage(format!(
                "--merge: lines {at}..{to} of --lines {lines} are missing (a shard is missing?); the files cover {covered}"
            )));
        }
        at = at.max(r.1);
    }
    if at < lines {
        return Err(CliError::usage(format!(
            "--merge: lines {at}..{lines} of --lines {lines} are missing (a shard is missing?); the files cover {covered}"
        )));
    }
    Err(CliError::usage(format!("--merge: the files cover {covered}, past --lines {lines} (a shard of another run?)")))
}

/// Before a `--merge` reads any counts: the headers of its files (binary
/// counts files; a JSON file is checked as it is read, and gives no
/// estimate), checked to be of one run, their line ranges joined (a line
/// counted twice is refused; with `--lines N` missing lines are named),
/// and the bytes the merge may hold at its peak estimated
/// ([`merge_memory`]): refused if past the memory budget
/// (`itgfx_backends::memory`).
///
/// # Errors
/// One-line usage errors naming the file.
fn plan_merge(o: &ComplexityOptions) -> Result<Option<u64>, CliError> {
    let mut heads: Vec<itgfx_backends::visibility::counts_binary::CountsHeader> =
        Vec::with_capacity(o.shards.merge.len());
    for f in &o.shards.merge {
        let fail = |e: itgfx_backends::visibility::CountsError| CliError::usage(format!("{f:?}: {e}"));
        let Some(h) = VisibilityCounts::peek(f).map_err(fail)? else { return Ok(None) };
        if let Some(first) = heads.first() {
            first.same_run(&h).map_err(fail)?;
        }
        heads.push(h);
    }
    let mut ranges = Vec::new();
    for (f, h) in o.shards.merge.iter().zip(&heads) {
        ranges = join_ranges(&ranges, &h.ranges).map_err(|e| CliError::usage(format!("{f:?}: {e}")))?;
    }
    if let Some(n) = o.lines {
        check_coverage(&ranges, n)?;
    }
    let need = merge_memory(&heads, o.shards.save_shard.is_some(), !o.counts_only);
    itgfx_backends::memory::check(
        || format!("--merge of these {} files (estimated from their headers)", o.shards.merge.len()),
        need,
    )
    .map_err(|e| {
        CliError::usage(format!(
            "{e}: merge fewer at a time (a merge tree: merge groups with --save-counts --counts-only, then the results)"
        ))
    })?;
    Ok(Some(need))
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

/// Runs `itgfx complexity`.
///
/// # Errors
/// Usage, scene and backend errors.
pub fn run(o: &ComplexityOptions) -> Result<(Report, VisibilityCounts, Scene), CliError> {
    let spec = check(o)?;
    let base = o.common.base;
    let unit = Some(base.unit());
    let (seed, local) = (o.seed, o.local);
    let (offset, lines) = if o.shards.merge.is_empty() { line_range(o)? } else { (0, 0) };
    let scene = load_scene(&spec, o.subdivide)?;
    let t0 = Instant::now();
    let prepared = Prepared::new(&scene);
    let tracer = open(o.tracing.backend, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let opts = LineOptions { lines, seed, local, blocks: o.blocks, offset };
    let mut estimate = None;
    let counts = if o.shards.merge.is_empty() {
        let mut progress = Progress::new();
        count_visibility(&scene, &prepared, tracer.as_ref(), &opts, &mut |d, t| progress.update(d, t))
            .map_err(|e| CliError::usage(e.to_string()))?
    } else {
        // Evaluate saved shards instead of tracing.
        estimate = plan_merge(o)?;
        let mut merged: Option<VisibilityCounts> = None;
        for f in &o.shards.merge {
            let (_, c) = VisibilityCounts::read(f).map_err(|e| CliError::usage(format!("{f:?}: {e}")))?;
            c.check_scene(&scene).map_err(|e| CliError::usage(format!("{f:?}: {e}")))?;
            match &mut merged {
                None => merged = Some(c),
                Some(m) => m.merge(c).map_err(|e| CliError::usage(format!("{f:?}: {e}")))?,
            }
        }
        let merged = merged.ok_or_else(|| CliError::usage("--merge: no files"))?;
        if let Some(n) = o.lines {
            check_coverage(&merged.ranges, n)?;
        }
        merged
    };
    if let Some(p) = &o.shards.save_shard {
        // Binary (version 3) unless the name ends in .json (version 2).
        let bytes = if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
            let mut bytes = Vec::new();
            counts.save(&scene.name, &mut bytes).map_err(|e| CliError::usage(format!("{p:?}: {e}")))?;
            bytes
        } else {
            counts.to_binary(&scene.name)
        };
        crate::output::write(p, &bytes)?;
    }
    if o.counts_only {
        return Ok((counts_report(o, &scene, tracer.name(), &counts, estimate, t0), counts, scene));
    }
    let c = counts.complexity(base);
    if c.segments == 0 && c.lines > 0 {
        // Kept, not refused: the measures of an empty channel are what the
        // scene gives; but a closed mesh wound outwards is the usual cause.
        eprintln!(
            "itgfx: warning: {}: none of {} lines joined two patches facing each other, so every measure is that of an empty channel: complexity looks at a scene from inside (faces wound inwards); an object wound outwards is seen from outside only",
            scene.name, c.lines
        );
    }
    let seconds = t0.elapsed().as_secs_f64();
    let m = &c.measures;
    let mut r = Report::new();
    r.text("scene", scene.name.clone())
        .text("backend", tracer.name())
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
    // Pictures: information (or discretisation error) per unit area.
    let by = o.color_by.as_str();
    let (ply, png) = (o.export_ply.as_deref(), o.image.as_deref());
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
            crate::export::write_ply(&scene, &values, p)?;
            r.text("ply", p.display().to_string());
        }
        if let Some(p) = png {
            crate::export::render_png(tracer.as_ref(), &values, p, (640, 480))?;
            r.text("image", p.display().to_string());
        }
    }
    Ok((r, counts, scene))
}
