//! Triangulation of one OBJ polygon in its own plane: convex polygons are
//! fanned from their first vertex (as before, so a quad stays two
//! triangles `(0,1,2), (0,2,3)`), concave ones are ear-clipped, and
//! self-intersecting ones are refused.

use glam::{DVec2, DVec3};

/// Most vertices of one face; the simplicity check is quadratic and ear
/// clipping at worst cubic in this number.
pub const MAX_FACE_VERTICES: usize = 1024;

/// Largest distance of a vertex from the polygon's plane, relative to the
/// polygon's radius, below which a face counts as planar.
pub const PLANAR_TOLERANCE: f64 = 1e-6;

/// A triangulated polygon.
#[derive(Debug)]
pub struct Triangulated {
    /// Triangles with the polygon's winding, original vertices.
    pub triangles: Vec<[DVec3; 3]>,
    /// Largest distance of a vertex from the plane through the centroid
    /// (Newell normal), relative to the polygon's radius.
    pub deviation: f64,
}

/// Orientation of `c` relative to the line `a → b`, in units of the
/// polygon's radius squared (positive: left).
fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

/// Relative tolerance of orientation tests on coordinates of order 1.
const EPS: f64 = 1e-12;

/// Whether segments `p1p2` and `q1q2` intersect or touch.
fn segments_meet(p1: DVec2, p2: DVec2, q1: DVec2, q2: DVec2) -> bool {
    let (d1, d2) = (orient(q1, q2, p1), orient(q1, q2, p2));
    let (d3, d4) = (orient(p1, p2, q1), orient(p1, p2, q2));
    let on = |a: DVec2, b: DVec2, c: DVec2, d: f64| {
        d.abs() <= EPS
            && c.x >= a.x.min(b.x) - EPS
            && c.x <= a.x.max(b.x) + EPS
            && c.y >= a.y.min(b.y) - EPS
            && c.y <= a.y.max(b.y) + EPS
    };
    if ((d1 > EPS && d2 < -EPS) || (d1 < -EPS && d2 > EPS)) && ((d3 > EPS && d4 < -EPS) || (d3 < -EPS && d4 > EPS)) {
        return true;
    }
    on(q1, q2, p1, d1) || on(q1, q2, p2, d2) || on(p1, p2, q1, d3) || on(p1, p2, q2, d4)
}

/// The message of a polygon with no area.
pub const DEGENERATE: &str = "is degenerate (zero area)";

