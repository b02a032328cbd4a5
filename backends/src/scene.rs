//! Scenes: triangles grouped into patches (Part III §1.3), built in or read
//! from Wavefront OBJ.
//!
//! A patch is one polygon of the input or one cell of a subdivision; the
//! visibility channel's states are patches. Triangles keep the winding of
//! their polygon: the front side (counter-clockwise seen from the front) is
//! where the patch emits and receives lines. Enclosures face inwards, solid
//! objects outwards.

use std::fmt;

use glam::DVec3;

/// Surface properties carried through to radiosity and rendering.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Material name (from the OBJ's `usemtl`, or the built-in's).
    pub name: String,
    /// Diffuse reflectance ρ per RGB channel.
    pub reflectance: [f64; 3],
    /// Emittance E per RGB channel.
    pub emittance: [f64; 3],
    /// Ideal mirror.
    pub mirror: bool,
}

impl Default for Material {
    fn default() -> Self {
        Self { name: "default".into(), reflectance: [0.7; 3], emittance: [0.0; 3], mirror: false }
    }
}

/// One patch.
#[derive(Clone, Debug, PartialEq)]
pub struct Patch {
    /// A readable name (`"floor[3,4]"`, `"g box/face 2"`).
    pub name: String,
    /// Area in scene units².
    pub area: f64,
    /// Area-weighted unit normal (front side).
    pub normal: DVec3,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

/// Triangles grouped into patches.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// Scene name (built-in spec or file name).
    pub name: String,
    /// Triangle vertices, three per triangle.
    pub triangles: Vec<[DVec3; 3]>,
    /// Patch of each triangle.
    pub triangle_patch: Vec<u32>,
    /// Patches.
    pub patches: Vec<Patch>,
    /// Materials.
    pub materials: Vec<Material>,
    /// An analytic sphere of this radius at the origin, seen from inside
    /// (then `triangles` is empty and patches are its equal-area cells).
    pub sphere: Option<SphereCells>,
}

/// Equal-area cells of a sphere: `bands` slabs of equal height in z
/// (equal area by Archimedes) times `sectors` equal angles in φ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereCells {
    /// Radius.
    pub radius: f64,
    /// Slabs in z.
    pub bands: u32,
    /// Sectors in φ.
    pub sectors: u32,
}

impl SphereCells {
    /// The cell containing the point `p` on the sphere.
    #[must_use]
    pub fn cell(&self, p: DVec3) -> u32 {
        let z = (p.z / self.radius).clamp(-1.0, 1.0);
        let band = (((1.0 - z) / 2.0 * f64::from(self.bands)) as u32).min(self.bands - 1);
        let phi = p.y.atan2(p.x).rem_euclid(std::f64::consts::TAU);
        let sector = ((phi / std::f64::consts::TAU * f64::from(self.sectors)) as u32).min(self.sectors - 1);
        band * self.sectors + sector
    }
}

/// Why a scene could not be made.
#[derive(Debug, Clone, PartialEq)]
pub enum SceneError {
    /// Unknown built-in name or bad parameter.
    Spec(String),
    /// The OBJ file could not be read or parsed.
    Obj {
        /// File path.
        path: String,
        /// What went wrong, with line or face where known.
        message: String,
    },
    /// Geometry that cannot be traced.
    Geometry(String),
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::Spec(m) | SceneError::Geometry(m) => f.write_str(m),
            SceneError::Obj { path, message } => write!(f, "{path}: {message}"),
        }
    }
}

impl std::error::Error for SceneError {}

/// Built-in scene names, for help texts.
pub const BUILT_IN: &[(&str, &str)] = &[
    ("cube-enclosure:N", "inside of the unit cube, each face split into N x N squares (Part III Fig. 13)"),
    (
        "tetrahedron | cube | octahedron | dodecahedron | icosahedron",
        "regular solids seen from inside, one patch per face (Table 4)",
    ),
    ("sphere[:B,S]", "exact sphere seen from inside, B z-bands x S sectors of equal area (default 8,16)"),
    (
        "cornell-box",
        "closed Cornell box from the published measurements: 5 walls, open front closed, light, two blocks (Fig. 20a)",
    ),
    ("geosphere[:L]", "unit geodesic sphere seen from outside, 20*4^(L-1) triangles (default L = 2: 80)"),
    ("torus[:U,V]", "ring torus (radii 1 and 0.4) seen from outside, U x V quads (default 48,24)"),
    ("table-chairs[:N]", "a table with four chairs, 25 boxes seen from outside, faces split N x N (default 2)"),
    (
        "cubes-room:K[:clustered][:SEED]",
        "cube enclosure 10x10 per face with K small cubes, random (default) or clustered (Figs. 11, 15, 16)",
    ),
];

