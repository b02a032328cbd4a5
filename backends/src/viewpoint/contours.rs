//! Where visibility can change across a triangle (the solid-angle channel's
//! `a_o`, Part V eq. (2), is exact for every other triangle), decided from
//! the mesh's edges.
//!
//! Seen from an eye, the part of a triangle `t` that is visible is bounded by
//! `t`'s own edges, by the projections of *contour* edges lying in front of
//! `t` (edges where the surface folds over in the image: both triangles of
//! the edge on the same side of the plane through the eye and the edge, and
//! every boundary or non-manifold edge), and by curves where `t` cuts through
//! another triangle. So when no contour edge in front of `t`'s plane
//! crosses the interior of `t`'s projection and `t` cuts no other triangle,
//! every point of `t` is seen or hidden alike: its centroid's visibility is
//! its own. A triangle this test flags is sampled ([`super::solid_angle`]);
//! the others are taken whole, exactly. The test is conservative: a contour
//! hidden behind something else, or one that only grazes `t`, still flags it,
//! which costs rays, never accuracy.

use glam::{DVec3, Vec3A};

/// A point of the image plane (tangent-plane coordinates, `[-1, 1]` across
/// the cone around the bounding sphere).
type Px = (f64, f64);

/// Twice the signed area of `a, b, q`: positive when `q` is left of `a → b`.
fn edge(a: Px, b: Px, q: Px) -> f64 {
    (b.0 - a.0) * (q.1 - a.1) - (b.1 - a.1) * (q.0 - a.0)
}

/// The apex of an edge that has no two triangles.
const NO_APEX: u32 = u32::MAX;

/// The edges of a mesh, each with the third vertices of its two triangles
/// (`None` for a boundary or non-manifold edge: always a contour).
pub(super) struct MeshEdges {
    /// Each triangle's vertex ids, and each vertex once: a view projects
    /// every vertex once ([`Contours::new`]), not once per triangle.
    corners: Vec<[u32; 3]>,
    vertices: Vec<DVec3>,
    /// Each edge's two ends and the third vertices of its two triangles, as
    /// vertex ids ([`NO_APEX`] twice for a boundary or non-manifold edge):
    /// 16 bytes an edge, read by every view ([`Contours::new`]), against
    /// the 104 of the positions themselves.
    ids: Vec<[u32; 4]>,
    /// The triangles of each edge (one repeated for a boundary edge; `None`
    /// for a non-manifold edge).
    owners: Vec<Option<[u32; 2]>>,
}

impl MeshEdges {
    /// The edges of `triangles`, vertices matched by exact position
    /// ([`crate::scene::vertex_key32`]: -0.0 is 0.0).
    pub(super) fn new(triangles: &[[Vec3A; 3]], tris: &[[DVec3; 3]]) -> Self {
        let key = crate::scene::vertex_key32;
        let mut ids = std::collections::HashMap::new();
        let vid: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| {
                t.map(|v| {
                    let n = ids.len() as u32;
                    *ids.entry(key(v)).or_insert(n)
                })
            })
            .collect();
        // (low vertex, high vertex, triangle, corner opposite the edge)
        let mut all: Vec<(u32, u32, u32, u8)> = Vec::with_capacity(3 * vid.len());
        for (t, v) in vid.iter().enumerate() {
            for c in 0..3 {
                let (a, b) = (v[(c + 1) % 3], v[(c + 2) % 3]);
                all.push((a.min(b), a.max(b), t as u32, c as u8));
            }
        }
        all.sort_unstable();
        let mut vertices = vec![DVec3::ZERO; ids.len()];
        for (t, v) in vid.iter().enumerate() {
            for c in 0..3 {
                vertices[v[c] as usize] = tris[t][c];
            }
        }
        let (mut ids, mut owners) = (Vec::new(), Vec::new());
        for run in all.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            let (t, c) = (run[0].2 as usize, usize::from(run[0].3));
            let apex = match run {
                [x, y] if x.2 != y.2 => [vid[x.2 as usize][usize::from(x.3)], vid[y.2 as usize][usize::from(y.3)]],
                _ => [NO_APEX; 2],
            };
            ids.push([vid[t][(c + 1) % 3], vid[t][(c + 2) % 3], apex[0], apex[1]]);
            owners.push(match run {
                [x] => Some([x.2, x.2]),
                [x, y] => Some([x.2, y.2]),
                _ => None,
            });
        }
        Self { corners: vid, vertices, ids, owners }
    }

    /// Vertex ids of triangle `t` (what [`Contours::crosses`] takes).
    pub(super) fn corners(&self, t: usize) -> [u32; 3] {
        self.corners[t]
    }
}

