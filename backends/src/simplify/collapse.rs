//! Edge collapses `u → v` on a manifold triangle mesh, the kept vertex `v`
//! left where it is (half-edge) or moved to a new position (full-edge):
//! the triangles around every vertex, the link condition, boundary rules
//! and the fold-over test that keep the surface manifold and its triangles
//! facing the way they did, and each vertex's quadric ([`Quadric`]).

use glam::DVec3;

use super::mesh::IndexedMesh;
use super::place::Quadric;

/// Smallest cosine between a triangle's normal before and after a
/// collapse: 0 refuses any triangle turned by more than 90°.
pub const MIN_NORMAL_COSINE: f64 = 0.0;

/// Weight of a boundary edge's plane in the quadrics, per squared edge
/// length (a face's plane weighs its area): Garland and Heckbert's
/// boundary constraint (SIGGRAPH 1997 §6), the plane through the edge
/// perpendicular to its triangle, so that a vertex placed on an open
/// boundary stays near the boundary's line.
pub const BOUNDARY_WEIGHT: f64 = 10.0;

/// A mesh being simplified: triangles keep their index while alive, so
/// per-triangle data can be updated in place.
#[derive(Clone, Debug)]
pub struct Dynamic {
    /// Vertex positions (a full-edge collapse moves the vertex it keeps).
    pub positions: Vec<DVec3>,
    /// Triangles (a dead one keeps its last vertices).
    pub faces: Vec<[u32; 3]>,
    /// Whether each triangle is still there.
    pub alive: Vec<bool>,
    /// Living triangles around each vertex.
    pub around: Vec<Vec<u32>>,
    /// Living triangles.
    pub live: usize,
    /// Quadric of each vertex: the area-weighted planes of the input's
    /// triangles around it, summed over the vertices merged into it.
    pub quadrics: Vec<Quadric>,
}

/// What a collapse `u → v` does to the triangles around `u` and `v`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Change {
    /// Triangles that contain both `u` and `v`: removed.
    pub removed: Vec<u32>,
    /// Triangles around `u` that stay, `u` replaced by `v`, then (when `v`
    /// moves) the triangles around `v` that stay.
    pub moved: Vec<u32>,
    /// Where `v` ends up (its own position for a half-edge collapse).
    pub position: DVec3,
}

