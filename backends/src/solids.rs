//! Geometry of the built-in scenes: the five regular solids, the Cornell
//! box, and the room of small cubes.

use glam::DVec3;

use crate::scene::{Material, Scene, SceneError};

/// Most cubes [`cubes_room`] packs in its cluster: a 13 x 13 x 13 lattice
/// of pitch 0.075 is the largest that stays inside the room.
pub const MAX_CLUSTERED: u32 = 13 * 13 * 13;

/// Most cubes [`cubes_room`] scatters at random; placements are tried at
/// most [`MAX_TRIES`] times.
pub const MAX_RANDOM: u32 = 1000;

/// Random placements tried by [`cubes_room`] before it gives up.
pub const MAX_TRIES: u64 = 1_000_000;

/// Orders coplanar convex points around their centroid, counter-clockwise
/// seen from the side `outward` points to.
fn ordered(points: &[DVec3], outward: DVec3) -> Vec<DVec3> {
    let c = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let n = outward.normalize();
    let e1 = (points[0] - c).normalize();
    let e2 = n.cross(e1);
    let mut v: Vec<(f64, DVec3)> = points.iter().map(|&p| ((p - c).dot(e2).atan2((p - c).dot(e1)), p)).collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v.into_iter().map(|(_, p)| p).collect()
}

/// Faces of a regular solid centred at the origin, wound outwards.
#[must_use]
pub fn faces(name: &str) -> Vec<Vec<DVec3>> {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let d = DVec3::new;
    let out = |pts: Vec<DVec3>| {
        let c = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
        ordered(&pts, c)
    };
    match name {
        "tetrahedron" => {
            let v = [d(1.0, 1.0, 1.0), d(1.0, -1.0, -1.0), d(-1.0, 1.0, -1.0), d(-1.0, -1.0, 1.0)];
            (0..4).map(|skip| out((0..4).filter(|&i| i != skip).map(|i| v[i]).collect())).collect()
        }
        "cube" => {
            let mut f = Vec::new();
            for axis in 0..3 {
                for s in [-1.0, 1.0] {
                    let mut pts = Vec::new();
                    for a in [-1.0, 1.0] {
                        for b in [-1.0, 1.0] {
                            let mut p = [0.0; 3];
                            p[axis] = s;
                            p[(axis + 1) % 3] = a;
                            p[(axis + 2) % 3] = b;
                            pts.push(DVec3::from_array(p));
                        }
                    }
                    f.push(out(pts));
                }
            }
            f
        }
        "octahedron" => {
            let mut f = Vec::new();
            for sx in [-1.0, 1.0] {
                for sy in [-1.0, 1.0] {
                    for sz in [-1.0, 1.0] {
                        f.push(out(vec![d(sx, 0.0, 0.0), d(0.0, sy, 0.0), d(0.0, 0.0, sz)]));
                    }
                }
            }
            f
        }
        "icosahedron" => icosahedron(phi).1,
        "dodecahedron" => {
            // Dual of the icosahedron: one face per icosahedron vertex, made of
            // the centroids of the five triangles around it.
            let (verts, tris) = icosahedron(phi);
            verts
                .iter()
                .map(|&v| {
                    out(tris
                        .iter()
                        .filter(|t| t.iter().any(|&p| (p - v).length() < 1e-9))
                        .map(|t| (t[0] + t[1] + t[2]) / 3.0)
                        .collect())
                })
                .collect()
        }
        _ => Vec::new(),
    }
}

fn icosahedron(phi: f64) -> (Vec<DVec3>, Vec<Vec<DVec3>>) {
    let mut v = Vec::new();
    for a in [-1.0, 1.0] {
        for b in [-phi, phi] {
            v.push(DVec3::new(0.0, a, b));
            v.push(DVec3::new(a, b, 0.0));
            v.push(DVec3::new(b, 0.0, a));
        }
    }
    let mut f = Vec::new();
    let adj = |a: DVec3, b: DVec3| ((a - b).length() - 2.0).abs() < 1e-9;
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if adj(v[i], v[j]) && adj(v[j], v[k]) && adj(v[i], v[k]) {
                    let pts = vec![v[i], v[j], v[k]];
                    let c = (v[i] + v[j] + v[k]) / 3.0;
                    f.push(ordered(&pts, c));
                }
            }
        }
    }
    (v, f)
}

