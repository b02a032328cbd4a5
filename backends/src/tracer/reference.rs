//! The brute-force reference backend: every triangle tested against every
//! line. Slow by design; the oracle the real backends are tested against.

use super::watertight::{Shear, before, finish, sphere_crossings, sphere_hit, test_triangle, triangle_hit};
use super::{BackendError, CrossingBuffer, Hit, Prepared, Tracer};
use crate::lines::Line;

/// The brute-force reference tracer.
pub struct ReferenceTracer {
    scene: Prepared,
}

impl ReferenceTracer {
    /// A reference tracer over a prepared scene.
    #[must_use]
    pub fn new(scene: &Prepared) -> Self {
        Self { scene: scene.clone() }
    }

    /// Every triangle crossed by `l` within its interval, with its `t`.
    fn crossed<'a>(&'a self, l: &'a Line) -> impl Iterator<Item = (f32, u32)> + 'a {
        let (shear, _) = Shear::of(l);
        self.scene
            .triangles
            .iter()
            .enumerate()
            .filter_map(move |(tri, v)| shear.hit(v).filter(|&t| t >= l.tmin && t <= l.tmax).map(|t| (t, tri as u32)))
    }
}

impl Tracer for ReferenceTracer {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        out.clear();
        let mut hits = Vec::new();
        for l in lines {
            if let Some(s) = &self.scene.sphere {
                sphere_crossings(s, l, &mut hits);
            } else {
                let (shear, dir) = Shear::of(l);
                for tri in 0..self.scene.triangles.len() {
                    test_triangle(&self.scene, &shear, l, dir, tri, &mut hits);
                }
            }
            finish(&mut hits, out);
        }
        Ok(())
    }

    fn closest_hit(&self, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
        out.clear();
        out.extend(lines.iter().map(|l| {
            if let Some(s) = &self.scene.sphere {
                return sphere_hit(s, l);
            }
            let mut best = None;
            for (t, tri) in self.crossed(l) {
                if before(t, tri, best) {
                    best = Some((t, tri));
                }
            }
            best.and_then(|(_, tri)| triangle_hit(&self.scene, l, tri))
        }));
        Ok(())
    }

    fn occluded(&self, lines: &[Line], out: &mut Vec<bool>) -> Result<(), BackendError> {
        out.clear();
        out.extend(lines.iter().map(|l| match &self.scene.sphere {
            Some(s) => sphere_hit(s, l).is_some(),
            None => self.crossed(l).next().is_some(),
        }));
        Ok(())
    }
}
