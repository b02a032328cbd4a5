//! The element hierarchy: one root per input polygon (a planar quad, or
//! each triangle of any other patch), split 4-ways in its own parameter
//! space (a quadtree over the patch).
//!
//! A quad root maps `(u, v) ∈ [0,1]²` bilinearly onto its four corners;
//! for a planar quad the image of a parameter rectangle is a convex quad
//! with straight edges, so children are exactly the four quads through the
//! edge midpoints and the centre. A triangle root uses barycentric
//! parameters `(b1, b2)`; children are the four midpoint triangles.

use glam::{DVec2, DVec3};

use crate::scene::Scene;

/// Index of an element in [`Hierarchy::elements`].
pub type ElementId = u32;

/// The shape of a root polygon in scene space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RootShape {
    /// A planar quad `q0 q1 q2 q3` (counter-clockwise seen from the front).
    Quad([DVec3; 4]),
    /// A triangle `a b c`.
    Triangle([DVec3; 3]),
}

impl RootShape {
    /// The scene point at parameter `p`.
    #[must_use]
    pub fn point(&self, p: DVec2) -> DVec3 {
        match self {
            RootShape::Quad(q) => {
                let (u, v) = (p.x, p.y);
                q[0] * ((1.0 - u) * (1.0 - v)) + q[1] * (u * (1.0 - v)) + q[2] * (u * v) + q[3] * ((1.0 - u) * v)
            }
            RootShape::Triangle(t) => t[0] * (1.0 - p.x - p.y) + t[1] * p.x + t[2] * p.y,
        }
    }

    /// The parameter of a scene point on the polygon's plane (Newton on the
    /// bilinear map for quads, a few steps from the parallelogram guess).
    #[must_use]
    pub fn parameter(&self, x: DVec3) -> DVec2 {
        match self {
            RootShape::Triangle(t) => solve2(t[1] - t[0], t[2] - t[0], x - t[0]),
            RootShape::Quad(q) => {
                let mut p = solve2(q[1] - q[0], q[3] - q[0], x - q[0]);
                for _ in 0..8 {
                    let (u, v) = (p.x, p.y);
                    let du = (q[1] - q[0]) * (1.0 - v) + (q[2] - q[3]) * v;
                    let dv = (q[3] - q[0]) * (1.0 - u) + (q[2] - q[1]) * u;
                    let step = solve2(du, dv, x - self.point(p));
                    p += step;
                    if step.length_squared() < 1e-24 {
                        break;
                    }
                }
                p
            }
        }
    }
}

