//! `itgfx register FIXED MOVING`: rigid registration by mutual information.

use std::path::{Path, PathBuf};
use std::time::Instant;

use itgfx_backends::imaging::register::{joint_histogram, resample};
use itgfx_backends::imaging::{
    Gray, HistogramKind, Level, Metric, RegisterOptions as Engine, Registration, Rigid2, register,
};
use itgfx_core::JointEntropies;

use super::RegisterOptions;
use crate::CliError;
use crate::imaging::pictures::{checkerboard, histogram_image, overlay, plot, read_gray, write_gray, write_rgb};
use crate::report::Report;

/// The `--levels` pyramid, coarse to fine.
#[derive(Clone, Debug, PartialEq)]
pub struct Levels(pub Vec<Level>);

/// Parses `--levels`: `shrink:sigma` pairs, comma-separated (shrink
/// 1..=64, sigma in `[0, 64]` full-resolution pixels), 1 to 8 levels.
///
/// # Errors
/// A reason.
pub fn levels(s: &str) -> Result<Levels, String> {
    let mut out = Vec::new();
    for part in s.split(',') {
        let (a, b) = part.split_once(':').ok_or(format!("{part:?} is not shrink:sigma"))?;
        let shrink: usize = a.trim().parse().map_err(|_| format!("shrink {a:?} is not a whole number"))?;
        let sigma: f64 =
            b.trim().parse().ok().filter(|x: &f64| x.is_finite()).ok_or(format!("sigma {b:?} is not a number"))?;
        if !(1..=64).contains(&shrink) {
            return Err(format!("shrink {shrink} must be in 1..=64"));
        }
        if !(0.0..=64.0).contains(&sigma) {
            return Err(format!("sigma {:?} must be in [0, 64]", b.trim()));
        }
        out.push(Level { shrink, sigma });
    }
    if out.is_empty() || out.len() > 8 {
        return Err("give 1 to 8 levels".into());
    }
    Ok(Levels(out))
}

/// `--levels`, or without it the default pyramid: shrink 4, 2, 1 with σ 2,
/// 1, 1 for images and 2, 1, 0.5 for volumes (on 10 phantom volume pairs
/// outside the benchmark's, σ 0.5 at the last level took the median
/// rotation error from 0.52° to 0.38° at the same cost: docs/IMAGING.md).
#[must_use]
pub fn pyramid(o: &RegisterOptions, volume: bool) -> Vec<Level> {
    let last = if volume { 0.5 } else { 1.0 };
    o.levels.as_ref().map_or_else(
        || vec![Level { shrink: 4, sigma: 2.0 }, Level { shrink: 2, sigma: 1.0 }, Level { shrink: 1, sigma: last }],
        |l| l.0.clone(),
    )
}

/// What a registration input holds, from its first bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A PNG image (2D).
    Png,
    /// An NRRD volume (3D).
    Nrrd,
}

/// Reads the signature of `path`.
///
/// # Errors
/// One line naming the file: missing, unreadable, neither PNG nor NRRD.
pub fn sniff(path: &Path) -> Result<Kind, CliError> {
    let fail = |e: &dyn std::fmt::Display| CliError::usage(format!("{path:?}: {e}"));
    if path.is_dir() {
        return Err(fail(&"is a directory, not a PNG image or NRRD volume"));
    }
    let mut head = [0u8; 8];
    let mut file = itgfx_backends::files::open_regular(path).map_err(|e| fail(&e))?;
    let n = std::io::Read::read(&mut file, &mut head).map_err(|e| fail(&e))?;
    match &head[..n] {
        b"\x89PNG\r\n\x1a\n" => Ok(Kind::Png),
        h if h.starts_with(b"NRRD000") => Ok(Kind::Nrrd),
        _ => Err(fail(&"not a PNG image nor an NRRD volume (no PNG or NRRD signature)")),
    }
}

