//! Area lights and per-triangle materials of a scene, in the tracer's
//! normalised coordinates.
//!
//! An emissive material's `emittance` is read as the constant radiance
//! `L_e` leaving the front side of its triangles (the convention of
//! Mitsuba's `area` emitter: the Cornell box's light is `L_e = (17, 12, 4)`).
//! Lights are chosen for next-event estimation with probability proportional
//! to `area × Y(L_e)` (power), then a point uniformly on the triangle.

use glam::{DVec3, Vec3A};
use itgfx_core::pixel::luminance;

use crate::scene::{Material, Scene};
use crate::tracer::Prepared;

/// One emitting triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightTriangle {
    /// Vertices (normalised coordinates).
    pub vertices: [DVec3; 3],
    /// Unit front normal.
    pub normal: DVec3,
    /// Area (normalised units²).
    pub area: f64,
    /// Radiance leaving the front side.
    pub radiance: [f64; 3],
}

/// The emitting triangles with their selection probabilities.
#[derive(Clone, Debug, PartialEq)]
pub struct Lights {
    /// Emitting triangles.
    pub triangles: Vec<LightTriangle>,
    /// Cumulative selection probabilities (last is 1).
    pub cdf: Vec<f64>,
    /// Selection probability of each light.
    pub probability: Vec<f64>,
    /// Light index of each scene triangle (`u32::MAX`: not a light).
    pub of_triangle: Vec<u32>,
    /// The same lights in f32 for the path tracer's shading.
    pub(crate) fast: Vec<FastLight>,
    /// [`Lights::cdf`] in f32.
    pub(crate) cdf32: Vec<f32>,
}

/// A light triangle as the f32 shading reads it: a vertex and two edges,
/// the unit front normal, the radiance, and `P(light) / area`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FastLight {
    pub(crate) v0: Vec3A,
    pub(crate) e1: Vec3A,
    pub(crate) e2: Vec3A,
    pub(crate) normal: Vec3A,
    pub(crate) radiance: Vec3A,
    pub(crate) density: f32,
}

impl Lights {
    /// The emitting triangles of `scene` (prepared as `prepared`); `None`
    /// when nothing emits.
    #[must_use]
    pub fn new(scene: &Scene, prepared: &Prepared) -> Option<Self> {
        let mut triangles = Vec::new();
        let mut weights = Vec::new();
        let mut of_triangle = vec![u32::MAX; prepared.triangles.len()];
        for (t, tri) in prepared.triangles.iter().enumerate() {
            let m = &scene.materials[scene.patches[prepared.triangle_patch[t] as usize].material];
            let y = luminance(m.emittance);
            if !(y > 0.0) {
                continue;
            }
            let v = tri.map(|p| DVec3::from(p.to_array().map(f64::from)));
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            let area = 0.5 * n.length();
            if !(area > 0.0) {
                continue;
            }
            of_triangle[t] = triangles.len() as u32;
            triangles.push(LightTriangle { vertices: v, normal: n / (2.0 * area), area, radiance: m.emittance });
            weights.push(area * y);
        }
        if triangles.is_empty() {
            return None;
        }
        let total: f64 = weights.iter().sum();
        let probability: Vec<f64> = weights.iter().map(|w| w / total).collect();
        let mut acc = 0.0;
        let mut cdf: Vec<f64> = probability
            .iter()
            .map(|p| {
                acc += p;
                acc
            })
            .collect();
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let fast = triangles
            .iter()
            .zip(&probability)
            .map(|(l, p)| {
                let v = l.vertices.map(|x| x.as_vec3a());
                FastLight {
                    v0: v[0],
                    e1: v[1] - v[0],
                    e2: v[2] - v[0],
                    normal: l.normal.as_vec3a(),
                    radiance: DVec3::from(l.radiance).as_vec3a(),
                    density: (p / l.area) as f32,
                }
            })
            .collect();
        let cdf32 = cdf.iter().map(|&c| c as f32).collect();
        Some(Self { triangles, cdf, probability, of_triangle, fast, cdf32 })
    }

    /// [`Lights::sample`] in f32: `(light, point)`, the point
    /// `v0 + √a (1 − b) e1 + √a b e2` (uniform on the triangle).
    #[inline]
    pub(crate) fn sample32(&self, u: f32, a: f32, b: f32) -> (usize, Vec3A) {
        let i = self.cdf32.partition_point(|&c| c <= u).min(self.cdf32.len() - 1);
        let l = &self.fast[i];
        let s = a.sqrt();
        (i, l.v0 + l.e1 * (s * (1.0 - b)) + l.e2 * (s * b))
    }

    /// [`Lights::pdf`] in f32.
    #[inline]
    pub(crate) fn pdf32(&self, i: usize, distance: f32, cos_light: f32) -> f32 {
        self.fast[i].density * distance * distance / cos_light
    }

    /// Picks a light with `u` and a point on it with `(a, b)`: `(light, point)`.
    #[must_use]
    pub fn sample(&self, u: f64, a: f64, b: f64) -> (usize, DVec3) {
        let i = crate::lines::sample_cdf(&self.cdf, u);
        let [v0, v1, v2] = self.triangles[i].vertices;
        let s = a.sqrt();
        (i, v0 * (1.0 - s) + v1 * (s * (1.0 - b)) + v2 * (s * b))
    }

    /// Solid-angle density of next-event estimation choosing the point
    /// `distance` away on light `i`, whose normal makes cosine `cos_light`
    /// with the direction back to the shading point.
    #[must_use]
    pub fn pdf(&self, i: usize, distance: f64, cos_light: f64) -> f64 {
        self.probability[i] / self.triangles[i].area * distance * distance / cos_light
    }
}

/// Materials of a scene by triangle.
#[derive(Clone, Debug, PartialEq)]
pub struct Surfaces {
    /// Material of each triangle.
    pub material: Vec<u32>,
    /// The scene's materials.
    pub materials: Vec<Material>,
    /// The scene's materials in f32, as the path tracer's shading reads them.
    pub(crate) fast: Vec<FastMaterial>,
}

/// A material in f32: reflectance, emitted radiance, whether a mirror.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FastMaterial {
    pub(crate) reflectance: Vec3A,
    pub(crate) emittance: Vec3A,
    pub(crate) mirror: bool,
}

impl Surfaces {
    /// Materials of `scene`'s triangles.
    #[must_use]
    pub fn new(scene: &Scene) -> Self {
        let material = scene.triangle_patch.iter().map(|&p| scene.patches[p as usize].material as u32).collect();
        let fast = scene
            .materials
            .iter()
            .map(|m| FastMaterial {
                reflectance: DVec3::from(m.reflectance).as_vec3a(),
                emittance: DVec3::from(m.emittance).as_vec3a(),
                mirror: m.mirror,
            })
            .collect();
        Self { material, materials: scene.materials.clone(), fast }
    }

    /// [`Surfaces::of`] in f32.
    #[inline]
    pub(crate) fn fast_of(&self, t: u32) -> &FastMaterial {
        &self.fast[self.material[t as usize] as usize]
    }

    /// Material of triangle `t`.
    #[must_use]
    pub fn of(&self, t: u32) -> &Material {
        &self.materials[self.material[t as usize] as usize]
    }
}