impl Scene {
    /// Total area `A_T`.
    #[must_use]
    pub fn total_area(&self) -> f64 {
        self.patches.iter().map(|p| p.area).sum()
    }

    /// Patch areas.
    #[must_use]
    pub fn areas(&self) -> Vec<f64> {
        self.patches.iter().map(|p| p.area).collect()
    }

    /// Axis-aligned bounds `(min, max)`.
    #[must_use]
    pub fn bounds(&self) -> (DVec3, DVec3) {
        if let Some(s) = self.sphere {
            return (DVec3::splat(-s.radius), DVec3::splat(s.radius));
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &self.triangles {
            for v in t {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
        }
        (lo, hi)
    }

    /// Starts a scene with one material.
    #[must_use]
    pub fn named(name: &str) -> Self {
        Self::new(name)
    }

    /// Starts a scene with one material.
    fn new(name: &str) -> Self {
        Self { name: name.to_string(), materials: vec![Material::default()], ..Self::default() }
    }

    /// Adds a planar convex polygon (fan-triangulated) as one patch; returns its index.
    pub fn add_polygon(&mut self, name: impl Into<String>, vertices: &[DVec3], material: usize) -> u32 {
        let id = self.patches.len() as u32;
        let mut area = 0.0;
        let mut normal = DVec3::ZERO;
        for k in 1..vertices.len() - 1 {
            let t = [vertices[0], vertices[k], vertices[k + 1]];
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            area += 0.5 * n.length();
            normal += n;
            self.triangles.push(t);
            self.triangle_patch.push(id);
        }
        self.patches.push(Patch { name: name.into(), area, normal: normal.normalize_or_zero(), material });
        id
    }

    /// Adds a quad `corner, corner + u, corner + u + v, corner + v` split into
    /// `nu × nv` cells, each its own patch (front side `u × v`).
    #[allow(clippy::too_many_arguments)]
    pub fn add_grid(&mut self, name: &str, corner: DVec3, u: DVec3, v: DVec3, nu: u32, nv: u32, material: usize) {
        for a in 0..nu {
            for b in 0..nv {
                let p =
                    |i: u32, j: u32| corner + u * (f64::from(i) / f64::from(nu)) + v * (f64::from(j) / f64::from(nv));
                let quad = [p(a, b), p(a + 1, b), p(a + 1, b + 1), p(a, b + 1)];
                self.add_polygon(format!("{name}[{a},{b}]"), &quad, material);
            }
        }
    }

    /// Adds an axis-aligned box `[lo, hi]` facing outwards (or inwards),
    /// each face split `n × n`.
    pub fn add_box(&mut self, name: &str, lo: DVec3, hi: DVec3, n: u32, inward: bool, material: usize) {
        let d = hi - lo;
        let (x, y, z) = (DVec3::new(d.x, 0.0, 0.0), DVec3::new(0.0, d.y, 0.0), DVec3::new(0.0, 0.0, d.z));
        // (corner, u, v) with u × v pointing outwards.
        let faces = [
            ("x-", lo, z, y),
            ("x+", lo + x, y, z),
            ("y-", lo, x, z),
            ("y+", lo + y, z, x),
            ("z-", lo, y, x),
            ("z+", lo + z, x, y),
        ];
        for (f, c, u, v) in faces {
            let (u, v) = if inward { (v, u) } else { (u, v) };
            self.add_grid(&format!("{name} {f}"), c, u, v, n, n, material);
        }
    }

    /// Splits every patch into `k × k` cells (quads) or `k²` triangles.
    ///
    /// Triangle `(a, b, c)` is split into the `k²` triangles of its regular
    /// subdivision; a patch made of two triangles forming a parallelogram is
    /// split into `k × k` parallelogram cells.
    #[must_use]
    pub fn subdivided(&self, k: u32) -> Scene {
        if k <= 1 || self.sphere.is_some() {
            let mut s = self.clone();
            if let Some(c) = &mut s.sphere {
                *c = SphereCells { bands: c.bands * k.max(1), sectors: c.sectors * k.max(1), ..*c };
                s.patches = sphere_patches(*c);
            }
            return s;
        }
        let mut out =
            Scene { name: format!("{}/{k}", self.name), materials: self.materials.clone(), ..Scene::default() };
        // Group triangles by patch.
        let mut by_patch: Vec<Vec<usize>> = vec![Vec::new(); self.patches.len()];
        for (t, &p) in self.triangle_patch.iter().enumerate() {
            by_patch[p as usize].push(t);
        }
        for (pi, tris) in by_patch.iter().enumerate() {
            let patch = &self.patches[pi];
            if let Some(q) = parallelogram(tris.iter().map(|&t| self.triangles[t]).collect::<Vec<_>>().as_slice()) {
                let (c, u, v) = q;
                out.add_grid(&patch.name, c, u, v, k, k, patch.material);
                continue;
            }
            let mut cell = 0;
            for &t in tris {
                let [a, b, c] = self.triangles[t];
                let p = |i: u32, j: u32| {
                    a + (b - a) * (f64::from(i) / f64::from(k)) + (c - a) * (f64::from(j) / f64::from(k))
                };
                for i in 0..k {
                    for j in 0..k - i {
                        out.add_polygon(
                            format!("{}#{cell}", patch.name),
                            &[p(i, j), p(i + 1, j), p(i, j + 1)],
                            patch.material,
                        );
                        cell += 1;
                        if i + j + 1 < k {
                            out.add_polygon(
                                format!("{}#{cell}", patch.name),
                                &[p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)],
                                patch.material,
                            );
                            cell += 1;
                        }
                    }
                }
            }
        }
        out
    }

    /// Checks the scene can be traced: at least one patch, finite
    /// coordinates, no degenerate (zero-area) triangle.
    ///
    /// # Errors
    /// [`SceneError::Geometry`] naming the first offending triangle and patch.
    pub fn validate(&self) -> Result<(), SceneError> {
        if self.patches.is_empty() {
            return Err(SceneError::Geometry(format!("{}: scene has no faces", self.name)));
        }
        if self.sphere.is_some() {
            return Ok(());
        }
        let (lo, hi) = self.bounds();
        let scale = (hi - lo).length().max(f64::MIN_POSITIVE);
        for (t, tri) in self.triangles.iter().enumerate() {
            if tri.iter().any(|v| !v.is_finite()) {
                return Err(SceneError::Geometry(format!(
                    "{}: triangle {t} (patch {:?}) has a non-finite coordinate",
                    self.name, self.patches[self.triangle_patch[t] as usize].name
                )));
            }
            let area = 0.5 * (tri[1] - tri[0]).cross(tri[2] - tri[0]).length();
            if !(area > 1e-14 * scale * scale) {
                return Err(SceneError::Geometry(format!(
                    "{}: triangle {t} (patch {:?}) is degenerate (area {area:e})",
                    self.name, self.patches[self.triangle_patch[t] as usize].name
                )));
            }
        }
        Ok(())
    }
}

/// If `tris` are two triangles forming a parallelogram, `(corner, u, v)`.
fn parallelogram(tris: &[[DVec3; 3]]) -> Option<(DVec3, DVec3, DVec3)> {
    if tris.len() != 2 {
        return None;
    }
    // Fan of a quad (p0,p1,p2,p3): (p0,p1,p2), (p0,p2,p3).
    let ([p0, p1, p2], [q0, q2, p3]) = (tris[0], tris[1]);
    if p0 != q0 || p2 != q2 {
        return None;
    }
    let (u, v) = (p1 - p0, p3 - p0);
    ((p0 + u + v - p2).length() <= 1e-12 * (u.length() + v.length())).then_some((p0, u, v))
}

fn sphere_patches(c: SphereCells) -> Vec<Patch> {
    let area = 4.0 * std::f64::consts::PI * c.radius * c.radius / f64::from(c.bands * c.sectors);
    let mut out = Vec::new();
    for b in 0..c.bands {
        for s in 0..c.sectors {
            let z = 1.0 - 2.0 * (f64::from(b) + 0.5) / f64::from(c.bands);
            let phi = std::f64::consts::TAU * (f64::from(s) + 0.5) / f64::from(c.sectors);
            let r = (1.0 - z * z).sqrt();
            out.push(Patch {
                name: format!("sphere[{b},{s}]"),
                area,
                normal: -DVec3::new(r * phi.cos(), r * phi.sin(), z),
                material: 0,
            });
        }
    }
    out
}

fn parse_u32(spec: &str, what: &str, s: &str, max: u32) -> Result<u32, SceneError> {
    s.parse::<u32>()
        .ok()
        .filter(|&v| v >= 1 && v <= max)
        .ok_or_else(|| SceneError::Spec(format!("{spec}: {what} must be an integer in 1..={max}, got {s:?}")))
}

/// An optional `A,B` parameter pair of integers in `1..=4096`, or `default`.
fn parse_pair(
    spec: &str,
    part: Option<&str>,
    names: (&str, &str),
    default: (u32, u32),
) -> Result<(u32, u32), SceneError> {
    let Some(p) = part else { return Ok(default) };
    let (a, b) = p.split_once(',').ok_or_else(|| {
        let kind = spec.split(':').next().unwrap_or(spec);
        SceneError::Spec(format!("{spec}: expected {kind}:{},{}", names.0, names.1))
    })?;
    Ok((parse_u32(spec, names.0, a, 4096)?, parse_u32(spec, names.1, b, 4096)?))
}

/// A built-in scene by name (see [`BUILT_IN`]).
///
/// # Errors
/// [`SceneError::Spec`] for an unknown name or a bad parameter.
pub fn built_in(spec: &str) -> Result<Scene, SceneError> {
    let parts: Vec<&str> = spec.split(':').collect();
    let scene = match parts[0] {
        "cube-enclosure" => {
            let n = parse_u32(spec, "N", parts.get(1).copied().unwrap_or("10"), 1000)?;
            let mut s = Scene::new(spec);
            s.add_box("cube", DVec3::ZERO, DVec3::ONE, n, true, 0);
            s
        }
        "tetrahedron" | "cube" | "octahedron" | "dodecahedron" | "icosahedron" => {
            let mut s = Scene::new(spec);
            for (i, face) in crate::solids::faces(parts[0]).iter().enumerate() {
                // Seen from inside: reverse the outward winding.
                let inward: Vec<DVec3> = face.iter().rev().copied().collect();
                s.add_polygon(format!("face {i}"), &inward, 0);
            }
            s
        }
        "sphere" => {
            let (b, sct) = parse_pair(spec, parts.get(1).copied(), ("B", "S"), (8, 16))?;
            let cells = SphereCells { radius: 1.0, bands: b, sectors: sct };
            Scene {
                name: spec.into(),
                patches: sphere_patches(cells),
                materials: vec![Material::default()],
                sphere: Some(cells),
                ..Scene::default()
            }
        }
        "cornell-box" => crate::solids::cornell_box(),
        "geosphere" => {
            let l = parse_u32(spec, "L", parts.get(1).copied().unwrap_or("2"), 9)?;
            crate::meshes::geosphere(spec, l - 1)
        }
        "torus" => {
            let (u, v) = parse_pair(spec, parts.get(1).copied(), ("U", "V"), (48, 24))?;
            if u < 3 || v < 3 {
                return Err(SceneError::Spec(format!("{spec}: U and V must be at least 3")));
            }
            crate::meshes::torus(spec, 1.0, 0.4, u, v)
        }
        "table-chairs" => {
            let n = parse_u32(spec, "N", parts.get(1).copied().unwrap_or("2"), 256)?;
            crate::meshes::table_with_chairs(spec, n)
        }
        "cubes-room" => {
            let k = parse_u32(spec, "K", parts.get(1).copied().unwrap_or("27"), 4096)?;
            let mut clustered = false;
            let mut seed = 1u64;
            for p in &parts[2..] {
                match *p {
                    "clustered" => clustered = true,
                    "random" => clustered = false,
                    s => {
                        seed = s.parse().map_err(|_| {
                            SceneError::Spec(format!("{spec}: expected 'clustered', 'random' or a seed, got {s:?}"))
                        })?;
                    }
                }
            }
            crate::solids::cubes_room(spec, k, clustered, seed)
        }
        other => {
            return Err(SceneError::Spec(format!(
                "unknown scene {other:?}: not a built-in (cube-enclosure:N, tetrahedron, cube, octahedron, dodecahedron, icosahedron, sphere, cornell-box, cubes-room:K, geosphere:L, torus:U,V, table-chairs:N) and no such .obj file"
            )));
        }
    };
    scene.validate()?;
    Ok(scene)
}
