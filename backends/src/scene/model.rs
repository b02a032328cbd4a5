//! The scene model: materials, patches and [`Scene`] (Part III §1.3), below
//! the built-in scenes, which are made of solids and meshes that use it.

use glam::DVec3;

use super::{Limits, SceneError};

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

impl Material {
    /// Largest emittance accepted per channel: 10¹². Radiosity pictures are
    /// f32 (largest 3.4·10³⁸) and the renderer sums squared radiance over up
    /// to 2¹⁶ samples a pixel; 10¹² keeps those sums 10⁹ below overflow,
    /// and no physical light in scene units comes near it (the Cornell
    /// box's is 12). `Ke 1e300` once made infinite pixels.
    pub const MAX_EMITTANCE: f64 = 1e12;
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
    /// The camera the file states (glTF's first camera, Mitsuba's sensor),
    /// in scene units; the default camera of the picture-writing commands.
    pub camera: Option<crate::camera::Camera>,
    /// Named warnings about the input (`"name: file:line: what"`), e.g. a
    /// non-planar OBJ face or an MTL statement that is not used; callers
    /// print them. Empty for built-in scenes.
    pub warnings: Vec<String>,
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

impl Scene {
    /// The name without the `/K` suffixes [`Scene::subdivided`] appends
    /// (`cornell-box/2` is still the Cornell box, with its camera).
    #[must_use]
    pub fn base_name(&self) -> &str {
        let mut name = self.name.as_str();
        while let Some((head, k)) = name.rsplit_once('/')
            && !head.is_empty()
            && !k.is_empty()
            && k.bytes().all(|b| b.is_ascii_digit())
        {
            name = head;
        }
        name
    }

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
    pub(super) fn new(name: &str) -> Self {
        Self { name: name.to_string(), materials: vec![Material::default()], ..Self::default() }
    }

    /// Adds one patch made of the given triangles (already triangulated,
    /// wound like their polygon); returns its index.
    pub fn add_triangles(&mut self, name: impl Into<String>, triangles: &[[DVec3; 3]], material: usize) -> u32 {
        let id = self.patches.len() as u32;
        let mut area = 0.0;
        let mut normal = DVec3::ZERO;
        for t in triangles {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            area += 0.5 * n.length();
            normal += n;
            self.triangles.push(*t);
            self.triangle_patch.push(id);
        }
        self.patches.push(Patch { name: name.into(), area, normal: normal.normalize_or_zero(), material });
        id
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
    ///
    /// The size of the result is computed first and checked against
    /// [`Limits`] before anything is allocated.
    ///
    /// # Errors
    /// [`SceneError::TooLarge`] when the subdivided scene would pass the limits.
    pub fn subdivided(&self, k: u32) -> Result<Scene, SceneError> {
        if k <= 1 {
            return Ok(self.clone());
        }
        let what = || format!("{} subdivided {k} x {k}", self.name);
        let k2 = u64::from(k) * u64::from(k);
        if let Some(c) = self.sphere {
            let (b, s) = (u64::from(c.bands) * u64::from(k), u64::from(c.sectors) * u64::from(k));
            Limits::check(&what(), 0, b.saturating_mul(s))?;
            let mut out = self.clone();
            let cells = SphereCells { bands: b as u32, sectors: s as u32, ..c };
            out.sphere = Some(cells);
            out.patches = sphere_patches(cells);
            return Ok(out);
        }
        // Every triangle becomes k² triangles; a parallelogram patch k²
        // patches, any other patch k² per triangle. Counted before allocating.
        let mut by_patch: Vec<Vec<usize>> = vec![Vec::new(); self.patches.len()];
        for (t, &p) in self.triangle_patch.iter().enumerate() {
            by_patch[p as usize].push(t);
        }
        let grids: Vec<Option<(DVec3, DVec3, DVec3)>> = by_patch
            .iter()
            .map(|tris| parallelogram(tris.iter().map(|&t| self.triangles[t]).collect::<Vec<_>>().as_slice()))
            .collect();
        let patches: u64 = by_patch
            .iter()
            .zip(&grids)
            .map(|(tris, g)| if g.is_some() { k2 } else { (tris.len() as u64).saturating_mul(k2) })
            .fold(0, u64::saturating_add);
        let triangles = (self.triangles.len() as u64).saturating_mul(k2);
        Limits::check(&what(), triangles, patches)?;
        let mut out = Scene {
            name: format!("{}/{k}", self.name),
            materials: self.materials.clone(),
            camera: self.camera,
            ..Scene::default()
        };
        // Both counts were checked against the limits above: grown in
        // place, the 1.1M-triangle bunny's lists were copied ~20 times.
        out.triangles.reserve(triangles as usize);
        out.triangle_patch.reserve(triangles as usize);
        out.patches.reserve(patches as usize);
        for (pi, tris) in by_patch.iter().enumerate() {
            let patch = &self.patches[pi];
            if let Some(q) = grids[pi] {
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
        Ok(out)
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
        // Halves first: `hi - lo` of coordinates near ±f64::MAX overflows.
        let scale = (hi * 0.5 - lo * 0.5).abs().max_element().max(f64::MIN_POSITIVE);
        for (t, tri) in self.triangles.iter().enumerate() {
            if tri.iter().any(|v| !v.is_finite()) {
                return Err(SceneError::Geometry(format!(
                    "{}: triangle {t} (patch {:?}) has a non-finite coordinate",
                    self.name, self.patches[self.triangle_patch[t] as usize].name
                )));
            }
            // Area relative to the scene's extent squared, computed on
            // scaled edges so that neither overflows nor underflows.
            let (e1, e2) = ((tri[1] - tri[0]) / scale, (tri[2] - tri[0]) / scale);
            let area = 0.5 * e1.cross(e2).length();
            if !(area > 1e-14) {
                return Err(SceneError::Geometry(format!(
                    "{}: triangle {t} (patch {:?}) is degenerate (area {area:e} of the extent squared)",
                    self.name, self.patches[self.triangle_patch[t] as usize].name
                )));
            }
        }
        if let Some((i, p)) = self.patches.iter().enumerate().find(|(_, p)| !(p.area.is_finite() && p.area > 0.0)) {
            return Err(SceneError::Geometry(format!(
                "{}: patch {i} ({:?}) has area {:e}, not a positive finite number in f64",
                self.name, p.name, p.area
            )));
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

pub(crate) fn sphere_patches(c: SphereCells) -> Vec<Patch> {
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