/// Tiles per side of the contour grid for a mesh of `triangles` triangles:
/// about 4 × 4 triangles' worth of image each where the mesh fills it.
pub(super) fn contour_tiles(triangles: usize) -> usize {
    ((triangles as f64).sqrt() / 4.0).ceil().clamp(16.0, 256.0) as usize
}

/// One view's contour edges, projected and bucketed in a grid of tiles.
pub(super) struct Contours {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    /// Tiles per side of the grid over the image, and tiles per unit of
    /// image coordinate.
    tiles: usize,
    per_unit: f64,
    /// Every vertex of the mesh projected (by [`MeshEdges`] id).
    points: Vec<Px>,
    /// The tile range `[x0, x1, y0, y1]` of each projected vertex alone
    /// ([`Contours::tile_range`] of one point): a triangle's range is the
    /// least and greatest of its corners', since [`Contours::tile`] never
    /// decreases (four float-to-integer conversions a triangle were ~9% of
    /// a 1.1M-triangle first pass, against two a vertex here).
    vertex_tiles: Vec<[u16; 4]>,
    /// Tile `k`'s contours are `members[starts[k]..starts[k + 1]]`, each
    /// with its projected ends copied in tile order (read in sequence by
    /// [`Contours::crosses`], which takes their box and, for the few whose
    /// box meets the triangle's, the exact test from them) and its index.
    starts: Vec<u32>,
    members: Vec<([Px; 2], u32)>,
    /// Each contour's ends, in space and projected, and its edge (by
    /// [`MeshEdges`] index): every contour of the view, also those that
    /// [`Contours::hide`] left out of the tiles.
    ends: Vec<[DVec3; 2]>,
    projected: Vec<[Px; 2]>,
    edge: Vec<u32>,
}

impl Contours {
    /// The contours of `edges` seen from `eye` (outside the unit bounding
    /// sphere), in a grid of `tiles × tiles`.
    pub(super) fn new(edges: &MeshEdges, eye: DVec3, tiles: usize) -> Self {
        let forward = -eye.normalize();
        let (right, up) = forward.any_orthonormal_pair();
        // At most 2^16 a side: every tile index fits the u16 of `vertex_tiles`.
        let tiles = tiles.clamp(1, 1 << 16);
        // The image spans ±tan of the cone's half-angle around the unit sphere.
        let cone = 1.0 / (eye.length_squared() - 1.0).max(f64::MIN_POSITIVE).sqrt();
        let mut c = Self {
            eye,
            forward,
            right,
            up,
            tiles,
            per_unit: 0.5 * tiles as f64 / cone,
            points: Vec::new(),
            vertex_tiles: Vec::new(),
            starts: Vec::new(),
            members: Vec::new(),
            ends: Vec::new(),
            projected: Vec::new(),
            edge: Vec::new(),
        };
        c.points = edges.vertices.iter().map(|&p| c.project(p)).collect();
        c.vertex_tiles = c.points.iter().map(|p| c.tile_range(std::slice::from_ref(p)).map(|k| k as u16)).collect();
        let at = |k: u32| edges.vertices[k as usize];
        for (k, &[a, b, p, q]) in edges.ids.iter().enumerate() {
            let (ea, eb) = (at(a), at(b));
            let fold = p == NO_APEX || {
                let m = (ea - eye).cross(eb - eye);
                m.dot(at(p) - eye) * m.dot(at(q) - eye) >= 0.0
            };
            if fold {
                c.ends.push([ea, eb]);
                c.projected.push([c.points[a as usize], c.points[b as usize]]);
                c.edge.push(k as u32);
            }
        }
        c.bucket(|_| true);
        c
    }

