//! `itgfx volume --time SERIES`: a time-varying volume (Part VI §2.2 after
//! [BS05] and [JS06]). Every frame gets the channel `V → Z` of a single
//! volume (the same ray caster, measures and core functions), with the
//! scalar normalised by the series' common range; then
//! * the best static view for the whole span: the least VMI averaged over
//!   the frames (VMI, Part V eq. (7), as [VFSG06] use it; lower is better),
//!   and, beside it, the largest noteworthiness VE averaged over the frames
//!   ([BS05]'s measure, higher is better);
//! * the dynamic view path ([JS06]): one viewpoint per frame, the least
//!   total VMI with the camera turning at most `--max-turn` between two
//!   frames (exact dynamic programming, `volume::paths::dynamic_path`).

use std::path::Path;
use std::time::Instant;

use glam::DVec3;
use itgfx_backends::backend::open_volume;
use itgfx_backends::viewpoint::{ViewpointWeights, icosphere};
use itgfx_backends::volume::paths::{dynamic_path, static_view, turn};
use itgfx_backends::volume::raycast::Caster;
use itgfx_backends::volume::series::{check_frames, common_range, is_series_built_in, series_built_in};
use itgfx_backends::volume::shard_job::{HELD_BYTES_PER_VOXEL, PROCESS_BYTES, cast_memory};
use itgfx_backends::volume::{TransferFunction, Volume, VolumeChannelOptions, volume_channel, volume_measures};

use super::VolumeOptions;
use super::pictures::view;
use crate::export::{montage, write_png};
use crate::progress::Progress;
use crate::report::Report;
use crate::values::viewpoint_level;
use crate::{CliError, core_err};

/// The files under `--out` for a series, the report last.
pub(super) const SERIES_FILES: [&str; 4] = ["path.png", "static.png", "frames-best.png", "series.json"];

/// The frames of `spec`: the built-in series, a glob (`*`, `?` in the
/// file name; matches sorted by name) or a comma-separated list of volumes.
fn frames(o: &VolumeOptions, spec: &str) -> Result<Vec<Volume>, CliError> {
    let usage = |e: itgfx_backends::volume::VolumeError| CliError::usage(format!("--time: {e}"));
    let frames = if is_series_built_in(spec) && !Path::new(spec).exists() {
        if o.dims.is_some() || o.value_type.is_some() || o.spacing.is_some() {
            return Err(CliError::usage("--dims, --type and --spacing are for raw files, not built-in volumes"));
        }
        let budget = itgfx_backends::memory::budget().map_or(u64::MAX, |b| b.bytes);
        series_built_in(spec, budget).map_err(usage)?
    } else {
        let items = if spec.contains(['*', '?']) { glob(spec)? } else { split(spec) };
        if items.len() > itgfx_backends::volume::series::MAX_FRAMES {
            return Err(CliError::usage(format!(
                "--time: {} frames; at most {}",
                items.len(),
                itgfx_backends::volume::series::MAX_FRAMES
            )));
        }
        let budget = itgfx_backends::memory::budget();
        let mut frames: Vec<Volume> = Vec::with_capacity(items.len());
        for (k, s) in items.iter().enumerate() {
            if s.trim().is_empty() {
                return Err(CliError::usage(format!("--time: frame {k} is empty")));
            }
            // Every frame has frame 0's grid (checked below): refuse before loading more than fits.
            if let Some(first) = frames.first() {
                let bytes = items.len() as u64 * first.voxels() as u64 * HELD_BYTES_PER_VOXEL;
                let what = || format!("--time: {} frames of {} voxels", items.len(), first.voxels());
                itgfx_backends::memory::check_within(budget, what, bytes)
                    .map_err(|e| CliError::usage(format!("{e}: fewer frames or voxels")))?;
            }
            frames
                .push(super::input::load(o, s.trim()).map_err(|e| CliError::usage(format!("--time frame {k}: {e}")))?);
        }
        frames
    };
    check_frames(&frames).map_err(usage)?;
    Ok(frames)
}

/// A comma-separated list of volumes; a piece that is only a number
/// continues the previous one, so built-ins with arguments fit
/// (`hydrogen:2,1,1,16,sphere:16` is two frames).
fn split(spec: &str) -> Vec<String> {
    let mut items: Vec<String> = Vec::new();
    for piece in spec.split(',') {
        let numeric =
            !piece.trim().is_empty() && piece.trim().chars().all(|c| c.is_ascii_digit() || c == '-' || c == '+');
        match items.last_mut() {
            Some(last) if numeric => {
                last.push(',');
                last.push_str(piece);
            }
            _ => items.push(piece.to_string()),
        }
    }
    items
}