/// Triangulates `poly` (at least 3 vertices, finite coordinates).
///
/// # Errors
/// A message (without line) for a degenerate (zero-area), too large or
/// self-intersecting polygon.
pub fn triangulate(poly: &[DVec3]) -> Result<Triangulated, String> {
    let n = poly.len();
    if n > MAX_FACE_VERTICES {
        return Err(format!("has {n} vertices, at most {MAX_FACE_VERTICES} are supported"));
    }
    let centre = poly.iter().copied().sum::<DVec3>() / n as f64;
    let radius = poly.iter().map(|p| (*p - centre).abs().max_element()).fold(0.0, f64::max);
    if !(radius > 0.0 && radius.is_finite()) {
        return Err(DEGENERATE.into());
    }
    let q: Vec<DVec3> = poly.iter().map(|p| (*p - centre) / radius).collect();
    // Newell's normal: twice the vector area, exact for planar polygons.
    let newell: DVec3 = (0..n).map(|i| q[i].cross(q[(i + 1) % n])).sum();
    if !(newell.length() > 1e-12) {
        return Err(DEGENERATE.into());
    }
    let normal = newell.normalize();
    let deviation = q.iter().map(|p| p.dot(normal).abs()).fold(0.0, f64::max);
    if n == 3 {
        return Ok(Triangulated { triangles: vec![[poly[0], poly[1], poly[2]]], deviation });
    }
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    // Counter-clockwise in (u, v), since u × v = normal.
    let p2: Vec<DVec2> = q.iter().map(|p| DVec2::new(p.dot(u), p.dot(v))).collect();
    // Simple: no two edges meet except neighbours at their shared vertex,
    // and no neighbour folds back onto the other.
    for i in 0..n {
        let (a, b) = (p2[i], p2[(i + 1) % n]);
        if (b - a).length() <= EPS {
            return Err(format!("is self-intersecting (vertices {} and {} coincide)", i + 1, (i + 1) % n + 1));
        }
        let c = p2[(i + 2) % n];
        if orient(a, b, c).abs() <= EPS && (b - a).dot(c - b) < 0.0 {
            return Err(format!("is self-intersecting (it folds back at vertex {})", (i + 1) % n + 1));
        }
        for j in i + 2..n {
            if (j + 1) % n == i {
                continue;
            }
            if segments_meet(a, b, p2[j], p2[(j + 1) % n]) {
                return Err(format!("is self-intersecting (edges {} and {} meet)", i + 1, j + 1));
            }
        }
    }
    // The fan from vertex 0 when it has no flat triangle (a vertex on a
    // straight edge makes one): then ear clipping, which skips flat corners.
    let convex = (0..n).all(|i| orient(p2[i], p2[(i + 1) % n], p2[(i + 2) % n]) >= -EPS)
        && (1..n - 1).all(|k| orient(p2[0], p2[k], p2[k + 1]) > EPS);
    let mut triangles = Vec::with_capacity(n - 2);
    if convex {
        for k in 1..n - 1 {
            triangles.push([poly[0], poly[k], poly[k + 1]]);
        }
        return Ok(Triangulated { triangles, deviation });
    }
    // Ear clipping: a convex corner whose triangle holds no other vertex.
    let mut idx: Vec<usize> = (0..n).collect();
    while idx.len() > 3 {
        let m = idx.len();
        let ear = (0..m).find(|&k| {
            let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
            if orient(p2[a], p2[b], p2[c]) <= EPS {
                return false;
            }
            idx.iter().all(|&o| {
                o == a
                    || o == b
                    || o == c
                    || orient(p2[a], p2[b], p2[o]) < -EPS
                    || orient(p2[b], p2[c], p2[o]) < -EPS
                    || orient(p2[c], p2[a], p2[o]) < -EPS
            })
        });
        let Some(k) = ear else {
            return Err("could not be triangulated (no ear found)".into());
        };
        let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
        triangles.push([poly[a], poly[b], poly[c]]);
        idx.remove(k);
    }
    triangles.push([poly[idx[0]], poly[idx[1]], poly[idx[2]]]);
    Ok(Triangulated { triangles, deviation })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(t: &[[DVec3; 3]]) -> f64 {
        t.iter().map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()).sum()
    }

    #[test]
    fn concave_polygon_area_is_the_shoelace_area() {
        // An arrow: area 2.2 by the shoelace formula; a fan from vertex 0 covers 3.8.
        let p: Vec<DVec3> = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (1.0, 0.2), (0.0, 2.0)]
            .iter()
            .map(|&(x, y)| DVec3::new(x, y, 0.0))
            .collect();
        let t = triangulate(&p).unwrap();
        assert_eq!(t.triangles.len(), 3);
        assert!((area(&t.triangles) - 2.2).abs() < 1e-12, "{}", area(&t.triangles));
        for tri in &t.triangles {
            assert!((tri[1] - tri[0]).cross(tri[2] - tri[0]).z > 0.0, "winding kept");
        }
    }

    #[test]
    fn vertex_on_a_straight_edge_gives_no_flat_triangle() {
        let p: Vec<DVec3> = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0)]
            .iter()
            .map(|&(x, y)| DVec3::new(x, y, 0.0))
            .collect();
        let t = triangulate(&p).unwrap();
        assert!((area(&t.triangles) - 2.0).abs() < 1e-12);
        for tri in &t.triangles {
            assert!((tri[1] - tri[0]).cross(tri[2] - tri[0]).z > 1e-9, "{tri:?}");
        }
    }

    #[test]
    fn bowtie_is_refused() {
        let p: Vec<DVec3> =
            [(0.0, 0.0), (2.0, 2.0), (2.0, 0.0), (0.0, 1.0)].iter().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect();
        assert!(triangulate(&p).unwrap_err().contains("self-intersecting"));
    }

    #[test]
    fn convex_quad_is_fanned_and_planar() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let t = triangulate(&p).unwrap();
        assert_eq!(t.triangles, vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]]]);
        assert!(t.deviation < 1e-15);
        let bent = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.3), DVec3::Y];
        assert!(triangulate(&bent).unwrap().deviation > 0.05);
    }
}
