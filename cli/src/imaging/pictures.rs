//! Image files of the imaging commands: reading scalar PNGs, writing grey,
//! colour, checkerboard, overlay, histogram and curve pictures (atomically,
//! through [`crate::output::write`]).

use std::path::Path;

use image::{GrayImage, ImageReader, Rgb, RgbImage};
use itgfx_backends::imaging::{Gray, Gray3};

use crate::CliError;
use crate::export::{viridis, write_png};
use crate::plot::{Axis, Curve, Style, chart};

/// Most pixels an input image may have (memory: a few `f32` copies each).
pub const MAX_PIXELS: u64 = 16 * 1024 * 1024;

/// Reads a PNG (8 or 16 bit, grey or colour: converted to luma) as samples in `[0, 1]`.
/// The size is checked against [`MAX_PIXELS`] before decoding.
///
/// # Errors
/// One line naming the file: missing, not a PNG, too large, undecodable.
pub fn read_gray(path: &Path) -> Result<Gray, CliError> {
    let fail = |e: &dyn std::fmt::Display| CliError::usage(format!("{path:?}: {e}"));
    if path.is_dir() {
        return Err(fail(&"is a directory, not a PNG image"));
    }
    let mut head = [0u8; 8];
    let mut file = itgfx_backends::files::open_regular(path).map_err(|e| fail(&e))?;
    let n = std::io::Read::read(&mut file, &mut head).map_err(|e| fail(&e))?;
    if n < 8 || head != *b"\x89PNG\r\n\x1a\n" {
        return Err(fail(&"not a PNG image (no PNG signature)"));
    }
    let reader = ImageReader::open(path).map_err(|e| fail(&e))?.with_guessed_format().map_err(|e| fail(&e))?;
    let (w, h) = ImageReader::open(path)
        .map_err(|e| fail(&e))?
        .with_guessed_format()
        .map_err(|e| fail(&e))?
        .into_dimensions()
        .map_err(|e| fail(&e))?;
    if u64::from(w) * u64::from(h) > MAX_PIXELS {
        return Err(fail(&format!("{w} x {h} pixels: more than the {MAX_PIXELS} allowed")));
    }
    let img = reader.decode().map_err(|e| fail(&e))?.to_luma32f();
    Ok(Gray { width: w as usize, height: h as usize, data: img.into_raw() })
}

/// Writes an 8-bit grey PNG of samples in `[0, 1]` (clamped).
///
/// # Errors
/// Encoding and I/O errors, one line.
pub fn write_gray(g: &Gray, path: &Path) -> Result<(), CliError> {
    let img = GrayImage::from_fn(g.width as u32, g.height as u32, |x, y| {
        image::Luma([(g.at(x as usize, y as usize).clamp(0.0, 1.0) * 255.0).round() as u8])
    });
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| CliError::usage(format!("{path:?}: {e}")))?;
    crate::output::write(path, &bytes)
}