/// Least-squares `(a, b)` with `a·e1 + b·e2 ≈ r`.
fn solve2(e1: DVec3, e2: DVec3, r: DVec3) -> DVec2 {
    let (a11, a12, a22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (b1, b2) = (e1.dot(r), e2.dot(r));
    let det = a11 * a22 - a12 * a12;
    if det.abs() <= f64::MIN_POSITIVE {
        return DVec2::ZERO;
    }
    DVec2::new((b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det)
}

/// One root polygon.
#[derive(Clone, Debug, PartialEq)]
pub struct Root {
    /// Its shape.
    pub shape: RootShape,
    /// The scene patch it belongs to.
    pub patch: u32,
    /// Its element (the top of its quadtree).
    pub element: ElementId,
}

/// One element: a region of a root in parameter space.
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    /// Root it belongs to.
    pub root: u32,
    /// Corners in the root's parameter space (3 used for triangles).
    pub param: [DVec2; 4],
    /// 3 or 4 corners.
    pub corners: u8,
    /// Corners in scene space.
    pub points: [DVec3; 4],
    /// Area.
    pub area: f64,
    /// Unit front normal.
    pub normal: DVec3,
    /// Children (first child index; always 4 consecutive), if split.
    pub children: Option<ElementId>,
    /// Depth below its root.
    pub level: u8,
}

impl Element {
    /// Centroid of the corners.
    #[must_use]
    pub fn centre(&self) -> DVec3 {
        let n = usize::from(self.corners);
        self.points[..n].iter().copied().sum::<DVec3>() / n as f64
    }

    /// A uniform point on the element from two uniforms in `[0, 1)`.
    #[must_use]
    pub fn sample(&self, u1: f64, u2: f64) -> DVec3 {
        let p = &self.points;
        let (a, b, c, u1) = if self.corners == 4 {
            // One of the two triangles by area, u1 reused for the rest.
            let a0 = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
            let f = if self.area > 0.0 { (a0 / self.area).clamp(1e-12, 1.0 - 1e-12) } else { 0.5 };
            if u1 < f { (p[0], p[1], p[2], u1 / f) } else { (p[0], p[2], p[3], (u1 - f) / (1.0 - f)) }
        } else {
            (p[0], p[1], p[2], u1)
        };
        let s = u1.sqrt();
        a * (1.0 - s) + b * (s * (1.0 - u2)) + c * (s * u2)
    }

    /// Whether parameter `p` lies in this element (closed, with slack `tol`).
    #[must_use]
    pub fn contains(&self, p: DVec2, tol: f64) -> bool {
        let n = usize::from(self.corners);
        (0..n).all(|k| {
            let (a, b) = (self.param[k], self.param[(k + 1) % n]);
            (b - a).perp_dot(p - a) >= -tol * (b - a).length()
        })
    }
}

/// The elements of a scene: roots and their quadtrees.
#[derive(Clone, Debug, Default)]
pub struct Hierarchy {
    /// Root polygons.
    pub roots: Vec<Root>,
    /// Roots of each triangle of the scene (the index into `roots`).
    pub triangle_root: Vec<u32>,
    /// Every element ever made (interior and leaves).
    pub elements: Vec<Element>,
}

fn element_from(shape: &RootShape, root: u32, param: [DVec2; 4], corners: u8, level: u8) -> Element {
    let mut points = [DVec3::ZERO; 4];
    for k in 0..usize::from(corners) {
        points[k] = shape.point(param[k]);
    }
    let (area, normal) = if corners == 4 {
        let n =
            (points[1] - points[0]).cross(points[2] - points[0]) + (points[2] - points[0]).cross(points[3] - points[0]);
        (0.5 * n.length(), n.normalize_or_zero())
    } else {
        let n = (points[1] - points[0]).cross(points[2] - points[0]);
        (0.5 * n.length(), n.normalize_or_zero())
    };
    Element { root, param, corners, points, area, normal, children: None, level }
}

/// Whether two fan triangles `[a,b,c]`, `[a,c,d]` form a planar convex quad.
fn planar_quad(t0: &[DVec3; 3], t1: &[DVec3; 3]) -> Option<[DVec3; 4]> {
    if t0[0] != t1[0] || t0[2] != t1[1] {
        return None;
    }
    let q = [t0[0], t0[1], t0[2], t1[2]];
    let n0 = (q[1] - q[0]).cross(q[2] - q[0]);
    let n1 = (q[2] - q[0]).cross(q[3] - q[0]);
    let scale = n0.length().max(n1.length());
    if scale <= 0.0 || n0.cross(n1).length() > 1e-9 * scale * scale.max(1.0) || n0.dot(n1) <= 0.0 {
        return None;
    }
    // Convex: every corner turns the same way.
    let n = n0 + n1;
    let convex = (0..4).all(|k| (q[(k + 1) % 4] - q[k]).cross(q[(k + 2) % 4] - q[(k + 1) % 4]).dot(n) > 0.0);
    convex.then_some(q)
}

impl Hierarchy {
    /// Roots for every patch of `scene`: its two fan triangles as one quad
    /// when they form a planar convex quad, otherwise one root per triangle.
    #[must_use]
    pub fn new(scene: &Scene) -> Self {
        let mut by_patch: Vec<Vec<usize>> = vec![Vec::new(); scene.patches.len()];
        for (t, &p) in scene.triangle_patch.iter().enumerate() {
            by_patch[p as usize].push(t);
        }
        let mut h = Hierarchy { triangle_root: vec![0; scene.triangles.len()], ..Hierarchy::default() };
        for (patch, tris) in by_patch.iter().enumerate() {
            let quad =
                if tris.len() == 2 { planar_quad(&scene.triangles[tris[0]], &scene.triangles[tris[1]]) } else { None };
            if let Some(q) = quad {
                let r = h.add_root(RootShape::Quad(q), patch as u32);
                for &t in tris {
                    h.triangle_root[t] = r;
                }
            } else {
                for &t in tris {
                    h.triangle_root[t] = h.add_root(RootShape::Triangle(scene.triangles[t]), patch as u32);
                }
            }
        }
        h
    }

    fn add_root(&mut self, shape: RootShape, patch: u32) -> u32 {
        let r = self.roots.len() as u32;
        let e = self.elements.len() as ElementId;
        let (param, corners) = match shape {
            RootShape::Quad(_) => ([DVec2::ZERO, DVec2::X, DVec2::ONE, DVec2::Y], 4),
            RootShape::Triangle(_) => ([DVec2::ZERO, DVec2::X, DVec2::Y, DVec2::ZERO], 3),
        };
        self.elements.push(element_from(&shape, r, param, corners, 0));
        self.roots.push(Root { shape, patch, element: e });
        r
    }

    /// Splits a leaf into four children; returns the first child.
    pub fn split(&mut self, e: ElementId) -> ElementId {
        if let Some(c) = self.elements[e as usize].children {
            return c;
        }
        let el = self.elements[e as usize].clone();
        let shape = self.roots[el.root as usize].shape;
        let first = self.elements.len() as ElementId;
        let p = el.param;
        let level = el.level.saturating_add(1);
        let kids: [([DVec2; 4], u8); 4] = if el.corners == 4 {
            let m = |a: DVec2, b: DVec2| (a + b) * 0.5;
            let c = (p[0] + p[2]) * 0.5;
            [
                ([p[0], m(p[0], p[1]), c, m(p[3], p[0])], 4),
                ([m(p[0], p[1]), p[1], m(p[1], p[2]), c], 4),
                ([c, m(p[1], p[2]), p[2], m(p[2], p[3])], 4),
                ([m(p[3], p[0]), c, m(p[2], p[3]), p[3]], 4),
            ]
        } else {
            let (a, b, c) = (p[0], p[1], p[2]);
            let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
            [([a, ab, ca, a], 3), ([ab, b, bc, ab], 3), ([ca, bc, c, ca], 3), ([bc, ca, ab, bc], 3)]
        };
        for (param, corners) in kids {
            self.elements.push(element_from(&shape, el.root, param, corners, level));
        }
        self.elements[e as usize].children = Some(first);
        first
    }

    /// The leaf of root `r` containing parameter `p`.
    #[must_use]
    pub fn locate(&self, r: u32, p: DVec2) -> ElementId {
        self.locate_below(self.roots[r as usize].element, p)
    }

    /// The leaf under element `e` (itself when a leaf) containing parameter
    /// `p` of `e`'s root; a point outside `e` goes to the nearest child at
    /// each level.
    #[must_use]
    pub fn locate_below(&self, e: ElementId, p: DVec2) -> ElementId {
        let mut e = e;
        while let Some(c) = self.elements[e as usize].children {
            let next = (c..c + 4).find(|&k| self.elements[k as usize].contains(p, 1e-9));
            // A point just outside every child (rounding): the nearest centre.
            e = next.unwrap_or_else(|| {
                (c..c + 4)
                    .min_by(|&a, &b| {
                        let d = |k: ElementId| {
                            let el = &self.elements[k as usize];
                            let n = usize::from(el.corners);
                            (el.param[..n].iter().copied().sum::<DVec2>() / n as f64 - p).length()
                        };
                        d(a).total_cmp(&d(b))
                    })
                    .unwrap_or(c)
            });
        }
        e
    }

    /// Leaves, in element order.
    #[must_use]
    pub fn leaves(&self) -> Vec<ElementId> {
        (0..self.elements.len() as ElementId).filter(|&e| self.elements[e as usize].children.is_none()).collect()
    }

    /// The patch of an element.
    #[must_use]
    pub fn patch(&self, e: ElementId) -> u32 {
        self.roots[self.elements[e as usize].root as usize].patch
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_split_into_four_equal_area_children_and_locate_points() {
        let mut s = Scene::named("t");
        let q = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(1.5, 1.0, 0.0), DVec3::new(0.5, 1.0, 0.0)];
        s.add_polygon("trapezoid", &q, 0);
        let mut h = Hierarchy::new(&s);
        assert_eq!(h.roots.len(), 1);
        assert!(matches!(h.roots[0].shape, RootShape::Quad(_)));
        let c = h.split(0);
        let total: f64 = (c..c + 4).map(|k| h.elements[k as usize].area).sum();
        assert!((total - 1.5).abs() < 1e-12);
        let x = DVec3::new(1.4, 0.8, 0.0);
        let p = h.roots[0].shape.parameter(x);
        assert!((h.roots[0].shape.point(p) - x).length() < 1e-12);
        let leaf = h.locate(0, p);
        let el = &h.elements[leaf as usize];
        assert!(el.contains(p, 0.0), "the leaf found contains the point");
        // Uniform samples land inside the element.
        for k in 0..50 {
            let y = el.sample((f64::from(k) + 0.5) / 50.0, 0.37);
            assert!(el.contains(h.roots[0].shape.parameter(y), 1e-9));
        }
    }

    #[test]
    fn triangles_split_into_four_and_locate_points() {
        let mut s = Scene::named("t");
        s.add_polygon("tri", &[DVec3::ZERO, DVec3::X, DVec3::Y], 0);
        let mut h = Hierarchy::new(&s);
        let c = h.split(0);
        for k in c..c + 4 {
            assert!((h.elements[k as usize].area - 0.125).abs() < 1e-12);
        }
        let leaf = h.locate(0, DVec2::new(0.3, 0.3));
        assert_eq!(leaf, c + 3, "the middle triangle");
    }
}
