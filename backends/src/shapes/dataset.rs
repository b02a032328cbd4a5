//! The labelled retrieval set of `itgfx shapes`' benchmark and tests:
//! rotated, scaled, translated, noised and remeshed (subdivided or decimated)
//! copies of given meshes, one class each, plus parametric families with
//! varied proportions and tessellations (tori, boxes, cylinders, cones,
//! ellipsoids). Every shape is a pure function of `(seed, class, index)`;
//! even indices form the tuning part, odd ones the held-out part.

use glam::{DQuat, DVec3};

use crate::lines::LineRng;
use crate::scene::Scene;

/// Which part of the set a shape belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Descriptor settings may be chosen on these.
    Tuning,
    /// Never looked at while choosing settings.
    HeldOut,
}

/// One shape of the set.
#[derive(Clone, Debug)]
pub struct Item {
    /// File stem: `class-index`.
    pub name: String,
    /// Its class.
    pub class: String,
    /// Tuning or held out.
    pub split: Split,
    /// What was done to the base shape, for the labels file.
    pub how: String,
    /// The mesh.
    pub scene: Scene,
}

/// The parametric families, in order.
pub const FAMILIES: [&str; 5] = ["torus", "box", "cylinder", "cone", "ellipsoid"];

/// `scene` with every vertex moved by `f`, patch areas and normals recomputed.
#[must_use]
pub fn mapped(scene: &Scene, f: impl Fn(DVec3) -> DVec3) -> Scene {
    let mut s = scene.clone();
    for t in &mut s.triangles {
        *t = t.map(&f);
    }
    for p in &mut s.patches {
        p.area = 0.0;
        p.normal = DVec3::ZERO;
    }
    for (t, &p) in s.triangles.iter().zip(&s.triangle_patch) {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let patch = &mut s.patches[p as usize];
        patch.area += 0.5 * n.length();
        patch.normal += n;
    }
    for p in &mut s.patches {
        p.normal = p.normal.normalize_or_zero();
    }
    s
}

/// A scene of the given triangles, one patch each.
fn from_triangles(name: &str, triangles: &[[DVec3; 3]]) -> Scene {
    let mut s = Scene::named(name);
    for (i, t) in triangles.iter().enumerate() {
        s.add_triangles(format!("t{i}"), std::slice::from_ref(t), 0);
    }
    s
}

/// Vertex clustering (Rossignac and Borrel 1993): vertices are snapped to
/// the mean of their cell of a `cells`-per-side grid over the bounding box,
/// and triangles that lose a corner are dropped. Crude (it may leave
/// non-manifold edges), but fast and with no parameter but the grid.
#[must_use]
pub fn cluster(scene: &Scene, cells: u32) -> Scene {
    let (lo, hi) = scene.bounds();
    let size = (hi - lo).max_element().max(f64::MIN_POSITIVE) / f64::from(cells.max(1));
    let key = |v: DVec3| {
        let c = ((v - lo) / size).floor();
        (c.x as i64, c.y as i64, c.z as i64)
    };
    let mut sums: std::collections::HashMap<(i64, i64, i64), (DVec3, f64)> = std::collections::HashMap::new();
    for v in scene.triangles.iter().flatten() {
        let e = sums.entry(key(*v)).or_insert((DVec3::ZERO, 0.0));
        e.0 += *v;
        e.1 += 1.0;
    }
    let tris: Vec<[DVec3; 3]> = scene
        .triangles
        .iter()
        .filter_map(|t| {
            let k = t.map(key);
            if k[0] == k[1] || k[1] == k[2] || k[0] == k[2] {
                return None;
            }
            Some(k.map(|k| sums[&k].0 / sums[&k].1))
        })
        .collect();
    from_triangles(&scene.name, &tris)
}

/// [`cluster`] with the grid that leaves the most triangles not above `target`.
#[must_use]
pub fn decimate(scene: &Scene, target: usize) -> Scene {
    if scene.triangles.len() <= target {
        return scene.clone();
    }
    let (mut lo, mut hi) = (2u32, 1024u32);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if cluster(scene, mid).triangles.len() <= target { lo = mid } else { hi = mid }
    }
    cluster(scene, lo)
}

/// Moves every vertex a random distance of up to `sigma` (in units of the
/// bounding box's half diagonal) in a random direction; copies of one
/// position (shared corners) move alike, so the surface does not crack.
#[must_use]
pub fn noised(scene: &Scene, sigma: f64, seed: u64) -> Scene {
    let (lo, hi) = scene.bounds();
    let amount = sigma * ((hi - lo) * 0.5).length();
    mapped(scene, |v| {
        let bits = v.x.to_bits() ^ v.y.to_bits().rotate_left(21) ^ v.z.to_bits().rotate_left(42);
        let r = LineRng::new(seed, bits);
        v + r.sphere_point(0) * (amount * r.uniform(8))
    })
}

/// A random rotation, a scale in `[0.5, 2]` and a translation of up to 10
/// units, from draws `first..first+6` of `r`.
fn placed(scene: &Scene, r: &LineRng, first: u32) -> Scene {
    let axis = r.sphere_point(first);
    let angle = std::f64::consts::TAU * r.uniform(first + 20);
    let q = DQuat::from_axis_angle(axis, angle);
    let scale = 0.5 * 4f64.powf(r.uniform(first + 21));
    let shift = (DVec3::new(r.uniform(first + 22), r.uniform(first + 23), r.uniform(first + 24)) - 0.5) * 20.0;
    mapped(scene, |v| q * v * scale + shift)
}

