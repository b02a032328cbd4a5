//! `render --export-scene`: the scene as other renderers read it: one OBJ of
//! triangles per material (`material-K.obj`, winding kept: the front side is
//! counter-clockwise), `scene.xml` for Mitsuba 3 that names them
//! ([`itgfx_backends::formats::mitsuba::scene_xml`]; `mitsuba scene.xml`
//! renders it, `itgfx render scene.xml` reads it back) and `scene.json` with
//! each material (diffuse reflectance, front-side emitted radiance, mirror),
//! the camera and the image size, so a peer renders exactly what itgfx
//! renders (`bench/render_mitsuba.py`, `bench/mitsuba_scene_xml.py`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use itgfx_backends::camera::Camera;
use itgfx_backends::formats::mitsuba::scene_xml;
use itgfx_backends::scene::Scene;
use serde_json::json;

use crate::CliError;

/// Writes the files into `dir`; returns their paths.
///
/// # Errors
/// Output errors, one line.
pub fn export_scene(
    scene: &Scene,
    camera: &Camera,
    size: (u32, u32),
    spp: u32,
    dir: &Path,
) -> Result<Vec<PathBuf>, CliError> {
    let mut written = Vec::new();
    let mut materials = Vec::new();
    let mut shapes = Vec::new();
    for (k, m) in scene.materials.iter().enumerate() {
        let mut obj = String::new();
        let mut n = 0;
        for (t, tri) in scene.triangles.iter().enumerate() {
            if scene.patches[scene.triangle_patch[t] as usize].material != k {
                continue;
            }
            for v in tri {
                let _ = writeln!(obj, "v {:?} {:?} {:?}", v.x, v.y, v.z);
            }
            let _ = writeln!(obj, "f {} {} {}", 3 * n + 1, 3 * n + 2, 3 * n + 3);
            n += 1;
        }
        if n == 0 {
            continue;
        }
        let name = format!("material-{k}.obj");
        let path = dir.join(&name);
        crate::output::write(&path, obj.as_bytes())?;
        written.push(path);
        shapes.push((name.clone(), k));
        materials.push(json!({
            "name": m.name, "file": name, "triangles": n, "reflectance": m.reflectance,
            "radiance": m.emittance, "mirror": m.mirror,
        }));
    }
    let path = dir.join("scene.xml");
    crate::output::write(&path, scene_xml(scene, &shapes, camera, size, spp).as_bytes())?;
    written.push(path);
    let target = camera.eye + camera.forward;
    let doc = json!({
        "scene": scene.name,
        "materials": materials,
        "camera": {
            "eye": camera.eye.to_array(), "target": target.to_array(), "up": camera.up.to_array(),
            "fov_y_degrees": camera.fov_y.to_degrees(),
        },
        "width": size.0, "height": size.1,
        "conventions": "two-sided reflection, one-sided (front, counter-clockwise) emission, box pixel filter, linear RGB",
    });
    let path = dir.join("scene.json");
    crate::output::write(&path, format!("{doc:#}\n").as_bytes())?;
    written.push(path);
    Ok(written)
}
