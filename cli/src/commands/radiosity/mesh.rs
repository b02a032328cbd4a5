//! The radiosity solution's adaptive mesh as a PLY file: every leaf element a
//! face, corners shared per patch, each vertex carrying its Gouraud radiosity
//! (linear, float `radiosity_r/g/b`) and a display colour (`red/green/blue`,
//! tone-mapped like `radiosity.png`), so mesh viewers show the solution and
//! scripts read the numbers.

use std::fmt::Write as _;
use std::path::Path;

use itgfx_backends::radiosity::render::{LeafMesh, tonemap};

use crate::CliError;

/// The PLY text of `mesh` (ASCII 1.0); `white` is the tone-mapping white point.
#[must_use]
pub fn ply(mesh: &LeafMesh, scene: &str, white: f64) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "ply\nformat ascii 1.0\ncomment itgfx radiosity: {scene}, one face per leaf element\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float radiosity_r\nproperty float radiosity_g\nproperty float radiosity_b\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.faces.len()
    );
    for (p, b) in mesh.positions.iter().zip(&mesh.radiosity) {
        let c = tonemap(*b, white);
        let _ = writeln!(s, "{} {} {} {:e} {:e} {:e} {} {} {}", p.x, p.y, p.z, b[0], b[1], b[2], c[0], c[1], c[2]);
    }
    for f in &mesh.faces {
        let _ = write!(s, "{}", f.len());
        for i in f {
            let _ = write!(s, " {i}");
        }
        s.push('\n');
    }
    s
}

/// Writes [`ply`] atomically.
///
/// # Errors
/// I/O errors, one line naming the path.
pub fn write(mesh: &LeafMesh, scene: &str, white: f64, path: &Path) -> Result<(), CliError> {
    crate::output::write(path, ply(mesh, scene, white).as_bytes())
}