fn byte(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// A checkerboard of `a` and `b` in squares of `tile` pixels.
#[must_use]
pub fn checkerboard(a: &Gray, b: &Gray, tile: usize) -> RgbImage {
    RgbImage::from_fn(a.width as u32, a.height as u32, |x, y| {
        let (x, y) = (x as usize, y as usize);
        let v = if (x / tile + y / tile).is_multiple_of(2) { a.at(x, y) } else { b.at(x, y) };
        Rgb([byte(v); 3])
    })
}

/// `a` in magenta, `b` in green: edges coincide when the images are aligned
/// (grey only where the two intensities are equal, i.e. one modality).
#[must_use]
pub fn overlay(a: &Gray, b: &Gray) -> RgbImage {
    RgbImage::from_fn(a.width as u32, a.height as u32, |x, y| {
        let (p, q) = (byte(a.at(x as usize, y as usize)), byte(b.at(x as usize, y as usize)));
        Rgb([p, q, p])
    })
}

/// A `bins × bins` joint histogram as a picture (`log(1 + count)`, viridis),
/// fixed bins down, moving bins across, each bin `scale` pixels.
#[must_use]
pub fn histogram_image(counts: &[f64], bins: usize, scale: u32) -> RgbImage {
    let top = counts.iter().copied().fold(0.0, f64::max).ln_1p().max(1e-12);
    RgbImage::from_fn(bins as u32 * scale, bins as u32 * scale, |x, y| {
        let (i, j) = ((y / scale) as usize, (x / scale) as usize);
        Rgb(viridis(counts[i * bins + j].ln_1p() / top))
    })
}

/// A distinct colour for label `k`.
#[must_use]
pub fn palette(k: usize) -> [u8; 3] {
    // Golden-angle hues, alternating lightness.
    let h = (k as f64 * 0.618_033_988_75).fract() * 6.0;
    let (l, s) = if k.is_multiple_of(2) { (0.55, 0.75) } else { (0.4, 0.65) };
    let c = (1.0 - (2.0 * l - 1.0f64).abs()) * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as usize {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = l - c / 2.0;
    [((r + m) * 255.0) as u8, ((g + m) * 255.0) as u8, ((b + m) * 255.0) as u8]
}

/// Labels in [`palette`] colours.
#[must_use]
pub fn label_image(labels: &[usize], w: usize, h: usize) -> RgbImage {
    RgbImage::from_fn(w as u32, h as u32, |x, y| Rgb(palette(labels[y as usize * w + x as usize])))
}

/// Curves `y(x)` on a white `w × h` chart with linear axes spanning
/// `[x0, x1] × [y0, y1]` ([`crate::plot::chart`], axis ends labelled).
#[must_use]
pub fn plot(curves: &[Curve], x: (f64, f64), y: (f64, f64), size: (u32, u32)) -> RgbImage {
    chart(curves, Axis::linear(x.0, x.1), Axis::linear(y.0, y.1), size, &Style::LIGHT)
}

/// Writes a colour picture.
///
/// # Errors
/// Encoding and I/O errors, one line.
pub fn write_rgb(img: &RgbImage, path: &Path) -> Result<(), CliError> {
    write_png(img, path)
}

/// A volume as NRRD bytes: `float`, raw, little-endian, its spacing as
/// axis-aligned `space directions` (what `volume` and `register` read).
#[must_use]
pub fn nrrd_bytes(v: &Gray3) -> Vec<u8> {
    let [nx, ny, nz] = v.dims;
    let [sx, sy, sz] = v.spacing;
    let head = format!(
        "NRRD0004\n# itgfx\ntype: float\ndimension: 3\nspace: left-posterior-superior\nsizes: {nx} {ny} {nz}\n\
         space directions: ({sx:?},0,0) (0,{sy:?},0) (0,0,{sz:?})\nkinds: domain domain domain\n\
         endian: little\nencoding: raw\nspace origin: (0,0,0)\n\n"
    );
    let mut bytes = Vec::with_capacity(head.len() + v.data.len() * 4);
    bytes.extend_from_slice(head.as_bytes());
    v.data.iter().for_each(|x| bytes.extend_from_slice(&x.to_le_bytes()));
    bytes
}

/// Writes a volume as NRRD ([`nrrd_bytes`]).
///
/// # Errors
/// I/O errors, one line.
pub fn write_nrrd(v: &Gray3, path: &Path) -> Result<(), CliError> {
    crate::output::write(path, &nrrd_bytes(v))
}

/// The middle slices of a volume across `z`, `y` and `x` (axial `x–y`,
/// coronal `x–z`, sagittal `y–z`), as images.
#[must_use]
pub fn middle_slices(v: &Gray3) -> [Gray; 3] {
    let [nx, ny, nz] = v.dims;
    let slice = |w: usize, h: usize, f: &dyn Fn(usize, usize) -> f32| {
        let mut g = Gray::new(w, h);
        for y in 0..h {
            for x in 0..w {
                g.data[y * w + x] = f(x, y);
            }
        }
        g
    };
    [
        slice(nx, ny, &|x, y| v.at(x, y, nz / 2)),
        slice(nx, nz, &|x, z| v.at(x, ny / 2, z)),
        slice(ny, nz, &|y, z| v.at(nx / 2, y, z)),
    ]
}

/// Pictures side by side on black, 4 pixels apart, tops aligned.
#[must_use]
pub fn side_by_side(parts: &[RgbImage]) -> RgbImage {
    let gap = 4;
    let w = parts.iter().map(|p| p.width() + gap).sum::<u32>().saturating_sub(gap).max(1);
    let h = parts.iter().map(RgbImage::height).max().unwrap_or(1);
    let mut out = RgbImage::new(w, h);
    let mut x0 = 0;
    for p in parts {
        for (x, y, px) in p.enumerate_pixels() {
            out.put_pixel(x0 + x, y, *px);
        }
        x0 += p.width() + gap;
    }
    out
}
