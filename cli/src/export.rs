//! Pictures of per-patch values: PLY meshes with vertex colours and PNG
//! renders through the tracing seam. Every file is written atomically
//! (a temporary file in the same directory, then a rename), so a failed or
//! interrupted run never leaves a half-written file behind (see [`crate::output`]).

use std::path::Path;

use glam::DVec3;
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::Tracer;
use rayon::prelude::*;

use crate::CliError;

/// Viridis colour map at `x ∈ [0, 1]` (8 control points, linear between).
#[must_use]
pub fn viridis(x: f64) -> [u8; 3] {
    const C: [[f64; 3]; 8] = [
        [68.0, 1.0, 84.0],
        [70.0, 50.0, 127.0],
        [54.0, 92.0, 141.0],
        [39.0, 127.0, 142.0],
        [31.0, 161.0, 135.0],
        [74.0, 194.0, 109.0],
        [159.0, 218.0, 58.0],
        [253.0, 231.0, 37.0],
    ];
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 } * 7.0;
    let i = (x.floor() as usize).min(6);
    let f = x - i as f64;
    let mut out = [0u8; 3];
    for k in 0..3 {
        out[k] = (C[i][k] * (1.0 - f) + C[i + 1][k] * f).round() as u8;
    }
    out
}

/// The 2nd and 98th percentiles of the finite values (`hi > lo` always).
#[must_use]
pub fn percentile_range(values: &[f64]) -> (f64, f64) {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let (lo, hi) =
        if v.is_empty() { (0.0, 1.0) } else { (v[v.len() * 2 / 100], v[(v.len() * 98 / 100).min(v.len() - 1)]) };
    (lo, if hi > lo { hi } else { lo + 1.0 })
}

/// Per-patch colours from values, scaled between their 2nd and 98th percentiles.
#[must_use]
pub fn colours(values: &[f64]) -> Vec<[u8; 3]> {
    let (lo, hi) = percentile_range(values);
    values.iter().map(|&x| viridis((x - lo) / (hi - lo))).collect()
}

/// Triangles of each patch for export (the analytic sphere is tessellated).
fn patch_triangles(scene: &Scene) -> Vec<([DVec3; 3], u32)> {
    if let Some(s) = scene.sphere {
        let mut out = Vec::new();
        let sub = 4;
        for b in 0..s.bands {
            for c in 0..s.sectors {
                let id = b * s.sectors + c;
                for i in 0..sub {
                    for j in 0..sub {
                        let p = |u: u32, v: u32| {
                            let z = 1.0 - 2.0 * (f64::from(b) + f64::from(u) / f64::from(sub)) / f64::from(s.bands);
                            let phi = std::f64::consts::TAU * (f64::from(c) + f64::from(v) / f64::from(sub))
                                / f64::from(s.sectors);
                            let r = (1.0 - z * z).max(0.0).sqrt();
                            DVec3::new(r * phi.cos(), r * phi.sin(), z) * s.radius
                        };
                        out.push(([p(i, j), p(i + 1, j), p(i + 1, j + 1)], id));
                        out.push(([p(i, j), p(i + 1, j + 1), p(i, j + 1)], id));
                    }
                }
            }
        }
        return out;
    }
    scene.triangles.iter().copied().zip(scene.triangle_patch.iter().copied()).collect()
}

/// An ASCII PLY of the scene with every vertex coloured by its patch's value
/// (and the value itself as a float property `value`).
///
/// # Errors
/// I/O errors, one line.
pub fn write_ply(scene: &Scene, values: &[f64], path: &Path) -> Result<(), CliError> {
    write_ply_with(scene, values, &colours(values), path)
}

/// As [`write_ply`] with explicit patch colours.
///
/// # Errors
/// I/O errors, one line.
pub fn write_ply_with(scene: &Scene, values: &[f64], cols: &[[u8; 3]], path: &Path) -> Result<(), CliError> {
    let tris = patch_triangles(scene);
    let mut s = String::new();
    s.push_str(&format!(
        "ply\nformat ascii 1.0\ncomment itgfx: {} coloured per patch\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nproperty float value\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        scene.name,
        tris.len() * 3,
        tris.len()
    ));
    for (t, p) in &tris {
        let c = cols[*p as usize];
        for v in t {
            s.push_str(&format!(
                "{} {} {} {} {} {} {}\n",
                v.x as f32, v.y as f32, v.z as f32, c[0], c[1], c[2], values[*p as usize] as f32
            ));
        }
    }
    for i in 0..tris.len() {
        s.push_str(&format!("3 {} {} {}\n", 3 * i, 3 * i + 1, 3 * i + 2));
    }
    crate::output::write(path, s.as_bytes())
}

/// Renders the scene with every patch in its value's colour, from a camera
/// outside the scene looking at its centre. Back faces are culled, so the
/// walls of an enclosure that face away from the camera let it look inside.
///
/// # Errors
/// Tracing and encoding errors, one line.
pub fn render_png(tracer: &dyn Tracer, values: &[f64], path: &Path, size: (u32, u32)) -> Result<(), CliError> {
    // Camera on the -z side, a little above, 3.2 half-diagonals away.
    render_png_from(tracer, &colours(values), DVec3::new(0.35, 0.45, -3.2), path, size)
}

