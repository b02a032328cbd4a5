//! Pictures of a solution: what each pixel of a camera sees (first
//! front-facing surface, through [`Tracer::closest_hit`]), the
//! Gouraud-shaded radiosity there, and the mesh drawn as element edges.

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::Rgb;
use super::element::{ElementId, Hierarchy};
use crate::backend::BackendError;
use crate::camera::Camera;
use crate::lines::Line;
use crate::scene::{BuiltIn, Scene, scene_camera};
use crate::tracer::{Hit, Prepared, Tracer};

/// The surface point a pixel sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sight {
    /// Root polygon hit.
    pub root: u32,
    /// Parameter of the point in its root.
    pub param: DVec2,
    /// Scene-space point.
    pub point: DVec3,
    /// Unit front normal.
    pub normal: DVec3,
    /// Scene patch.
    pub patch: u32,
}

/// What every pixel of a `width × height` camera image sees (row-major, top row first).
#[derive(Clone, Debug)]
pub struct View {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The surface each pixel centre sees, if any.
    pub sights: Vec<Option<Sight>>,
}

/// The camera pictures use: the scene's own view ([`scene_camera`] with
/// [`BuiltIn::radiosity_camera`]: a file's camera, else the registry
/// entry's: the Cornell box's published camera outside its front wall,
/// the views of `render` for the other built-ins that have one), otherwise
/// a view from a corner of the bounding box's front-right-top framing the
/// scene (wider than `render`'s, since the pictures may look through the
/// walls that face away). Subdivided scenes keep their built-in's camera.
#[must_use]
pub fn default_camera(scene: &Scene) -> Camera {
    if let Some(c) = scene_camera(scene, BuiltIn::radiosity_camera) {
        return c;
    }
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo) * 0.5).length().max(f64::MIN_POSITIVE);
    let eye = centre + DVec3::new(0.9, 0.7, 1.6).normalize() * radius * 2.6;
    let up = if (eye - centre).cross(DVec3::Y).length() < 1e-9 * radius { DVec3::Z } else { DVec3::Y };
    Camera::look_at(eye, centre, up, 2.0 * (1.1 / 2.6f64).asin().to_degrees())
        .unwrap_or_else(|_| Camera::framing_unit_sphere(DVec3::new(0.9, 0.7, 1.6).normalize() * 2.6))
}

/// Traces the view: pixel centres, back faces looked through (a few rounds).
///
/// # Errors
/// Tracing errors.
pub fn view(
    scene: &Scene,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    h: &Hierarchy,
    camera: &Camera,
    size: (u32, u32),
) -> Result<View, BackendError> {
    let (w, hgt) = size;
    let cam = camera.normalised(prepared);
    let reach = cam.eye.length() + 2.0;
    let mut lines: Vec<Line> = (0..hgt)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| cam.ray(f64::from(x) + 0.5, f64::from(y) + 0.5, w, hgt, reach))
        .collect();
    let mut hits = closest(tracer, &lines)?;
    for _ in 0..8 {
        let pending: Vec<usize> = (0..hits.len()).filter(|&i| hits[i].is_some_and(|c| c.cos >= 0.0)).collect();
        if pending.is_empty() {
            break;
        }
        let batch: Vec<Line> =
            pending.iter().map(|&i| Line { tmin: hits[i].map_or(0.0, |c| c.t) + 1e-6, ..lines[i] }).collect();
        let again = closest(tracer, &batch)?;
        for (k, &i) in pending.iter().enumerate() {
            lines[i] = batch[k];
            hits[i] = again[k];
        }
    }
    let sights = hits.iter().map(|hit| hit.filter(|c| c.cos < 0.0).map(|c| sight(scene, h, &c))).collect();
    Ok(View { width: w, height: hgt, sights })
}

/// The scene point, root and parameter of a hit.
#[must_use]
pub fn sight(scene: &Scene, h: &Hierarchy, c: &Hit) -> Sight {
    let t = scene.triangles[c.primitive as usize];
    let (b1, b2) = (f64::from(c.barycentric[0]), f64::from(c.barycentric[1]));
    let point = t[0] * (1.0 - b1 - b2) + t[1] * b1 + t[2] * b2;
    let root = h.triangle_root[c.primitive as usize];
    let param = h.roots[root as usize].shape.parameter(point);
    let normal = DVec3::new(f64::from(c.normal[0]), f64::from(c.normal[1]), f64::from(c.normal[2]));
    Sight { root, param, point, normal, patch: c.patch }
}

/// Closest hits of many lines, in parallel batches.
///
/// # Errors
/// Tracing errors.
pub fn closest(tracer: &dyn Tracer, lines: &[Line]) -> Result<Vec<Option<Hit>>, BackendError> {
    let parts: Vec<Vec<Option<Hit>>> = lines
        .par_chunks(4096)
        .map(|c| {
            let mut out = Vec::new();
            tracer.closest_hit(c, &mut out).map(|()| out)
        })
        .collect::<Result<_, _>>()?;
    Ok(parts.into_iter().flatten().collect())
}