/// A closed surface of revolution around y: the profile `(radius, y)` from
/// bottom to top, `around` segments; ends with radius 0 close by themselves,
/// others get a flat cap.
fn revolution(name: &str, profile: &[(f64, f64)], around: u32) -> Scene {
    let ring = |k: u32, (r, y): (f64, f64)| {
        let a = std::f64::consts::TAU * f64::from(k % around) / f64::from(around);
        DVec3::new(r * a.cos(), y, -r * a.sin())
    };
    let mut tris = Vec::new();
    for w in profile.windows(2) {
        for k in 0..around {
            let (a, b, c, d) = (ring(k, w[0]), ring(k + 1, w[0]), ring(k + 1, w[1]), ring(k, w[1]));
            if w[0].0 > 0.0 {
                tris.push([a, b, c]);
            }
            if w[1].0 > 0.0 {
                tris.push([a, c, d]);
            }
        }
    }
    let (first, last) = (profile[0], profile[profile.len() - 1]);
    for k in 0..around {
        if first.0 > 0.0 {
            tris.push([DVec3::new(0.0, first.1, 0.0), ring(k + 1, first), ring(k, first)]);
        }
        if last.0 > 0.0 {
            tris.push([DVec3::new(0.0, last.1, 0.0), ring(k, last), ring(k + 1, last)]);
        }
    }
    from_triangles(name, &tris)
}

/// Member `index` of parametric family `family` (one of [`FAMILIES`]):
/// proportions and tessellation drawn from `r`, about 1-5k triangles.
#[must_use]
pub fn family_member(family: &str, r: &LineRng) -> Option<(Scene, String)> {
    let u = |k| r.uniform(k);
    let around = 24 + (u(1) * 40.0) as u32;
    let rows = 6 + (u(2) * 14.0) as u32;
    let profile = |f: &dyn Fn(f64) -> (f64, f64)| -> Vec<(f64, f64)> {
        (0..=rows).map(|i| f(f64::from(i) / f64::from(rows))).collect()
    };
    Some(match family {
        "torus" => {
            let ratio = 1.5 + 2.5 * u(3);
            let s = crate::meshes::torus(family, 1.0, 1.0 / ratio, around, 12 + (u(2) * 20.0) as u32);
            (s, format!("R/r {ratio:.2}, {around} around"))
        }
        "box" => {
            let d = DVec3::new(1.0, 0.4 + 0.6 * u(3), 0.15 + 0.85 * u(4));
            let mut s = Scene::named(family);
            s.add_box(family, -d, d, 4 + (u(2) * 14.0) as u32, false, 0);
            (s, format!("sides 1 : {:.2} : {:.2}", d.y, d.z))
        }
        "cylinder" => {
            let h = 0.5 + 3.5 * u(3);
            (revolution(family, &profile(&|t| (1.0, h * t)), around), format!("h/r {h:.2}, {around} around"))
        }
        "cone" => {
            let h = 0.7 + 2.8 * u(3);
            (revolution(family, &profile(&|t| (1.0 - t, h * t)), around), format!("h/r {h:.2}, {around} around"))
        }
        "ellipsoid" => {
            let (b, c) = (0.35 + 0.65 * u(3), 0.2 + 0.8 * u(4));
            let s = crate::meshes::geosphere(family, 3 + u32::from(u(2) > 0.5));
            (mapped(&s, |v| DVec3::new(v.x, v.y * b, v.z * c)), format!("axes 1 : {b:.2} : {c:.2}"))
        }
        _ => return None,
    })
}

/// A copy of the mesh `base` (already about the size wanted): remeshed
/// (clustered to 55-90 % of its triangles, or subdivided 2 × 2 when it has
/// fewer than 3,000), noised (half of them), from draws of `r`.
#[must_use]
pub fn mesh_copy(base: &Scene, r: &LineRng) -> (Scene, String) {
    let n = base.triangles.len();
    let (mut s, mut how) = if r.uniform(1) < 0.34 {
        (base.clone(), "as is".to_string())
    } else if n < 3000 {
        (base.subdivided(2).unwrap_or_else(|_| base.clone()), "subdivided 2x2".to_string())
    } else {
        let keep = 0.55 + 0.35 * r.uniform(2);
        let d = decimate(base, (n as f64 * keep) as usize);
        let how = format!("clustered to {} triangles", d.triangles.len());
        (d, how)
    };
    if r.uniform(3) < 0.5 {
        let sigma = 0.002 + 0.004 * r.uniform(4);
        s = noised(&s, sigma, u64::from(r.u32(5)));
        how += &format!(", noise {sigma:.4}");
    }
    (s, how)
}

/// The set: `per_class` members of each mesh class (`meshes`: class name
/// and base mesh) and of each of `families`, each placed at random.
#[must_use]
pub fn retrieval_set(meshes: &[(String, Scene)], families: &[&str], per_class: usize, seed: u64) -> Vec<Item> {
    let mut out = Vec::new();
    let classes =
        meshes.iter().map(|(c, s)| (c.clone(), Some(s))).chain(families.iter().map(|f| (f.to_string(), None)));
    for (ci, (class, base)) in classes.enumerate() {
        for i in 0..per_class {
            let r = LineRng::new(seed, ((ci as u64) << 32) | i as u64);
            let (s, how) = match base {
                Some(b) => mesh_copy(b, &r),
                None => match family_member(&class, &r) {
                    Some(x) => x,
                    None => continue,
                },
            };
            let mut s = placed(&s, &r, 40);
            s.name = format!("{class}-{i:02}");
            let split = if i % 2 == 0 { Split::Tuning } else { Split::HeldOut };
            out.push(Item { name: s.name.clone(), class: class.clone(), split, how, scene: s });
        }
    }
    out
}
