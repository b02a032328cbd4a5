//! The indexed triangle mesh the simplifier works on: a scene's triangle
//! soup welded into shared vertices (equal coordinates; `-0.0` is `0.0`),
//! checked to be an edge- and vertex-manifold surface (with or without
//! boundary), in the normalised frame of the original scene.

use std::collections::HashMap;

use glam::{DVec3, Vec3A};

use crate::scene::{Material, Patch, Scene};
use crate::tracer::Prepared;

/// A welded triangle mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct IndexedMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Triangles: vertex indices, counter-clockwise seen from the front.
    pub faces: Vec<[u32; 3]>,
}

/// Why a mesh cannot be simplified as it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MeshError {
    /// No triangles.
    Empty,
    /// A triangle uses one vertex twice or has no area.
    Degenerate {
        /// Triangle index.
        face: usize,
    },
    /// Two triangles share all three vertices.
    Duplicate {
        /// The later of the two.
        face: usize,
    },
    /// An edge shared by more than two triangles.
    NonManifoldEdge {
        /// Its vertices.
        edge: [u32; 2],
        /// Triangles that share it.
        faces: usize,
    },
    /// A vertex whose triangles form more than one fan (two surfaces touching at a point).
    NonManifoldVertex {
        /// The vertex.
        vertex: u32,
        /// Fans around it.
        fans: usize,
    },
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MeshError::Empty => write!(f, "the mesh has no triangles"),
            MeshError::Degenerate { face } => write!(f, "triangle {face} is degenerate (a repeated vertex or no area)"),
            MeshError::Duplicate { face } => write!(f, "triangle {face} repeats the vertices of an earlier triangle"),
            MeshError::NonManifoldEdge { edge, faces } => write!(
                f,
                "non-manifold mesh: the edge between vertices {} and {} is shared by {faces} triangles (at most 2)",
                edge[0] + 1,
                edge[1] + 1
            ),
            MeshError::NonManifoldVertex { vertex, fans } => write!(
                f,
                "non-manifold mesh: {fans} separate fans of triangles meet at vertex {} (a surface touching itself)",
                vertex + 1
            ),
        }
    }
}

impl std::error::Error for MeshError {}

impl IndexedMesh {
    /// Welds triangles (scene units) by exact vertex coordinates, maps them
    /// to the normalised frame `(p − centre) / scale`, [repairs](IndexedMesh::repair)
    /// what it can and checks that the result is manifold.
    ///
    /// # Errors
    /// [`MeshError`] for an empty or non-manifold mesh.
    pub fn weld(triangles: &[[DVec3; 3]], centre: DVec3, scale: f64) -> Result<(Self, Repairs), MeshError> {
        let mut mesh = Self::index(triangles, centre, scale);
        let repairs = mesh.repair();
        mesh.check()?;
        Ok((mesh, repairs))
    }

    /// As [`IndexedMesh::weld`] without the manifold checks, for meshes
    /// that are only measured (another simplifier's output).
    ///
    /// # Errors
    /// [`MeshError::Empty`] when there are no triangles.
    pub fn weld_any(triangles: &[[DVec3; 3]], centre: DVec3, scale: f64) -> Result<Self, MeshError> {
        if triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        Ok(Self::index(triangles, centre, scale))
    }

    /// One vertex per distinct coordinate triple, compared as numbers:
    /// `-0.0` and `0.0` are the same coordinate (the Utah teapot's OBJ
    /// writes both on its symmetry planes; keyed by their bits they left 20
    /// zero-width slits along its seams). Mapped to `(p − centre) / scale`.
    fn index(triangles: &[[DVec3; 3]], centre: DVec3, scale: f64) -> Self {
        let key = crate::scene::vertex_key;
        let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
        let mut positions = Vec::new();
        let faces = triangles
            .iter()
            .map(|t| {
                t.map(|v| {
                    *ids.entry(key(v)).or_insert_with(|| {
                        positions.push((v - centre) / scale);
                        (positions.len() - 1) as u32
                    })
                })
            })
            .collect();
        Self { positions, faces }
    }

    /// Triangles.
    #[must_use]
    pub fn triangles(&self) -> usize {
        self.faces.len()
    }

