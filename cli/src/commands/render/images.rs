//! Image files of `itgfx render` and `itgfx compare`: linear radiance as
//! OpenEXR (f32 RGB, lossless), sRGB-encoded PNG, and the sampling-density map.

use std::io::Cursor;
use std::path::Path;

use exr::prelude::{ReadChannels, ReadLayers, ReadSpecificChannel, SpecificChannels, Vec2, WritableImage, read};

use crate::CliError;
use crate::export::{viridis, write_png};

/// Largest image read by `compare` (pixels).
pub const MAX_PIXELS: usize = 1 << 26;

/// A linear RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Radiance {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major RGB, top row first.
    pub rgb: Vec<[f64; 3]>,
}

/// Writes `image` as an OpenEXR file of 32-bit float R, G, B (atomically).
///
/// # Errors
/// A one-line error naming the path.
pub fn write_exr(image: &Radiance, path: &Path) -> Result<(), CliError> {
    let w = image.width;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let c = image.rgb[y * w + x];
        (c[0] as f32, c[1] as f32, c[2] as f32)
    });
    let img = exr::image::Image::from_channels((image.width, image.height), channels);
    let mut bytes = Cursor::new(Vec::new());
    img.write().to_buffered(&mut bytes).map_err(|e| CliError::usage(format!("{path:?}: EXR: {e}")))?;
    crate::output::write(path, bytes.get_ref())
}

/// Reads the first RGB(A) layer of an OpenEXR file as linear RGB; at most
/// 1 GiB on disk and [`MAX_PIXELS`] pixels (checked from the header first).
///
/// # Errors
/// A one-line error naming the path.
pub fn read_exr(path: &Path) -> Result<Radiance, CliError> {
    let e = |m: String| CliError::usage(format!("{path:?}: {m}"));
    let bytes = itgfx_backends::obj::read_limited(path, 1 << 30).map_err(|x| CliError::usage(x.to_string()))?;
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(&bytes), false)
        .map_err(|x| e(format!("not a readable OpenEXR file: {x}")))?;
    let header = meta.headers.first().ok_or_else(|| e("no image in the file".into()))?;
    let (w, h) = (header.layer_size.width(), header.layer_size.height());
    if w.saturating_mul(h) > MAX_PIXELS {
        return Err(e(format!("{w} x {h} pixels is more than the {MAX_PIXELS} this command reads")));
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required("R")
        .required("G")
        .required("B")
        .collect_pixels(
            |size: Vec2<usize>, _| vec![[0.0f64; 3]; size.width() * size.height()],
            move |px: &mut Vec<[f64; 3]>, p: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                px[p.y() * w + p.x()] = [f64::from(r), f64::from(g), f64::from(b)];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(&bytes))
        .map_err(|x| e(format!("no R, G, B layer read: {x}")))?;
    let layer = image.layer_data;
    let size = layer.size;
    let rgb = layer.channel_data.pixels;
    if let Some(i) = rgb.iter().position(|c| !c.iter().all(|v| v.is_finite())) {
        return Err(e(format!("pixel ({}, {}) is not finite", i % size.width(), i / size.width())));
    }
    Ok(Radiance { width: size.width(), height: size.height(), rgb })
}

pub use itgfx_core::pixel::srgb_encode;

/// The displayed image, `255 · sRGB(clamp(2^exposure · L))` per channel, as reals.
#[must_use]
pub fn display_values(image: &Radiance, exposure: f64) -> Vec<f64> {
    let k = exposure.exp2();
    image.rgb.iter().flat_map(|c| c.map(|v| 255.0 * srgb_encode(v * k))).collect()
}

/// Writes the tone-mapped PNG.
///
/// # Errors
/// A one-line error naming the path.
pub fn write_display_png(image: &Radiance, exposure: f64, path: &Path) -> Result<(), CliError> {
    let v = display_values(image, exposure);
    let bytes: Vec<u8> = v.iter().map(|x| x.round().clamp(0.0, 255.0) as u8).collect();
    let img = image::RgbImage::from_raw(image.width as u32, image.height as u32, bytes)
        .ok_or_else(|| CliError::usage("image size mismatch"))?;
    write_png(&img, path)
}

/// The sampling-density map: samples per pixel on a log scale from the
/// fewest (dark) to the most (bright), viridis colours.
///
/// # Errors
/// A one-line error naming the path.
pub fn write_density_png(samples: &[u32], width: usize, height: usize, path: &Path) -> Result<(), CliError> {
    let (lo, hi) = samples.iter().fold((u32::MAX, 0), |(a, b), &s| (a.min(s), b.max(s)));
    let (l, h) = (f64::from(lo.max(1)).ln(), f64::from(hi.max(1)).ln());
    let bytes: Vec<u8> = samples
        .iter()
        .flat_map(|&s| viridis(if h > l { (f64::from(s.max(1)).ln() - l) / (h - l) } else { 0.5 }))
        .collect();
    let img = image::RgbImage::from_raw(width as u32, height as u32, bytes)
        .ok_or_else(|| CliError::usage("image size mismatch"))?;
    write_png(&img, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_ends_and_knee() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-12);
        assert!((srgb_encode(0.003_130_8) - 0.040_45).abs() < 1e-5);
        assert_eq!(srgb_encode(7.0), srgb_encode(1.0), "clamped above 1");
    }

    #[test]
    fn exr_round_trips_f32() {
        let dir = std::env::temp_dir().join(format!("itgfx-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.exr");
        let img =
            Radiance { width: 3, height: 2, rgb: (0..6).map(|i| [f64::from(i), 0.5, 1e-3 * f64::from(i)]).collect() };
        write_exr(&img, &p).unwrap();
        let back = read_exr(&p).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        for (a, b) in img.rgb.iter().zip(&back.rgb) {
            for c in 0..3 {
                assert_eq!(b[c], f64::from(a[c] as f32));
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
