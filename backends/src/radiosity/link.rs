//! Links between elements: the form factor and the oracle's geometric part,
//! both estimated from `N_s` random point pairs whose mutual visibility is
//! asked of [`Tracer::occluded`].
//!
//! Sample `k` joins a uniform point `x_k` on the receiver `i` to a uniform
//! point `y_k` on the source `j`; its point-to-point form factor is
//! `F(x_k, y_k) = V cos θ_x cos θ_y / (π r² + A_j / N_s)` (Wallace et al.'s
//! disc regularisation keeps it bounded where elements touch): these are
//! the oracle's samples. The transported form factor is
//! `F_ij = mean_k F(x_k → A_j) · (visible pairs / pairs facing)`, the
//! exact unoccluded point-to-polygon factor (Lambert) at the receiver's
//! points times the visible fraction of the traced pairs: the plain
//! point-pair mean `A_j mean_k F(x_k, y_k)` (Part III eqs. 26-28) has
//! infinite variance where elements touch, and at 10 samples it
//! underestimates light there most of the time. The oracle is
//! linear in `ρ_i B_j`, so it is evaluated once per link with `ρ_i = B_j = 1`
//! by the core's function and scaled when refining.

use glam::DVec3;
use itgfx_core::Base;
use itgfx_core::oracle::{
    DivergenceKernel, divergence_oracle, kernel_smoothness_average_oracle, kernel_smoothness_oracle,
    mutual_information_oracle, power_oracle,
};
use rayon::prelude::*;

use super::Oracle;
use super::element::{ElementId, Hierarchy};
use crate::backend::BackendError;
use crate::lines::{Line, LineRng};
use crate::tracer::{Prepared, Tracer};

/// One link: the receiver gathers from the source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// Receiving element `i`.
    pub receiver: ElementId,
    /// Source element `j`.
    pub source: ElementId,
    /// Estimated form factor `F_ij`.
    pub form_factor: f64,
    /// The oracle at `ρ_i = B_j = 1`.
    pub oracle: f64,
    /// Rays its estimate cast.
    pub rays: u32,
}

/// What a batch of link evaluations needs.
pub(crate) struct Sampler<'a> {
    pub prepared: &'a Prepared,
    pub tracer: &'a dyn Tracer,
    pub oracle: Oracle,
    pub samples: u32,
    pub seed: u64,
    pub total_area: f64,
}

/// One pair's kernel samples (before visibility), its mean analytic
/// point-to-polygon factor, and the segments to trace.
type PairSamples = (Vec<f64>, f64, Vec<(usize, Line)>);

/// Lines per tracer call.
const BATCH: usize = 8192;

/// A tiny offset off both surfaces (normalised units) so a segment does
/// not report its own end points.
const GAP: f64 = 2e-4;

