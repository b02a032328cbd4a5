//! The pixel quality and contrast maps of Part IV §3–§4 (Figs. 1–6), from
//! the 8-spp oracle pass: PNG pictures and EXR values; beside them Simmons'
//! priorities `p_c`, `p_d`, `p_v` (§2 eqs. (2)–(4)) of the same samples.
//!
//! As in the tutorial, each picture's scale is the values' mean `± k σ`
//! (`k = 2`; outliers go to the ends), intersected with `[0, 1]`; the
//! unbounded `C_log^g` (eq. (22)) is scaled by the mean `± k σ` of its finite
//! values, and its infinite pixels (a ray that met nothing beside one that
//! met a surface) are drawn at the top. Colour
//! quality and the contrasts use a thermal scale (blue lowest, red highest);
//! geometry quality a grey scale (dark lowest), as Fig. 1.c. `p_c` and
//! `p_v` weigh contrasts by mean radiance, so they are not bounded by 1:
//! their scale is the mean `± k σ` cut at 0 only.

use std::path::{Path, PathBuf};

use itgfx_backends::render::{ContrastMap, PriorityMap};

use super::images::{Radiance, write_exr};
use crate::CliError;
use crate::export::write_png;

/// Width of the picture scale in standard deviations either side of the mean.
const K_SIGMA: f64 = 2.0;

/// The files [`write_maps`] writes into `dir`.
#[must_use]
pub fn files(dir: &Path) -> Vec<PathBuf> {
    [
        "quality.png",
        "geometry-quality.png",
        "contrast.png",
        "colour-contrast.png",
        "binary-contrast.png",
        "geometry-contrast.png",
        "geometry-binary-contrast.png",
        "geometry-log-contrast.png",
        "quality.exr",
        "contrast.exr",
        "geometry-contrast.exr",
        "priority-colour.png",
        "depth-difference.png",
        "priority-value.png",
        "priority.exr",
    ]
    .iter()
    .map(|f| dir.join(f))
    .collect()
}

/// Thermal colour scale at `x ∈ [0, 1]`: blue, cyan, green, yellow, red.
#[must_use]
pub fn thermal(x: f64) -> [u8; 3] {
    const C: [[f64; 3]; 5] =
        [[0.0, 0.0, 255.0], [0.0, 255.0, 255.0], [0.0, 255.0, 0.0], [255.0, 255.0, 0.0], [255.0, 0.0, 0.0]];
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 } * 4.0;
    let i = (x.floor() as usize).min(3);
    let f = x - i as f64;
    std::array::from_fn(|k| (C[i][k] * (1.0 - f) + C[i + 1][k] * f).round() as u8)
}

/// The scale `[mean − kσ, mean + kσ] ∩ [0, 1]` of `values` (never empty).
#[must_use]
pub fn scale(values: &[f64]) -> (f64, f64) {
    scale_within(values, 1.0)
}

