//! The CPU backend: an obvhs compressed wide BVH over triangle bounds and
//! the watertight test for each candidate.

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::ray::{Ray, RayHit};

use super::watertight::{Shear, before, finish, sphere_crossings, sphere_hit, test_triangle, triangle_hit};
use super::{BackendError, CrossingBuffer, Hit, Prepared, Tracer};
use crate::lines::Line;

/// Triangle boxes and build parameters shared by the CPU and Vulkan BVHs:
/// obvhs's medium preset with `search_depth_threshold = 0` (measured 10×
/// faster on tessellated walls: `docs/TRACING.md`), and boxes padded by 1e-5
/// (normalised units), since obvhs's f32 slab test can cull a box the line
/// only grazes and wall triangles have flat boxes. The watertight triangle
/// test still decides every hit.
pub(crate) fn bvh_input(scene: &Prepared) -> (Vec<Aabb>, obvhs::BvhBuildParams) {
    let pad = Vec3A::splat(1e-5);
    let aabbs: Vec<Aabb> = scene
        .triangles
        .iter()
        .map(|t| Aabb { min: t[0].min(t[1]).min(t[2]) - pad, max: t[0].max(t[1]).max(t[2]) + pad })
        .collect();
    let mut params = obvhs::BvhBuildParams::medium_build();
    params.search_depth_threshold = 0;
    (aabbs, params)
}

/// The CPU backend.
pub struct CpuTracer {
    scene: Prepared,
    bvh: Option<CwBvh>,
}

impl CpuTracer {
    /// Builds the BVH over the scene's triangles.
    #[must_use]
    pub fn new(scene: &Prepared) -> Self {
        let bvh = (!scene.triangles.is_empty()).then(|| {
            let (aabbs, params) = bvh_input(scene);
            build_cwbvh(&aabbs, params, &mut std::time::Duration::default())
        });
        Self { scene: scene.clone(), bvh }
    }

    /// The first crossing of one line: obvhs's closest-hit walk shrinks the
    /// interval as hits are found, and ties in `t` go to the smaller triangle.
    pub(crate) fn closest(&self, l: &Line) -> Option<Hit> {
        if let Some(s) = &self.scene.sphere {
            return sphere_hit(s, l);
        }
        let bvh = self.bvh.as_ref()?;
        let (shear, dir) = Shear::of(l);
        let mut best: Option<(f32, u32)> = None;
        let mut rh = RayHit::none();
        bvh.ray_traverse(Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax), &mut rh, |_, id| {
            let tri = bvh.primitive_indices[id];
            match shear.hit(&self.scene.triangles[tri as usize]) {
                Some(t) if t >= l.tmin && t <= l.tmax => {
                    if before(t, tri, best) {
                        best = Some((t, tri));
                    }
                    t
                }
                _ => f32::INFINITY,
            }
        });
        best.and_then(|(_, tri)| triangle_hit(&self.scene, l, tri))
    }

    fn any(&self, l: &Line) -> bool {
        if let Some(s) = &self.scene.sphere {
            return sphere_hit(s, l).is_some();
        }
        let Some(bvh) = &self.bvh else { return false };
        let (shear, dir) = Shear::of(l);
        !bvh.ray_traverse_miss(Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax), |_, id| {
            match shear.hit(&self.scene.triangles[bvh.primitive_indices[id] as usize]) {
                // Any value below the ray's tmax ends the walk as a hit.
                Some(t) if t >= l.tmin && t <= l.tmax => f32::NEG_INFINITY,
                _ => f32::INFINITY,
            }
        })
    }
}

impl Tracer for CpuTracer {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        out.clear();
        let mut hits = Vec::with_capacity(16);
        for l in lines {
            if let Some(s) = &self.scene.sphere {
                sphere_crossings(s, l, &mut hits);
            } else if let Some(bvh) = &self.bvh {
                let (shear, dir) = Shear::of(l);
                let ray = Ray::new(Vec3A::from(l.origin), dir, l.tmin, l.tmax);
                bvh.ray_traverse_anyhit(ray, |_, id| {
                    test_triangle(&self.scene, &shear, l, dir, bvh.primitive_indices[id] as usize, &mut hits);
                });
            }
            finish(&mut hits, out);
        }
        Ok(())
    }

    fn closest_hit(&self, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
        out.clear();
        out.extend(lines.iter().map(|l| self.closest(l)));
        Ok(())
    }

    fn occluded(&self, lines: &[Line], out: &mut Vec<bool>) -> Result<(), BackendError> {
        out.clear();
        out.extend(lines.iter().map(|l| self.any(l)));
        Ok(())
    }
}
