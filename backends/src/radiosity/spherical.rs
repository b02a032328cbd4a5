//! Uniform sampling of the solid angle a planar convex polygon subtends
//! from a point (Arvo 1995, "Stratified sampling of spherical triangles"),
//! for the links' transport estimate: a direction uniform in solid angle,
//! weighted by `Ω cos θ_x / π`, is an unbiased estimate of the point's
//! form factor to the polygon (`F = (1/π) ∫_Ω cos θ_x dω`) whose weight is
//! bounded by `Ω / π`, unlike a uniform point of the polygon weighted by
//! the point-to-point kernel, whose weight is unbounded where the polygon
//! touches the point's surface.

use glam::DVec3;

use crate::viewpoint::solid_angle::triangle_solid_angle;

/// The angle at `a` of the spherical triangle `a, b, c` (unit vectors).
fn corner_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (tb, tc) = (b - a * a.dot(b), c - a * a.dot(c));
    tb.cross(tc).length().atan2(tb.dot(tc))
}

/// A direction uniform in the spherical triangle `a, b, c` (unit vectors,
/// solid angle `omega`) from two uniforms (Arvo's algorithm).
#[must_use]
pub fn sample_triangle(a: DVec3, b: DVec3, c: DVec3, omega: f64, u1: f64, u2: f64) -> DVec3 {
    let alpha = corner_angle(a, b, c);
    let area = u1 * omega;
    let (s, t) = (area - alpha).sin_cos();
    let u = t - alpha.cos();
    let v = s + alpha.sin() * a.dot(b);
    let den = (v * s + u * t) * alpha.sin();
    let q = if den.abs() > 0.0 { (((v * t - u * s) * alpha.cos() - v) / den).clamp(-1.0, 1.0) } else { a.dot(c) };
    let c_hat = a * q + (c - a * a.dot(c)).normalize_or_zero() * (1.0 - q * q).max(0.0).sqrt();
    let z = 1.0 - u2 * (1.0 - c_hat.dot(b));
    (b * z + (c_hat - b * c_hat.dot(b)).normalize_or_zero() * (1.0 - z * z).max(0.0).sqrt()).normalize_or_zero()
}

/// A point of the planar convex `polygon` (wholly in front of `x`) whose
/// direction from `x` is uniform in the polygon's solid angle, and that
/// solid angle; `None` when it is too small to sample this way (then a
/// uniform point of the polygon is as good: the kernel is nearly constant).
#[must_use]
pub fn sample_polygon(x: DVec3, polygon: &[DVec3], u0: f64, u1: f64, u2: f64) -> Option<(DVec3, f64)> {
    if polygon.len() < 3 {
        return None;
    }
    let d: Vec<DVec3> = polygon.iter().map(|p| *p - x).collect();
    let fan: Vec<f64> = (1..d.len() - 1).map(|t| triangle_solid_angle(d[0], d[t], d[t + 1])).collect();
    let omega: f64 = fan.iter().sum();
    if !(omega > 1e-6) {
        return None;
    }
    // A fan triangle chosen by solid angle.
    let mut target = u0 * omega;
    let mut t = 0;
    while t + 1 < fan.len() && target >= fan[t] {
        target -= fan[t];
        t += 1;
    }
    let w = sample_triangle(d[0].normalize(), d[t + 1].normalize(), d[t + 2].normalize(), fan[t], u1, u2);
    // Where the direction meets the polygon's plane.
    let n = (d[1] - d[0]).cross(d[2] - d[0]);
    let den = n.dot(w);
    if den.abs() <= 0.0 {
        return None;
    }
    let s = n.dot(d[0]) / den;
    (s > 0.0 && s.is_finite()).then(|| (x + w * s, omega))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lines::LineRng;
    use crate::radiosity::link::point_to_polygon;

    /// `(1/π) mean(Ω cos θ)` over uniform solid-angle samples is the point's
    /// form factor (Lambert's formula), near and far, and every sample lands
    /// on the polygon.
    #[test]
    fn solid_angle_samples_reproduce_the_point_to_polygon_factor() {
        let square = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        for (x, n) in [
            (DVec3::new(0.3, 0.4, 1.0), DVec3::NEG_Z),
            (DVec3::new(0.5, 0.5, 0.01), DVec3::NEG_Z),
            (DVec3::new(-0.001, 0.5, 0.3), DVec3::new(1.0, 0.0, -1.0).normalize()),
            (DVec3::new(2.0, 5.0, 40.0), DVec3::NEG_Z),
        ] {
            let rng = LineRng::new(3, 0);
            let m = 20_000u32;
            let mut sum = 0.0;
            for k in 0..m {
                let (y, omega) =
                    sample_polygon(x, &square, rng.uniform(3 * k), rng.uniform(3 * k + 1), rng.uniform(3 * k + 2))
                        .expect("a sample");
                assert!(y.z.abs() < 1e-9 && (-1e-9..=1.0 + 1e-9).contains(&y.x) && (-1e-9..=1.0 + 1e-9).contains(&y.y));
                sum += omega * n.dot((y - x).normalize()).max(0.0) / std::f64::consts::PI;
            }
            let f = sum / f64::from(m);
            let exact = point_to_polygon(x, n, &square);
            assert!((f - exact).abs() < 0.02 * exact, "{x}: {f} vs {exact}");
        }
    }
}