impl Sampler<'_> {
    /// Evaluates links for `pairs` (receiver, source); links whose samples
    /// are all zero (facing away or occluded) transport nothing and are
    /// dropped. Returns the links and the rays cast.
    ///
    /// # Errors
    /// Tracing errors.
    pub fn evaluate(&self, h: &Hierarchy, pairs: &[(ElementId, ElementId)]) -> Result<(Vec<Link>, u64), BackendError> {
        // Kernel values before visibility, and the segment of each that needs a ray.
        let per_pair: Vec<PairSamples> = pairs.par_iter().map(|&(i, j)| self.unoccluded_kernel(h, i, j)).collect();
        let mut lines = Vec::new();
        let mut owner = Vec::new();
        for (p, (_, _, rays)) in per_pair.iter().enumerate() {
            for &(k, l) in rays {
                lines.push(l);
                owner.push((p, k));
            }
        }
        let blocked: Vec<Vec<bool>> = lines
            .par_chunks(BATCH)
            .map(|c| {
                let mut out = Vec::new();
                self.tracer.occluded(c, &mut out).map(|()| out)
            })
            .collect::<Result<_, _>>()?;
        let analytic: Vec<f64> = per_pair.iter().map(|p| p.1).collect();
        let mut kernels: Vec<Vec<f64>> = per_pair.into_iter().map(|(k, _, _)| k).collect();
        let mut valid = vec![0u32; pairs.len()];
        let mut visible = vec![0u32; pairs.len()];
        for ((p, k), b) in owner.iter().zip(blocked.iter().flatten()) {
            valid[*p] += 1;
            if *b {
                kernels[*p][*k] = 0.0;
            } else {
                visible[*p] += 1;
            }
        }
        let mut ray_count = vec![0u32; pairs.len()];
        for (p, _) in &owner {
            ray_count[*p] += 1;
        }
        let links = pairs
            .par_iter()
            .zip(kernels.par_iter())
            .zip(ray_count.par_iter())
            .enumerate()
            .filter_map(|(p, ((&(i, j), ks), &rays))| {
                let sum: f64 = ks.iter().sum();
                if sum <= 0.0 || visible[p] == 0 {
                    return None;
                }
                let (ai, aj) = (h.elements[i as usize].area, h.elements[j as usize].area);
                let f = analytic[p] * f64::from(visible[p]) / f64::from(valid[p]);
                let oracle = self.oracle_value(ai, aj, f, ks);
                Some(Link { receiver: i, source: j, form_factor: f, oracle, rays })
            })
            .collect();
        Ok((links, owner.len() as u64))
    }

    /// The samples' kernels without visibility, and the rays to test.
    fn unoccluded_kernel(&self, h: &Hierarchy, i: ElementId, j: ElementId) -> PairSamples {
        let (ei, ej) = (&h.elements[i as usize], &h.elements[j as usize]);
        let n = self.samples as usize;
        let rng = LineRng::new(self.seed, (u64::from(i) << 32) | u64::from(j));
        let reg = ej.area / n as f64;
        let mut kernel = vec![0.0; n];
        let mut rays = Vec::new();
        let mut analytic = 0.0;
        let polygon = &ej.points[..usize::from(ej.corners)];
        for (k, kv) in kernel.iter_mut().enumerate() {
            let d = 4 * k as u32;
            let x = ei.sample(rng.uniform(d), rng.uniform(d + 1));
            // A receiver point behind the source's plane sees only its back.
            if ej.normal.dot(x - ej.points[0]) > 0.0 {
                analytic += point_to_polygon(x, ei.normal, polygon) / n as f64;
            }
            let y = ej.sample(rng.uniform(d + 2), rng.uniform(d + 3));
            let v = y - x;
            let r2 = v.length_squared();
            if r2 <= 0.0 {
                continue;
            }
            let r = r2.sqrt();
            let (cx, cy) = (ei.normal.dot(v) / r, -ej.normal.dot(v) / r);
            if cx <= 0.0 || cy <= 0.0 {
                continue;
            }
            *kv = cx * cy / (std::f64::consts::PI * r2 + reg);
            let (a, b) = (self.prepared.to_normalised(x), self.prepared.to_normalised(y));
            let len = (b - a).length();
            if len > 2.0 * GAP {
                let dir: DVec3 = (b - a) / len;
                rays.push((k, Line::ray(a, dir, GAP, len - GAP)));
            }
        }
        (kernel, analytic, rays)
    }

    /// The oracle of a link at `ρ_i = B_j = 1` (the core's formulas).
    fn oracle_value(&self, ai: f64, aj: f64, f: f64, ks: &[f64]) -> f64 {
        let v = match self.oracle {
            Oracle::Power => power_oracle(1.0, ai, f, 1.0),
            Oracle::KernelSmoothness => kernel_smoothness_oracle(1.0, ks, aj, 1.0),
            Oracle::KernelSmoothnessAverage => kernel_smoothness_average_oracle(1.0, ks, aj, 1.0),
            Oracle::MutualInformation => mutual_information_oracle(1.0, ai, aj, self.total_area, ks, 1.0, Base::Nats),
            Oracle::KullbackLeibler => divergence_oracle(DivergenceKernel::KullbackLeibler, 1.0, ai, aj, ks, 1.0),
            Oracle::ChiSquare => divergence_oracle(DivergenceKernel::ChiSquare, 1.0, ai, aj, ks, 1.0),
            Oracle::Hellinger => divergence_oracle(DivergenceKernel::Hellinger, 1.0, ai, aj, ks, 1.0),
            Oracle::Variance => divergence_oracle(DivergenceKernel::Variance, 1.0, ai, aj, ks, 1.0),
        };
        // Samples are finite and non-negative and areas positive by
        // construction; a failure would be a bug, and refines nothing.
        v.unwrap_or(0.0)
    }
}

