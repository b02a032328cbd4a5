//! Wavefront OBJ scenes through `tobj`: each polygon is one patch, groups
//! and materials are kept (`g`/`o` names prefix patch names).
//!
//! `tobj` reports malformed files without line numbers, so the file is
//! first checked line by line here: vertex coordinates must be three finite
//! numbers, face indices must name existing vertices, polygons must have
//! area. Errors name the file and the line.

use std::path::Path;

use glam::DVec3;

use crate::scene::{Material, Scene, SceneError};

fn err(path: &Path, message: String) -> SceneError {
    SceneError::Obj { path: path.display().to_string(), message }
}

/// Reads an OBJ file into a scene (one patch per polygon).
///
/// # Errors
/// [`SceneError::Obj`] with the line for unreadable files, bad numbers,
/// non-finite coordinates, bad indices, degenerate polygons, or no faces.
pub fn load_obj(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|e| err(path, e.to_string()))?;
    // Pass 1: line-level validation with line numbers.
    let mut verts: Vec<DVec3> = Vec::new();
    let mut faces = 0usize;
    for (ln, raw) in text.lines().enumerate() {
        let line = ln + 1;
        let mut it = raw.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<&str> = it.collect();
                if c.len() < 3 {
                    return Err(err(path, format!("line {line}: vertex needs 3 coordinates, found {}", c.len())));
                }
                let mut p = [0.0; 3];
                for (k, s) in c[..3].iter().enumerate() {
                    let v: f64 = s
                        .parse()
                        .map_err(|_| err(path, format!("line {line}: vertex coordinate {s:?} is not a number")))?;
                    if !v.is_finite() {
                        return Err(err(path, format!("line {line}: vertex coordinate {s:?} is not finite")));
                    }
                    p[k] = v;
                }
                verts.push(DVec3::from_array(p));
            }
            Some("f") => {
                faces += 1;
                let idx: Vec<&str> = it.collect();
                if idx.len() < 3 {
                    return Err(err(
                        path,
                        format!("line {line}: face {faces} has {} vertices, needs at least 3", idx.len()),
                    ));
                }
                let mut poly = Vec::with_capacity(idx.len());
                for s in &idx {
                    let first = s.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| {
                        err(path, format!("line {line}: face {faces}: vertex index {s:?} is not an integer"))
                    })?;
                    let n = verts.len() as i64;
                    let k = if i < 0 { n + i } else { i - 1 };
                    if i == 0 || k < 0 || k >= n {
                        return Err(err(
                            path,
                            format!(
                                "line {line}: face {faces}: vertex index {i} is out of range (1..={n} defined so far)"
                            ),
                        ));
                    }
                    poly.push(verts[k as usize]);
                }
                let mut area2 = DVec3::ZERO;
                for k in 1..poly.len() - 1 {
                    area2 += (poly[k] - poly[0]).cross(poly[k + 1] - poly[0]);
                }
                let scale = poly.iter().map(|p| (*p - poly[0]).length()).fold(0.0, f64::max);
                if !(area2.length() > 1e-12 * scale * scale) {
                    return Err(err(path, format!("line {line}: face {faces} is degenerate (zero area)")));
                }
            }
            _ => {}
        }
    }
    if faces == 0 {
        return Err(err(path, "no faces (f lines) found".into()));
    }
    // Pass 2: tobj, polygons kept.
    let opts = tobj::LoadOptions { triangulate: false, single_index: false, ignore_points: true, ignore_lines: true };
    let (models, materials) = tobj::load_obj(path, &opts).map_err(|e| err(path, format!("{e}")))?;
    let mut scene =
        Scene { name: path.display().to_string(), materials: vec![Material::default()], ..Scene::default() };
    // Missing .mtl files are not fatal: the default material is used.
    let mat_offset = scene.materials.len();
    if let Ok(mats) = materials {
        for m in mats {
            let kd = m.diffuse.unwrap_or([0.7, 0.7, 0.7]);
            let ke = m.unknown_param.get("Ke").and_then(|s| {
                let v: Vec<f64> = s.split_whitespace().filter_map(|x| x.parse().ok()).collect();
                (v.len() == 3).then(|| [v[0], v[1], v[2]])
            });
            scene.materials.push(Material {
                name: m.name.clone(),
                reflectance: [f64::from(kd[0]), f64::from(kd[1]), f64::from(kd[2])],
                emittance: ke.unwrap_or([0.0; 3]),
                mirror: m.illumination_model == Some(3) || m.illumination_model == Some(5),
            });
        }
    }
    for model in &models {
        let mesh = &model.mesh;
        let material = mesh.material_id.map_or(0, |m| m + mat_offset);
        let arities: Vec<u32> =
            if mesh.face_arities.is_empty() { vec![3; mesh.indices.len() / 3] } else { mesh.face_arities.clone() };
        let mut at = 0usize;
        for (f, &n) in arities.iter().enumerate() {
            let n = n as usize;
            let poly: Vec<DVec3> = mesh.indices[at..at + n]
                .iter()
                .map(|&i| {
                    let i = i as usize * 3;
                    DVec3::new(
                        f64::from(mesh.positions[i]),
                        f64::from(mesh.positions[i + 1]),
                        f64::from(mesh.positions[i + 2]),
                    )
                })
                .collect();
            at += n;
            scene.add_polygon(format!("{}/{f}", model.name), &poly, material);
        }
    }
    scene.validate()?;
    Ok(scene)
}

/// Writes a scene as OBJ (one `f` per triangle, one group per patch run), so
/// built-in scenes can be given to other tracers.
///
/// # Errors
/// I/O errors.
pub fn write_obj(scene: &Scene, out: &mut impl std::io::Write) -> std::io::Result<()> {
    writeln!(out, "# {} — written by itgfx; {} patches", scene.name, scene.patches.len())?;
    for t in &scene.triangles {
        for v in t {
            writeln!(out, "v {} {} {}", v.x, v.y, v.z)?;
        }
    }
    let mut last = u32::MAX;
    for (i, &p) in scene.triangle_patch.iter().enumerate() {
        if p != last {
            writeln!(out, "g patch{p}")?;
            last = p;
        }
        writeln!(out, "f {} {} {}", 3 * i + 1, 3 * i + 2, 3 * i + 3)?;
    }
    Ok(())
}
