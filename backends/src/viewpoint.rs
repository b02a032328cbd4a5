//! The viewpoint channel `V → O` of Part V: viewpoints on a sphere around an
//! object, `p(o|v)` from the solid angle each polygon subtends at `v`.
//!
//! For each viewpoint, rays are cast through a stratified grid of directions
//! covering the cone that contains the object's bounding sphere; every ray
//! carries the same solid angle `Ω_cone / N`, so `a_o` (the projected area of
//! polygon `o` on the sphere of directions, Part V eq. (2)) is estimated by
//! `Ω_cone · hits_o / N` and converges as the resolution grows. The first
//! crossing facing the viewpoint is the polygon seen (back faces are
//! skipped); rays that miss see the background.
//!
//! Measures are those of `itgfx-core`'s channel: viewpoint entropy `H(O|v)`
//! (eqs. (2), (5)), viewpoint mutual information `I(v;O)` (eq. (7)), `I(V;O)`
//! (eq. (6)), the viewpoint Kullback–Leibler distance (eq. (3)) and the
//! heuristic of eq. (1).

use glam::DVec3;
use itgfx_core::{Base, Channel, jensen_shannon, kl_divergence};
use rayon::prelude::*;

use crate::lines::Line;
use crate::tracer::{BackendError, CrossingBuffer, Prepared, Tracer};

/// Unit directions of a subdivided icosahedron: 12, 42, 162, 642, 2562
/// points for `level` 0..=4 (normalised midpoints, shared edges split once).
#[must_use]
pub fn icosphere(level: u32) -> Vec<DVec3> {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = Vec::new();
    for a in [-1.0, 1.0] {
        for b in [-phi, phi] {
            v.push(DVec3::new(0.0, a, b).normalize());
            v.push(DVec3::new(a, b, 0.0).normalize());
            v.push(DVec3::new(b, 0.0, a).normalize());
        }
    }
    let edge = 2.0 / (1.0 + phi * phi).sqrt();
    let mut faces = Vec::new();
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                let near = |a: usize, b: usize| ((v[a] - v[b]).length() - edge).abs() < 1e-9;
                if near(i, j) && near(j, k) && near(i, k) {
                    faces.push([i, j, k]);
                }
            }
        }
    }
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(faces.len() * 4);
        let mut midpoint = |a: usize, b: usize, v: &mut Vec<DVec3>| -> usize {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        for [a, b, c] in faces {
            let (ab, bc, ca) = (midpoint(a, b, &mut v), midpoint(b, c, &mut v), midpoint(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    v
}

/// How the input distribution `p(V)` is chosen (Part V §3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewpointWeights {
    /// Proportional to the object's projected solid angle at `v` (the default).
    ProjectedArea,
    /// `1 / N_v`.
    Uniform,
}

impl ViewpointWeights {
    /// `p(V)` over the viewpoints that see the object, from their projected
    /// solid angles `seen`.
    #[must_use]
    pub fn distribution(self, seen: &[f64]) -> Vec<f64> {
        match self {
            ViewpointWeights::ProjectedArea => {
                let t: f64 = seen.iter().sum();
                seen.iter().map(|s| s / t).collect()
            }
            ViewpointWeights::Uniform => vec![1.0 / seen.len() as f64; seen.len()],
        }
    }
}

/// The sampled channel.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewpointChannel {
    /// Viewpoint positions (normalised scene coordinates).
    pub positions: Vec<DVec3>,
    /// Projected solid angle `a_o` of each patch at each viewpoint
    /// (row-major `viewpoints × patches`, steradians).
    pub solid_angle: Vec<f64>,
    /// Solid angle of the background inside the sampled cone, per viewpoint.
    pub background: Vec<f64>,
    /// Patches.
    pub patches: usize,
}

/// Per-viewpoint measures, in one unit.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewpointMeasures {
    /// `p(v)`.
    pub weight: Vec<f64>,
    /// Viewpoint entropy `H(O|v)` (eq. (2), background excluded).
    pub entropy: Vec<f64>,
    /// Viewpoint mutual information `I(v;O)` (eq. (7)).
    pub mutual_information: Vec<f64>,
    /// Viewpoint Kullback–Leibler distance to the actual areas (eq. (3)).
    pub kullback_leibler: Vec<f64>,
    /// Plemenos–Benayada heuristic (eq. (1)) with `P_i(v)/r` as solid-angle fractions.
    pub heuristic: Vec<f64>,
    /// `I(V;O)` (eq. (6)).
    pub total_mutual_information: f64,
    /// `H(O|V)` (eq. (5)).
    pub conditional_entropy: f64,
    /// Index of the viewpoint with minimum VMI: the best view.
    pub best: usize,
    /// Index of the viewpoint with maximum VMI.
    pub worst: usize,
}

