//! Image files of `itgfx render`, `itgfx compare` and `itgfx radiosity`
//! (the film's output): linear radiance as OpenEXR (f32 RGB, lossless) and
//! PFM, sRGB-encoded PNG, and the sampling-density map.

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

/// `image` as PFM bytes: colour, little-endian (scale −1), bottom row
/// first, f32 values.
#[must_use]
pub fn pfm_bytes(image: &Radiance) -> Vec<u8> {
    let (width, height) = (image.width, image.height);
    let mut out = format!("PF\n{width} {height}\n-1.0\n").into_bytes();
    for y in (0..height).rev() {
        for x in 0..width {
            for c in image.rgb[y * width + x] {
                out.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
    }
    out
}

/// Writes `image` as a PFM file ([`pfm_bytes`]).
///
/// # Errors
/// A one-line error naming the path.
pub fn write_pfm(image: &Radiance, path: &Path) -> Result<(), CliError> {
    crate::output::write(path, &pfm_bytes(image))
}

/// Reads a colour PFM as [`write_pfm`] writes it (little-endian): linear
/// radiance, so every value finite and `>= 0`. Errors name `what` (the
/// option that gave the file) and the path.
///
/// # Errors
/// A one-line error naming `what` and the path.
pub fn read_pfm(path: &Path, what: &str) -> Result<Radiance, CliError> {
    let bad = |why: &str| CliError::usage(format!("{what} {path:?}: {why}"));
    let bytes = itgfx_backends::files::read_regular(path).map_err(|e| bad(&e.to_string()))?;
    let mut fields = Vec::new();
    let mut at = 0;
    while fields.len() < 4 && at < bytes.len().min(256) {
        while at < bytes.len() && bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while at < bytes.len() && !bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        fields.push(String::from_utf8_lossy(&bytes[start..at]).into_owned());
    }
    at += 1;
    if fields.len() < 4 || fields[0] != "PF" {
        return Err(bad("not a colour PFM (PF header)"));
    }
    let (w, h) = (fields[1].parse::<u32>(), fields[2].parse::<u32>());
    let (Ok(w), Ok(h)) = (w, h) else { return Err(bad("bad size in the PFM header")) };
    if fields[3].parse::<f64>().map_or(true, |s| s >= 0.0) {
        return Err(bad("only little-endian PFM (negative scale) is read"));
    }
    let n = w as usize * h as usize;
    if bytes.len().saturating_sub(at) != n * 12 {
        return Err(bad(&format!("{w} x {h} pixels need {} bytes of data", n * 12)));
    }
    let mut px = vec![[0.0; 3]; n];
    for (k, chunk) in bytes[at..].chunks_exact(12).enumerate() {
        let (y, x) = (h as usize - 1 - k / w as usize, k % w as usize);
        for c in 0..3 {
            let v = f64::from(f32::from_le_bytes(chunk[4 * c..4 * c + 4].try_into().unwrap_or_default()));
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad("a pixel is negative or not finite"));
            }
            px[y * w as usize + x][c] = v;
        }
    }
    Ok(Radiance { width: w as usize, height: h as usize, rgb: px })
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

    #[test]
    fn pfm_round_trips_bottom_row_first() {
        let dir = std::env::temp_dir().join(format!("itgfx-pfm-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.pfm");
        let img = Radiance { width: 2, height: 3, rgb: (0..6).map(|i| [f64::from(i), 0.25, 0.1]).collect() };
        let bytes = pfm_bytes(&img);
        let header = b"PF\n2 3\n-1.0\n";
        assert_eq!(&bytes[..header.len()], header);
        // The first pixel stored is the bottom row's first, pixel 4.
        assert_eq!(&bytes[header.len()..header.len() + 4], &4f32.to_le_bytes());
        write_pfm(&img, &p).unwrap();
        let back = read_pfm(&p, "--x").unwrap();
        let want: Vec<[f64; 3]> = img.rgb.iter().map(|c| c.map(|v| f64::from(v as f32))).collect();
        assert_eq!((back.width, back.height, back.rgb), (2, 3, want));
        std::fs::write(&p, b"P6\n1 1\n255\n").unwrap();
        assert!(read_pfm(&p, "--x").unwrap_err().to_string().starts_with("--x "));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
