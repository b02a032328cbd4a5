//! The pixel quality and contrast maps of Part IV §3–§4 (Figs. 1–6), from
//! the 8-spp oracle pass: PNG pictures and EXR values.
//!
//! As in the tutorial, each picture's scale is the values' mean `± k σ`
//! (`k = 2`; outliers go to the ends), intersected with `[0, 1]`. Colour
//! quality and the contrasts use a thermal scale (blue lowest, red highest);
//! geometry quality a grey scale (dark lowest), as Fig. 1.c.

use std::path::{Path, PathBuf};

use itgfx_backends::render::ContrastMap;

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
        "quality.exr",
        "contrast.exr",
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
    let n = values.len().max(1) as f64;
    let m = values.iter().sum::<f64>() / n;
    let sd = (values.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt();
    let (lo, hi) = ((m - K_SIGMA * sd).max(0.0), (m + K_SIGMA * sd).min(1.0));
    if hi > lo { (lo, hi) } else { (0.0, 1.0) }
}

fn picture(values: &[f64], w: u32, h: u32, colour: fn(f64) -> [u8; 3], path: &Path) -> Result<(), CliError> {
    let (lo, hi) = scale(values);
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
/// `geometry-contrast.png` `C^g` (eq. (20), Fig. 4.a); `quality.exr` holds
/// `(Q^c, Q^g, 0)` and `contrast.exr` `(C^c, C_b^c, C^g)` per pixel, unscaled.
///
/// # Errors
/// A one-line error naming the path.
pub fn write_maps(map: &ContrastMap, dir: &Path) -> Result<(), CliError> {
    let f = files(dir);
    let (w, h) = (map.width, map.height);
    let col = |g: fn(&itgfx_backends::render::PixelMeasures) -> f64| map.measures.iter().map(g).collect::<Vec<f64>>();
    picture(&col(|m| m.colour_quality), w, h, thermal, &f[0])?;
    picture(&col(|m| m.geometry_quality), w, h, grey, &f[1])?;
    picture(&col(|m| m.contrast), w, h, thermal, &f[2])?;
    picture(&col(|m| m.colour_contrast), w, h, thermal, &f[3])?;
    picture(&col(|m| m.binary_contrast), w, h, thermal, &f[4])?;
    picture(&col(|m| m.geometry_contrast), w, h, thermal, &f[5])?;
    let exr =
        |rgb: Vec<[f64; 3]>, path: &Path| write_exr(&Radiance { width: w as usize, height: h as usize, rgb }, path);
    exr(map.measures.iter().map(|m| [m.colour_quality, m.geometry_quality, 0.0]).collect(), &f[6])?;
    exr(map.measures.iter().map(|m| [m.colour_contrast, m.binary_contrast, m.geometry_contrast]).collect(), &f[7])
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
    }
}