/// The files matching a pattern with `*` and `?` in its last component, by name.
fn glob(spec: &str) -> Result<Vec<String>, CliError> {
    let path = Path::new(spec);
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let pattern = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    if dir.to_string_lossy().contains(['*', '?']) {
        return Err(CliError::usage(format!("--time {spec:?}: wildcards only in the file name")));
    }
    let entries = std::fs::read_dir(dir).map_err(|e| CliError::usage(format!("--time {spec:?}: {dir:?}: {e}")))?;
    let mut names: Vec<String> = entries
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| matches(pattern.as_bytes(), n.as_bytes()))
        .collect();
    names.sort();
    if names.is_empty() {
        return Err(CliError::usage(format!("--time {spec:?}: no file matches")));
    }
    Ok(names.into_iter().map(|n| dir.join(n).to_string_lossy().into_owned()).collect())
}

/// Whether `name` matches `pattern` (`*` any run, `?` one byte).
fn matches(pattern: &[u8], name: &[u8]) -> bool {
    match (pattern.first(), name.first()) {
        (None, None) => true,
        (Some(b'*'), _) => matches(&pattern[1..], name) || (!name.is_empty() && matches(pattern, &name[1..])),
        (Some(b'?'), Some(_)) => matches(&pattern[1..], &name[1..]),
        (Some(p), Some(c)) if p == c => matches(&pattern[1..], &name[1..]),
        _ => false,
    }
}