/// Orients a polygon so its normal points away from `from` (outward) or towards it.
fn facing(poly: &[DVec3], reference: DVec3, towards: bool) -> Vec<DVec3> {
    let c = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
    let n = (poly[1] - poly[0]).cross(poly[2] - poly[0]);
    let away = n.dot(c - reference) > 0.0;
    if away != towards { poly.to_vec() } else { poly.iter().rev().copied().collect() }
}

/// The Cornell box from the Cornell Program of Computer Graphics
/// measurements (millimetres), closed by a front wall.
///
/// 17 patches: floor, ceiling, back, left (red), right (green), front, the
/// light (1 mm under the ceiling), and the five visible faces of each block.
/// Fig. 20a of Part III counts 19; the two block bottoms that make the
/// difference lie on the floor and exchange no lines with anything.
/// As in the published data, the floor quad also runs under the blocks and
/// the ceiling above the light: lines from those parts meet back faces and
/// are counted against the background (about 3% of local lines).
#[must_use]
pub fn cornell_box() -> Scene {
    let d = DVec3::new;
    let mut s = Scene { name: "cornell-box".into(), ..Scene::default() };
    s.materials = vec![
        Material { name: "white".into(), reflectance: [0.73, 0.73, 0.73], ..Material::default() },
        Material { name: "red".into(), reflectance: [0.63, 0.065, 0.05], ..Material::default() },
        Material { name: "green".into(), reflectance: [0.14, 0.45, 0.091], ..Material::default() },
        Material { name: "light".into(), reflectance: [0.78, 0.78, 0.78], emittance: [17.0, 12.0, 4.0], mirror: false },
    ];
    let centre = d(278.0, 274.4, 279.6);
    let walls: [(&str, [DVec3; 4], usize); 6] = [
        ("floor", [d(552.8, 0.0, 0.0), d(0.0, 0.0, 0.0), d(0.0, 0.0, 559.2), d(549.6, 0.0, 559.2)], 0),
        ("ceiling", [d(556.0, 548.8, 0.0), d(556.0, 548.8, 559.2), d(0.0, 548.8, 559.2), d(0.0, 548.8, 0.0)], 0),
        ("back", [d(549.6, 0.0, 559.2), d(0.0, 0.0, 559.2), d(0.0, 548.8, 559.2), d(556.0, 548.8, 559.2)], 0),
        ("right", [d(0.0, 0.0, 559.2), d(0.0, 0.0, 0.0), d(0.0, 548.8, 0.0), d(0.0, 548.8, 559.2)], 2),
        ("left", [d(552.8, 0.0, 0.0), d(549.6, 0.0, 559.2), d(556.0, 548.8, 559.2), d(556.0, 548.8, 0.0)], 1),
        ("front", [d(0.0, 0.0, 0.0), d(552.8, 0.0, 0.0), d(556.0, 548.8, 0.0), d(0.0, 548.8, 0.0)], 0),
    ];
    for (name, q, m) in walls {
        s.add_polygon(name, &facing(&q, centre, true), m);
    }
    let light = [d(343.0, 547.8, 227.0), d(343.0, 547.8, 332.0), d(213.0, 547.8, 332.0), d(213.0, 547.8, 227.0)];
    s.add_polygon("light", &facing(&light, d(278.0, 0.0, 279.6), true), 3);
    let short: [[DVec3; 4]; 5] = [
        [d(130.0, 165.0, 65.0), d(82.0, 165.0, 225.0), d(240.0, 165.0, 272.0), d(290.0, 165.0, 114.0)],
        [d(290.0, 0.0, 114.0), d(290.0, 165.0, 114.0), d(240.0, 165.0, 272.0), d(240.0, 0.0, 272.0)],
        [d(130.0, 0.0, 65.0), d(130.0, 165.0, 65.0), d(290.0, 165.0, 114.0), d(290.0, 0.0, 114.0)],
        [d(82.0, 0.0, 225.0), d(82.0, 165.0, 225.0), d(130.0, 165.0, 65.0), d(130.0, 0.0, 65.0)],
        [d(240.0, 0.0, 272.0), d(240.0, 165.0, 272.0), d(82.0, 165.0, 225.0), d(82.0, 0.0, 225.0)],
    ];
    let tall: [[DVec3; 4]; 5] = [
        [d(423.0, 330.0, 247.0), d(265.0, 330.0, 296.0), d(314.0, 330.0, 456.0), d(472.0, 330.0, 406.0)],
        [d(423.0, 0.0, 247.0), d(423.0, 330.0, 247.0), d(472.0, 330.0, 406.0), d(472.0, 0.0, 406.0)],
        [d(472.0, 0.0, 406.0), d(472.0, 330.0, 406.0), d(314.0, 330.0, 456.0), d(314.0, 0.0, 456.0)],
        [d(314.0, 0.0, 456.0), d(314.0, 330.0, 456.0), d(265.0, 330.0, 296.0), d(265.0, 0.0, 296.0)],
        [d(265.0, 0.0, 296.0), d(265.0, 330.0, 296.0), d(423.0, 330.0, 247.0), d(423.0, 0.0, 247.0)],
    ];
    for (name, block, c) in
        [("short block", short, d(185.5, 82.5, 168.5)), ("tall block", tall, d(368.5, 165.0, 351.5))]
    {
        for (i, q) in block.iter().enumerate() {
            s.add_polygon(
                format!("{name} {}", ["top", "side 1", "side 2", "side 3", "side 4"][i]),
                &facing(q, c, false),
                0,
            );
        }
    }
    s
}

