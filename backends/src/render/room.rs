//! The `mirror-room` test scene, in the spirit of Part IV Figs. 7 and 11 /
//! Part III-IV Fig. 7: a closed room lit by one area light in the ceiling,
//! with a mirrored pyramid and a mirrored sphere standing on the floor and
//! two diffuse blocks casting shadows.

use glam::DVec3;

use crate::meshes::icosphere_mesh;
use crate::scene::{Material, Scene};

/// Room extent (scene units): x across, y up, z deep.
const ROOM: DVec3 = DVec3::new(4.0, 3.0, 5.0);

/// The scene; the sphere is the geodesic sphere of subdivision level `sphere_level` (`20·4^L` triangles).
#[must_use]
pub fn mirror_room(name: &str, sphere_level: u32) -> Scene {
    let d = DVec3::new;
    let mut s = Scene::named(name);
    let white = |n: &str, c: [f64; 3]| Material { name: n.into(), reflectance: c, ..Material::default() };
    s.materials = vec![
        white("white", [0.75, 0.75, 0.75]),
        white("red", [0.75, 0.18, 0.15]),
        white("blue", [0.15, 0.25, 0.75]),
        Material { name: "light".into(), reflectance: [0.8; 3], emittance: [12.0, 11.0, 9.0], mirror: false },
        Material { name: "mirror".into(), reflectance: [0.9, 0.9, 0.9], emittance: [0.0; 3], mirror: true },
        white("ochre", [0.7, 0.55, 0.25]),
    ];
    let (x, y, z) = (d(ROOM.x, 0.0, 0.0), d(0.0, ROOM.y, 0.0), d(0.0, 0.0, ROOM.z));
    let o = DVec3::ZERO;
    // Inward-facing walls: (corner, u, v) with u × v pointing into the room.
    let walls = [
        ("floor", o, z, x, 0),
        ("ceiling", y, x, z, 0),
        ("back wall", z, y, x, 0),
        ("front wall", o, x, y, 0),
        ("left wall", o, y, z, 1),
        ("right wall", x, z, y, 2),
    ];
    for (n, c, u, v, m) in walls {
        s.add_grid(n, c, u, v, 4, 4, m);
    }
    // The light: a 1 x 1 quad 1 mm under the ceiling, facing down.
    let l = d(1.5, ROOM.y - 0.001, 2.0);
    s.add_polygon("light", &[l, l + d(1.0, 0.0, 0.0), l + d(1.0, 0.0, 1.0), l + d(0.0, 0.0, 1.0)], 3);
    // Mirrored square pyramid, base 1.4, height 1.3, a little rotated.
    let (c, half, h, a) = (d(1.15, 0.0, 3.3), 0.7, 1.3, 0.5f64);
    let corner = |k: f64| {
        let t = a + k * std::f64::consts::FRAC_PI_2;
        c + d(half * std::f64::consts::SQRT_2 * t.cos(), 0.0, half * std::f64::consts::SQRT_2 * t.sin())
    };
    let apex = c + d(0.0, h, 0.0);
    for k in 0..4 {
        let (p, q) = (corner(f64::from(k)), corner(f64::from(k + 1)));
        // Wound outwards: (q, p, apex) has its normal away from the axis.
        let n = (p - q).cross(apex - q);
        let tri = if n.dot((p + q) * 0.5 - c) > 0.0 { [q, p, apex] } else { [p, q, apex] };
        s.add_polygon(format!("pyramid side {k}"), &tri, 4);
    }
    // Mirrored sphere resting on the floor.
    let (centre, r) = (d(2.85, 0.65, 3.2), 0.65);
    let (v, faces) = icosphere_mesh(sphere_level);
    for (i, [a, b, cc]) in faces.into_iter().enumerate() {
        s.add_polygon(format!("sphere {i}"), &[centre + v[a] * r, centre + v[b] * r, centre + v[cc] * r], 4);
    }
    // Diffuse blocks casting shadows.
    s.add_box("tall block", d(0.35, 0.0, 1.6), d(0.95, 1.6, 2.2), 1, false, 5);
    s.add_box("cube", d(2.55, 0.0, 1.5), d(3.15, 0.6, 2.1), 1, false, 0);
    s
}