    /// Buckets each contour that `keep` takes (by index) into the tiles its
    /// bounding box touches (counting, then filling, so each tile's list is
    /// in contour order).
    fn bucket(&mut self, keep: impl Fn(usize) -> bool) {
        let tiles = self.tiles;
        let ranges: Vec<(usize, [usize; 4])> =
            (0..self.projected.len()).filter(|&i| keep(i)).map(|i| (i, self.tile_range(&self.projected[i]))).collect();
        let mut count = vec![0u32; tiles * tiles + 1];
        for (_, r) in &ranges {
            for y in r[2]..=r[3] {
                for x in r[0]..=r[1] {
                    count[y * tiles + x + 1] += 1;
                }
            }
        }
        for k in 1..count.len() {
            count[k] += count[k - 1];
        }
        let mut fill = count.clone();
        self.members = vec![([(0.0, 0.0); 2], 0); count[tiles * tiles] as usize];
        for &(i, r) in &ranges {
            let ends = self.projected[i];
            for y in r[2]..=r[3] {
                for x in r[0]..=r[1] {
                    let k = y * tiles + x;
                    self.members[fill[k] as usize] = (ends, i as u32);
                    fill[k] += 1;
                }
            }
        }
        self.starts = count;
    }

    /// Leaves out of [`Contours::crosses`] every contour whose two triangles
    /// are both `hidden` (a boundary edge's one triangle; a non-manifold
    /// edge is always kept): the contours that a view built with those
    /// edges skipped would have, in the same order, without projecting the
    /// vertices or testing the folds again. Each call starts from all the
    /// view's contours.
    pub(super) fn hide(&mut self, edges: &MeshEdges, hidden: &[bool]) {
        let edge = std::mem::take(&mut self.edge);
        self.bucket(|i| {
            edges.owners[edge[i] as usize].is_none_or(|[a, b]| !(hidden[a as usize] && hidden[b as usize]))
        });
        self.edge = edge;
    }

    /// Contour edges of this view.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.ends.len()
    }

    /// The triangle pairs of the manifold edges that are no contour: where
    /// neither triangle of such an edge is crossed by a contour
    /// ([`Contours::crosses`]) nor cuts another, both are seen or hidden
    /// alike, since nothing bounds visibility between them.
    /// `edges` are the view's own ([`Contours::new`]'s); the contours are
    /// its edges in increasing order, so the links are the rest, read in
    /// step with them (no list of the ~1.65M links of a 1.1M-triangle
    /// view is written).
    pub(super) fn links<'a>(&'a self, edges: &'a MeshEdges) -> impl Iterator<Item = [u32; 2]> + 'a {
        let mut contour = self.edge.iter().copied().peekable();
        edges.owners.iter().enumerate().filter_map(move |(k, owners)| {
            // A boundary or non-manifold edge is always a contour.
            if contour.next_if_eq(&(k as u32)).is_some() { None } else { *owners }
        })
    }

    /// Where `p` projects (central projection onto the image plane).
    fn project(&self, p: DVec3) -> Px {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        (d.dot(self.right) / z, d.dot(self.up) / z)
    }

    /// Tile index of image coordinate `c`, clamped to the grid.
    fn tile(&self, c: f64) -> usize {
        // Truncation is the floor for the non-negative; NaN goes to 0.
        (((c * self.per_unit) + 0.5 * self.tiles as f64).max(0.0) as usize).min(self.tiles - 1)
    }

    /// [`Contours::tile_range`] of the projected corners `corners` (vertex
    /// ids), from their own ranges: a corner that projects to NaN has the
    /// empty range (`x0`, `y0` at the last tile, `x1`, `y1` at 0), as the
    /// box's `min`/`max` pass it over.
    fn corner_tiles(&self, corners: [u32; 3]) -> [usize; 4] {
        let [a, b, c] = corners.map(|k| self.vertex_tiles[k as usize]);
        [
            usize::from(a[0].min(b[0]).min(c[0])),
            usize::from(a[1].max(b[1]).max(c[1])),
            usize::from(a[2].min(b[2]).min(c[2])),
            usize::from(a[3].max(b[3]).max(c[3])),
        ]
    }

    /// `[x0, x1, y0, y1]` of the tiles the bounding box of `pts` touches.
    fn tile_range(&self, pts: &[Px]) -> [usize; 4] {
        let (mut lo, mut hi) = ((f64::INFINITY, f64::INFINITY), (f64::NEG_INFINITY, f64::NEG_INFINITY));
        for p in pts {
            lo = (lo.0.min(p.0), lo.1.min(p.1));
            hi = (hi.0.max(p.0), hi.1.max(p.1));
        }
        [self.tile(lo.0), self.tile(hi.0), self.tile(lo.1), self.tile(hi.1)]
    }

    /// Whether some contour edge not wholly behind the plane of `v` crosses
    /// the interior of `v`'s projection (see the module docs). A contour
    /// whose projection's box lies strictly outside the projected
    /// triangle's box cannot meet its interior and is passed over before
    /// the exact test; `v`'s plane is made only for a contour that crosses.
    /// `corners` are `v`'s vertex ids ([`MeshEdges::corners`]).
    pub(super) fn crosses(&self, corners: [u32; 3], v: &[DVec3; 3]) -> bool {
        let r = self.corner_tiles(corners);
        // Most triangles meet no contour's tile: nothing else is read.
        let rows = (r[2]..=r[3]).map(|y| y * self.tiles);
        if rows.clone().all(|row| self.starts[row + r[0]] == self.starts[row + r[1] + 1]) {
            return false;
        }
        let proj = corners.map(|k| self.points[k as usize]);
        let sign = edge(proj[0], proj[1], proj[2]).signum();
        if sign == 0.0 {
            return false;
        }
        let lo = (proj[0].0.min(proj[1].0).min(proj[2].0), proj[0].1.min(proj[1].1).min(proj[2].1));
        let hi = (proj[0].0.max(proj[1].0).max(proj[2].0), proj[0].1.max(proj[1].1).max(proj[2].1));
        // Without branches: most members fail, unpredictably.
        let outside = |[a, b]: &[Px; 2]| {
            (a.0.max(b.0) < lo.0) | (a.0.min(b.0) > hi.0) | (a.1.max(b.1) < lo.1) | (a.1.min(b.1) > hi.1)
        };
        let mut plane: Option<(DVec3, f64, f64)> = None;
        let mut behind = |p: DVec3| {
            let (n, eye_side, tol) = *plane.get_or_insert_with(|| {
                let n = (v[1] - v[0]).cross(v[2] - v[0]);
                (n, n.dot(self.eye - v[0]), 1e-9 * n.length_squared().sqrt())
            });
            let d = n.dot(p - v[0]);
            d.abs() > tol && d * eye_side < 0.0
        };
        // The tiles of one row of the range are consecutive in `members`
        // (tile order): one slice, the members in the same order as tile
        // by tile.
        for row in rows {
            let (first, last) = (self.starts[row + r[0]] as usize, self.starts[row + r[1] + 1] as usize);
            for (s, i) in &self.members[first..last] {
                if outside(s) || !crosses_interior(&proj, sign, *s) {
                    continue;
                }
                let e = &self.ends[*i as usize];
                if !(behind(e[0]) && behind(e[1])) {
                    return true;
                }
            }
        }
        false
    }
}

