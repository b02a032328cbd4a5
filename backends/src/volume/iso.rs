//! Iso-surfaces for the iso-surface route of Part VI §2.1 (after Takahashi et al. 2005): the
//! surface where the normalised scalar equals a value, extracted by marching
//! tetrahedra (each cell of eight voxel centres split into six tetrahedra
//! around its main diagonal, so neighbouring cells split shared faces alike
//! and the surface has no cracks), then handed to the polygonal viewpoint
//! channel like any mesh.

use glam::DVec3;

use super::Volume;

/// The six tetrahedra of a cell (corner `c` is at offset `(c&1, c>>1&1, c>>2&1)`),
/// one per order of the three axes from corner 0 to corner 7.
const TETRAHEDRA: [[usize; 4]; 6] =
    [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];

/// Triangles (normalised coordinates) of the surface where the scalar,
/// normalised by the volume's range to `[0, 1]`, equals `iso`; triangles of
/// (near) zero area are dropped. Stops with `None` beyond `max` triangles.
#[must_use]
pub fn iso_surface(v: &Volume, iso: f64, max: usize) -> Option<Vec<[DVec3; 3]>> {
    let (lo, hi) = v.range();
    let (lo, hi) = (f64::from(lo), f64::from(hi));
    let inv = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
    let value = |i: usize, j: usize, k: usize| (f64::from(v.data[v.index(i, j, k)]) - lo) * inv;
    let [nx, ny, nz] = v.dims;
    let min_area = 1e-12 * v.voxel_size() * v.voxel_size();
    let mut out = Vec::new();
    for k in 0..nz.saturating_sub(1) {
        for j in 0..ny.saturating_sub(1) {
            for i in 0..nx.saturating_sub(1) {
                let corner = |c: usize| (i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                let vals: [f64; 8] = std::array::from_fn(|c| {
                    let (a, b, d) = corner(c);
                    value(a, b, d)
                });
                if vals.iter().all(|&x| x > iso) || vals.iter().all(|&x| x <= iso) {
                    continue;
                }
                let pos: [DVec3; 8] = std::array::from_fn(|c| {
                    let (a, b, d) = corner(c);
                    v.centre(a, b, d)
                });
                for t in TETRAHEDRA {
                    tetrahedron(t.map(|c| (pos[c], vals[c])), iso, &mut |tri| {
                        if (tri[1] - tri[0]).cross(tri[2] - tri[0]).length() * 0.5 > min_area {
                            out.push(tri);
                        }
                    });
                }
                if out.len() > max {
                    return None;
                }
            }
        }
    }
    Some(out)
}

/// A tetrahedron's corner: position and normalised value.
type Corner = (DVec3, f64);

/// The surface's piece in one tetrahedron: a triangle when one corner is on
/// its own side, two when two are.
fn tetrahedron(c: [(DVec3, f64); 4], iso: f64, emit: &mut impl FnMut([DVec3; 3])) {
    let edge = |a: (DVec3, f64), b: (DVec3, f64)| {
        let t = ((iso - a.1) / (b.1 - a.1)).clamp(0.0, 1.0);
        a.0 + (b.0 - a.0) * t
    };
    let (inside, outside): (Vec<&Corner>, Vec<&Corner>) = c.iter().partition(|x| x.1 > iso);
    match (inside.len(), outside.len()) {
        (1, 3) | (3, 1) => {
            let (one, rest) = if inside.len() == 1 { (inside[0], &outside) } else { (outside[0], &inside) };
            emit([edge(*one, *rest[0]), edge(*one, *rest[1]), edge(*one, *rest[2])]);
        }
        (2, 2) => {
            let (a, b, x, y) = (*inside[0], *inside[1], *outside[0], *outside[1]);
            let (ax, ay, by, bx) = (edge(a, x), edge(a, y), edge(b, y), edge(b, x));
            emit([ax, ay, by]);
            emit([ax, by, bx]);
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::builtin::built_in;

    #[test]
    fn sphere_iso_surface_has_the_sphere_area() {
        // exp(-8 r^2) = 0.5 at r = sqrt(ln 2 / 8) in [-1, 1]^3 units, i.e.
        // r / sqrt(3) in normalised units (the box's half diagonal is 1).
        let v = built_in("sphere:48").unwrap();
        let tris = iso_surface(&v, 0.5, 1 << 20).unwrap();
        let area: f64 = tris.iter().map(|t| (t[1] - t[0]).cross(t[2] - t[0]).length() * 0.5).sum();
        let (lo, hi) = v.range();
        let level = f64::from(lo) + 0.5 * f64::from(hi - lo);
        let r = (-level.ln() / 8.0).sqrt() / 3f64.sqrt();
        let want = 4.0 * std::f64::consts::PI * r * r;
        assert!((area - want).abs() < 0.02 * want, "{area} vs {want}");
        for t in &tris {
            for p in t {
                assert!((p.length() - r).abs() < 0.03, "{p}");
            }
        }
        assert!(iso_surface(&v, 0.5, 10).is_none());
    }
}