/// The unoccluded form factor from a point `x` with unit normal `n` to a
/// planar polygon (Lambert's contour formula), the polygon clipped to the
/// half-space in front of `x` first.
#[must_use]
pub fn point_to_polygon(x: DVec3, n: DVec3, polygon: &[DVec3]) -> f64 {
    // Sutherland-Hodgman against n · (p − x) ≥ 0.
    let mut clipped: Vec<DVec3> = Vec::with_capacity(polygon.len() + 2);
    let m = polygon.len();
    for k in 0..m {
        let (a, b) = (polygon[k], polygon[(k + 1) % m]);
        let (da, db) = (n.dot(a - x), n.dot(b - x));
        if da >= 0.0 {
            clipped.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            clipped.push(a + (b - a) * (da / (da - db)));
        }
    }
    let m = clipped.len();
    if m < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for k in 0..m {
        let (a, b) = ((clipped[k] - x), (clipped[(k + 1) % m] - x));
        let c = a.cross(b);
        let len = c.length();
        if len <= 0.0 {
            continue;
        }
        let theta = len.atan2(a.dot(b));
        sum += theta * n.dot(c) / len;
    }
    (sum / std::f64::consts::TAU).abs()
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::scene::Scene;
    use crate::tracer::CpuTracer;

    fn estimate(scene: &Scene, samples: u32, seeds: u64) -> (f64, f64) {
        let p = Prepared::new(scene);
        let t = CpuTracer::new(&p);
        let h = Hierarchy::new(scene);
        let mut v = Vec::new();
        for seed in 0..seeds {
            let s = Sampler { prepared: &p, tracer: &t, oracle: Oracle::Power, samples, seed, total_area: 2.0 };
            let (links, _) = s.evaluate(&h, &[(0, 1)]).unwrap();
            v.push(links.first().map_or(0.0, |l| l.form_factor));
        }
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() as f64 - 1.0);
        (m, (var / v.len() as f64).sqrt())
    }

    #[test]
    fn parallel_and_perpendicular_squares_match_the_analytic_form_factors() {
        let mut s = Scene::named("parallel");
        s.add_polygon("a", &[DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y], 0);
        s.add_polygon(
            "b",
            &[DVec3::Z, DVec3::new(0.0, 1.0, 1.0), DVec3::new(1.0, 1.0, 1.0), DVec3::new(1.0, 0.0, 1.0)],
            0,
        );
        let (m, se) = estimate(&s, 100, 200);
        eprintln!("parallel {m} ± {se}");
        assert!((m - 0.199_825).abs() < 3.0 * se, "parallel: {m} ± {se}");
        let mut s = Scene::named("perpendicular");
        s.add_polygon("a", &[DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y], 0);
        s.add_polygon("b", &[DVec3::ZERO, DVec3::Z, DVec3::new(1.0, 0.0, 1.0), DVec3::X], 0);
        let (m, se) = estimate(&s, 100, 200);
        eprintln!("perpendicular {m} ± {se}");
        assert!((m - 0.200_044).abs() < 3.0 * se, "perpendicular: {m} ± {se}");
    }

    /// Link 0 ← 1 of a scene whose first two patches face each other.
    fn oracle_of(scene: &Scene, oracle: Oracle) -> f64 {
        let p = Prepared::new(scene);
        let t = CpuTracer::new(&p);
        let h = Hierarchy::new(scene);
        let s = Sampler { prepared: &p, tracer: &t, oracle, samples: 10, seed: 7, total_area: scene.total_area() };
        let (links, _) = s.evaluate(&h, &[(0, 1)]).unwrap();
        links[0].oracle
    }

    fn facing_squares(gap: f64, blocker: bool) -> Scene {
        let mut s = Scene::named("pair");
        s.add_polygon("floor", &[DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y], 0);
        let z = gap;
        s.add_polygon(
            "top",
            &[DVec3::new(0.0, 0.0, z), DVec3::new(0.0, 1.0, z), DVec3::new(1.0, 1.0, z), DVec3::new(1.0, 0.0, z)],
            0,
        );
        if blocker {
            // A plate over half the floor, half-way up: a shadow boundary across the link.
            let h = z / 2.0;
            s.add_polygon(
                "plate",
                &[
                    DVec3::new(-0.5, -0.5, h),
                    DVec3::new(0.5, -0.5, h),
                    DVec3::new(0.5, 1.5, h),
                    DVec3::new(-0.5, 1.5, h),
                ],
                0,
            );
        }
        s
    }

    #[test]
    fn information_oracles_refine_across_a_shadow_boundary_not_an_unoccluded_far_link() {
        for oracle in [Oracle::MutualInformation, Oracle::KullbackLeibler, Oracle::ChiSquare, Oracle::Hellinger] {
            let shadowed = oracle_of(&facing_squares(1.0, true), oracle);
            let far = oracle_of(&facing_squares(20.0, false), oracle);
            assert!(shadowed > 0.0, "{oracle}: a shadow boundary");
            // Far apart, the kernel is nearly constant: its divergence from
            // uniform is second order in the size/distance ratio.
            assert!(far < 1e-3 * shadowed, "{oracle}: far {far} vs shadowed {shadowed}");
        }
        // The power oracle cannot tell: it sees only the transported power.
        let p_shadowed = oracle_of(&facing_squares(1.0, true), Oracle::Power);
        let p_open = oracle_of(&facing_squares(1.0, false), Oracle::Power);
        assert!(p_shadowed < p_open, "the blocker removes power: {p_shadowed} vs {p_open}");
    }
}
