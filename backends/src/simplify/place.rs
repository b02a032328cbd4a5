//! Where a full-edge collapse puts the vertex it keeps: the quadric error
//! of Garland and Heckbert (SIGGRAPH 1997), `Q(p) = Σ_planes A (n·p + d)²`
//! over the area-weighted planes of the triangles that have merged into a
//! vertex, and its minimiser. The tutorial's own collapses (Part VII's
//! syllabus, with Part V's channel) are half-edge ones that keep one of the
//! two vertices; [`Placement`] selects that form or a placed vertex.

use glam::DVec3;

/// How a collapse chooses the position of the vertex it keeps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Placement {
    /// Half-edge `u → v`: `v` stays where it is (the tutorial's form).
    Endpoint,
    /// Full-edge: the quadric's minimiser (or, where the quadric is
    /// singular or the minimiser folds a triangle over, the valid one of
    /// the midpoint and the two endpoints with the least quadric error);
    /// the viewpoint cost of the collapse with that vertex orders them.
    Quadric,
    /// As [`Placement::Quadric`], the order by the viewpoint cost plus
    /// `λ · Q(p) / A_T` (the quadric error as a mean squared distance over
    /// the surface's area `A_T`, in bounding-sphere radii²).
    Blend(f64),
    /// Full-edge: the viewpoint cost minimised over the quadric's
    /// minimiser, the midpoint and the two endpoints.
    Best,
}

/// A quadric `pᵀ A p + 2 bᵀ p + c` (`A` symmetric: `xx, xy, xz, yy, yz, zz`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quadric {
    a: [f64; 6],
    b: [f64; 3],
    c: f64,
}

impl std::ops::Add for Quadric {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            a: std::array::from_fn(|i| self.a[i] + o.a[i]),
            b: std::array::from_fn(|i| self.b[i] + o.b[i]),
            c: self.c + o.c,
        }
    }
}

impl Quadric {
    /// `w (n·p + d)²` for the plane `n·p + d = 0` (`n` a unit vector).
    #[must_use]
    pub fn plane(n: DVec3, d: f64, w: f64) -> Self {
        Self {
            a: [w * n.x * n.x, w * n.x * n.y, w * n.x * n.z, w * n.y * n.y, w * n.y * n.z, w * n.z * n.z],
            b: [w * n.x * d, w * n.y * d, w * n.z * d],
            c: w * d * d,
        }
    }

    /// The plane of triangle `t` weighted by its area (zero for a triangle
    /// without area).
    #[must_use]
    pub fn of_triangle(t: &[DVec3; 3]) -> Self {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let len = n.length();
        if len <= 0.0 {
            return Self::default();
        }
        let n = n / len;
        Self::plane(n, -n.dot(t[0]), 0.5 * len)
    }

    /// Garland and Heckbert's boundary constraint for the boundary edge
    /// `a`–`b` of triangle `t`: the plane through the edge perpendicular to
    /// the triangle, weighted by the edge's squared length (zero for a
    /// triangle or edge without extent).
    #[must_use]
    pub fn of_boundary_edge(t: &[DVec3; 3], a: DVec3, b: DVec3) -> Self {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let e = b - a;
        let m = e.cross(n);
        let len = m.length();
        if len <= 0.0 || !len.is_finite() {
            return Self::default();
        }
        let m = m / len;
        Self::plane(m, -m.dot(a), e.length_squared())
    }

    /// `w · Q`.
    #[must_use]
    pub fn scaled(self, w: f64) -> Self {
        Self { a: self.a.map(|x| w * x), b: self.b.map(|x| w * x), c: w * self.c }
    }

    /// `Q(p)`, clamped at 0 against rounding.
    #[must_use]
    pub fn error(&self, p: DVec3) -> f64 {
        let [xx, xy, xz, yy, yz, zz] = self.a;
        let ap =
            DVec3::new(xx * p.x + xy * p.y + xz * p.z, xy * p.x + yy * p.y + yz * p.z, xz * p.x + yz * p.y + zz * p.z);
        (p.dot(ap) + 2.0 * (self.b[0] * p.x + self.b[1] * p.y + self.b[2] * p.z) + self.c).max(0.0)
    }

    /// The minimiser of `Q`, solving `A p = −b` (Cramer's rule), or `None`
    /// where `A` is singular: `|det A|` at most `1e-10` of the product of
    /// its diagonal (planes all alike, as on a flat or cylindrical patch).
    #[must_use]
    pub fn minimiser(&self) -> Option<DVec3> {
        let [xx, xy, xz, yy, yz, zz] = self.a;
        let (c0, c1, c2) = (DVec3::new(xx, xy, xz), DVec3::new(xy, yy, yz), DVec3::new(xz, yz, zz));
        let det = c0.dot(c1.cross(c2));
        let scale = (xx * yy * zz).abs();
        if !(det.abs() > 1e-10 * scale) || scale == 0.0 {
            return None;
        }
        let r = -DVec3::from(self.b);
        let p = DVec3::new(r.dot(c1.cross(c2)), c0.dot(r.cross(c2)), c0.dot(c1.cross(r))) / det;
        p.is_finite().then_some(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_planes_meet_at_the_minimiser() {
        // The corner of a cube: x = 1, y = 2, z = -1 with different weights.
        let q = Quadric::plane(DVec3::X, -1.0, 2.0)
            + Quadric::plane(DVec3::Y, -2.0, 0.5)
            + Quadric::plane(DVec3::Z, 1.0, 3.0);
        let p = q.minimiser().unwrap();
        assert!((p - DVec3::new(1.0, 2.0, -1.0)).length() < 1e-12, "{p}");
        assert!(q.error(p) < 1e-20);
        // Away from it the error is the weighted squared distances.
        let e = q.error(DVec3::new(2.0, 2.0, 0.0));
        assert!((e - (2.0 + 3.0)).abs() < 1e-12, "{e}");
    }

    #[test]
    fn a_flat_patch_has_no_minimiser() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let q = Quadric::of_triangle(&t) + Quadric::of_triangle(&[DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
        assert_eq!(q.minimiser(), None);
        assert!(q.error(DVec3::new(0.3, 0.4, 0.0)) < 1e-20);
        assert!((q.error(DVec3::new(0.3, 0.4, 2.0)) - 4.0).abs() < 1e-12);
    }
}