/// `--histogram` and `--metric`.
#[must_use]
/// Without `--metric`, images take MI and volumes (`volume`) NMI: on the 3D
/// phantom MI's overlap bias (a rotation that moves background corners out
/// of the moving volume raises MI) fails 12 pairs of 20 where NMI fails none
/// (docs/IMAGING.md, "Measured: itgfx against SimpleITK in 3D").
pub fn choices(o: &RegisterOptions, volume: bool) -> (HistogramKind, Metric) {
    let kind = match o.histogram.as_str() {
        "binned" => HistogramKind::Binned,
        "pv" => HistogramKind::PartialVolume,
        _ => HistogramKind::Parzen,
    };
    let metric = match o.metric.as_deref().unwrap_or(if volume { "nmi" } else { "mi" }) {
        "nmi" => Metric::Nmi,
        "ecc" => Metric::Ecc,
        "mi-over-joint" => Metric::MiOverJoint,
        _ => Metric::Mi,
    };
    (kind, metric)
}

/// The metric after every Powell iteration, levels one after another, one
/// colour each (values differ between levels: smoothing and shrinking
/// change the histogram).
#[must_use]
pub fn trace_picture(traces: &[&[f64]]) -> image::RgbImage {
    let colours = [[200, 40, 40], [40, 90, 200], [40, 160, 40], [230, 120, 20]];
    let (mut curves, mut at) = (Vec::new(), 0usize);
    for (k, l) in traces.iter().enumerate() {
        let pts: Vec<(f64, f64)> = l.iter().enumerate().map(|(i, v)| ((at + i) as f64, *v)).collect();
        at += l.len();
        curves.push((pts, colours[k % colours.len()]));
    }
    let all = traces.iter().flat_map(|l| l.iter().copied());
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    plot(&curves, (0.0, (at.max(2) - 1) as f64), (lo, hi), (320, 200))
}

/// The joint histogram's measures at the answer (converted from bits to
/// `--base`), the MI at the start, and what was maximised.
pub fn measures(
    rep: &mut Report,
    o: &RegisterOptions,
    metric: Metric,
    e: &JointEntropies,
    initial: Option<&JointEntropies>,
) {
    let base = o.common.base;
    let k = std::f64::consts::LN_2 * base.per_nat();
    let unit = Some(base.unit());
    rep.text("metric", metric.name())
        .text("histogram", o.histogram.as_str())
        .count("bins", o.bins as u64)
        .text("unit", base.unit())
        .real("metric_value", in_base(metric, metric.value(e), k), None)
        .real("MI", e.mutual_information * k, unit)
        .real("NMI", e.studholme_nmi(), None)
        .real("ECC", e.entropy_correlation(), None)
        .real("MI_over_joint", e.mi_over_joint(), None)
        .real("H_fixed", e.h_x * k, unit)
        .real("H_moving", e.h_y * k, unit)
        .real("H_joint", e.h_xy * k, unit)
        .maybe_real("MI_initial", initial.map(|e| e.mutual_information * k), unit);
}

/// A metric value in bits converted by `k` when it is MI (the normalised
/// metrics have no unit).
#[must_use]
pub fn in_base(metric: Metric, v: f64, k: f64) -> f64 {
    if metric == Metric::Mi { v * k } else { v }
}

/// One level of `result.json`: its pyramid step, size, Powell's iterations
/// and evaluations, the parameters it ended at and the metric after each
/// iteration (in `--base` for MI, `k` converting from bits).
#[must_use]
pub fn level_report(
    level: Level,
    size: &[usize],
    counts: (usize, usize),
    params: &[f64],
    trace: &[f64],
    metric: Metric,
    k: f64,
) -> Report {
    let mut x = Report::new();
    x.count("shrink", level.shrink as u64)
        .real("sigma", level.sigma, None)
        .counts("size", size.iter().map(|&n| n as u64).collect())
        .count("iterations", counts.0 as u64)
        .count("evaluations", counts.1 as u64)
        .reals("transform", params.to_vec())
        .reals("trace", trace.iter().map(|v| in_base(metric, *v, k)).collect());
    x
}

/// `--initial` of an image: `DEG,X,Y`.
///
/// # Errors
/// One line.
fn start(o: &RegisterOptions) -> Result<Rigid2, CliError> {
    match o.initial.as_ref().map(|n| n.0.as_slice()) {
        None => Ok(Rigid2::default()),
        Some(&[a, x, y]) if a.abs() <= 180.0 => Ok(Rigid2 { angle_deg: a, tx: x, ty: y }),
        Some(&[_, _, _]) => Err(CliError::usage("--initial: the angle must be in [-180, 180]")),
        Some(_) => Err(CliError::usage("--initial: an image takes DEG,X,Y (three numbers)")),
    }
}