    /// The three corners of face `f`.
    #[must_use]
    pub fn corners(&self, f: usize) -> [DVec3; 3] {
        self.faces[f].map(|i| self.positions[i as usize])
    }

    /// Surface area.
    #[must_use]
    pub fn area(&self) -> f64 {
        (0..self.faces.len()).map(|f| triangle_area(&self.corners(f))).sum()
    }

    /// Checks that every triangle has three distinct vertices and an area,
    /// no two triangles repeat their vertices, every edge has one or two
    /// triangles and the triangles around every vertex form one fan.
    ///
    /// # Errors
    /// The first problem found, as a [`MeshError`].
    pub fn check(&self) -> Result<(), MeshError> {
        if self.faces.is_empty() {
            return Err(MeshError::Empty);
        }
        let mut seen = HashMap::new();
        for (f, t) in self.faces.iter().enumerate() {
            let [a, b, c] = self.corners(f);
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || (b - a).cross(c - a).length_squared() == 0.0 {
                return Err(MeshError::Degenerate { face: f });
            }
            let mut s = *t;
            s.sort_unstable();
            if seen.insert(s, f).is_some() {
                return Err(MeshError::Duplicate { face: f });
            }
        }
        let mut edges: Vec<(u32, u32)> = Vec::with_capacity(3 * self.faces.len());
        for t in &self.faces {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                edges.push((a.min(b), a.max(b)));
            }
        }
        edges.sort_unstable();
        for run in edges.chunk_by(|x, y| x == y) {
            if run.len() > 2 {
                return Err(MeshError::NonManifoldEdge { edge: [run[0].0, run[0].1], faces: run.len() });
            }
        }
        let mut around: Vec<Vec<u32>> = vec![Vec::new(); self.positions.len()];
        for (f, t) in self.faces.iter().enumerate() {
            for &v in t {
                around[v as usize].push(f as u32);
            }
        }
        for (v, fs) in around.iter().enumerate() {
            let fans = fans(&self.faces, v as u32, fs);
            if fans > 1 {
                return Err(MeshError::NonManifoldVertex { vertex: v as u32, fans });
            }
        }
        Ok(())
    }

    /// The mesh as a scene in scene units (`prepared`'s frame undone), one
    /// patch per triangle, for tracing and OBJ output.
    #[must_use]
    pub fn to_scene(&self, name: &str, centre: DVec3, scale: f64) -> Scene {
        let mut scene = Scene { name: name.into(), materials: vec![Material::default()], ..Scene::default() };
        for f in 0..self.faces.len() {
            let t = self.corners(f).map(|p| p * scale + centre);
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            scene.triangles.push(t);
            scene.triangle_patch.push(f as u32);
            scene.patches.push(Patch {
                name: format!("t{f}"),
                area: 0.5 * n.length(),
                normal: n.normalize_or_zero(),
                material: 0,
            });
        }
        scene
    }

    /// The mesh ready to trace in its own (already normalised) frame: one
    /// patch per triangle, centre 0 and scale 1, so that channels and
    /// renders of the original and the simplified meshes share one frame.
    #[must_use]
    pub fn prepared(&self) -> Prepared {
        let triangles: Vec<[Vec3A; 3]> =
            (0..self.faces.len()).map(|f| self.corners(f).map(|p| Vec3A::from(p.as_vec3()))).collect();
        let normals = (0..self.faces.len())
            .map(|f| {
                let [a, b, c] = self.corners(f);
                Vec3A::from((b - a).cross(c - a).normalize_or_zero().as_vec3())
            })
            .collect();
        Prepared {
            triangles,
            normals,
            triangle_patch: (0..self.faces.len() as u32).collect(),
            sphere: None,
            centre: DVec3::ZERO,
            scale: 1.0,
            patches: self.faces.len(),
        }
    }

    /// Wavefront OBJ text in scene units (`p · scale + centre`), vertices
    /// that no triangle uses left out.
    #[must_use]
    pub fn to_obj(&self, centre: DVec3, scale: f64, comment: &str) -> String {
        use std::fmt::Write;
        let mut used = vec![u32::MAX; self.positions.len()];
        let mut order = Vec::new();
        for t in &self.faces {
            for &v in t {
                if used[v as usize] == u32::MAX {
                    used[v as usize] = order.len() as u32;
                    order.push(v);
                }
            }
        }
        let mut s = String::with_capacity(40 * (order.len() + self.faces.len()));
        for line in comment.lines() {
            let _ = writeln!(s, "# {line}");
        }
        for &v in &order {
            let p = self.positions[v as usize] * scale + centre;
            let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
        }
        for t in &self.faces {
            let _ =
                writeln!(s, "f {} {} {}", used[t[0] as usize] + 1, used[t[1] as usize] + 1, used[t[2] as usize] + 1);
        }
        s
    }
}

