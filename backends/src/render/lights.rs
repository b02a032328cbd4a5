//! Area lights and per-triangle materials of a scene, in the tracer's
//! normalised coordinates.
//!
//! An emissive material's `emittance` is read as the constant radiance
//! `L_e` leaving the front side of its triangles (the convention of
//! Mitsuba's `area` emitter: the Cornell box's light is `L_e = (17, 12, 4)`).
//! Lights are chosen for next-event estimation with probability proportional
//! to `area × Y(L_e)` (power), then a point uniformly on the triangle.

use glam::DVec3;
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
        Some(Self { triangles, cdf, probability, of_triangle })
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
}

impl Surfaces {
    /// Materials of `scene`'s triangles.
    #[must_use]
    pub fn new(scene: &Scene) -> Self {
        let material = scene.triangle_patch.iter().map(|&p| scene.patches[p as usize].material as u32).collect();
        Self { material, materials: scene.materials.clone() }
    }

    /// Material of triangle `t`.
    #[must_use]
    pub fn of(&self, t: u32) -> &Material {
        &self.materials[self.material[t as usize] as usize]
    }
}
