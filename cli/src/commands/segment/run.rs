//! `itgfx segment IMAGE`: split-and-merge by the information channel
//! between regions and intensities.

use std::time::Instant;

use itgfx_backends::imaging::segment::SegmentOptions as Engine;
use itgfx_backends::imaging::{Gray, Segmentation, segment};

use super::SegmentOptions;
use crate::CliError;
use crate::imaging::pictures::{label_image, plot, read_gray, write_gray, write_rgb};
use crate::report::Report;

const FILES: [&str; 4] = ["labels.png", "means.png", "curve.png", "result.json"];

/// Segments, writes the pictures and `result.json`, returns the report.
///
/// # Errors
/// Bad input and output errors, one line.
pub fn run_segment(o: &SegmentOptions) -> Result<Report, CliError> {
    let img = read_gray(&o.image)?;
    let (lo, hi) = img.range();
    if lo >= hi {
        return Err(CliError::usage(format!("{:?}: the image is constant (H(X) = 0): nothing to segment", o.image)));
    }
    let paths = crate::output::out_files(&o.out, &FILES)?;
    let engine = Engine {
        bins: o.bins,
        max_leaves: o.max_leaves as usize,
        split_ratio: o.split_ratio,
        regions: o.regions.map(|k| k as usize),
        ratio: o.ratio,
    };
    let t0 = Instant::now();
    let mut next = 1;
    let s = segment(&img, &engine, |d, n| {
        if d == n {
            crate::imaging::say(&format!(
                "segment: {n} leaves; merging by the information bottleneck (cost ~ leaves^3)"
            ));
        } else if d >= next {
            crate::imaging::say(&format!("segment: splitting, {d}/{n} leaves"));
            next = d * 2;
        }
    })
    .map_err(|e| CliError::usage(format!("{:?}: {e}", o.image)))?;
    let seconds = t0.elapsed().as_secs_f64();
    write_pictures(&s, (img.width, img.height), &paths)?;
    // The engine measures in bits; `--base` converts every entropy.
    let base = o.common.base;
    let k = std::f64::consts::LN_2 * base.per_nat();
    let unit = Some(base.unit());
    let mut rep = Report::new();
    rep.text("unit", base.unit())
        .real("H_X", s.h_x * k, unit)
        .count("bins", o.bins as u64)
        .count("leaves", s.leaves.len() as u64)
        .real("I_split", *s.split_curve.last().unwrap_or(&0.0) * k, unit)
        .count("regions", s.regions as u64)
        .real("I_regions", s.information * k, unit)
        .real("fraction_of_H", s.information / s.h_x, None)
        .reals("split_curve", s.split_curve.iter().map(|v| v * k).collect())
        .reals("merge_curve", s.merge_curve.iter().map(|v| v * k).collect())
        .reals("region_means", s.means.clone())
        .real("seconds", seconds, Some("s"));
    rep.write_result(&paths)
}

/// The labels, the region means and the curve of `I(R;X)` against the
/// number of regions.
fn write_pictures(s: &Segmentation, (w, h): (usize, usize), paths: &[std::path::PathBuf]) -> Result<(), CliError> {
    write_rgb(&label_image(&s.labels, w, h), &paths[0])?;
    let means = Gray { width: w, height: h, data: s.labels.iter().map(|&l| s.means[l] as f32).collect() };
    write_gray(&means, &paths[1])?;
    // I(R;X) against the number of regions: split (blue) rising, merge (orange) read from 1 cluster
    // up, H(X) (grey) above, the kept count (green).
    let split: Vec<(f64, f64)> = s.split_curve.iter().enumerate().map(|(i, v)| ((i + 1) as f64, *v)).collect();
    let merge: Vec<(f64, f64)> = s.merge_curve.iter().enumerate().map(|(i, v)| ((i + 1) as f64, *v)).collect();
    let hx = [(1.0, s.h_x), (s.leaves.len() as f64, s.h_x)].to_vec();
    let chosen = [(s.regions as f64, 0.0), (s.regions as f64, s.information)].to_vec();
    let xmax = s.leaves.len().max(2) as f64;
    write_rgb(
        &plot(
            &[(hx, [160, 160, 160]), (chosen, [40, 160, 40]), (split, [40, 90, 200]), (merge, [230, 120, 20])],
            (1.0, xmax),
            (0.0, 1.05 * s.h_x),
            (360, 240),
        ),
        &paths[2],
    )
}