impl ViewpointChannel {
    /// Casts `resolution²` rays from each viewpoint at `distance` (in
    /// bounding-sphere radii, > 1) in each direction of `directions`.
    ///
    /// # Errors
    /// Backend errors.
    pub fn build(
        prepared: &Prepared,
        tracer: &dyn Tracer,
        directions: &[DVec3],
        distance: f64,
        resolution: u32,
    ) -> Result<Self, BackendError> {
        let n = prepared.patches;
        let rows: Vec<Result<(Vec<f64>, f64), BackendError>> = directions
            .par_iter()
            .map(|&dir| {
                let eye = dir.normalize() * distance;
                let axis = -eye.normalize();
                let cos_a = (1.0 - 1.0 / (distance * distance)).max(0.0).sqrt();
                let cone = std::f64::consts::TAU * (1.0 - cos_a);
                let (t, b) = axis.any_orthonormal_pair();
                let r = resolution.max(1);
                let per = cone / f64::from(r * r);
                let mut lines = Vec::with_capacity((r * r) as usize);
                for i in 0..r {
                    for j in 0..r {
                        // Stratified, equal solid angle: cos θ uniform in [cos α, 1].
                        let ct = 1.0 - (f64::from(i) + 0.5) / f64::from(r) * (1.0 - cos_a);
                        let st = (1.0 - ct * ct).max(0.0).sqrt();
                        let ph = std::f64::consts::TAU * (f64::from(j) + 0.5) / f64::from(r);
                        let d = axis * ct + (t * ph.cos() + b * ph.sin()) * st;
                        lines.push(Line {
                            origin: eye.as_vec3().to_array(),
                            tmin: 0.0,
                            direction: d.as_vec3().to_array(),
                            tmax: 4.0 * distance as f32,
                        });
                    }
                }
                let mut buf = CrossingBuffer::default();
                tracer.trace_all(&lines, &mut buf)?;
                let mut row = vec![0.0; n];
                let mut bg = 0.0;
                for k in 0..lines.len() {
                    match buf.line(k).iter().find(|c| c.cos < 0.0) {
                        Some(c) => row[c.patch as usize] += per,
                        None => bg += per,
                    }
                }
                Ok((row, bg))
            })
            .collect();
        let mut solid_angle = Vec::with_capacity(directions.len() * n);
        let mut background = Vec::with_capacity(directions.len());
        for r in rows {
            let (row, bg) = r?;
            solid_angle.extend(row);
            background.push(bg);
        }
        Ok(Self {
            positions: directions.iter().map(|d| d.normalize() * distance).collect(),
            solid_angle,
            background,
            patches: n,
        })
    }

    /// Viewpoints that see the object at all (a viewpoint seeing only
    /// background has no `p(O|v)`).
    fn rows(&self) -> impl Iterator<Item = &[f64]> {
        self.solid_angle.chunks(self.patches)
    }

    /// `p(O|v)` as a row-major matrix over the viewpoints that see the
    /// object, their projected solid angles, and their indices.
    #[must_use]
    pub fn conditional(&self) -> (Vec<f64>, Vec<f64>, Vec<usize>) {
        let mut m = Vec::new();
        let mut seen = Vec::new();
        let mut idx = Vec::new();
        for (v, row) in self.rows().enumerate() {
            let s: f64 = row.iter().sum();
            if s > 0.0 {
                m.extend(row.iter().map(|x| x / s));
                seen.push(s);
                idx.push(v);
            }
        }
        (m, seen, idx)
    }

