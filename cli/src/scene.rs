//! Scene loading shared by the commands: a scene file (OBJ, PLY, glTF/GLB,
//! Mitsuba XML; [`itgfx_backends::formats`]) or a built-in name.

use std::path::Path;

use itgfx_backends::formats;
use itgfx_backends::scene::{Scene, built_in};

use crate::CliError;

/// Loads a scene spec: an existing file, a path with a scene extension
/// (`.obj`, `.ply`, `.gltf`, `.glb`, `.xml`) or a built-in name, then
/// `--subdivide K`.
///
/// # Errors
/// Scene errors, one line.
pub fn load_scene(spec: &str, subdivide: u32) -> Result<Scene, CliError> {
    let path = Path::new(spec);
    let scene = if path.is_file() || formats::by_extension(path).is_some() {
        formats::load(path).map_err(|e| CliError::usage(e.to_string()))?
    } else {
        built_in(spec).map_err(|e| CliError::usage(e.to_string()))?
    };
    let scene = scene.subdivided(subdivide).map_err(|e| CliError::usage(e.to_string()))?;
    for w in &scene.warnings {
        eprintln!("itgfx: warning: {w}");
    }
    scene.validate().map_err(|e| CliError::usage(e.to_string()))?;
    Ok(scene)
}