/// Vertex radiosities: each leaf corner gets the area-weighted mean of the
/// leaves of its patch that share it (by position, so the two triangles of a
/// non-planar quad are smoothed across their diagonal too).
#[derive(Clone, Debug)]
pub struct Vertices {
    map: HashMap<(u32, [i64; 3]), Rgb>,
    quantum: f64,
}

impl Vertices {
    fn key(&self, patch: u32, p: DVec3) -> (u32, [i64; 3]) {
        (patch, (p / self.quantum).round().as_i64vec3().to_array())
    }

    /// The vertex value at corner `k` of leaf `e`, if known.
    #[must_use]
    pub fn get(&self, h: &Hierarchy, e: ElementId, k: usize) -> Option<Rgb> {
        let el = &h.elements[e as usize];
        self.map.get(&self.key(h.roots[el.root as usize].patch, el.points[k])).copied()
    }
}

/// The [`Vertices`] of a solution.
#[must_use]
pub fn vertex_radiosity(h: &Hierarchy, radiosity: &[Rgb]) -> Vertices {
    let mut size = 0.0f64;
    for r in &h.roots {
        size = size.max(h.elements[r.element as usize].points.iter().fold(0.0f64, |m, p| m.max(p.abs().max_element())));
    }
    let mut v = Vertices { map: HashMap::new(), quantum: (size * 1e-7).max(f64::MIN_POSITIVE) };
    let mut acc: HashMap<(u32, [i64; 3]), (Rgb, f64)> = HashMap::new();
    for e in h.leaves() {
        let el = &h.elements[e as usize];
        let patch = h.roots[el.root as usize].patch;
        for p in &el.points[..usize::from(el.corners)] {
            let a = acc.entry(v.key(patch, *p)).or_insert(([0.0; 3], 0.0));
            for (s, b) in a.0.iter_mut().zip(radiosity[e as usize]) {
                *s += el.area * b;
            }
            a.1 += el.area;
        }
    }
    v.map = acc.into_iter().map(|(k, (s, a))| (k, if a > 0.0 { s.map(|x| x / a) } else { s })).collect();
    v
}

/// The leaves as one polygon mesh: shared corners (per patch, by position,
/// as [`Vertices`] shares them), each corner's Gouraud vertex radiosity, and
/// each leaf's corner indices (3 or 4, counter-clockwise as the element).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LeafMesh {
    /// Corner positions in scene space.
    pub positions: Vec<DVec3>,
    /// Radiosity at each corner (the [`vertex_radiosity`] value).
    pub radiosity: Vec<Rgb>,
    /// Corner indices of each leaf, in leaf order.
    pub faces: Vec<Vec<u32>>,
}

/// The [`LeafMesh`] of a solution.
#[must_use]
pub fn leaf_mesh(h: &Hierarchy, radiosity: &[Rgb]) -> LeafMesh {
    let vertices = vertex_radiosity(h, radiosity);
    let mut index: HashMap<(u32, [i64; 3]), u32> = HashMap::new();
    let mut mesh = LeafMesh::default();
    for e in h.leaves() {
        let el = &h.elements[e as usize];
        let patch = h.roots[el.root as usize].patch;
        let mut face = Vec::with_capacity(usize::from(el.corners));
        for (k, p) in el.points[..usize::from(el.corners)].iter().enumerate() {
            let i = *index.entry(vertices.key(patch, *p)).or_insert_with(|| {
                mesh.positions.push(*p);
                mesh.radiosity.push(vertices.get(h, e, k).unwrap_or(radiosity[e as usize]));
                (mesh.positions.len() - 1) as u32
            });
            face.push(i);
        }
        mesh.faces.push(face);
    }
    mesh
}

/// Radiosity at a sight: the leaf's own value (`flat`) or interpolated from
/// its corners' vertex values (Gouraud: bilinear on quads, linear on triangles).
#[must_use]
pub fn shade(h: &Hierarchy, radiosity: &[Rgb], vertices: Option<&Vertices>, s: &Sight) -> (ElementId, Rgb) {
    let e = h.locate(s.root, s.param);
    let el = &h.elements[e as usize];
    let Some(vs) = vertices else { return (e, radiosity[e as usize]) };
    let v = |k: usize| vs.get(h, e, k).unwrap_or(radiosity[e as usize]);
    let p = &el.param;
    let weights: Vec<(usize, f64)> = if el.corners == 4 {
        let (d, q) = (p[2] - p[0], s.param - p[0]);
        let (u, w) = ((q.x / d.x).clamp(0.0, 1.0), (q.y / d.y).clamp(0.0, 1.0));
        vec![(0, (1.0 - u) * (1.0 - w)), (1, u * (1.0 - w)), (2, u * w), (3, (1.0 - u) * w)]
    } else {
        let area = (p[1] - p[0]).perp_dot(p[2] - p[0]);
        let q = s.param - p[0];
        let (l1, l2) = if area == 0.0 {
            (0.0, 0.0)
        } else {
            ((q.perp_dot(p[2] - p[0]) / area).clamp(0.0, 1.0), ((p[1] - p[0]).perp_dot(q) / area).clamp(0.0, 1.0))
        };
        vec![(0, (1.0 - l1 - l2).max(0.0)), (1, l1), (2, l2)]
    };
    let mut out = [0.0; 3];
    for (k, wk) in weights {
        let vk = v(k);
        for c in 0..3 {
            out[c] += wk * vk[c];
        }
    }
    (e, out)
}