    /// Every per-viewpoint measure, with `p(V)` chosen by `weights` and the
    /// patch areas `areas` (for VKL), in `base`.
    ///
    /// # Panics
    /// If no viewpoint sees the object (an empty scene).
    #[must_use]
    pub fn measures(&self, areas: &[f64], weights: ViewpointWeights, base: Base) -> ViewpointMeasures {
        let (m, seen, idx) = self.conditional();
        let nv = seen.len();
        assert!(nv > 0, "no viewpoint sees the object");
        let w = weights.distribution(&seen);
        let ch = Channel::new(&w, &m, self.patches).expect("rows of p(O|v) are distributions");
        let cm = ch.measures(base);
        let mut po = vec![0.0; self.patches];
        ch.output_into(&mut po).expect("sizes");
        let mut vmi = vec![0.0; nv];
        ch.specific_information_into(&po, base, &mut vmi).expect("sizes");
        let mut ve = vec![0.0; nv];
        itgfx_core::row_entropies_into(&m, nv, self.patches, base, &mut ve).expect("sizes");
        let total: f64 = areas.iter().sum();
        let rel: Vec<f64> = areas.iter().map(|a| a / total).collect();
        let vkl: Vec<f64> =
            m.chunks(self.patches).map(|row| kl_divergence(row, &rel, base).unwrap_or(f64::INFINITY)).collect();
        let heuristic: Vec<f64> = idx
            .iter()
            .map(|&v| {
                let row = &self.solid_angle[v * self.patches..(v + 1) * self.patches];
                let visible = row.iter().filter(|&&a| a > 0.0).count() as f64 / self.patches as f64;
                visible + row.iter().sum::<f64>() / (4.0 * std::f64::consts::PI)
            })
            .collect();
        // Expand back to all viewpoints (those seeing nothing get weight 0, VMI ∞).
        let expand = |x: &[f64], missing: f64| {
            let mut out = vec![missing; self.positions.len()];
            for (k, &v) in idx.iter().enumerate() {
                out[v] = x[k];
            }
            out
        };
        let best = idx[(0..nv).min_by(|&a, &b| vmi[a].total_cmp(&vmi[b])).unwrap_or(0)];
        let worst = idx[(0..nv).max_by(|&a, &b| vmi[a].total_cmp(&vmi[b])).unwrap_or(0)];
        ViewpointMeasures {
            weight: expand(&w, 0.0),
            entropy: expand(&ve, 0.0),
            mutual_information: expand(&vmi, f64::INFINITY),
            kullback_leibler: expand(&vkl, f64::INFINITY),
            heuristic: expand(&heuristic, 0.0),
            total_mutual_information: cm.mutual_information,
            conditional_entropy: cm.h_y_given_x,
            best,
            worst,
        }
    }

    /// Polygonal mutual information `I(o;V) = D_KL(p(V|o) ‖ p(V))` of every
    /// patch (the reversed channel, Part V), and `p(o)`; patches never seen
    /// get 0 and `p(o) = 0`.
    #[must_use]
    pub fn polygonal_information(&self, weights: ViewpointWeights, base: Base) -> (Vec<f64>, Vec<f64>) {
        let (m, seen, _) = self.conditional();
        let nv = seen.len();
        let w = weights.distribution(&seen);
        let ch = Channel::new(&w, &m, self.patches).expect("rows of p(O|v) are distributions");
        let mut po = vec![0.0; self.patches];
        ch.output_into(&mut po).expect("sizes");
        let mut rev = vec![0.0; nv * self.patches];
        ch.reversed_into(&mut rev).expect("sizes");
        let mut info = vec![0.0; self.patches];
        ch.output_specific_information_into(&rev, base, &mut info).expect("sizes");
        for (i, p) in info.iter_mut().zip(&po) {
            if *p == 0.0 {
                *i = 0.0;
            }
        }
        (info, po)
    }

    /// Viewpoint stability: the mean dissimilarity of each viewpoint to its
    /// `k` nearest neighbours on the viewpoint sphere (low = stable).
    #[must_use]
    pub fn instability(&self, measures: &ViewpointMeasures, k: usize, base: Base) -> Vec<f64> {
        let n = self.positions.len();
        (0..n)
            .map(|a| {
                if measures.weight[a] == 0.0 {
                    return f64::NAN;
                }
                let mut near: Vec<(f64, usize)> = (0..n)
                    .filter(|&b| b != a && measures.weight[b] > 0.0)
                    .map(|b| ((self.positions[a] - self.positions[b]).length(), b))
                    .collect();
                near.sort_by(|x, y| x.0.total_cmp(&y.0));
                let near = &near[..k.min(near.len())];
                if near.is_empty() {
                    return 0.0;
                }
                near.iter()
                    .map(|&(_, b)| self.dissimilarity(a, b, (measures.weight[a], measures.weight[b]), base))
                    .sum::<f64>()
                    / near.len() as f64
            })
            .collect()
    }

    /// Dissimilarity of two viewpoints: the Jensen–Shannon divergence of
    /// their `p(O|v)` weighted by `p(v)` (Part II eq. (17)); 0 for identical views.
    ///
    /// # Panics
    /// If either viewpoint sees nothing.
    #[must_use]
    pub fn dissimilarity(&self, a: usize, b: usize, weights: (f64, f64), base: Base) -> f64 {
        let n = self.patches;
        let norm = |v: usize| {
            let row = &self.solid_angle[v * n..(v + 1) * n];
            let s: f64 = row.iter().sum();
            row.iter().map(|x| x / s).collect::<Vec<f64>>()
        };
        let (pa, pb) = (norm(a), norm(b));
        let t = weights.0 + weights.1;
        jensen_shannon(&[weights.0 / t, weights.1 / t], &[pa, pb].concat(), n, base).expect("valid views")
    }
}