/// Whether segment `s` meets the open interior of triangle `p` (`sign`: the
/// sign of its signed area): the part of the segment on the inner side of
/// all three edges, clipped parameter by parameter, is not empty.
fn crosses_interior(p: &[Px; 3], sign: f64, s: [Px; 2]) -> bool {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for i in 0..3 {
        let (a, b) = (p[(i + 1) % 3], p[(i + 2) % 3]);
        let (fa, fb) = (sign * edge(a, b, s[0]), sign * edge(a, b, s[1]));
        if fa <= 0.0 && fb <= 0.0 {
            return false;
        }
        if fa > 0.0 && fb > 0.0 {
            continue;
        }
        let at = fa / (fa - fb);
        if fa <= 0.0 {
            lo = lo.max(at);
        } else {
            hi = hi.min(at);
        }
    }
    lo < hi
}

/// Triangles that cut through another triangle (not one sharing a vertex
/// with them): an edge of one crosses the other. Candidates come from a grid
/// of cells about the size of the largest triangle's box.
pub(super) fn cutting(tris: &[[DVec3; 3]]) -> Vec<bool> {
    let mut out = vec![false; tris.len()];
    if tris.is_empty() {
        return out;
    }
    let boxes: Vec<(DVec3, DVec3)> =
        tris.iter().map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))).collect();
    let mut sizes: Vec<f64> = boxes.iter().map(|b| (b.1 - b.0).max_element()).collect();
    sizes.sort_unstable_by(f64::total_cmp);
    // Cells twice the median box: most triangles fall in one to eight.
    let h = (2.0 * sizes[sizes.len() / 2]).max(1e-9);
    let cell = |p: DVec3| (p / h).floor().as_i64vec3();
    let mut keyed: Vec<(u64, u32)> = Vec::new();
    for (t, b) in boxes.iter().enumerate() {
        let (lo, hi) = (cell(b.0), cell(b.1));
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let k = (x as u64 & 0x1f_ffff) | (y as u64 & 0x1f_ffff) << 21 | (z as u64 & 0x1f_ffff) << 42;
                    keyed.push((k, t as u32));
                }
            }
        }
    }
    keyed.sort_unstable();
    let shares = |a: &[DVec3; 3], b: &[DVec3; 3]| a.iter().any(|p| b.contains(p));
    for run in keyed.chunk_by(|x, y| x.0 == y.0) {
        for (i, &(_, a)) in run.iter().enumerate() {
            for &(_, b) in &run[i + 1..] {
                let (ta, tb) = (&tris[a as usize], &tris[b as usize]);
                let (ba, bb) = (boxes[a as usize], boxes[b as usize]);
                if ba.0.cmpgt(bb.1).any() || bb.0.cmpgt(ba.1).any() || shares(ta, tb) {
                    continue;
                }
                if edges_cross(ta, tb) || edges_cross(tb, ta) {
                    out[a as usize] = true;
                    out[b as usize] = true;
                }
            }
        }
    }
    out
}

