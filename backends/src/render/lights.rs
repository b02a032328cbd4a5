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

#[cfg(target_arch = "x86_64")]
use crate::lines::Vec3x8;
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
    /// [`Lights::fast`] as columns for the 8-wide shading: `v0`, `e1`, `e2`,
    /// `normal`, `radiance` (x, y, z each), then `density`; padded with the
    /// last light to at least 8 rows.
    pub(crate) columns: [Vec<f32>; 16],
}

/// Eight lanes of next-event estimation's light sample
/// ([`Lights::sample32x8`]): the point, and its light's normal, radiance
/// and `P(light) / area`.
#[cfg(target_arch = "x86_64")]
pub(crate) struct Light8 {
    pub(crate) point: Vec3x8,
    pub(crate) normal: Vec3x8,
    pub(crate) radiance: Vec3x8,
    pub(crate) density: std::arch::x86_64::__m256,
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
        let cdf = cumulative(&probability);
        let fast: Vec<FastLight> = triangles
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
        let columns = light_columns(&fast);
        Some(Self { triangles, cdf, probability, of_triangle, fast, cdf32, columns })
    }

    /// The light that draw `u` chooses: the first whose cumulative
    /// probability (f32) exceeds `u`.
    #[inline]
    fn choose32(&self, u: f32) -> usize {
        self.cdf32.partition_point(|&c| c <= u).min(self.cdf32.len() - 1)
    }

    /// [`Lights::sample`] in f32: `(light, point)`, the point
    /// `v0 + √a (1 − b) e1 + √a b e2` (uniform on the triangle).
    #[inline]
    pub(crate) fn sample32(&self, u: f32, a: f32, b: f32) -> (usize, Vec3A) {
        let i = self.choose32(u);
        let l = &self.fast[i];
        let s = a.sqrt();
        (i, l.v0 + l.e1 * (s * (1.0 - b)) + l.e2 * (s * b))
    }

    /// [`Lights::sample32`] of 8 lanes, with the chosen lights' normal,
    /// radiance and density: the same choice and the same f32 operations
    /// lane by lane, so the same bits. Up to 8 lights the choice counts the
    /// cumulative probabilities at or below `u` (the partition point of a
    /// non-decreasing list) and the fields are permuted out of one register
    /// each; with more, each lane's choice is [`Lights::choose32`]'s and the
    /// fields are gathered.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn sample32x8(
        &self,
        u: std::arch::x86_64::__m256,
        a: std::arch::x86_64::__m256,
        b: std::arch::x86_64::__m256,
    ) -> Light8 {
        use std::arch::x86_64::{
            _CMP_LE_OQ, _mm256_castps_si256, _mm256_cmp_ps, _mm256_i32gather_ps, _mm256_min_epu32, _mm256_mul_ps,
            _mm256_permutevar8x32_ps, _mm256_set1_ps, _mm256_setzero_si256, _mm256_sqrt_ps, _mm256_sub_epi32,
            _mm256_sub_ps,
        };

        use crate::lines::{load8, load8f, splat8, store8f};

        let few = self.fast.len() <= 8;
        let i = if few {
            let mut count = _mm256_setzero_si256();
            for &c in &self.cdf32 {
                // A lane's mask is −1 where `c ≤ u`: subtracting it counts.
                count = _mm256_sub_epi32(count, _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_set1_ps(c), u)));
            }
            _mm256_min_epu32(count, splat8(self.cdf32.len() as u32 - 1))
        } else {
            load8(&store8f(u).map(|u| self.choose32(u) as u32))
        };
        let field = |k: usize| {
            let column = &self.columns[k];
            if few {
                _mm256_permutevar8x32_ps(load8f(column[..8].try_into().expect("eight rows")), i)
            } else {
                // SAFETY: every lane of `i` is a light's index, below
                // `fast.len()`, which is `column.len()` here (no padding
                // above 8 lights); the gather reads those f32s only.
                unsafe { _mm256_i32gather_ps::<4>(column.as_ptr(), i) }
            }
        };
        let vec = |k: usize| Vec3x8 { x: field(k), y: field(k + 1), z: field(k + 2) };
        let s = _mm256_sqrt_ps(a);
        let point = vec(0)
            .add(vec(3).scale(_mm256_mul_ps(s, _mm256_sub_ps(_mm256_set1_ps(1.0), b))))
            .add(vec(6).scale(_mm256_mul_ps(s, b)));
        Light8 { point, normal: vec(9), radiance: vec(12), density: field(15) }
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

