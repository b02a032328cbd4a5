//! Scene files, by extension (case-insensitive) and then by their first
//! bytes: Wavefront OBJ ([`crate::obj`]), Stanford PLY ([`ply`]), glTF 2.0
//! `.gltf` / `.glb` ([`gltf`]) and Mitsuba 3 XML ([`mitsuba`]). Every
//! command that reads a mesh goes through [`load`]; docs/SCENES.md says
//! what each reader takes and why.

pub mod gltf;
pub mod mitsuba;
pub mod ply;

use std::io::Read;
use std::path::Path;

use crate::scene::{Scene, SceneError};

/// The scene file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Wavefront OBJ (with MTL).
    Obj,
    /// Stanford PLY.
    Ply,
    /// glTF 2.0, JSON or binary.
    Gltf,
    /// Mitsuba 3 XML.
    Mitsuba,
}

/// The format an extension names, if any.
#[must_use]
pub fn by_extension(path: &Path) -> Option<Format> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    Some(match ext.as_str() {
        "obj" => Format::Obj,
        "ply" => Format::Ply,
        "gltf" | "glb" => Format::Gltf,
        "xml" => Format::Mitsuba,
        _ => return None,
    })
}

/// The format the first bytes show: `ply`, `glTF`, an XML declaration
/// or `<scene`, a JSON object; else OBJ.
#[must_use]
pub fn by_magic(head: &[u8]) -> Format {
    let head = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    let text = head.trim_ascii_start();
    if ply::is_ply(head) {
        Format::Ply
    } else if gltf::is_glb(head) || text.starts_with(b"{") {
        Format::Gltf
    } else if text.starts_with(b"<?xml") || text.starts_with(b"<scene") {
        Format::Mitsuba
    } else {
        Format::Obj
    }
}

/// Reads a scene file: the format by extension, else by its first bytes.
///
/// # Errors
/// The reader's [`SceneError`], one line naming the file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let format = match by_extension(path) {
        Some(f) => f,
        None => {
            let mut head = [0u8; 64];
            let n = crate::files::open_regular(path)
                .and_then(|mut f| f.read(&mut head))
                .map_err(|e| SceneError::Obj { path: path.display().to_string(), message: e.to_string() })?;
            by_magic(&head[..n])
        }
    };
    match format {
        Format::Obj => crate::obj::load_obj(path),
        Format::Ply => ply::load_ply(path),
        Format::Gltf => gltf::load_gltf(path),
        Format::Mitsuba => mitsuba::load_mitsuba(path),
    }
}