/// Fans of triangles around vertex `v` (`fs`: its triangles): groups
/// connected through edges that contain `v`. Returns the fan of each
/// triangle of `fs` (`0..fans`, in order of first appearance) and the count.
pub(crate) fn fan_labels(faces: &[[u32; 3]], v: u32, fs: &[u32]) -> (Vec<usize>, usize) {
    // Union-find over the triangles around v, joined by their other vertices.
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut parent: Vec<usize> = (0..fs.len()).collect();
    let mut by_vertex: HashMap<u32, usize> = HashMap::new();
    for (i, &f) in fs.iter().enumerate() {
        for &w in &faces[f as usize] {
            if w == v {
                continue;
            }
            if let Some(&j) = by_vertex.get(&w) {
                let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                parent[a] = b;
            } else {
                by_vertex.insert(w, i);
            }
        }
    }
    let mut label = vec![usize::MAX; fs.len()];
    let mut of_root: HashMap<usize, usize> = HashMap::new();
    for (i, l) in label.iter_mut().enumerate() {
        let r = root(&mut parent, i);
        let n = of_root.len();
        *l = *of_root.entry(r).or_insert(n);
    }
    let n = of_root.len();
    (label, n)
}

/// Fans of triangles around vertex `v` (see [`fan_labels`]).
pub(crate) fn fans(faces: &[[u32; 3]], v: u32, fs: &[u32]) -> usize {
    fan_labels(faces, v, fs).1
}

/// What [`IndexedMesh::repair`] changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Repairs {
    /// Triangles removed for a repeated vertex or no area.
    pub degenerate: usize,
    /// Triangles removed for repeating an earlier triangle's vertices.
    pub duplicates: usize,
    /// Triangles given vertices of their own because an edge of theirs
    /// already had two triangles (the later ones in input order).
    pub detached: usize,
    /// Vertices split because separate fans of triangles met there.
    pub split_vertices: usize,
}

impl Repairs {
    /// Whether anything changed.
    #[must_use]
    pub fn any(&self) -> bool {
        self.degenerate + self.duplicates + self.detached + self.split_vertices > 0
    }
}

impl std::fmt::Display for Repairs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "removed {} degenerate and {} duplicate triangles, detached {} triangles from edges with more than two, \
             split {} vertices where separate surfaces touched",
            self.degenerate, self.duplicates, self.detached, self.split_vertices
        )
    }
}

impl IndexedMesh {
    /// Repairs what can be repaired without guessing: triangles with a
    /// repeated vertex or no area and repeated triangles are removed, and a
    /// vertex where several fans of triangles meet becomes one vertex per
    /// fan (same position). A triangle with an edge that two earlier
    /// triangles already have gets copies of its vertices (it becomes a
    /// separate piece), as OpenMesh's reader does. The result passes
    /// [`IndexedMesh::check`] unless it is empty.
    pub fn repair(&mut self) -> Repairs {
        let mut r = Repairs::default();
        let mut seen = std::collections::HashSet::new();
        let positions = &self.positions;
        self.faces.retain(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || (b - a).cross(c - a).length_squared() == 0.0 {
                r.degenerate += 1;
                return false;
            }
            let mut s = *t;
            s.sort_unstable();
            if seen.insert(s) {
                true
            } else {
                r.duplicates += 1;
                false
            }
        });
        let mut count: HashMap<(u32, u32), u8> = HashMap::new();
        for f in 0..self.faces.len() {
            let t = self.faces[f];
            let key = |a: u32, b: u32| (a.min(b), a.max(b));
            let full = [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
                .iter()
                .any(|&(a, b)| count.get(&key(a, b)).is_some_and(|&c| c >= 2));
            if full {
                r.detached += 1;
                let first = self.positions.len() as u32;
                for w in t {
                    self.positions.push(self.positions[w as usize]);
                }
                self.faces[f] = [first, first + 1, first + 2];
                continue;
            }
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *count.entry(key(a, b)).or_default() += 1;
            }
        }
        let mut around: Vec<Vec<u32>> = vec![Vec::new(); self.positions.len()];
        for (f, t) in self.faces.iter().enumerate() {
            for &v in t {
                around[v as usize].push(f as u32);
            }
        }
        for (v, fs) in around.iter().enumerate() {
            let (label, n) = fan_labels(&self.faces, v as u32, fs);
            if n <= 1 {
                continue;
            }
            r.split_vertices += 1;
            let first = self.positions.len() as u32;
            for _ in 1..n {
                self.positions.push(self.positions[v]);
            }
            for (i, &f) in fs.iter().enumerate() {
                if label[i] > 0 {
                    for w in &mut self.faces[f as usize] {
                        if *w == v as u32 {
                            *w = first + label[i] as u32 - 1;
                        }
                    }
                }
            }
        }
        r
    }
}

