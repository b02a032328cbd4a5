//! `itgfx render SCENE ... --shard i/n --save-shard F` and
//! `itgfx render --merge F1,F2,... --out DIR`: a job array's tasks each
//! render a range of pixel rows and save them; the merge concatenates the
//! rows into the single run's frame (bit for bit, every sampler) and writes
//! its images. See `backends/src/render/shard_file.rs` for why rows.

use std::path::{Path, PathBuf};

use std::time::Instant;

use itgfx_backends::render::Frame;
use itgfx_backends::render::shard_file::{RenderShard, merge};

use super::RenderOptions;
use super::run::{frame_stats, image_files, out_dir, read_reference, write_frame};
use crate::CliError;
use crate::report::Report;
use crate::shard::MAX_SHARD_BYTES;

/// `--shard`'s help.
pub const SHARD_HELP: &str =
    "Shard i of n (0-based): render pixel rows [i*H/n, (i+1)*H/n) only and save them (--save-shard)";
/// `--merge`'s help.
pub const MERGE_HELP: &str = "Write the images of the saved shards F1,F2,... (all n of one run) to --out instead of \
                              rendering; no SCENE or sampler options (the shards carry them)";
/// What `--merge` takes from the shards, so refuses.
pub const MERGE_CONFLICTS: [&str; 17] = [
    "shard",
    "scene",
    "sampler",
    "spp",
    "size",
    "seed",
    "camera",
    "threshold",
    "tutorial_form",
    "delta",
    "binary_contrast",
    "node_samples",
    "maps",
    "max_spp",
    "export_scene",
    "backend",
    "save_shard",
];

/// Checks the shard options before any work.
///
/// # Errors
/// One-line usage errors.
pub fn check(o: &RenderOptions) -> Result<(), CliError> {
    if let Some(s) = o.shards.shard {
        if s.count > u64::from(o.size.1) {
            return Err(CliError::usage(format!(
                "--shard {s}: more shards than the {} rows of the image (give at most {})",
                o.size.1, o.size.1
            )));
        }
        if o.out.is_some() || o.reference.is_some() || o.maps || o.export_scene {
            return Err(CliError::usage(
                "--shard saves pixel rows only: give --out, --reference, --maps, --export-scene to the --merge run (maps: a single run)",
            ));
        }
    }
    if let Some(p) = &o.shards.save_shard {
        crate::output::check("--save-shard", p)?;
    }
    Ok(())
}

/// Saves a shard's file ([`RenderShard`], made by the render job) to
/// `--save-shard`, and reports it.
///
/// # Errors
/// Output errors.
pub fn save(path: &Path, shard: &RenderShard, r: &mut Report) -> Result<(), CliError> {
    let text = shard.to_json().map_err(|e| CliError::runtime(format!("--save-shard: {e}")))?;
    crate::output::write(path, text.as_bytes())?;
    r.text("shard", format!("{}/{}", shard.header.shard, shard.header.shards));
    r.count("first_row", u64::from(shard.first_row)).count("end_row", u64::from(shard.end_row));
    r.text("saved", path.display().to_string()).count("bytes", text.len() as u64);
    Ok(())
}

/// Reads and merges `--merge`'s shards: the run's settings (from the first
/// shard) and the whole frame.
///
/// # Errors
/// Unreadable, foreign, duplicate or missing shards: one line.
pub fn merged(files: &[PathBuf]) -> Result<(RenderShard, Frame, f64), CliError> {
    let t0 = Instant::now();
    let fail = |e| CliError::usage(crate::shard::describe(&e));
    let named = itgfx_backends::shards::read_files(files, MAX_SHARD_BYTES).map_err(fail)?;
    let (first, frame) = merge(named).map_err(fail)?;
    Ok((first, frame, t0.elapsed().as_secs_f64()))
}

/// Runs `itgfx render --merge F1,F2,... --out DIR`: the images of the
/// merged shards, and the report a single run gives (but the tuning pilot).
///
/// # Errors
/// Shard errors, output errors, one line each.
pub fn run_merge(o: &RenderOptions) -> Result<Report, CliError> {
    if let Some(r) = &o.reference {
        crate::input::regular("--reference", r)?;
    }
    let (dir, made) = out_dir(o)?;
    let result = merge_into(o, &dir);
    if result.is_err() && made {
        let _ = std::fs::remove_dir(&dir);
    }
    result
}

fn merge_into(o: &RenderOptions, dir: &Path) -> Result<Report, CliError> {
    for f in image_files(dir) {
        crate::output::check("--out", &f)?;
    }
    let (first, frame, seconds) = merged(&o.shards.merge)?;
    let (h, st) = (&first.header, &first.header.settings);
    let reference = read_reference(o, (st.width, st.height))?;
    let (image, wrote) = write_frame(&frame, o.exposure, dir)?;
    let mut r = Report::new();
    r.text("scene", h.scene.name.clone()).text("backend", st.backend.clone()).text("sampler", st.sampler.clone());
    r.count("width", u64::from(st.width)).count("height", u64::from(st.height)).count("seed", st.seed);
    r.count("shards", h.shards).maybe_real("threshold", first.threshold_used, None);
    r.count("spp_requested", u64::from(st.spp));
    frame_stats(&mut r, &frame, Some(&image), reference.as_ref(), o.exposure)?;
    r.real("seconds", seconds, Some("s"));
    r.texts("wrote", wrote.iter().map(|p| p.display().to_string()).collect());
    Ok(r)
}
