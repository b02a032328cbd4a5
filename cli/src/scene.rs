//! Scene loading shared by the commands: an `.obj` file or a built-in name.

use std::path::Path;

use itgfx_backends::obj::load_obj;
use itgfx_backends::scene::{Scene, built_in};

use crate::CliError;

/// Loads a scene spec: an existing `.obj` path or a built-in name, then
/// `--subdivide K`.
///
/// # Errors
/// Scene errors, one line.
pub fn load_scene(spec: &str, subdivide: u32) -> Result<Scene, CliError> {
    let scene = if Path::new(spec).is_file() || spec.ends_with(".obj") {
        load_obj(Path::new(spec)).map_err(|e| CliError::usage(e.to_string()))?
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