/// Area of the triangle with corners `t`.
#[must_use]
pub(crate) fn triangle_area(t: &[DVec3; 3]) -> f64 {
    0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> IndexedMesh {
        IndexedMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            faces: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        }
    }

    #[test]
    fn closed_tetrahedron_is_manifold() {
        assert_eq!(tetra().check(), Ok(()));
    }

    #[test]
    fn three_triangles_on_an_edge_are_refused() {
        let mut m = tetra();
        m.positions.push(DVec3::new(-1.0, -1.0, 0.5));
        m.faces.push([0, 1, 4]);
        assert!(matches!(m.check(), Err(MeshError::NonManifoldEdge { faces: 3, .. })));
        let r = m.repair();
        assert_eq!(r.detached, 1);
        assert_eq!(m.check(), Ok(()));
        assert_eq!(m.faces[4], [5, 6, 7]);
    }

    #[test]
    fn two_cones_touching_at_a_vertex_are_refused() {
        // Two triangles sharing only vertex 0.
        let m = IndexedMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, -DVec3::X, -DVec3::Y + DVec3::Z],
            faces: vec![[0, 1, 2], [0, 3, 4]],
        };
        assert_eq!(m.check(), Err(MeshError::NonManifoldVertex { vertex: 0, fans: 2 }));
        let mut fixed = m.clone();
        let r = fixed.repair();
        assert_eq!(r.split_vertices, 1);
        assert_eq!(fixed.check(), Ok(()));
        assert_eq!(fixed.positions.len(), 6);
        assert_eq!(fixed.positions[5], fixed.positions[0]);
    }

    #[test]
    fn minus_zero_welds_with_zero() {
        // Two triangles on the plane x = 0 sharing an edge, one written
        // with -0.0 there (as the Utah teapot's OBJ is): one surface, the
        // shared edge inside it, no boundary there.
        let (z, m) = (0.0, -0.0);
        let tris = [
            [DVec3::new(z, 0.0, 0.0), DVec3::new(z, 1.0, 0.0), DVec3::new(1.0, 0.5, 0.0)],
            [DVec3::new(m, 1.0, 0.0), DVec3::new(m, 0.0, 0.0), DVec3::new(-1.0, 0.5, 0.0)],
        ];
        let (w, r) = IndexedMesh::weld(&tris, DVec3::ZERO, 1.0).unwrap();
        assert!(!r.any(), "{r}");
        assert_eq!(w.positions.len(), 4);
        assert_eq!(IndexedMesh::weld_any(&tris, DVec3::ZERO, 1.0).unwrap().positions.len(), 4);
    }

    #[test]
    fn degenerate_and_duplicate_triangles_are_refused() {
        let mut m = tetra();
        m.faces.push([2, 0, 1]);
        assert_eq!(m.check(), Err(MeshError::Duplicate { face: 4 }));
        let mut m = tetra();
        m.faces[0] = [0, 0, 1];
        assert_eq!(m.check(), Err(MeshError::Degenerate { face: 0 }));
        let mut m = tetra();
        m.faces.push([2, 0, 1]);
        m.faces.push([3, 3, 1]);
        let r = m.repair();
        assert_eq!((r.duplicates, r.degenerate), (1, 1));
        assert_eq!(m, tetra());
    }
}
