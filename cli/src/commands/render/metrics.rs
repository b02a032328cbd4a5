//! Image errors of `compare` and `render --reference`: the tutorial's RMSE
//! and PSNR (Part IV §6.4 Table 2, Part III-IV Table 3) through
//! `itgfx_core::pixel::image_error`, taken on the 8-bit sRGB display values
//! (peak 255, as the published tables), and the relative MSE on linear
//! radiance that current papers report.

use itgfx_core::pixel::{SRGB_LUMINANCE_WEIGHTS, image_error, luminance};

use super::images::{Radiance, display_values};
use crate::report::Report;
use crate::{CliError, core_err};

/// The errors of one image against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// RMSE, channels weighted equally.
    pub rmse_a: f64,
    /// RMSE, channels weighted by the sRGB luminance weights.
    pub rmse_p: f64,
    /// PSNR (dB) of `rmse_a`.
    pub psnr_a: f64,
    /// PSNR (dB) of `rmse_p`.
    pub psnr_p: f64,
    /// Mean of `(a − b)² / (b² + 0.01)` over pixels and channels, linear radiance.
    pub rel_mse: f64,
    /// Mean luminance of the image.
    pub mean_a: f64,
    /// Mean luminance of the reference.
    pub mean_b: f64,
}

impl Comparison {
    /// Adds the metrics to a report.
    pub fn report(&self, r: &mut Report) {
        r.real("RMSE_a", self.rmse_a, None)
            .real("RMSE_p", self.rmse_p, None)
            .real("PSNR_a", self.psnr_a, Some("dB"))
            .real("PSNR_p", self.psnr_p, Some("dB"))
            .real("relMSE", self.rel_mse, None)
            .real("mean_luminance_a", self.mean_a, None)
            .real("mean_luminance_b", self.mean_b, None);
    }
}

/// Mean RGB of a radiance image.
#[must_use]
pub fn mean_rgb(rgb: &[[f64; 3]]) -> [f64; 3] {
    let mut acc = [0.0; 3];
    for c in rgb {
        for k in 0..3 {
            acc[k] += c[k];
        }
    }
    acc.map(|v| v / rgb.len().max(1) as f64)
}

/// Scores `a` against the reference `b` (same size).
///
/// # Errors
/// Different sizes.
pub fn compare_images(a: &Radiance, b: &Radiance, exposure: f64) -> Result<Comparison, CliError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(CliError::usage(format!(
            "images differ in size: {} x {} against {} x {}",
            a.width, a.height, b.width, b.height
        )));
    }
    let (da, db) = (display_values(a, exposure), display_values(b, exposure));
    let ea = image_error(&da, &db, 3, &[1.0; 3], 255.0).map_err(|e| core_err("RMSE_a", e))?;
    let ep = image_error(&da, &db, 3, &SRGB_LUMINANCE_WEIGHTS, 255.0).map_err(|e| core_err("RMSE_p", e))?;
    let mut rel = 0.0;
    for (x, y) in a.rgb.iter().zip(&b.rgb) {
        for k in 0..3 {
            rel += (x[k] - y[k]).powi(2) / (y[k] * y[k] + 0.01);
        }
    }
    Ok(Comparison {
        rmse_a: ea.rmse,
        rmse_p: ep.rmse,
        psnr_a: ea.psnr,
        psnr_p: ep.psnr,
        rel_mse: rel / (3 * a.rgb.len().max(1)) as f64,
        mean_a: luminance(mean_rgb(&a.rgb)),
        mean_b: luminance(mean_rgb(&b.rgb)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_by_hand() {
        // Display values: 0 and 1 map to 0 and 255; one channel of one pixel differs by 255.
        let a = Radiance { width: 2, height: 1, rgb: vec![[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]] };
        let b = Radiance { width: 2, height: 1, rgb: vec![[0.0; 3], [0.0; 3]] };
        let m = compare_images(&a, &b, 0.0).unwrap();
        // MSE_R = 255²/2, others 0: equal weights give 255²/6, sRGB weights 0.2126·255²/2.
        assert!((m.rmse_a - (255.0f64 * 255.0 / 6.0).sqrt()).abs() < 1e-9);
        assert!((m.rmse_p - (0.2126 * 255.0f64 * 255.0 / 2.0).sqrt()).abs() < 1e-9);
        assert!((m.psnr_a - 10.0 * 6f64.log10()).abs() < 1e-9);
        // relMSE: one term 1/0.01 over 6.
        assert!((m.rel_mse - 100.0 / 6.0).abs() < 1e-9);
        assert!(compare_images(&a, &Radiance { width: 1, height: 2, rgb: b.rgb.clone() }, 0.0).is_err());
    }
}