/// The scale `[mean − kσ, mean + kσ] ∩ [0, top]` of the finite `values`
/// (never empty: `[0, top]` for a flat map, `[0, 1]` if `top` is infinite).
fn scale_within(values: &[f64], top: f64) -> (f64, f64) {
    let finite = || values.iter().copied().filter(|v| v.is_finite());
    let n = finite().count().max(1) as f64;
    let m = finite().sum::<f64>() / n;
    let sd = (finite().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt();
    let (lo, hi) = ((m - K_SIGMA * sd).max(0.0), (m + K_SIGMA * sd).min(top));
    if hi > lo { (lo, hi) } else { (0.0, if top.is_finite() { top } else { 1.0 }) }
}

fn picture(values: &[f64], w: u32, h: u32, colour: fn(f64) -> [u8; 3], path: &Path) -> Result<(), CliError> {
    picture_scaled(values, scale(values), w, h, colour, path)
}

/// As `picture` with the scale given; `+∞` is drawn at the top of the scale.
fn picture_scaled(
    values: &[f64],
    (lo, hi): (f64, f64),
    w: u32,
    h: u32,
    colour: fn(f64) -> [u8; 3],
    path: &Path,
) -> Result<(), CliError> {
    let values: Vec<f64> = values.iter().map(|&v| if v == f64::INFINITY { hi } else { v }).collect();
    let bytes: Vec<u8> = values.iter().flat_map(|&v| colour((v - lo) / (hi - lo))).collect();
    let img = image::RgbImage::from_raw(w, h, bytes).ok_or_else(|| CliError::usage("image size mismatch"))?;
    write_png(&img, path)
}

fn grey(x: f64) -> [u8; 3] {
    [(255.0 * x.clamp(0.0, 1.0)).round() as u8; 3]
}

/// Writes the maps of `map` into `dir` (the names of [`files`]):
/// `quality.png` colour quality `Q^c` (eq. (11), Fig. 1.b),
/// `geometry-quality.png` `Q^g` (eq. (15), Fig. 1.c), `contrast.png` the
/// oracle's contrast (eq. (23)), `colour-contrast.png` `C^c` (eq. (18),
/// Fig. 2.c), `binary-contrast.png` `C_b^c` (eq. (19), Fig. 2.d),
/// `geometry-contrast.png` `C^g` (eq. (20), Fig. 4.a),
/// `geometry-binary-contrast.png` `C_b^g` (eq. (21), Fig. 4.b),
/// `geometry-log-contrast.png` `C_log^g` in bits (eq. (22), Fig. 4.c);
/// `quality.exr` holds `(Q^c, Q^g, 0)`, `contrast.exr` `(C^c, C_b^c, C^g)`
/// and `geometry-contrast.exr` `(C^g, C_b^g, C_log^g)` per pixel, unscaled
/// (`C_log^g` may be `+∞`); from `priority`, `priority-colour.png` `p_c`
/// (eq. (2), Fig. 2.b), `depth-difference.png` `p_d` (eq. (3), Figs. 4.d
/// and 5.d), `priority-value.png` `p_v` (eq. (4), Fig. 6.a) and
/// `priority.exr` `(p_c, p_d, p_v)`.
///
/// # Errors
/// A one-line error naming the path.
pub fn write_maps(map: &ContrastMap, priority: &PriorityMap, dir: &Path) -> Result<(), CliError> {
    let f = files(dir);
    let (w, h) = (map.width, map.height);
    let col = |g: fn(&itgfx_backends::render::PixelMeasures) -> f64| map.measures.iter().map(g).collect::<Vec<f64>>();
    picture(&col(|m| m.colour_quality), w, h, thermal, &f[0])?;
    picture(&col(|m| m.geometry_quality), w, h, grey, &f[1])?;
    picture(&col(|m| m.contrast), w, h, thermal, &f[2])?;
    picture(&col(|m| m.colour_contrast), w, h, thermal, &f[3])?;
    picture(&col(|m| m.binary_contrast), w, h, thermal, &f[4])?;
    picture(&col(|m| m.geometry_contrast), w, h, thermal, &f[5])?;
    picture(&col(|m| m.geometry_binary_contrast), w, h, thermal, &f[6])?;
    let log = col(|m| m.geometry_log_contrast);
    picture_scaled(&log, scale_within(&log, f64::INFINITY), w, h, thermal, &f[7])?;
    let exr =
        |rgb: Vec<[f64; 3]>, path: &Path| write_exr(&Radiance { width: w as usize, height: h as usize, rgb }, path);
    exr(map.measures.iter().map(|m| [m.colour_quality, m.geometry_quality, 0.0]).collect(), &f[8])?;
    exr(map.measures.iter().map(|m| [m.colour_contrast, m.binary_contrast, m.geometry_contrast]).collect(), &f[9])?;
    exr(
        map.measures
            .iter()
            .map(|m| [m.geometry_contrast, m.geometry_binary_contrast, m.geometry_log_contrast])
            .collect(),
        &f[10],
    )?;
    let pri = |g: fn(&itgfx_backends::render::Priority) -> f64| priority.pixels.iter().map(g).collect::<Vec<f64>>();
    let unbounded = |v: &[f64], path: &Path| picture_scaled(v, scale_within(v, f64::INFINITY), w, h, thermal, path);
    unbounded(&pri(|p| p.colour), &f[11])?;
    picture(&pri(|p| p.depth), w, h, thermal, &f[12])?;
    unbounded(&pri(|p| p.value), &f[13])?;
    exr(priority.pixels.iter().map(|p| [p.colour, p.depth, p.value]).collect(), &f[14])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thermal_ends_and_scale() {
        assert_eq!(thermal(0.0), [0, 0, 255]);
        assert_eq!(thermal(1.0), [255, 0, 0]);
        assert_eq!(thermal(0.5), [0, 255, 0]);
        // mean 0.5, sd 0.1: [0.3, 0.7]; clamped to [0, 1] otherwise.
        assert!({
            let (lo, hi) = scale(&[0.4, 0.6]);
            (lo - 0.3).abs() < 1e-12 && (hi - 0.7).abs() < 1e-12
        });
        assert_eq!(scale(&[0.0, 1.0]), (0.0, 1.0));
        assert_eq!(scale(&[0.5, 0.5]), (0.0, 1.0), "a flat map still has a scale");
        // The unbounded scale ignores infinities and is not cut at 1.
        let (lo, hi) = scale_within(&[2.0, 4.0, f64::INFINITY], f64::INFINITY);
        assert!((lo - 1.0).abs() < 1e-12 && (hi - 5.0).abs() < 1e-12, "{lo} {hi}");
    }

    /// Eqs. (21) and (22) by hand on two geometry factors 1 and 3:
    /// `C_b^g = 1 − H_b(1/4)` = 1 − (¼·2 + ¾·log₂(4/3)) = 0.188722… and
    /// `C_log^g = log₂ 3`; a ray that meets nothing (g = 0) beside one that
    /// meets a surface gives `C_b^g = 1` and `C_log^g = +∞`.
    #[test]
    fn geometry_binary_and_log_contrasts_by_hand() {
        use itgfx_backends::render::supersample::measures;
        let oracle = itgfx_backends::render::Oracle { delta: 1.0, binary: false };
        let grey = [[0.5; 3], [0.5; 3]];
        let m = measures(&grey, &[1.0, 3.0], oracle);
        let hb = 0.25 * 2.0 + 0.75 * (4.0f64 / 3.0).log2();
        assert!((m.geometry_binary_contrast - (1.0 - hb)).abs() < 1e-12, "{}", m.geometry_binary_contrast);
        assert!((m.geometry_binary_contrast - 0.188_721_9).abs() < 1e-7);
        assert!((m.geometry_log_contrast - 3f64.log2()).abs() < 1e-12, "{}", m.geometry_log_contrast);
        let edge = measures(&[[0.5; 3]; 3], &[0.0, 2.0, 2.0], oracle);
        assert_eq!(edge.geometry_binary_contrast, 1.0);
        assert_eq!(edge.geometry_log_contrast, f64::INFINITY);
        let flat = measures(&grey, &[2.0, 2.0], oracle);
        assert!(flat.geometry_binary_contrast.abs() < 1e-12 && flat.geometry_log_contrast.abs() < 1e-12);
    }
}