/// The cumulative sums of `probability`, the last set to exactly 1.
fn cumulative(probability: &[f64]) -> Vec<f64> {
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
    cdf
}

/// The columns of [`Lights::columns`].
fn light_columns(fast: &[FastLight]) -> [Vec<f32>; 16] {
    let rows = fast.len().max(8);
    std::array::from_fn(|k| {
        (0..rows)
            .map(|i| {
                let l = &fast[i.min(fast.len() - 1)];
                match k {
                    0..=2 => l.v0[k],
                    3..=5 => l.e1[k - 3],
                    6..=8 => l.e2[k - 6],
                    9..=11 => l.normal[k - 9],
                    12..=14 => l.radiance[k - 12],
                    _ => l.density,
                }
            })
            .collect()
    })
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

#[cfg(test)]
impl Lights {
    /// Lights of these selection probabilities, each a random triangle
    /// about the origin (for the tests of the batched shading).
    pub(crate) fn random(probability: &[f64]) -> Self {
        let r = crate::lines::LineRng::new(3, probability.len() as u64);
        let v = |k: u32| Vec3A::new(r.uniform32(k), r.uniform32(k + 1), r.uniform32(k + 2)) - 0.5;
        let fast: Vec<FastLight> = (0..probability.len() as u32)
            .map(|i| FastLight {
                v0: v(20 * i),
                e1: v(20 * i + 3),
                e2: v(20 * i + 6),
                normal: v(20 * i + 9).normalize(),
                radiance: v(20 * i + 12) + 1.0,
                density: r.uniform32(20 * i + 15) * 5.0,
            })
            .collect();
        let cdf = cumulative(probability);
        Self {
            triangles: Vec::new(),
            cdf32: cdf.iter().map(|&c| c as f32).collect(),
            cdf,
            probability: probability.to_vec(),
            of_triangle: Vec::new(),
            columns: light_columns(&fast),
            fast,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lines::LineRng;

    /// The 8-lane light samples are the scalar ones bit for bit: one
    /// light, two, eight (one register), thirteen (gathered), with
    /// probabilities of zero among them and draws at the cumulative
    /// probabilities' edges.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn sample32x8_is_sample32() {
        use crate::lines::{load8f, store8f};
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        for probability in [
            &[1.0][..],
            &[0.5, 0.5],
            &[0.1, 0.0, 0.2, 0.05, 0.15, 0.1, 0.3, 0.1],
            &[0.05, 0.1, 0.0, 0.1, 0.1, 0.05, 0.1, 0.05, 0.1, 0.1, 0.05, 0.1, 0.1],
        ] {
            let l = Lights::random(probability);
            let r = LineRng::new(8, 1);
            let mut u: Vec<f32> = (0..400).map(|k| r.uniform32(k)).collect();
            u.extend(l.cdf32.iter().copied());
            u.extend(l.cdf32.iter().map(|c| c - f32::EPSILON / 4.0));
            u.resize(u.len().div_ceil(8) * 8, 0.5);
            for (g, group) in u.chunks_exact(8).enumerate() {
                let u8: [f32; 8] = group.try_into().unwrap();
                let a: [f32; 8] = std::array::from_fn(|k| r.uniform32(1000 + 16 * g as u32 + k as u32));
                let b: [f32; 8] = std::array::from_fn(|k| r.uniform32(1008 + 16 * g as u32 + k as u32));
                // SAFETY: AVX2 was detected above.
                let (p, n, e, d) = unsafe {
                    let s = l.sample32x8(load8f(&u8), load8f(&a), load8f(&b));
                    (s.point.lanes(), s.normal.lanes(), s.radiance.lanes(), store8f(s.density))
                };
                for k in 0..8 {
                    let (i, want) = l.sample32(u8[k], a[k], b[k]);
                    let f = &l.fast[i];
                    let got = |c: [[f32; 8]; 3]| [c[0][k], c[1][k], c[2][k]].map(f32::to_bits);
                    let bits = |v: Vec3A| v.to_array().map(f32::to_bits);
                    assert_eq!(got(p), bits(want), "{probability:?} u {}", u8[k]);
                    assert_eq!(
                        (got(n), got(e), d[k].to_bits()),
                        (bits(f.normal), bits(f.radiance), f.density.to_bits())
                    );
                }
            }
        }
    }
}