/// Whether an edge of `a` crosses triangle `b` (Möller–Trumbore in `f64`,
/// ends and rims included; edges parallel to `b`'s plane never cross).
fn edges_cross(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    let (e1, e2) = (b[1] - b[0], b[2] - b[0]);
    (0..3).any(|i| {
        let (p, d) = (a[i], a[(i + 1) % 3] - a[i]);
        let h = d.cross(e2);
        let det = e1.dot(h);
        if det.abs() <= 1e-14 * e1.length() * e2.length() * d.length() {
            return false;
        }
        let s = p - b[0];
        let u = s.dot(h) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        (0.0..=1.0).contains(&t) && u >= 0.0 && v >= 0.0 && u + v <= 1.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing an edge whose vertices are written once with
    /// -0.0 and once with 0.0 (as the Utah teapot's OBJ does): one manifold
    /// edge between them, not two boundary edges.
    #[test]
    fn minus_zero_is_the_same_vertex() {
        let (z, m) = (0.0f32, -0.0f32);
        let a = [Vec3A::new(z, 0.0, 0.0), Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(z, 1.0, 0.0)];
        let b = [Vec3A::new(m, 1.0, 0.0), Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(1.0, 1.0, 0.0)];
        let d = |t: [Vec3A; 3]| t.map(|v| DVec3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z)));
        let e = MeshEdges::new(&[a, b], &[d(a), d(b)]);
        assert_eq!(e.owners.len(), 5, "five edges, the diagonal shared");
        assert_eq!(e.owners.iter().filter(|o| matches!(o, Some([x, y]) if x != y)).count(), 1);
        assert_eq!(e.vertices.len(), 4);
    }

    #[test]
    fn segments_cross_the_open_interior_only() {
        let t = [(0.0, 0.0), (4.0, 0.0), (0.0, 4.0)];
        let sign = 1.0;
        assert!(crosses_interior(&t, sign, [(-1.0, 1.0), (5.0, 1.0)]), "straight through");
        assert!(crosses_interior(&t, sign, [(1.0, 1.0), (1.5, 1.0)]), "wholly inside");
        assert!(crosses_interior(&t, sign, [(0.0, 0.0), (1.0, 1.0)]), "from a vertex inwards");
        assert!(!crosses_interior(&t, sign, [(0.0, 0.0), (4.0, 0.0)]), "along an edge");
        assert!(!crosses_interior(&t, sign, [(0.0, 0.0), (-1.0, -1.0)]), "from a vertex outwards");
        assert!(!crosses_interior(&t, sign, [(4.0, 0.0), (4.0, 4.0)]), "touching at a vertex");
        assert!(!crosses_interior(&t, sign, [(3.0, 3.0), (5.0, 5.0)]), "outside");
        let reversed = [t[0], t[2], t[1]];
        assert!(crosses_interior(&reversed, -1.0, [(-1.0, 1.0), (5.0, 1.0)]));
    }

    /// Two unit squares (two triangles each) folded at a shared edge, the
    /// fold seen from either side: a contour only when both triangles of the
    /// edge lie on one side of the plane through the eye and the edge.
    #[test]
    fn a_fold_is_a_contour_and_a_flat_sheet_is_not() {
        let v = |x: f32, y: f32, z: f32| Vec3A::new(x, y, z);
        // Flat sheet in z = 0, two triangles sharing the diagonal.
        let flat = [
            [v(0.0, 0.0, 0.0), v(0.5, 0.0, 0.0), v(0.0, 0.5, 0.0)],
            [v(0.5, 0.0, 0.0), v(0.5, 0.5, 0.0), v(0.0, 0.5, 0.0)],
        ];
        // The second triangle folded back over the first.
        let folded = [flat[0], [v(0.5, 0.0, 0.0), v(0.1, 0.1, 0.2), v(0.0, 0.5, 0.0)]];
        let d = |t: &[[Vec3A; 3]]| t.iter().map(|t| t.map(|p| p.as_dvec3())).collect::<Vec<_>>();
        let eye = DVec3::new(0.1, 0.2, 3.0);
        let count = |t: &[[Vec3A; 3]]| {
            let tris = d(t);
            Contours::new(&MeshEdges::new(t, &tris), eye, 8).len()
        };
        // Flat: the four rim edges only; folded: the shared edge too.
        assert_eq!(count(&flat), 4);
        assert_eq!(count(&folded), 5);
        // In the folded pair the lower triangle is crossed by the upper one's
        // rim edges in front of it; the upper one, in front, by none.
        let tris = d(&folded);
        let edges = MeshEdges::new(&folded, &tris);
        let c = Contours::new(&edges, eye, 8);
        assert!(c.crosses(edges.corners(0), &tris[0]));
        assert!(!c.crosses(edges.corners(1), &tris[1]));
        // Flat: nothing crosses either.
        let tris = d(&flat);
        let edges = MeshEdges::new(&flat, &tris);
        let c = Contours::new(&edges, eye, 8);
        assert!(!c.crosses(edges.corners(0), &tris[0]) && !c.crosses(edges.corners(1), &tris[1]));
    }

    /// Hiding the upper triangle of the folded pair leaves out its rim
    /// edges (both ends of each are that triangle), which were what crossed
    /// the lower one; the shared fold (one end seen) stays. Each call starts
    /// from all the view's contours.
    #[test]
    fn hiding_drops_the_contours_of_hidden_triangles_only() {
        let v = |x: f32, y: f32, z: f32| Vec3A::new(x, y, z);
        let folded = [
            [v(0.0, 0.0, 0.0), v(0.5, 0.0, 0.0), v(0.0, 0.5, 0.0)],
            [v(0.5, 0.0, 0.0), v(0.1, 0.1, 0.2), v(0.0, 0.5, 0.0)],
        ];
        let tris: Vec<[DVec3; 3]> = folded.iter().map(|t| t.map(|p| p.as_dvec3())).collect();
        let edges = MeshEdges::new(&folded, &tris);
        let mut c = Contours::new(&edges, DVec3::new(0.1, 0.2, 3.0), 8);
        assert!(c.crosses(edges.corners(0), &tris[0]));
        c.hide(&edges, &[false, true]);
        assert!(!c.crosses(edges.corners(0), &tris[0]), "the upper rim is hidden");
        c.hide(&edges, &[true, false]);
        assert!(c.crosses(edges.corners(0), &tris[0]), "the upper rim is back");
        c.hide(&edges, &[false, false]);
        assert!(c.crosses(edges.corners(0), &tris[0]));
        assert_eq!(c.members.len(), Contours::new(&edges, DVec3::new(0.1, 0.2, 3.0), 8).members.len());
    }

    #[test]
    fn cutting_triangles_are_found_and_neighbours_are_not() {
        let tri = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| [DVec3::from(a), DVec3::from(b), DVec3::from(c)];
        let tris = vec![
            tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
            // Shares an edge with the first: a neighbour, not a cut.
            tri([1.0, 0.0, 0.0], [1.0, 1.0, 0.5], [0.0, 1.0, 0.0]),
            // Pierces the first through its interior.
            tri([0.2, 0.2, -0.5], [0.3, 0.2, 0.5], [0.2, 0.3, 0.5]),
            // Far away.
            tri([5.0, 5.0, 5.0], [6.0, 5.0, 5.0], [5.0, 6.0, 5.0]),
        ];
        assert_eq!(cutting(&tris), [true, false, true, false]);
    }
}