impl Dynamic {
    /// The mesh, every triangle alive.
    #[must_use]
    pub fn new(mesh: &IndexedMesh) -> Self {
        let mut around = vec![Vec::new(); mesh.positions.len()];
        let mut quadrics = vec![Quadric::default(); mesh.positions.len()];
        let mut edges: std::collections::HashMap<(u32, u32), (u32, u32)> = std::collections::HashMap::new();
        for (f, t) in mesh.faces.iter().enumerate() {
            let q = Quadric::of_triangle(&mesh.corners(f));
            for &v in t {
                around[v as usize].push(f as u32);
                quadrics[v as usize] = quadrics[v as usize] + q;
            }
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                edges.entry((a.min(b), a.max(b))).or_insert((f as u32, 0)).1 += 1;
            }
        }
        // Boundary edges (one triangle), in a fixed order: the sums do not
        // depend on the hash map's.
        let mut boundary: Vec<((u32, u32), u32)> =
            edges.into_iter().filter(|(_, (_, n))| *n == 1).map(|(e, (f, _))| (e, f)).collect();
        boundary.sort_unstable();
        for ((a, b), f) in boundary {
            let q = Quadric::of_boundary_edge(
                &mesh.corners(f as usize),
                mesh.positions[a as usize],
                mesh.positions[b as usize],
            );
            let q = q.scaled(BOUNDARY_WEIGHT);
            quadrics[a as usize] = quadrics[a as usize] + q;
            quadrics[b as usize] = quadrics[b as usize] + q;
        }
        Self {
            positions: mesh.positions.clone(),
            faces: mesh.faces.clone(),
            alive: vec![true; mesh.faces.len()],
            around,
            live: mesh.faces.len(),
            quadrics,
        }
    }

    /// The living triangles as a compact mesh (unused vertices kept).
    #[must_use]
    pub fn snapshot(&self) -> IndexedMesh {
        IndexedMesh {
            positions: self.positions.clone(),
            faces: self.faces.iter().zip(&self.alive).filter(|(_, a)| **a).map(|(t, _)| *t).collect(),
        }
    }

    /// Vertices sharing a living triangle with `u`, sorted.
    #[must_use]
    pub fn neighbours(&self, u: u32) -> Vec<u32> {
        let mut n: Vec<u32> =
            self.around[u as usize].iter().flat_map(|&f| self.faces[f as usize]).filter(|&w| w != u).collect();
        n.sort_unstable();
        n.dedup();
        n
    }

    /// Triangles containing both `a` and `b`.
    fn shared(&self, a: u32, b: u32) -> Vec<u32> {
        self.around[a as usize].iter().copied().filter(|&f| self.faces[f as usize].contains(&b)).collect()
    }

    /// Whether `u` lies on the boundary: one of its edges has one triangle.
    #[must_use]
    pub fn on_boundary(&self, u: u32) -> bool {
        self.neighbours(u).into_iter().any(|w| self.shared(u, w).len() == 1)
    }

    /// The triangles a collapse `u → v` with `v` moved to `position`
    /// removes and moves, or `None` when it would break the surface: `u`,
    /// `v` not joined by an edge; the link condition (the common neighbours
    /// of `u` and `v` are exactly the far corners of the triangles on the
    /// edge); a boundary vertex `u` moved off the boundary, or a boundary
    /// vertex moved by a full-edge collapse, unless the edge is a boundary
    /// edge (both ends then merge on that boundary); two triangles made
    /// identical; a triangle left with no area or turned past
    /// [`MIN_NORMAL_COSINE`]; fewer than 4 triangles.
    #[must_use]
    pub fn check(&self, u: u32, v: u32, position: DVec3) -> Option<Change> {
        if u == v || self.around[u as usize].is_empty() || self.around[v as usize].is_empty() {
            return None;
        }
        let removed = self.shared(u, v);
        if removed.is_empty() || removed.len() > 2 || self.live < 4 + removed.len() {
            return None;
        }
        let far: Vec<u32> = removed
            .iter()
            .map(|&f| self.faces[f as usize].into_iter().find(|&w| w != u && w != v).unwrap_or(u))
            .collect();
        let (nu, nv) = (self.neighbours(u), self.neighbours(v));
        let common = nu.iter().filter(|w| nv.binary_search(w).is_ok()).count();
        if common != far.len() || far.iter().any(|w| nv.binary_search(w).is_err()) {
            return None;
        }
        // A boundary u may only slide along a boundary edge.
        if removed.len() == 2 && self.on_boundary(u) {
            return None;
        }
        let placed = position != self.positions[v as usize];
        if placed && removed.len() == 2 && (self.on_boundary(u) || self.on_boundary(v)) {
            return None;
        }
        let mut moved: Vec<u32> = self.around[u as usize].iter().copied().filter(|f| !removed.contains(f)).collect();
        let from_u = moved.len();
        if placed {
            moved.extend(self.around[v as usize].iter().copied().filter(|f| !removed.contains(f)));
        }
        for (i, &f) in moved.iter().enumerate() {
            let t = self.faces[f as usize];
            let p = t.map(|i| self.positions[i as usize]);
            let q = self.moved_corners(f, u, v, position);
            let n0 = (p[1] - p[0]).cross(p[2] - p[0]);
            let n1 = (q[1] - q[0]).cross(q[2] - q[0]);
            let (l0, l1) = (n0.length(), n1.length());
            if l1 <= 1e-12 * l0.max(f64::MIN_POSITIVE) || n0.dot(n1) <= MIN_NORMAL_COSINE * l0 * l1 {
                return None;
            }
            if i >= from_u {
                continue;
            }
            // The moved triangle must not repeat one already around v.
            let (a, b) = match t.iter().position(|&i| i == u) {
                Some(0) => (t[1], t[2]),
                Some(1) => (t[2], t[0]),
                _ => (t[0], t[1]),
            };
            let twin = self.around[v as usize].iter().any(|&g| {
                !removed.contains(&g) && {
                    let s = self.faces[g as usize];
                    s.contains(&a) && s.contains(&b)
                }
            });
            if twin {
                return None;
            }
        }
        Some(Change { removed, moved, position })
    }

    /// Applies a checked collapse `u → v`: `v` moves to the change's
    /// position and takes `u`'s quadric as well as its own.
    pub fn apply(&mut self, u: u32, v: u32, change: &Change) {
        for &f in &change.removed {
            self.alive[f as usize] = false;
            self.live -= 1;
            for w in self.faces[f as usize] {
                self.around[w as usize].retain(|&g| g != f);
            }
        }
        for &f in &change.moved {
            let t = &mut self.faces[f as usize];
            if let Some(w) = t.iter_mut().find(|w| **w == u) {
                *w = v;
                self.around[v as usize].push(f);
            }
        }
        self.around[u as usize].clear();
        self.positions[v as usize] = change.position;
        self.quadrics[v as usize] = self.quadrics[v as usize] + self.quadrics[u as usize];
    }

    /// The corners of triangle `f` once `u` and `v` have merged at `position`.
    #[must_use]
    pub fn moved_corners(&self, f: u32, u: u32, v: u32, position: DVec3) -> [DVec3; 3] {
        self.faces[f as usize].map(|i| if i == u || i == v { position } else { self.positions[i as usize] })
    }

    /// The corners of triangle `f`.
    #[must_use]
    pub fn corners(&self, f: u32) -> [DVec3; 3] {
        self.faces[f as usize].map(|i| self.positions[i as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::meshes::icosphere_mesh;

    fn sphere() -> IndexedMesh {
        let (positions, faces) = icosphere_mesh(1);
        IndexedMesh { positions, faces: faces.iter().map(|t| t.map(|i| i as u32)).collect() }
    }

    #[test]
    fn collapses_keep_a_closed_sphere_manifold() {
        let mut d = Dynamic::new(&sphere());
        let mut done = 0;
        'outer: while d.live > 8 {
            for u in 0..d.positions.len() as u32 {
                for v in d.neighbours(u) {
                    if let Some(c) = d.check(u, v, d.positions[v as usize]) {
                        d.apply(u, v, &c);
                        done += 1;
                        let snap = d.snapshot();
                        assert_eq!(snap.check(), Ok(()), "after {done} collapses");
                        // Closed: every edge has two triangles, so V − E + F = 2.
                        continue 'outer;
                    }
                }
            }
            break;
        }
        assert!(done > 20, "{done}");
        assert!(d.live <= 8);
    }

    #[test]
    fn the_tetrahedron_cannot_collapse() {
        let m = IndexedMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            faces: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        };
        let d = Dynamic::new(&m);
        for u in 0..4 {
            for v in 0..4 {
                assert!(d.check(u, v, DVec3::ZERO).is_none());
            }
        }
    }
}
