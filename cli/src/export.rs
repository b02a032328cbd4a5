//! Pictures of per-patch values: PLY meshes with vertex colours and PNG
//! renders through the tracing seam. Every file is written atomically
//! (a temporary file in the same directory, then a rename), so a failed or
//! interrupted run never leaves a half-written file behind.

use std::io::Write;
use std::path::Path;

use glam::DVec3;
use itgfx_backends::lines::Line;
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::{CrossingBuffer, Tracer};

use crate::CliError;

/// Writes `bytes` to `path` atomically.
///
/// # Errors
/// A one-line error naming the path.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().ok_or_else(|| CliError::usage(format!("{}: not a file path", path.display())))?;
    let tmp = dir.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id()));
    let fail = |e: std::io::Error| CliError::usage(format!("{}: {e}", path.display()));
    let res = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if res.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    res.map_err(fail)
}

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

/// Per-patch colours from values, scaled between their 2nd and 98th percentiles.
#[must_use]
pub fn colours(values: &[f64]) -> Vec<[u8; 3]> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let (lo, hi) =
        if v.is_empty() { (0.0, 1.0) } else { (v[v.len() * 2 / 100], v[(v.len() * 98 / 100).min(v.len() - 1)]) };
    let span = if hi > lo { hi - lo } else { 1.0 };
    values.iter().map(|&x| viridis((x - lo) / span)).collect()
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
    let tris = patch_triangles(scene);
    let cols = colours(values);
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
    atomic_write(path, s.as_bytes())
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
/// looking at the origin.
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
    let (w, h) = size;
    let fwd = (-eye).normalize();
    let up_hint = if fwd.cross(DVec3::Y).length() < 1e-6 { DVec3::Z } else { DVec3::Y };
    let right = fwd.cross(up_hint).normalize();
    let up = right.cross(fwd);
    // Field of view: the unit bounding sphere with a margin.
    let tan = (1.15 / eye.length()).min(0.9).asin().tan();
    let mut lines = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let u = (2.0 * (f64::from(x) + 0.5) / f64::from(w) - 1.0) * tan * f64::from(w) / f64::from(h);
            let v = (1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(h)) * tan;
            let d = (fwd + right * u + up * v).normalize();
            lines.push(Line {
                origin: eye.as_vec3().to_array(),
                tmin: 0.0,
                direction: d.as_vec3().to_array(),
                tmax: 10.0,
            });
        }
    }
    let mut buf = CrossingBuffer::default();
    tracer.trace_all(&lines, &mut buf).map_err(|e| CliError::usage(e.to_string()))?;
    let mut img = image::RgbImage::new(w, h);
    for (i, px) in img.pixels_mut().enumerate() {
        // First crossing facing the camera.
        *px = match buf.line(i).iter().find(|c| c.cos < 0.0) {
            Some(c) => {
                let shade = 0.35 + 0.65 * f64::from(-c.cos);
                let col = cols[c.patch as usize];
                image::Rgb(col.map(|k| (f64::from(k) * shade).round() as u8))
            }
            None => image::Rgb([24, 24, 28]),
        };
    }
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| CliError::usage(format!("{}: {e}", path.display())))?;
    atomic_write(path, &bytes)
}