/// The unit cube enclosure (10 × 10 patches per face) with `k` small cubes
/// of side 0.05, one patch per face: scattered at random without overlap,
/// or packed in a cluster at the centre (Part III Figs. 11, 15, 16).
/// With side 0.05, 512 cubes give `H_P` = 11.541 bits, as Table 1 prints.
///
/// # Errors
/// [`SceneError::Geometry`] when `k` cubes do not fit: more than
/// [`MAX_CLUSTERED`] in the cluster, or not placed at random within
/// [`MAX_TRIES`] tries.
pub fn cubes_room(name: &str, k: u32, clustered: bool, seed: u64) -> Result<Scene, SceneError> {
    let side = 0.05;
    let mut s = Scene { name: name.into(), materials: vec![Material::default()], ..Scene::default() };
    s.add_box("room", DVec3::ZERO, DVec3::ONE, 10, true, 0);
    let mut placed: Vec<DVec3> = Vec::new();
    if clustered {
        // A lattice with gaps of half a side, centred in the room.
        let per = (f64::from(k)).cbrt().ceil() as u32;
        let pitch = side * 1.5;
        let start = 0.5 - pitch * f64::from(per) / 2.0 + (pitch - side) / 2.0;
        'outer: for i in 0..per {
            for j in 0..per {
                for l in 0..per {
                    if placed.len() as u32 == k {
                        break 'outer;
                    }
                    placed.push(DVec3::new(
                        start + pitch * f64::from(i),
                        start + pitch * f64::from(l),
                        start + pitch * f64::from(j),
                    ));
                }
            }
        }
    } else {
        let mut rng = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let margin = 0.02;
        let mut tries = 0u64;
        while (placed.len() as u32) < k && tries < MAX_TRIES {
            tries += 1;
            let lo = DVec3::new(next(), next(), next()) * (1.0 - side - 2.0 * margin) + DVec3::splat(margin);
            if placed.iter().all(|p| (*p - lo).abs().max_element() >= side + 0.01) {
                placed.push(lo);
            }
        }
    }
    if placed.len() as u32 != k || (clustered && k > MAX_CLUSTERED) {
        return Err(SceneError::Geometry(format!(
            "{name}: only {} of {k} cubes fit without overlap (clustered at most {MAX_CLUSTERED}; random: {MAX_TRIES} tries)",
            placed.len().min(MAX_CLUSTERED as usize)
        )));
    }
    for (i, lo) in placed.iter().enumerate() {
        s.add_box(&format!("cube {i}"), *lo, *lo + DVec3::splat(side), 1, false, 0);
    }
    Ok(s)
}
