//! Cameras for rendering: the default view of each scene and the check that
//! a camera is not inside a closed object.

use glam::DVec3;

use crate::camera::Camera;
use crate::lines::Line;
use crate::scene::{Scene, scene_camera};
use crate::tracer::{BackendError, Prepared, Tracer};

/// Probe rays cast from the eye by [`eye_place`].
const PROBES: u32 = 64;

/// The default camera of a scene, in scene units: its own view
/// ([`scene_camera`]: the file's camera, else its registry entry's
/// [`BuiltIn::camera`](crate::scene::BuiltIn::camera)), else a view from
/// outside framing the bounding box.
#[must_use]
pub fn default_camera(scene: &Scene) -> Camera {
    scene_camera(scene, |b| b.camera).unwrap_or_else(|| {
        let (lo, hi) = scene.bounds();
        let (c, r) = ((lo + hi) * 0.5, ((hi - lo) * 0.5).length().max(f64::MIN_POSITIVE));
        let eye = c + DVec3::new(0.35, 0.45, 2.6).normalize() * (2.8 * r);
        Camera::look_at(eye, c, DVec3::Y, 45.0).expect("a view from outside a validated scene's box is valid")
    })
}

/// Where a camera's eye is, as 64 probe rays spread over the sphere see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EyePlace {
    /// Most probes meet the front of a surface, or nothing.
    Clear,
    /// At least 90% of the probes hit something and most of those meet the
    /// back of a surface: the eye is inside a closed object.
    Inside {
        /// Share of the hits on back faces.
        share: f64,
        /// First back-face patch met.
        patch: u32,
    },
    /// Some probes escape and most hits are on back faces: the eye is
    /// outside a closed scene (a room seen from outside its walls).
    Outside {
        /// Share of the hits on back faces.
        share: f64,
        /// First back-face patch met.
        patch: u32,
    },
}

/// Where the eye of `camera` (normalised coordinates) is.
///
/// # Errors
/// Backend failures only.
pub fn eye_place(tracer: &dyn Tracer, camera: &Camera) -> Result<EyePlace, BackendError> {
    let lines: Vec<Line> = crate::viewpoint::fibonacci_sphere(PROBES as usize)
        .into_iter()
        .map(|d| Line::ray(camera.eye, d, 0.0, 1e5))
        .collect();
    let mut hits = Vec::new();
    tracer.closest_hit(&lines, &mut hits)?;
    let met: Vec<_> = hits.iter().flatten().collect();
    let back: Vec<u32> = met.iter().filter(|h| h.cos > 0.0).map(|h| h.patch).collect();
    if met.is_empty() || 2 * back.len() <= met.len() {
        return Ok(EyePlace::Clear);
    }
    let share = back.len() as f64 / met.len() as f64;
    Ok(if 10 * met.len() >= 9 * PROBES as usize {
        EyePlace::Inside { share, patch: back[0] }
    } else {
        EyePlace::Outside { share, patch: back[0] }
    })
}

/// The camera in normalised coordinates, refused when its eye is inside a
/// closed object or outside a closed scene (see [`eye_place`]).
///
/// # Errors
/// A one-line reason.
pub fn check_camera(
    tracer: &dyn Tracer,
    scene: &Scene,
    prepared: &Prepared,
    camera: &Camera,
) -> Result<Camera, super::RenderError> {
    let c = camera.normalised(prepared);
    let e = camera.eye;
    let (what, share, patch) = match eye_place(tracer, &c).map_err(super::RenderError::Backend)? {
        EyePlace::Clear => return Ok(c),
        EyePlace::Inside { share, patch } => ("is inside a closed object", share, patch),
        EyePlace::Outside { share, patch } => ("is outside the closed scene", share, patch),
    };
    Err(super::RenderError::CameraInside(format!(
        "camera eye ({}, {}, {}) {what}: {:.0}% of the surfaces seen from it are seen from behind (first: patch {:?})",
        e.x,
        e.y,
        e.z,
        share * 100.0,
        scene.patches[patch as usize].name
    )))
}