/// The solution seen by `view`: radiosity per pixel (`None`: background)
/// and the leaf each pixel shows.
#[must_use]
pub fn picture(
    h: &Hierarchy,
    radiosity: &[Rgb],
    view: &View,
    gouraud: bool,
) -> (Vec<Option<Rgb>>, Vec<Option<ElementId>>) {
    let vs = gouraud.then(|| vertex_radiosity(h, radiosity));
    view.sights
        .par_iter()
        .map(|s| match s {
            Some(s) => {
                let (e, b) = shade(h, radiosity, vs.as_ref(), s);
                (Some(b), Some(e))
            }
            None => (None, None),
        })
        .unzip()
}

/// Display value of a linear radiosity: `(x / white)^(1/2.2)`, clamped, in 0..=255.
#[must_use]
pub fn tonemap(x: Rgb, white: f64) -> [u8; 3] {
    x.map(|v| (255.0 * (v / white).clamp(0.0, 1.0).powf(1.0 / 2.2)).round() as u8)
}

/// The white point of a picture: the 95th percentile of the largest channel.
#[must_use]
pub fn white_point(px: &[Option<Rgb>]) -> f64 {
    let mut v: Vec<f64> = px.iter().flatten().map(|c| c[0].max(c[1]).max(c[2])).collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(f64::total_cmp);
    let w = v[((v.len() - 1) as f64 * 0.95) as usize];
    if w > 0.0 { w } else { 1.0 }
}

/// The mesh: each leaf in its flat radiosity, its edges (where the leaf
/// shown changes between neighbouring pixels) dark.
#[must_use]
pub fn mesh_picture(flat: &[Option<Rgb>], leaf: &[Option<ElementId>], width: u32, white: f64) -> Vec<[u8; 3]> {
    let w = width as usize;
    (0..leaf.len())
        .map(|i| {
            let Some(e) = leaf[i] else { return [24, 24, 28] };
            let edge = (i % w + 1 < w && leaf[i + 1] != Some(e)) || (i + w < leaf.len() && leaf[i + w] != Some(e));
            if edge {
                [20, 20, 20]
            } else {
                let c = tonemap(flat[i].unwrap_or([0.0; 3]), white);
                c.map(|x| (u16::from(x) * 3 / 4 + 60) as u8)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square split once, then one child split again: 7 leaves, the
    /// corners shared (3 x 3 grid plus the 5 new points of the inner split),
    /// and a corner's value the area-weighted mean of the leaves that touch it.
    #[test]
    fn leaf_mesh_shares_corners_and_averages_by_area() {
        let mut s = Scene::named("t");
        let q = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        s.add_polygon("square", &q, 0);
        let mut h = Hierarchy::new(&s);
        let c = h.split(0);
        let g = h.split(c);
        let mut b = vec![[0.0; 3]; h.elements.len()];
        for e in h.leaves() {
            b[e as usize] = [f64::from(e), 1.0, 0.0];
        }
        let m = leaf_mesh(&h, &b);
        assert_eq!(m.faces.len(), 7);
        assert_eq!(m.positions.len(), 9 + 5);
        assert!(m.faces.iter().all(|f| f.len() == 4));
        // The square's centre touches three children of the first split and
        // one grandchild (area 1/16): (b1 + b2 + b3) / 4 + b_g2 / 16, over 13/16.
        let centre = m.positions.iter().position(|p| (*p - DVec3::new(0.5, 0.5, 0.0)).length() < 1e-12).unwrap();
        let grand = (g..g + 4).find(|&e| h.elements[e as usize].points.contains(&DVec3::new(0.5, 0.5, 0.0))).unwrap();
        let want = ((c + 1..c + 4).map(f64::from).sum::<f64>() / 4.0 + f64::from(grand) / 16.0) / (13.0 / 16.0);
        assert!((m.radiosity[centre][0] - want).abs() < 1e-12, "{} vs {want}", m.radiosity[centre][0]);
        assert!((m.radiosity[centre][1] - 1.0).abs() < 1e-12);
    }
}
