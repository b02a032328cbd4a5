//! Open scenes for adaptive sampling: an object on a finite floor under a
//! small area light, open to a black background. Unlike the closed rooms,
//! where indirect light makes every pixel noisy, a large part of the image
//! (the background) is exactly black and the rest ranges from direct light
//! to soft shadow: the heterogeneity a per-pixel sample allocation exists for.

use glam::DVec3;

use crate::meshes::icosphere_mesh;
use crate::scene::{Material, Scene};

/// Side of the square floor (scene units), centred on the origin.
const FLOOR: f64 = 4.0;

/// The floor, the materials and the small light shared by the open scenes:
/// materials 0 floor, 1 red, 2 blue, 3 light, 4 ochre.
fn open_base(name: &str) -> Scene {
    let d = DVec3::new;
    let mut s = Scene::named(name);
    let diffuse = |n: &str, c: [f64; 3]| Material { name: n.into(), reflectance: c, ..Material::default() };
    s.materials = vec![
        diffuse("floor", [0.7, 0.7, 0.7]),
        diffuse("red", [0.75, 0.18, 0.15]),
        diffuse("blue", [0.15, 0.25, 0.75]),
        Material { name: "light".into(), reflectance: [0.8; 3], emittance: [40.0, 37.0, 30.0], mirror: false },
        diffuse("ochre", [0.7, 0.55, 0.25]),
    ];
    let h = FLOOR / 2.0;
    // Floor facing up (z × x = +y).
    s.add_grid("floor", d(-h, 0.0, -h), d(0.0, 0.0, FLOOR), d(FLOOR, 0.0, 0.0), 4, 4, 0);
    // A 0.5 x 0.5 light at height 3, off the axis, facing down (x × z = −y).
    let l = d(-0.9, 3.0, -0.6);
    s.add_polygon("light", &[l, l + d(0.5, 0.0, 0.0), l + d(0.5, 0.0, 0.5), l + d(0.0, 0.0, 0.5)], 3);
    s
}

/// `open-blocks`: a tall red block, a blue cube and a low ochre slab on the floor.
#[must_use]
pub fn open_blocks(name: &str) -> Scene {
    let d = DVec3::new;
    let mut s = open_base(name);
    s.add_box("tall block", d(-0.9, 0.0, -0.3), d(-0.3, 1.4, 0.3), 1, false, 1);
    s.add_box("cube", d(0.2, 0.0, 0.1), d(0.8, 0.6, 0.7), 1, false, 2);
    s.add_box("slab", d(-0.4, 0.0, 0.8), d(0.9, 0.25, 1.2), 1, false, 4);
    s
}

/// `open-sphere`: a diffuse geodesic sphere (level `level`, `20·4^level`
/// facets) beside a small cube.
#[must_use]
pub fn open_sphere(name: &str, level: u32) -> Scene {
    let d = DVec3::new;
    let mut s = open_base(name);
    let (centre, r) = (d(0.1, 0.7, 0.2), 0.7);
    let (v, faces) = icosphere_mesh(level);
    for (i, [a, b, c]) in faces.into_iter().enumerate() {
        s.add_polygon(format!("sphere {i}"), &[centre + v[a] * r, centre + v[b] * r, centre + v[c] * r], 4);
    }
    s.add_box("cube", d(-1.3, 0.0, 0.6), d(-0.8, 0.5, 1.1), 1, false, 2);
    s
}
