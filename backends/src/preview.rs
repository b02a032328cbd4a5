//! Preview renders of patch colours (the analyses' pictures): one
//! closest-hit query per pixel through the tracing seam, `|cos|` shading.

use glam::DVec3;

use crate::backend::BackendError;
use crate::camera::Camera;
use crate::lines::Line;
use crate::tracer::{Hit, Tracer};

/// Which crossing a pixel shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Faces {
    /// The first crossing facing the camera (enclosures seen from outside).
    Front,
    /// The first crossing, either side (objects; open meshes show their inside).
    Both,
}

/// Background colour of previews.
pub const BACKGROUND: [u8; 3] = [24, 24, 28];

/// Renders patches in their colours `cols` from `eye` (normalised
/// coordinates) looking at the origin: `w × h` pixels, row-major from the top.
///
/// # Errors
/// Tracing errors.
pub fn render_patches(
    tracer: &dyn Tracer,
    cols: &[[u8; 3]],
    eye: DVec3,
    size: (u32, u32),
    faces: Faces,
) -> Result<Vec<[u8; 3]>, BackendError> {
    let (w, h) = size;
    let cam = Camera::framing_unit_sphere(eye);
    // Past the far side of the unit sphere from any distance.
    let reach = eye.length() + 2.0;
    let mut lines: Vec<Line> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| cam.ray(f64::from(x) + 0.5, f64::from(y) + 0.5, w, h, reach))
        .collect();
    let mut hits: Vec<Option<Hit>> = Vec::new();
    tracer.closest_hit(&lines, &mut hits)?;
    if faces == Faces::Front {
        // Back faces are skipped by continuing past them; a few rounds
        // reach the first front face of any closed scene seen from outside.
        let mut pending: Vec<usize> = (0..hits.len()).filter(|&i| hits[i].is_some_and(|c| c.cos >= 0.0)).collect();
        let mut again = Vec::new();
        for _ in 0..8 {
            if pending.is_empty() {
                break;
            }
            let batch: Vec<Line> =
                pending.iter().map(|&i| Line { tmin: hits[i].map_or(0.0, |c| c.t) + 1e-6, ..lines[i] }).collect();
            tracer.closest_hit(&batch, &mut again)?;
            let mut next = Vec::new();
            for (k, &i) in pending.iter().enumerate() {
                lines[i] = batch[k];
                hits[i] = again[k];
                if again[k].is_some_and(|c| c.cos >= 0.0) {
                    next.push(i);
                }
            }
            pending = next;
        }
        for i in pending {
            hits[i] = None;
        }
    }
    Ok(hits
        .iter()
        .map(|hit| match hit {
            Some(c) => {
                let shade = 0.35 + 0.65 * f64::from(c.cos.abs());
                cols[c.patch as usize].map(|k| (f64::from(k) * shade).round() as u8)
            }
            None => BACKGROUND,
        })
        .collect())
}