/// The default turn limit: one step to the farthest nearest neighbour on
/// the viewpoint sphere (so the camera can reach a neighbour every frame).
fn neighbour_step(dirs: &[DVec3]) -> f64 {
    dirs.iter()
        .enumerate()
        .map(|(i, &a)| {
            dirs.iter().enumerate().filter(|&(j, _)| j != i).map(|(_, &b)| turn(a, b)).fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
        * 1.001
}

/// Per frame: what the series' measures need.
struct Frame {
    vmi: Vec<f64>,
    ve: Vec<f64>,
    noteworthiness: Vec<f64>,
    i_vz: f64,
    h_z: f64,
    h_z_given_v: f64,
    best: usize,
    worst: usize,
}

/// Runs `itgfx volume --time SERIES`: the frames, the memory they need,
/// each frame's channel and measures, the static view and the dynamic path,
/// the report and the montages.
pub(super) fn run(
    o: &VolumeOptions,
    spec: &str,
    tf: &TransferFunction,
    base: itgfx_core::Base,
    unit: Option<&'static str>,
) -> Result<Report, CliError> {
    let outputs = super::out_paths(o, &SERIES_FILES)?;
    let frames = frames(o, spec)?;
    let range = common_range(&frames);
    if range.0 >= range.1 {
        return Err(CliError::usage(format!("--time: every voxel of every frame is {}: nothing to see", range.0)));
    }
    let dirs = icosphere(viewpoint_level(o.viewpoints));
    let max_turn = o.max_turn.map_or_else(|| neighbour_step(&dirs), f64::to_radians);
    let largest = frames[0].dims.iter().copied().max().unwrap_or(1) as u32;
    let rays = o.size.unwrap_or((2 * largest).clamp(32, 512));
    let (need, radius) = memory_need(o, &frames, (tf, range), dirs.len(), rays)?;
    let t0 = Instant::now();
    let per_frame = measure_frames(o, &frames, (tf, range), &dirs, rays, base)?;
    let vmi: Vec<Vec<f64>> = per_frame.iter().map(|f| f.vmi.clone()).collect();
    let stat =
        static_view(&vmi).ok_or_else(|| CliError::usage("--time: no viewpoint sees the volume in every frame"))?;
    let path = dynamic_path(&vmi, &dirs, max_turn).ok_or_else(|| {
        CliError::usage(format!(
            "--time: no view path within --max-turn {:.1} degrees sees the volume in every frame",
            max_turn.to_degrees()
        ))
    })?;
    let seconds = t0.elapsed().as_secs_f64();
    let mut r = Report::new();
    r.text("series", spec).count("frames", frames.len() as u64).text("backend", o.backend.name());
    r.counts("dims", frames[0].dims.iter().map(|&d| d as u64).collect());
    r.count("viewpoints", dirs.len() as u64).count("rays_per_viewpoint", u64::from(rays) * u64::from(rays));
    r.reals("range", vec![range.0, range.1]).real("max_turn_deg", max_turn.to_degrees(), None);
    series_report(&mut r, (&frames, &per_frame, &vmi), &dirs, (stat, &path), unit);
    r.real("seconds", seconds, Some("s")).real("memory_estimate_MiB", need as f64 / f64::from(1u32 << 20), None);
    if o.out.is_some() {
        let half = (o.image / 2).max(16);
        let per_row = frames.len().min(8);
        let shots = |pick: &dyn Fn(usize) -> usize| -> Vec<image::RgbImage> {
            frames
                .iter()
                .enumerate()
                .map(|(k, f)| view(&Caster::with_range(f, tf, o.step, range), dirs[pick(k)], o.distance, radius, half))
                .collect()
        };
        write_png(&montage(&shots(&|k| path.0[k]), per_row), &outputs[0])?;
        write_png(&montage(&shots(&|_| stat.0), per_row), &outputs[1])?;
        write_png(&montage(&shots(&|k| per_frame[k].best), per_row), &outputs[2])?;
        r.texts("wrote", outputs.iter().map(|p| p.display().to_string()).collect());
        crate::output::write(&outputs[3], r.to_json().to_string().as_bytes())?;
    }
    Ok(r)
}

/// The memory the series needs (the process, every frame's values held,
/// one frame's channel at a time), refused above what the process may use; with the largest content radius of the frames.
/// Refuses a frame the transfer function makes transparent.
fn memory_need(
    o: &VolumeOptions,
    frames: &[Volume],
    (tf, range): (&TransferFunction, (f64, f64)),
    views: usize,
    rays: u32,
) -> Result<(u64, f64), CliError> {
    let held: u64 = PROCESS_BYTES + frames.iter().map(|f| f.voxels() as u64 * HELD_BYTES_PER_VOXEL).sum::<u64>();
    let mut need = held;
    let mut radius: f64 = 0.0;
    for (k, f) in frames.iter().enumerate() {
        let caster = Caster::with_range(f, tf, o.step, range);
        if caster.voxel_opacity.iter().all(|&a| a <= 0.0) {
            return Err(CliError::usage(format!(
                "--time frame {k} ({}): the transfer function makes every voxel transparent",
                f.name
            )));
        }
        radius = radius.max(caster.content_radius());
        let one = cast_memory(&caster, o.backend, views, u64::from(rays) * u64::from(rays));
        need = need.max(held + one);
    }
    itgfx_backends::memory::check(|| "--time: the series".into(), need)
        .map_err(|e| CliError::usage(format!("{e}: fewer --viewpoints, frames or voxels")))?;
    Ok((need, radius))
}

/// Each frame's channel (cast, one at a time) and the measures kept of it.
fn measure_frames(
    o: &VolumeOptions,
    frames: &[Volume],
    (tf, range): (&TransferFunction, (f64, f64)),
    dirs: &[DVec3],
    rays: u32,
    base: itgfx_core::Base,
) -> Result<Vec<Frame>, CliError> {
    let weights = if o.uniform_input { ViewpointWeights::Uniform } else { ViewpointWeights::ProjectedArea };
    let (nf, nv) = (frames.len() as u64, dirs.len() as u64);
    let mut progress = Progress::new();
    let mut per_frame = Vec::with_capacity(frames.len());
    for (k, f) in frames.iter().enumerate() {
        let caster = Caster::with_range(f, tf, o.step, range);
        let backend = open_volume(o.backend, &caster).map_err(|e| CliError::usage(e.to_string()))?;
        let copts = VolumeChannelOptions { directions: dirs.to_vec(), distance: o.distance, size: rays };
        let kk = k as u64;
        let ch = volume_channel(&*backend, &copts, &mut |d, _| progress.update(kk * nv + d, nf * nv))
            .map_err(|e| CliError::usage(e.to_string()))?;
        if ch.is_blind() {
            return Err(CliError::usage(format!("--time frame {k} ({}): no viewpoint sees any voxel", f.name)));
        }
        let m = volume_measures(ch, dirs, &caster.voxel_opacity, None, weights, base)
            .map_err(|e| core_err(&format!("frame {k}"), e))?;
        per_frame.push(Frame {
            vmi: m.views.mutual_information.clone(),
            ve: m.views.entropy.clone(),
            noteworthiness: m.noteworthiness_entropy.clone(),
            i_vz: m.views.total_mutual_information,
            h_z: m.views.object_entropy,
            h_z_given_v: m.views.conditional_entropy,
            best: m.views.best,
            worst: m.views.worst,
        });
    }
    Ok(per_frame)
}

/// The series' report: one record per frame, the static view (least mean
/// VMI, and the most noteworthy), the dynamic path, one record per viewpoint.
fn series_report(
    r: &mut Report,
    (frames, per_frame, vmi): (&[Volume], &[Frame], &[Vec<f64>]),
    dirs: &[DVec3],
    ((stat, stat_mean), (path, path_mean)): ((usize, f64), &(Vec<usize>, f64)),
    unit: Option<&'static str>,
) {
    let nf = frames.len() as f64;
    let dir = |v: usize| dirs[v].to_array().to_vec();
    let recs = per_frame
        .iter()
        .zip(frames)
        .enumerate()
        .map(|(k, (f, v))| {
            let mut x = Report::new();
            x.count("frame", k as u64).text("volume", v.name.clone());
            x.real("I_VZ", f.i_vz, unit).real("H_Z", f.h_z, unit).real("H_Z_given_V", f.h_z_given_v, unit);
            x.count("best_view", f.best as u64).reals("best_direction", dir(f.best));
            x.real("best_VMI", f.vmi[f.best], unit);
            x.count("worst_view", f.worst as u64).real("static_view_VMI", f.vmi[stat], unit);
            x
        })
        .collect();
    r.records("frame_measures", recs);
    r.text("static_criterion", "least VMI averaged over the frames");
    r.count("static_view", stat as u64).reals("static_direction", dir(stat)).real("static_mean_VMI", stat_mean, unit);
    // Noteworthiness VE is best at its maximum: its negative is the cost.
    let neg_nw: Vec<Vec<f64>> = per_frame
        .iter()
        .map(|f| f.noteworthiness.iter().map(|&x| if x > 0.0 { -x } else { f64::INFINITY }).collect())
        .collect();
    if let Some((v, m)) = static_view(&neg_nw) {
        r.count("static_noteworthiness_view", v as u64).reals("static_noteworthiness_direction", dir(v));
        r.real("static_noteworthiness_mean_VE", -m, unit);
    }
    r.text("path_criterion", "least total VMI, camera turn per frame at most max_turn_deg (exact dynamic programming)");
    let steps = path
        .iter()
        .enumerate()
        .map(|(k, &v)| {
            let mut x = Report::new();
            x.count("frame", k as u64).count("view", v as u64).reals("direction", dir(v));
            x.real("VMI", per_frame[k].vmi[v], unit).real("VE", per_frame[k].ve[v], unit);
            x.real("turn_deg", if k == 0 { 0.0 } else { turn(dirs[path[k - 1]], dirs[v]).to_degrees() }, None);
            x
        })
        .collect();
    r.records("path", steps);
    let lower = per_frame.iter().map(|f| f.vmi[f.best]).sum::<f64>() / nf;
    r.real("path_mean_VMI", *path_mean, unit).real("per_frame_best_mean_VMI", lower, unit);
    let views = (0..dirs.len())
        .map(|v| {
            let mut x = Report::new();
            x.reals("direction", dir(v));
            let mean = vmi.iter().map(|f| f[v]).sum::<f64>() / nf;
            x.maybe_real("mean_VMI", Some(mean).filter(|x| x.is_finite()), unit);
            x.reals("VMI", vmi.iter().map(|f| if f[v].is_finite() { f[v] } else { f64::NAN }).collect());
            x
        })
        .collect();
    r.records("views", views);
}

#[cfg(test)]
mod tests {
    use super::{matches, split};

    #[test]
    fn wildcards() {
        assert!(matches(b"f*.nrrd", b"f01.nrrd"));
        assert!(matches(b"f??.nrrd", b"f01.nrrd"));
        assert!(!matches(b"f?.nrrd", b"f01.nrrd"));
        assert!(matches(b"*", b""));
        assert!(!matches(b"f*.raw", b"f01.nrrd"));
        assert_eq!(split("hydrogen:2,1,-1,16,sphere:16,a.nrrd"), ["hydrogen:2,1,-1,16", "sphere:16", "a.nrrd"]);
        assert_eq!(split("a.nrrd,,b.nrrd"), ["a.nrrd", "", "b.nrrd"]);
    }
}