/// Reads `transform.json` (`angle_deg`, `tx`, `ty`).
///
/// # Errors
/// One line naming the file.
pub fn read_truth(path: &Path) -> Result<Rigid2, CliError> {
    let fail = |e: &dyn std::fmt::Display| CliError::usage(format!("--truth {path:?}: {e}"));
    let text = itgfx_backends::files::read_regular_to_string(path).map_err(|e| fail(&e))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| fail(&e))?;
    let get = |k: &str| v.get(k).and_then(serde_json::Value::as_f64).filter(|x| x.is_finite());
    match (get("angle_deg"), get("tx"), get("ty")) {
        (Some(a), Some(x), Some(y)) => Ok(Rigid2 { angle_deg: a, tx: x, ty: y }),
        _ => Err(fail(&"needs finite numbers angle_deg, tx and ty")),
    }
}

const FILES: [&str; 7] =
    ["registered.png", "checkerboard.png", "overlay.png", "joint.png", "joint-initial.png", "trace.png", "result.json"];

/// Registers, writes the pictures and `result.json`, returns the report.
///
/// # Errors
/// Bad inputs and output errors, one line.
pub fn run_register(o: &RegisterOptions) -> Result<Report, CliError> {
    if volumes(o)? {
        return super::run3::run_register3(o);
    }
    let levels = pyramid(o, false);
    let initial = start(o)?;
    let (fixed, moving) = read_pair(o)?;
    let truth = o.truth.as_deref().map(read_truth).transpose()?;
    let (kind, metric) = choices(o, false);
    let engine = Engine {
        bins: o.bins,
        kind,
        metric,
        levels,
        initial,
        max_iterations: o.max_iterations as usize,
        ..Engine::default()
    };
    // Everything readable and valid: now the output directory.
    let paths = crate::output::out_files(&o.out, &FILES)?;
    let t0 = Instant::now();
    let r = register(&fixed, &moving, &engine, |k, n| {
        let l = engine.levels[k];
        crate::imaging::say(&format!("register: level {}/{n} (shrink {}, sigma {})", k + 1, l.shrink, l.sigma));
    })
    .map_err(|e| CliError::usage(e.to_string()))?;
    let seconds = t0.elapsed().as_secs_f64();
    let t = r.transform;
    write_pictures((&fixed, &moving), &engine, &r, &paths)?;
    // The engine measures in bits; `--base` converts every entropy.
    let k = std::f64::consts::LN_2 * o.common.base.per_nat();
    let mut rep = Report::new();
    rep.real("angle_deg", t.angle_deg, Some("deg")).real("tx", t.tx, Some("px")).real("ty", t.ty, Some("px"));
    let levels = r.levels.iter().map(|l| {
        let size = [l.size.0, l.size.1];
        level_report(l.level, &size, (l.iterations, l.evaluations), &l.transform.params(), &l.trace, metric, k)
    });
    let counts = r.levels.iter().map(|l| (l.iterations, l.evaluations));
    let outcome = Outcome { entropies: &r.entropies, initial: r.initial_entropies.as_ref(), overlap: r.overlap };
    outcome.report(&mut rep, o, metric, (counts, levels.collect()), (None, seconds));
    if let Some(truth) = truth {
        let rot = (t.angle_deg - truth.angle_deg).abs();
        let trans = (t.tx - truth.tx).hypot(t.ty - truth.ty);
        rep.real("rotation_error_deg", rot, Some("deg"))
            .real("translation_error_px", trans, Some("px"))
            .real("corner_error_px", t.corner_distance(&truth, fixed.width, fixed.height), Some("px"))
            .flag("success", rot < 0.5 && trans < 0.5);
    }
    rep.write_result(&paths)
}