/// Renders with explicit patch colours from `eye` (normalised coordinates)
/// looking at the origin, back faces culled, and writes a PNG.
///
/// # Errors
/// Tracing and encoding errors, one line.
pub fn render_png_from(
    tracer: &dyn Tracer,
    cols: &[[u8; 3]],
    eye: DVec3,
    path: &Path,
    size: (u32, u32),
) -> Result<(), CliError> {
    write_png(&render_image(tracer, cols, eye, size, Faces::Front)?, path)
}

pub use itgfx_backends::preview::Faces;

/// Renders patches in their colours from `eye` looking at the origin, with
/// `|cos|` shading (`itgfx_backends::preview`).
///
/// # Errors
/// Tracing errors, one line.
pub fn render_image(
    tracer: &dyn Tracer,
    cols: &[[u8; 3]],
    eye: DVec3,
    size: (u32, u32),
    faces: Faces,
) -> Result<image::RgbImage, CliError> {
    let px = itgfx_backends::preview::render_patches(tracer, cols, eye, size, faces)
        .map_err(|e| CliError::usage(e.to_string()))?;
    Ok(image::RgbImage::from_fn(size.0, size.1, |x, y| image::Rgb(px[(y * size.0 + x) as usize])))
}

/// Writes an image as PNG, atomically.
///
/// # Errors
/// Encoding and I/O errors, one line.
pub fn write_png(img: &image::RgbImage, path: &Path) -> Result<(), CliError> {
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| CliError::usage(format!("{path:?}: {e}")))?;
    crate::output::write(path, &bytes)
}

/// Images side by side in rows of `per_row`, on a dark background, each in
/// a cell of the largest image's size (top-left aligned).
#[must_use]
pub fn montage(images: &[image::RgbImage], per_row: usize) -> image::RgbImage {
    let (w, h) = images.iter().fold((1, 1), |(w, h), i| (w.max(i.width()), h.max(i.height())));
    let per_row = per_row.clamp(1, images.len().max(1));
    let rows = images.len().div_ceil(per_row).max(1);
    let mut out = image::RgbImage::from_pixel(
        w * per_row as u32,
        h * rows as u32,
        image::Rgb(itgfx_backends::preview::BACKGROUND),
    );
    for (k, img) in images.iter().enumerate() {
        let (x0, y0) = ((k % per_row) as u32 * w, (k / per_row) as u32 * h);
        for (x, y, p) in img.enumerate_pixels() {
            out.put_pixel(x0 + x, y0 + y, *p);
        }
    }
    out
}

/// The viewpoint sphere seen from `+z` (left) and `−z` (right), one row per
/// measure: each pixel of a disc takes the colour of the nearest viewpoint's
/// value (viridis, 2nd-98th percentile); `mark` (a direction) is drawn as a
/// red dot.
#[must_use]
pub fn sphere_image(directions: &[DVec3], measures: &[&[f64]], mark: DVec3, radius: u32) -> image::RgbImage {
    let rows: Vec<Vec<[u8; 3]>> = measures.iter().map(|values| colours(values)).collect();
    sphere_image_coloured(directions, &rows, Some(mark), radius)
}

/// [`sphere_image`] with a given colour per viewpoint in each row, and an
/// optional mark.
#[must_use]
pub fn sphere_image_coloured(
    directions: &[DVec3],
    rows: &[Vec<[u8; 3]>],
    mark: Option<DVec3>,
    radius: u32,
) -> image::RgbImage {
    let side = 2 * radius + 8;
    let mut img = image::RgbImage::from_pixel(
        2 * side,
        side * rows.len() as u32,
        image::Rgb(itgfx_backends::preview::BACKGROUND),
    );
    let mark = mark.map(DVec3::normalize);
    // The nearest viewpoint of every disc pixel, shared by all rows.
    let d = 2 * radius;
    let nearest: Vec<Option<(usize, f64, bool)>> = (0..2 * d * d)
        .into_par_iter()
        .map(|k| {
            let (half, py, px) = (k / (d * d), (k / d) % d, k % d);
            let sign = if half == 0 { 1.0 } else { -1.0 };
            let u = (f64::from(px) + 0.5) / f64::from(radius) - 1.0;
            let v = 1.0 - (f64::from(py) + 0.5) / f64::from(radius);
            let r2 = u * u + v * v;
            if r2 > 1.0 {
                return None;
            }
            // Seen from -z the x axis points left: mirror u.
            let p = DVec3::new(u * sign, v, sign * (1.0 - r2).sqrt());
            let near =
                directions.iter().enumerate().max_by(|a, b| p.dot(*a.1).total_cmp(&p.dot(*b.1))).map_or(0, |(k, _)| k);
            Some((near, 0.55 + 0.45 * (1.0 - r2).sqrt(), mark.is_some_and(|m| p.dot(m) > 0.9995)))
        })
        .collect();
    for (row, cols) in rows.iter().enumerate() {
        for (k, n) in nearest.iter().enumerate() {
            let Some((near, shade, marked)) = *n else { continue };
            let (half, py, px) = (k as u32 / (d * d), (k as u32 / d) % d, k as u32 % d);
            let c = if marked { [230, 40, 40] } else { cols[near] };
            img.put_pixel(
                half * side + 4 + px,
                row as u32 * side + 4 + py,
                image::Rgb(c.map(|k| (f64::from(k) * shade).round() as u8)),
            );
        }
    }
    img
}
