//! Built-in objects to look at from outside (Part V): a geodesic sphere, a
//! torus and a table with four chairs. Every polygon faces outwards.

use glam::DVec3;

use crate::scene::Scene;

/// A subdivided icosahedron on the unit sphere: `10·4^L + 2` vertices and
/// `20·4^L` triangles for `level` L (normalised midpoints, each edge split once).
#[must_use]
pub fn icosphere_mesh(level: u32) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = Vec::new();
    for a in [-1.0, 1.0] {
        for b in [-phi, phi] {
            v.push(DVec3::new(0.0, a, b).normalize());
            v.push(DVec3::new(a, b, 0.0).normalize());
            v.push(DVec3::new(b, 0.0, a).normalize());
        }
    }
    let edge = 2.0 / (1.0 + phi * phi).sqrt();
    let mut faces = Vec::new();
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                let near = |a: usize, b: usize| ((v[a] - v[b]).length() - edge).abs() < 1e-9;
                if near(i, j) && near(j, k) && near(i, k) {
                    // Wind outwards.
                    let n = (v[j] - v[i]).cross(v[k] - v[i]);
                    faces.push(if n.dot(v[i]) > 0.0 { [i, j, k] } else { [i, k, j] });
                }
            }
        }
    }
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(faces.len() * 4);
        let mut midpoint = |a: usize, b: usize, v: &mut Vec<DVec3>| -> usize {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        for [a, b, c] in faces {
            let (ab, bc, ca) = (midpoint(a, b, &mut v), midpoint(b, c, &mut v), midpoint(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    (v, faces)
}

/// The unit geodesic sphere of [`icosphere_mesh`], one patch per triangle.
#[must_use]
pub fn geosphere(name: &str, level: u32) -> Scene {
    let mut s = Scene::named(name);
    let (v, faces) = icosphere_mesh(level);
    for (i, [a, b, c]) in faces.into_iter().enumerate() {
        s.add_polygon(format!("triangle {i}"), &[v[a], v[b], v[c]], 0);
    }
    s
}

/// A ring torus around the y axis with radii `big` and `small`, split into
/// `around × across` planar quads. Closed: the last ring and band of quads
/// reuse the first ones' vertices (angle 2π is taken as 0, whose sine and
/// cosine round differently), so the seams share vertices exactly.
#[must_use]
pub fn torus(name: &str, big: f64, small: f64, around: u32, across: u32) -> Scene {
    let mut s = Scene::named(name);
    let p = |i: u32, j: u32| {
        let (i, j) = (i % around, j % across);
        let (u, w) = (
            std::f64::consts::TAU * f64::from(i) / f64::from(around),
            std::f64::consts::TAU * f64::from(j) / f64::from(across),
        );
        let ring = big + small * w.cos();
        DVec3::new(ring * u.cos(), small * w.sin(), ring * u.sin())
    };
    for i in 0..around {
        for j in 0..across {
            let mut q = [p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)];
            let centre = q.iter().copied().sum::<DVec3>() / 4.0;
            let axis = DVec3::new(centre.x, 0.0, centre.z).normalize() * big;
            if (q[1] - q[0]).cross(q[2] - q[0]).dot(centre - axis) < 0.0 {
                q.reverse();
            }
            s.add_polygon(format!("torus[{i},{j}]"), &q, 0);
        }
    }
    s
}

/// Boxes of [`table_with_chairs`]: a top and four legs, and four chairs of
/// a seat, four legs and a backrest.
pub const TABLE_CHAIRS_BOXES: u64 = 5 + 4 * 6;

/// A table with four chairs, all boxes facing outwards, each box face split
/// `n × n`; y is up, the floor is not included.
#[must_use]
pub fn table_with_chairs(name: &str, n: u32) -> Scene {
    let mut s = Scene::named(name);
    let b = |x0: f64, y0: f64, z0: f64, x1: f64, y1: f64, z1: f64| (DVec3::new(x0, y0, z0), DVec3::new(x1, y1, z1));
    let mut boxes = vec![("table top", b(-0.6, 0.70, -0.4, 0.6, 0.76, 0.4))];
    for (sx, sz) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let (x, z) = (sx * 0.54, sz * 0.34);
        boxes.push(("table leg", b(x - 0.03, 0.0, z - 0.03, x + 0.03, 0.70, z + 0.03)));
    }
    // Chairs: centre (x, z) and the outward direction of the backrest.
    for (cx, cz, ox, oz) in
        [(-0.85, 0.0, -1.0, 0.0), (0.85, 0.0, 1.0, 0.0), (0.0, -0.62, 0.0, -1.0), (0.0, 0.62, 0.0, 1.0)]
    {
        let h = 0.2;
        boxes.push(("chair seat", b(cx - h, 0.42, cz - h, cx + h, 0.46, cz + h)));
        for (lx, lz) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
            let (x, z) = (cx + lx * (h - 0.03), cz + lz * (h - 0.03));
            boxes.push(("chair leg", b(x - 0.02, 0.0, z - 0.02, x + 0.02, 0.42, z + 0.02)));
        }
        // Backrest on the side away from the table.
        let (bx, bz) = (cx + ox * (h - 0.02), cz + oz * (h - 0.02));
        let (wx, wz) = if ox != 0.0 { (0.02, h) } else { (h, 0.02) };
        boxes.push(("chair back", b(bx - wx, 0.46, bz - wz, bx + wx, 0.95, bz + wz)));
    }
    debug_assert_eq!(boxes.len() as u64, TABLE_CHAIRS_BOXES);
    for (k, (label, (lo, hi))) in boxes.into_iter().enumerate() {
        s.add_box(&format!("{label} {k}"), lo, hi, n, false, 0);
    }
    s
}