/// Whether FIXED and MOVING are volumes (NRRD) rather than images (PNG);
/// refuses one of each.
fn volumes(o: &RegisterOptions) -> Result<bool, CliError> {
    match (sniff(&o.fixed)?, sniff(&o.moving)?) {
        (Kind::Png, Kind::Png) => Ok(false),
        (Kind::Nrrd, Kind::Nrrd) => Ok(true),
        (a, _) => {
            let name = |k| if k == Kind::Png { "a 2D PNG image" } else { "a 3D NRRD volume" };
            Err(CliError::usage(format!(
                "{:?} is {} but {:?} is {}: register needs two images or two volumes",
                o.fixed,
                name(a),
                o.moving,
                name(if a == Kind::Png { Kind::Nrrd } else { Kind::Png })
            )))
        }
    }
}

/// FIXED and MOVING, read and checked: the same size, at least 4 x 4,
/// neither constant.
fn read_pair(o: &RegisterOptions) -> Result<(Gray, Gray), CliError> {
    let fixed = read_gray(&o.fixed)?;
    let moving = read_gray(&o.moving)?;
    if (fixed.width, fixed.height) != (moving.width, moving.height) {
        return Err(CliError::usage(format!(
            "the fixed image is {} x {} but the moving image is {} x {}: register needs the same size",
            fixed.width, fixed.height, moving.width, moving.height
        )));
    }
    if fixed.width < 4 || fixed.height < 4 {
        return Err(CliError::usage(format!(
            "{:?}: {} x {} pixels: register needs at least 4 x 4",
            o.fixed, fixed.width, fixed.height
        )));
    }
    for (img, path) in [(&fixed, &o.fixed), (&moving, &o.moving)] {
        let (lo, hi) = img.range();
        if lo >= hi {
            return Err(CliError::usage(format!("{path:?}: the image is constant: nothing to register")));
        }
    }
    Ok((fixed, moving))
}

/// The registered image, the checkerboard and overlay against the fixed
/// one, the joint histograms after and before, and the metric's trace.
fn write_pictures(
    (fixed, moving): (&Gray, &Gray),
    engine: &Engine,
    r: &Registration,
    paths: &[PathBuf],
) -> Result<(), CliError> {
    let t = r.transform;
    let registered = resample(moving, &t, 0.0);
    write_gray(&registered, &paths[0])?;
    let tile = (fixed.width.max(fixed.height) / 8).max(2);
    write_rgb(&checkerboard(fixed, &registered, tile), &paths[1])?;
    write_rgb(&overlay(fixed, &registered), &paths[2])?;
    let hist = joint_histogram(fixed, moving, &t, engine.bins, engine.kind);
    let scale = (256 / engine.bins as u32).max(1);
    write_rgb(&histogram_image(&hist.counts, engine.bins, scale), &paths[3])?;
    let before = joint_histogram(fixed, moving, &engine.initial, engine.bins, engine.kind);
    write_rgb(&histogram_image(&before.counts, engine.bins, scale), &paths[4])?;
    let traces: Vec<&[f64]> = r.levels.iter().map(|l| l.trace.as_slice()).collect();
    write_rgb(&trace_picture(&traces), &paths[5])
}

/// What a registration of images or of volumes ends with: the metric's
/// entropies at the result and at the start, and the overlap.
pub struct Outcome<'a> {
    /// The entropies at the final transform.
    pub entropies: &'a JointEntropies,
    /// The entropies at the initial transform.
    pub initial: Option<&'a JointEntropies>,
    /// The overlap of the two at the final transform.
    pub overlap: f64,
}

impl Outcome<'_> {
    /// The report's fields the two registrations share: the measures, the
    /// overlap, the iterations and evaluations summed over the `levels`'
    /// `counts`, the time (and its estimate), one record per level.
    pub fn report(
        &self,
        rep: &mut Report,
        o: &RegisterOptions,
        metric: Metric,
        (counts, levels): (impl Iterator<Item = (usize, usize)>, Vec<Report>),
        (estimate, seconds): (Option<f64>, f64),
    ) {
        measures(rep, o, metric, self.entropies, self.initial);
        let (iterations, evaluations) = counts.fold((0, 0), |(i, e), (a, b)| (i + a as u64, e + b as u64));
        rep.real("overlap", self.overlap, None).count("iterations", iterations).count("evaluations", evaluations);
        if let Some(s) = estimate {
            rep.real("estimated_seconds", s, Some("s"));
        }
        rep.real("seconds", seconds, Some("s"));
        rep.records("levels", levels);
    }
}
