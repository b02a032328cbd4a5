//! The 2D rigid transform of the registration.

/// A rigid transform of the plane mapping fixed-image points to
/// moving-image points (ITK's convention): `T(x) = R(θ)(x − c) + c + t`,
/// `c` the image centre in pixel coordinates, `θ` counter-clockwise in the
/// image's `(x, y)` axes.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Rigid2 {
    /// Rotation `θ`, degrees.
    pub angle_deg: f64,
    /// Translation along `x`, pixels.
    pub tx: f64,
    /// Translation along `y`, pixels.
    pub ty: f64,
}

impl Rigid2 {
    /// The parameter vector `(θ°, t_x, t_y)` the optimiser moves.
    #[must_use]
    pub fn params(&self) -> [f64; 3] {
        [self.angle_deg, self.tx, self.ty]
    }

    /// From a parameter vector `(θ°, t_x, t_y)`.
    #[must_use]
    pub fn from_params(p: [f64; 3]) -> Self {
        Self { angle_deg: p[0], tx: p[1], ty: p[2] }
    }

    /// `T(x, y)` about the centre `c`.
    #[inline]
    #[must_use]
    pub fn apply(&self, c: (f64, f64), x: f64, y: f64) -> (f64, f64) {
        let (s, co) = self.angle_deg.to_radians().sin_cos();
        let (dx, dy) = (x - c.0, y - c.1);
        (co * dx - s * dy + c.0 + self.tx, s * dx + co * dy + c.1 + self.ty)
    }

    /// The inverse transform about the same centre.
    #[must_use]
    pub fn inverse(&self) -> Self {
        let (s, co) = self.angle_deg.to_radians().sin_cos();
        // T⁻¹(y) = R(−θ)(y − c − t) + c: translation −R(−θ) t.
        Self { angle_deg: -self.angle_deg, tx: -(co * self.tx + s * self.ty), ty: -(-s * self.tx + co * self.ty) }
    }

    /// Largest displacement between `self` and `other` over the corners of a
    /// `w × h` image (a rigid map's difference is largest at a corner).
    #[must_use]
    pub fn corner_distance(&self, other: &Self, w: usize, h: usize) -> f64 {
        let c = centre(w, h);
        let (xm, ym) = ((w - 1) as f64, (h - 1) as f64);
        [(0.0, 0.0), (xm, 0.0), (0.0, ym), (xm, ym)]
            .iter()
            .map(|&(x, y)| {
                let (a, b) = (self.apply(c, x, y), other.apply(c, x, y));
                (a.0 - b.0).hypot(a.1 - b.1)
            })
            .fold(0.0, f64::max)
    }
}

/// The centre of a `w × h` image in pixel coordinates.
#[must_use]
pub fn centre(w: usize, h: usize) -> (f64, f64) {
    ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_round_trips() {
        let t = Rigid2 { angle_deg: 7.5, tx: 3.25, ty: -1.5 };
        let c = (31.5, 20.0);
        let (x, y) = t.apply(c, 10.0, 50.0);
        let (u, v) = t.inverse().apply(c, x, y);
        assert!((u - 10.0).abs() < 1e-12 && (v - 50.0).abs() < 1e-12);
        assert!(t.corner_distance(&t, 64, 41) < 1e-12);
    }
}
