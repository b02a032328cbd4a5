//! A pinhole camera: pixel `(x, y)` of a `w × h` image to a ray.
//!
//! Cameras are stated in scene units (`--camera eye,target,up,fov`) and
//! traced in the tracer's normalised coordinates (`Camera::normalised`, defined
//! beside [`crate::tracer::Prepared`] so that the camera sits below the tracer).
//! Pixel `(0, 0)` is the top-left; `(x + 0.5, y + 0.5)` is a pixel's centre.

use glam::DVec3;

use crate::lines::Line;

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: DVec3,
    /// Unit viewing direction.
    pub forward: DVec3,
    /// Unit right vector of the image plane.
    pub right: DVec3,
    /// Unit up vector of the image plane.
    pub up: DVec3,
    /// Vertical field of view, radians.
    pub fov_y: f64,
}

/// Why a camera cannot be built.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CameraError(pub String);

impl std::fmt::Display for CameraError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for CameraError {}

impl Camera {
    /// A camera at `eye` looking at `target`, `up` roughly up, vertical
    /// field of view `fov_y_degrees`.
    ///
    /// # Errors
    /// Non-finite values, `eye == target`, `up` parallel to the view, or a
    /// field of view outside (0°, 179°].
    pub fn look_at(eye: DVec3, target: DVec3, up: DVec3, fov_y_degrees: f64) -> Result<Self, CameraError> {
        if !(eye.is_finite() && target.is_finite() && up.is_finite() && fov_y_degrees.is_finite()) {
            return Err(CameraError("camera values must be finite".into()));
        }
        if !(fov_y_degrees > 0.0 && fov_y_degrees <= 179.0) {
            return Err(CameraError(format!("field of view {fov_y_degrees}° is outside (0, 179]")));
        }
        let forward =
            (target - eye).try_normalize().ok_or_else(|| CameraError("camera eye equals its target".into()))?;
        let right = forward
            .cross(up)
            .try_normalize()
            .filter(|_| forward.cross(up.normalize_or_zero()).length() > 1e-9)
            .ok_or_else(|| CameraError("camera up vector is zero or parallel to the view direction".into()))?;
        let up = right.cross(forward);
        Ok(Self { eye, forward, right, up, fov_y: fov_y_degrees.to_radians() })
    }

    /// A camera at `eye` looking at the origin with `y` (or `z` when looking
    /// along `y`) up, framing the unit sphere with a margin: the preview
    /// camera of the analyses, in normalised coordinates.
    #[must_use]
    pub fn framing_unit_sphere(eye: DVec3) -> Self {
        let fwd = (-eye).normalize();
        let up = if fwd.cross(DVec3::Y).length() < 1e-6 { DVec3::Z } else { DVec3::Y };
        let half = (1.15 / eye.length()).min(0.9).asin();
        Self::look_at(eye, DVec3::ZERO, up, 2.0 * half.to_degrees()).expect("a finite eye away from the origin")
    }

    /// Unit direction through image point `(sx, sy)` in pixels (fractional:
    /// `x + 0.5` is a pixel's centre) of a `w × h` image.
    #[must_use]
    pub fn direction(&self, sx: f64, sy: f64, w: u32, h: u32) -> DVec3 {
        self.direction_tan(self.tan_half_fov(), sx, sy, w, h)
    }

    /// `tan(fov_y / 2)`, the scale of the image plane at unit distance:
    /// computed once for many [`Camera::direction_tan`] calls (a library
    /// `tan` per camera ray was about 0.5–0.8% of a render).
    #[must_use]
    pub fn tan_half_fov(&self) -> f64 {
        (self.fov_y * 0.5).tan()
    }

    /// [`Camera::direction`] with `tan` = [`Camera::tan_half_fov`] given:
    /// the same arithmetic, so the same bits.
    #[must_use]
    pub fn direction_tan(&self, tan: f64, sx: f64, sy: f64, w: u32, h: u32) -> DVec3 {
        let aspect = f64::from(w) / f64::from(h);
        let u = (2.0 * sx / f64::from(w) - 1.0) * tan * aspect;
        let v = (1.0 - 2.0 * sy / f64::from(h)) * tan;
        (self.forward + self.right * u + self.up * v).normalize()
    }

    /// The ray through image point `(sx, sy)`, out to `tmax`.
    #[must_use]
    pub fn ray(&self, sx: f64, sy: f64, w: u32, h: u32, tmax: f64) -> Line {
        Line::ray(self.eye, self.direction(sx, sy, w, h), 0.0, tmax)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_forward_and_corners_span_the_field_of_view() {
        let c = Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 90.0).unwrap();
        assert!((c.direction(50.0, 50.0, 100, 100) - DVec3::NEG_Z).length() < 1e-12);
        let top = c.direction(50.0, 0.0, 100, 100);
        assert!((top.angle_between(DVec3::NEG_Z) - 45f64.to_radians()).abs() < 1e-12);
        assert!(top.y > 0.0, "row 0 is the top");
        assert!(c.direction(100.0, 50.0, 100, 100).x > 0.0, "column w-1 is on the right");
    }

    #[test]
    fn direction_with_the_tangent_given_is_direction() {
        let c = Camera::look_at(DVec3::new(0.3, 0.2, 5.0), DVec3::ZERO, DVec3::Y, 37.0).unwrap();
        let tan = c.tan_half_fov();
        for (sx, sy) in [(0.0, 0.0), (12.25, 7.5), (63.9, 31.1)] {
            assert_eq!(c.direction(sx, sy, 64, 32), c.direction_tan(tan, sx, sy, 64, 32));
        }
    }

    #[test]
    fn bad_cameras_are_refused() {
        assert!(Camera::look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 40.0).is_err());
        assert!(Camera::look_at(DVec3::Z, DVec3::ZERO, DVec3::Z, 40.0).is_err());
        assert!(Camera::look_at(DVec3::Z, DVec3::ZERO, DVec3::Y, 0.0).is_err());
        assert!(Camera::look_at(DVec3::Z, DVec3::ZERO, DVec3::Y, 180.0).is_err());
        assert!(Camera::look_at(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ZERO, DVec3::Y, 40.0).is_err());
    }
}
