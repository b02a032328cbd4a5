//! The viewpoint channel from exact solid angles: `a_o` (Part V eq. (2))
//! as the exact solid angle of each triangle times the fraction of it that
//! the viewpoint sees, with that fraction sampled only where visibility
//! changes.
//!
//! The ray-grid estimate of [`ViewpointChannel::build`] counts which polygon
//! each of `R²` rays hits first. With many polygons smaller than the ray
//! spacing, the counts of the small ones are 0 or 1, and the plug-in
//! mutual information is biased upwards (the 69k-triangle bunny's `I(V;O)` is
//! 4.00 bits at R = 128 and 1.70 at R = 2048). Here instead:
//!
//! 1. every triangle gets its exact solid angle `Ω_t` from the eye (Van
//!    Oosterom and Strackee, IEEE TBME 1983) and one visibility ray, eye to
//!    centroid: the triangle is visible there when the ray's closest hit is
//!    the triangle itself;
//! 2. triangles whose centroid visibility differs from an edge neighbour's
//!    lie where visibility changes, and so do triangles on which an item
//!    buffer of about a pixel per triangle (triangle id and depth per pixel)
//!    shows something else inside them, or a surface in front of their plane
//!    (a gap behind it, for a hidden one) within a pixel of them; each is
//!    sampled at `m²` stratified
//!    points (the centroids of its `m × m` subdivision) and its visible
//!    fraction is the ratio estimate `f_t = Σ v_i w_i / Σ w_i` with the
//!    solid-angle density `w_i = |cos θ_i| / r_i²`;
//! 3. `a_o = Σ_{t ∈ o} Ω_t f_t`, exact for triangles entirely visible or
//!    hidden (a convex object is exact), and the standard error of each
//!    viewpoint's VMI follows by the delta method from the binomial
//!    variance of the sampled fractions; viewpoints whose VMI misses the
//!    tolerance get `m` doubled until it holds or `m` reaches its cap.
//!
//! The result is an ordinary [`ViewpointChannel`]: every measure downstream
//! is the same code as for the ray grid.

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use super::coherent::morton_order;
use super::{ViewpointAnalysis, ViewpointChannel, ViewpointWeights};
use crate::lines::Line;
use crate::tracer::{BackendError, Hit, Prepared, Tracer};

/// Solid angle of the triangle `a, b, c` (vectors from the eye) seen from the
/// eye: `tan(Ω/2) = |a·(b×c)| / (abc + (a·b)c + (a·c)b + (b·c)a)` (Van
/// Oosterom and Strackee 1983), in `[0, 2π]`.
#[must_use]
pub fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// How the solid-angle channel is built and refined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refinement {
    /// Viewpoint distance in bounding-sphere radii (> 1).
    pub distance: f64,
    /// Relative tolerance on every viewpoint's VMI: met when twice its
    /// standard error is at most `tolerance · VMI`.
    pub tolerance: f64,
    /// First subdivision `m` of triangles where visibility changes (`m²` points).
    pub first: u32,
    /// Largest `m`.
    pub max: u32,
    /// `p(V)` of the analysis whose VMI the tolerance is checked on.
    pub weights: ViewpointWeights,
    /// Whether that analysis counts the background as a polygon.
    pub background: bool,
}

impl Default for Refinement {
    fn default() -> Self {
        Self {
            distance: 3.0,
            tolerance: 0.01,
            first: 4,
            max: 32,
            weights: ViewpointWeights::ProjectedArea,
            background: false,
        }
    }
}

/// What the refinement reached.
#[derive(Clone, Debug, PartialEq)]
pub struct Convergence {
    /// Standard error of each viewpoint's VMI (nats; 0 for a viewpoint that
    /// sees nothing).
    pub vmi_stderr: Vec<f64>,
    /// Whether each viewpoint met the tolerance.
    pub met: Vec<bool>,
    /// Final subdivision of each viewpoint's boundary triangles.
    pub subdivision: Vec<u32>,
    /// Visibility rays cast in all.
    pub rays: u64,
    /// Triangles sampled beyond their centroid, summed over viewpoints.
    pub boundary_triangles: u64,
}

/// Why the channel could not be built.
#[derive(Debug, Clone, PartialEq)]
pub enum ChannelError {
    /// Tracing failed.
    Backend(BackendError),
    /// The channel's measures failed (no viewpoint sees the object).
    Measure(itgfx_core::Error),
}

impl std::fmt::Display for ChannelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ChannelError::Backend(e) => e.fmt(f),
            ChannelError::Measure(e) => write!(f, "viewpoint channel: {e}"),
        }
    }
}

impl std::error::Error for ChannelError {}

impl From<BackendError> for ChannelError {
    fn from(e: BackendError) -> Self {
        ChannelError::Backend(e)
    }
}

/// Triangles sharing an edge with each triangle (vertices matched exactly).
#[must_use]
pub fn triangle_adjacency(triangles: &[[Vec3A; 3]]) -> Vec<Vec<u32>> {
    let key = |v: Vec3A| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
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
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(3 * vid.len());
    for (t, v) in vid.iter().enumerate() {
        for (a, b) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
            edges.push((a.min(b), a.max(b), t as u32));
        }
    }
    edges.sort_unstable();
    let mut adj = vec![Vec::new(); triangles.len()];
    for run in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        for x in run {
            for y in run {
                if x.2 != y.2 {
                    adj[x.2 as usize].push(y.2);
                }
            }
        }
    }
    adj
}

/// Side of the item buffer for `triangles` triangles: about a pixel per
/// triangle, between 128 and 1024.
fn item_resolution(triangles: usize) -> u32 {
    ((triangles as f64).sqrt().ceil() as u32).clamp(128, 1024)
}

/// The triangle seen through each pixel centre of a perspective image that
/// covers the bounding sphere, and how far away it is: where a triangle's
/// projection covers pixel centres that show something else, part of it is
/// hidden (or, for a triangle hidden at its centroid, part of it is seen),
/// though its centroid and its neighbours' agree.
struct ItemBuffer {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    /// Tangent of the half-angle of the cone around the unit sphere.
    tan: f64,
    r: u32,
    item: Vec<u32>,
    /// Distance from the eye to the hit of each pixel's ray (∞ for none).
    depth: Vec<f32>,
    /// Each pixel's unit direction ([`ItemBuffer::direction`]), computed
    /// once: the margin test reads each pixel for several triangles.
    dirs: Vec<DVec3>,
}

/// Pixels around a triangle's projection that the item-buffer test also
/// reads: an occluder (or a gap) narrower than the pixel spacing is seen by
/// some pixel near the triangle even when no pixel centre falls inside it.
const MARGIN_PX: f64 = 1.0;

impl ItemBuffer {
    const NONE: u32 = u32::MAX;

    fn new(tracer: &dyn Tracer, eye: DVec3, r: u32) -> Result<Self, BackendError> {
        let forward = -eye.normalize();
        let (right, up) = forward.any_orthonormal_pair();
        let sin = 1.0 / eye.length();
        let tan = sin / (1.0 - sin * sin).max(0.0).sqrt();
        let mut ib = Self { eye, forward, right, up, tan, r, item: Vec::new(), depth: Vec::new(), dirs: Vec::new() };
        ib.dirs = (0..r * r).map(|k| ib.direction(k % r, k / r)).collect();
        let lines: Vec<Line> = ib.dirs.iter().map(|&d| Line::ray(eye, d, 0.0, 4.0 * eye.length())).collect();
        let mut hits = Vec::new();
        trace(tracer, &lines, &mut hits)?;
        ib.item = hits.iter().map(|h| h.map_or(Self::NONE, |h| h.primitive)).collect();
        ib.depth = hits.iter().map(|h| h.map_or(f32::INFINITY, |h| h.t)).collect();
        Ok(ib)
    }

    fn rays(&self) -> u64 {
        u64::from(self.r) * u64::from(self.r)
    }

    /// Image coordinate in `[-1, 1]` of pixel centre `i`.
    fn centre(&self, i: u32) -> f64 {
        2.0 * (f64::from(i) + 0.5) / f64::from(self.r) - 1.0
    }

    /// Unit direction of pixel `(x, y)`'s ray.
    fn direction(&self, x: u32, y: u32) -> DVec3 {
        (self.forward + self.right * (self.centre(x) * self.tan) + self.up * (self.centre(y) * self.tan)).normalize()
    }

    /// Whether the pixels on and around triangle `t`'s projection agree with
    /// its centroid's `visible`: every pixel centre inside shows `t` when
    /// visible and something else when not; and no pixel within
    /// [`MARGIN_PX`] of it shows a surface in front of `t`'s plane (when
    /// visible: an occluder over part of `t` that the pixel centres missed,
    /// often `t`'s own neighbour at a fold) or behind it or nothing (when
    /// hidden: a gap through which part of `t` is seen). A flagged triangle
    /// is only sampled more, so a false alarm costs rays, never accuracy.
    fn agrees(&self, v: &[DVec3; 3], t: u32, visible: bool) -> bool {
        let rf = f64::from(self.r);
        // Pixel coordinates of the projected vertices.
        let proj = v.map(|p| {
            let d = p - self.eye;
            let z = d.dot(self.forward);
            let to_px = |c: f64| (c + 1.0) * 0.5 * rf - 0.5;
            (to_px(d.dot(self.right) / (z * self.tan)), to_px(d.dot(self.up) / (z * self.tan)))
        });
        let lo = |f: fn(&(f64, f64)) -> f64| proj.iter().map(f).fold(f64::INFINITY, f64::min);
        let hi = |f: fn(&(f64, f64)) -> f64| proj.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
        let x0 = (lo(|p| p.0) - MARGIN_PX).ceil().max(0.0);
        let x1 = (hi(|p| p.0) + MARGIN_PX).floor().min(rf - 1.0);
        let y0 = (lo(|p| p.1) - MARGIN_PX).ceil().max(0.0);
        let y1 = (hi(|p| p.1) + MARGIN_PX).floor().min(rf - 1.0);
        if x1 < x0 || y1 < y0 {
            return true;
        }
        let edge = |a: (f64, f64), b: (f64, f64), q: (f64, f64)| (b.0 - a.0) * (q.1 - a.1) - (b.1 - a.1) * (q.0 - a.0);
        let area = edge(proj[0], proj[1], proj[2]);
        if area == 0.0 {
            return true;
        }
        let sign = area.signum();
        let lengths = [0, 1, 2].map(|i| {
            let (a, b) = (proj[(i + 1) % 3], proj[(i + 2) % 3]);
            (b.0 - a.0).hypot(b.1 - a.1).max(f64::MIN_POSITIVE)
        });
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        let plane = n.dot(v[0] - self.eye);
        let flat = 1e-12 * n.length();
        for y in y0 as u32..=y1 as u32 {
            for x in x0 as u32..=x1 as u32 {
                let q = (f64::from(x), f64::from(y));
                // Signed distances (pixels, positive inside) to the three edges.
                let w = [0, 1, 2].map(|i| sign * edge(proj[(i + 1) % 3], proj[(i + 2) % 3], q) / lengths[i]);
                if w.iter().any(|&e| e < -MARGIN_PX) {
                    continue;
                }
                let k = (y * self.r + x) as usize;
                let shown = self.item[k];
                if w.iter().all(|&e| e > 0.0) && (shown == t) != visible {
                    return false;
                }
                if shown == t {
                    continue;
                }
                let along = n.dot(self.dirs[k]);
                if along.abs() < flat {
                    continue;
                }
                let s = plane / along;
                let hit = f64::from(self.depth[k]);
                let occluder = visible && hit < s * (1.0 - 1e-4);
                let gap = !visible && hit > s * (1.0 + 1e-4);
                if occluder || gap {
                    return false;
                }
            }
        }
        true
    }
}

/// One triangle sampled beyond its probes.
#[derive(Clone, Copy, Debug)]
struct Sampled {
    tri: u32,
    omega: f64,
    fraction: f64,
    points: u32,
}

/// One viewpoint's visibility.
struct View {
    eye: DVec3,
    /// `(patch, Ω)` of every triangle visible at its centroid and not sampled further.
    whole: Vec<(u32, f64)>,
    sampled: Vec<Sampled>,
    m: u32,
    rays: u64,
}

/// A shadow ray from `eye` towards `p`, stopping short of it by a relative
/// 1e-5: `p` is seen when nothing is crossed (its own triangle, at the end,
/// is not; a ray that grazes its triangle's neighbour at a convex edge is
/// not taken for an occluder).
fn towards(eye: DVec3, p: DVec3) -> Line {
    let d = p - eye;
    let r = d.length();
    Line::ray(eye, d / r, 0.0, r * (1.0 - 1e-5))
}

/// Whether each of `lines` reaches its end unoccluded.
fn unoccluded(tracer: &dyn Tracer, lines: &[Line]) -> Result<Vec<bool>, BackendError> {
    let (mut out, mut part) = (Vec::with_capacity(lines.len()), Vec::new());
    for chunk in lines.chunks(16_384) {
        tracer.occluded(chunk, &mut part)?;
        out.extend(part.iter().map(|&o| !o));
    }
    Ok(out)
}

fn trace(tracer: &dyn Tracer, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
    out.clear();
    let mut part = Vec::new();
    for chunk in lines.chunks(16_384) {
        tracer.closest_hit(chunk, &mut part)?;
        out.extend_from_slice(&part);
    }
    Ok(())
}

/// Centroids of the `m × m` subdivision of triangle `v`.
fn sub_centroids(v: &[DVec3; 3], m: u32) -> impl Iterator<Item = DVec3> + '_ {
    let mf = f64::from(m);
    let (e1, e2) = ((v[1] - v[0]) / mf, (v[2] - v[0]) / mf);
    (0..m).flat_map(move |i| {
        (0..m - i).flat_map(move |j| {
            let (fi, fj) = (f64::from(i), f64::from(j));
            let up = v[0] + e1 * (fi + 1.0 / 3.0) + e2 * (fj + 1.0 / 3.0);
            let down = v[0] + e1 * (fi + 2.0 / 3.0) + e2 * (fj + 2.0 / 3.0);
            std::iter::once(up).chain((j + 1 < m - i).then_some(down))
        })
    })
}

fn as_d(t: &[Vec3A; 3]) -> [DVec3; 3] {
    t.map(|v| DVec3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z)))
}

/// What every view of one run shares: the triangles in `f64`, their
/// centroids, edge adjacency, and the coherent order their shadow rays are
/// traced in ([`morton_order`]).
struct Shared {
    tris: Vec<[DVec3; 3]>,
    centroids: Vec<DVec3>,
    adjacency: Vec<Vec<u32>>,
    order: Vec<u32>,
}

impl Shared {
    fn new(p: &Prepared) -> Self {
        let tris: Vec<[DVec3; 3]> = p.triangles.iter().map(as_d).collect();
        let centroids: Vec<DVec3> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let order = morton_order(&centroids);
        Self { tris, centroids, adjacency: triangle_adjacency(&p.triangles), order }
    }
}

impl View {
    fn new(p: &Prepared, tracer: &dyn Tracer, shared: &Shared, eye: DVec3, m: u32) -> Result<Self, BackendError> {
        let (tris, adjacency) = (&shared.tris, &shared.adjacency);
        // Centroid probes in coherent order, answers scattered back.
        let lines: Vec<Line> = shared.order.iter().map(|&t| towards(eye, shared.centroids[t as usize])).collect();
        let mut visible = vec![false; tris.len()];
        for (&t, seen) in shared.order.iter().zip(unoccluded(tracer, &lines)?) {
            visible[t as usize] = seen;
        }
        let mut rays = lines.len() as u64;
        drop(lines);
        let items = ItemBuffer::new(tracer, eye, item_resolution(tris.len()))?;
        rays += items.rays();
        let mut view = View { eye, whole: Vec::new(), sampled: Vec::new(), m, rays };
        for (t, tri) in tris.iter().enumerate() {
            let boundary = adjacency[t].iter().any(|&n| visible[n as usize] != visible[t])
                || !items.agrees(tri, t as u32, visible[t]);
            let omega = triangle_solid_angle(tri[0] - eye, tri[1] - eye, tri[2] - eye);
            if boundary {
                view.sampled.push(Sampled { tri: t as u32, omega, fraction: 0.0, points: 0 });
            } else if visible[t] && omega > 0.0 {
                view.whole.push((p.triangle_patch[t], omega));
            }
        }
        view.sample(tracer, tris)?;
        Ok(view)
    }

    /// (Re)samples every boundary triangle at the current `m`.
    fn sample(&mut self, tracer: &dyn Tracer, tris: &[[DVec3; 3]]) -> Result<(), BackendError> {
        let mut lines = Vec::new();
        let mut weights = Vec::new();
        for s in &self.sampled {
            let v = &tris[s.tri as usize];
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            for q in sub_centroids(v, self.m) {
                let d = q - self.eye;
                weights.push(n.dot(d).abs() / d.length().powi(3));
                lines.push(towards(self.eye, q));
            }
        }
        let visible = unoccluded(tracer, &lines)?;
        self.rays += lines.len() as u64;
        let k = (self.m * self.m) as usize;
        for (i, s) in self.sampled.iter_mut().enumerate() {
            let (mut seen, mut all) = (0.0, 0.0);
            for j in i * k..(i + 1) * k {
                all += weights[j];
                if visible[j] {
                    seen += weights[j];
                }
            }
            s.fraction = if all > 0.0 { seen / all } else { 0.0 };
            s.points = k as u32;
        }
        Ok(())
    }

    /// The row: patches seen (increasing) and their solid angles.
    fn row(&self, p: &Prepared) -> (Vec<u32>, Vec<f64>) {
        let mut all: Vec<(u32, f64)> = self.whole.clone();
        all.extend(
            self.sampled
                .iter()
                .filter(|s| s.fraction > 0.0 && s.omega > 0.0)
                .map(|s| (p.triangle_patch[s.tri as usize], s.omega * s.fraction)),
        );
        all.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let (mut patch, mut angle) = (Vec::new(), Vec::new());
        for run in all.chunk_by(|a, b| a.0 == b.0) {
            patch.push(run[0].0);
            angle.push(run.iter().map(|x| x.1).sum());
        }
        (patch, angle)
    }
}

fn assemble(p: &Prepared, views: &[View], distance: f64, cone: f64) -> ViewpointChannel {
    let mut starts = vec![0];
    let (mut patch, mut solid_angle, mut background) = (Vec::new(), Vec::new(), Vec::new());
    for v in views {
        let (ps, a) = v.row(p);
        background.push((cone - a.iter().sum::<f64>()).max(0.0));
        patch.extend(ps);
        solid_angle.extend(a);
        starts.push(patch.len());
    }
    ViewpointChannel {
        positions: views.iter().map(|v| v.eye.normalize() * distance).collect(),
        starts,
        patch,
        solid_angle,
        background,
        patches: p.patches,
        rays_per_viewpoint: views.iter().map(|v| v.rays).max().unwrap_or(0),
    }
}

/// Standard error (nats) of each viewpoint's VMI by the delta method:
/// `∂ VMI_v / ∂ a_o = (ln(q_o / p_o) − VMI_v) / A_v` with `q_o = a_o / A_v`,
/// and `Var(a_t) = Ω_t² f_t (1 − f_t) / k` for each sampled triangle.
fn vmi_stderr(p: &Prepared, ch: &ViewpointChannel, views: &[View], p_o: &[f64], vmi: &[f64]) -> Vec<f64> {
    views
        .iter()
        .enumerate()
        .map(|(v, view)| {
            let (ps, a) = ch.row(v);
            let total: f64 = a.iter().sum();
            if total <= 0.0 {
                return 0.0;
            }
            let ln_ratio = |patch: u32| -> f64 {
                let i = ps.partition_point(|&x| x < patch);
                let q = a[i] / total;
                (q / p_o[patch as usize]).ln()
            };
            let var: f64 = view
                .sampled
                .iter()
                .filter(|s| s.fraction > 0.0 && s.fraction < 1.0)
                .map(|s| {
                    let g = (ln_ratio(p.triangle_patch[s.tri as usize]) - vmi[v]) / total;
                    g * g * s.omega * s.omega * s.fraction * (1.0 - s.fraction) / f64::from(s.points)
                })
                .sum();
            var.sqrt()
        })
        .collect()
}

impl ViewpointChannel {
    /// The channel from exact triangle solid angles and sampled visibility
    /// (see the module docs) from viewpoints at `refine.distance` in each
    /// of `directions`, refined until every viewpoint's VMI meets
    /// `refine.tolerance` or its subdivision reaches `refine.max`.
    /// `progress(done, total)` counts viewpoints.
    ///
    /// # Errors
    /// Backend errors; [`ChannelError::Measure`] when nothing is seen.
    pub fn build_solid_angle(
        prepared: &Prepared,
        tracer: &dyn Tracer,
        directions: &[DVec3],
        refine: &Refinement,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(Self, Convergence), ChannelError> {
        let views = first_pass(prepared, tracer, directions, refine.distance, refine.first.max(1), progress)?;
        let tris: Vec<[DVec3; 3]> = prepared.triangles.iter().map(as_d).collect();
        refine_views(prepared, views, refine, &mut |views, todo| {
            let results: Vec<Result<(), BackendError>> = views
                .par_iter_mut()
                .enumerate()
                .filter(|(v, _)| todo.binary_search(v).is_ok())
                .map(|(_, view)| {
                    view.m = (view.m * 2).min(refine.max);
                    view.sample(tracer, &tris)
                })
                .collect();
            results.into_iter().collect::<Result<(), BackendError>>().map_err(ChannelError::Backend)
        })
    }

    /// The channel and its convergence from saved ladders (shards of one
    /// run, in viewpoint order): the same refinement as
    /// [`ViewpointChannel::build_solid_angle`], each step reading a view's
    /// next level from its ladder, or tracing it with `tracer` where the
    /// ladder stops short, so the result is bit for bit the one-process
    /// run's. `refine.first` and `refine.max` must be the ones the ladders
    /// were built with ([`ladder_levels`]).
    ///
    /// # Errors
    /// Backend errors; [`ChannelError::Measure`] when nothing is seen.
    pub fn from_ladders(
        prepared: &Prepared,
        tracer: &dyn Tracer,
        ladders: &[ViewLadder],
        refine: &Refinement,
    ) -> Result<(Self, Convergence), ChannelError> {
        let levels = ladder_levels(refine.first, refine.max);
        let tris: Vec<[DVec3; 3]> = prepared.triangles.iter().map(as_d).collect();
        let at = |l: &ViewLadder, k: usize| View {
            eye: l.eye,
            whole: l.whole.clone(),
            sampled: l
                .sampled
                .iter()
                .zip(&l.fractions[k])
                .map(|(&(tri, omega), &fraction)| Sampled { tri, omega, fraction, points: levels[k] * levels[k] })
                .collect(),
            m: levels[k],
            rays: l.base_rays + levels[..=k].iter().map(|&m| u64::from(m * m)).sum::<u64>() * l.sampled.len() as u64,
        };
        let views: Vec<View> = ladders.iter().map(|l| at(l, 0)).collect();
        refine_views(prepared, views, refine, &mut |views, todo| {
            let next = |m: u32| levels.iter().position(|&x| x == m).map_or(levels.len() - 1, |k| k + 1);
            let mut traced = Vec::new();
            for &v in todo {
                let k = next(views[v].m).min(levels.len() - 1);
                if k < ladders[v].fractions.len() {
                    views[v] = at(&ladders[v], k);
                } else {
                    traced.push(v);
                }
            }
            let results: Vec<Result<(), BackendError>> = views
                .par_iter_mut()
                .enumerate()
                .filter(|(v, _)| traced.binary_search(v).is_ok())
                .map(|(_, view)| {
                    view.m = (view.m * 2).min(refine.max);
                    view.sample(tracer, &tris)
                })
                .collect();
            results.into_iter().collect::<Result<(), BackendError>>().map_err(ChannelError::Backend)
        })
    }

    /// Every viewpoint's visibility at the first `keep` levels of the
    /// refinement ([`ladder_levels`]; all of them when `keep` is larger):
    /// what a shard of a solid-angle run saves. A ladder is a pure function
    /// of the scene, the direction, the distance and the levels, whatever
    /// the other viewpoints, so shards of any viewpoint ranges merge exactly
    /// ([`ViewpointChannel::from_ladders`], which traces the levels not
    /// kept that a viewpoint turns out to need). `progress(done, total)`
    /// counts viewpoints.
    ///
    /// # Errors
    /// Backend errors.
    pub fn ladders(
        prepared: &Prepared,
        tracer: &dyn Tracer,
        directions: &[DVec3],
        refine: &Refinement,
        keep: usize,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Vec<ViewLadder>, BackendError> {
        let mut levels = ladder_levels(refine.first, refine.max);
        levels.truncate(keep.max(1));
        let tris: Vec<[DVec3; 3]> = prepared.triangles.iter().map(as_d).collect();
        let views = first_pass(prepared, tracer, directions, refine.distance, levels[0], &mut |_, _| {})?;
        let n = views.len() as u64;
        let mut done = 0u64;
        let wave = (rayon::current_num_threads() * 2).max(2);
        let mut out = Vec::with_capacity(views.len());
        let mut views = views.into_iter();
        loop {
            let batch: Vec<View> = views.by_ref().take(wave).collect();
            if batch.is_empty() {
                break;
            }
            let made: Vec<Result<ViewLadder, BackendError>> = batch
                .into_par_iter()
                .map(|mut view| {
                    let base_rays = view.rays - u64::from(view.m * view.m) * view.sampled.len() as u64;
                    let mut fractions = vec![view.sampled.iter().map(|s| s.fraction).collect::<Vec<f64>>()];
                    for &m in &levels[1..] {
                        view.m = m;
                        view.sample(tracer, &tris)?;
                        fractions.push(view.sampled.iter().map(|s| s.fraction).collect());
                    }
                    Ok(ViewLadder {
                        eye: view.eye,
                        whole: view.whole,
                        sampled: view.sampled.iter().map(|s| (s.tri, s.omega)).collect(),
                        base_rays,
                        fractions,
                    })
                })
                .collect();
            for l in made {
                out.push(l?);
            }
            done = out.len() as u64;
            progress(done, n);
        }
        debug_assert_eq!(done, n);
        Ok(out)
    }
}

/// The subdivisions a viewpoint passes through: `first`, doubled until it
/// reaches `max` (capped there).
#[must_use]
pub fn ladder_levels(first: u32, max: u32) -> Vec<u32> {
    let mut m = first.max(1);
    let mut levels = vec![m];
    while m < max {
        m = (m * 2).min(max);
        levels.push(m);
    }
    levels
}

/// One viewpoint's visibility at every level of the refinement.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewLadder {
    /// The eye (normalised scene coordinates).
    pub eye: DVec3,
    /// `(patch, Ω)` of every triangle visible at its centroid and not sampled further.
    pub whole: Vec<(u32, f64)>,
    /// `(triangle, Ω)` of every triangle sampled beyond its centroid.
    pub sampled: Vec<(u32, f64)>,
    /// Rays of the centroid probes and the item buffer.
    pub base_rays: u64,
    /// Per level of [`ladder_levels`] kept (the first ones, at least one),
    /// the visible fraction of each sampled triangle.
    pub fractions: Vec<Vec<f64>>,
}

/// Every viewpoint's first visibility, at subdivision `m`.
fn first_pass(
    prepared: &Prepared,
    tracer: &dyn Tracer,
    directions: &[DVec3],
    distance: f64,
    m: u32,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Vec<View>, BackendError> {
    let shared = Shared::new(prepared);
    let n = directions.len() as u64;
    let wave = (rayon::current_num_threads() * 2).max(2);
    let mut views: Vec<View> = Vec::with_capacity(directions.len());
    for dirs in directions.chunks(wave) {
        let made: Vec<Result<View, BackendError>> =
            dirs.par_iter().map(|d| View::new(prepared, tracer, &shared, d.normalize() * distance, m)).collect();
        for v in made {
            views.push(v?);
        }
        progress(views.len() as u64, n);
    }
    Ok(views)
}

/// Step of the refinement: moves the views listed (increasing) one level up.
type Advance<'a> = dyn FnMut(&mut [View], &[usize]) -> Result<(), ChannelError> + 'a;

/// Refines `views` until every VMI meets the tolerance or its subdivision
/// reaches `refine.max`; `advance` moves the views that miss it one level up.
fn refine_views(
    prepared: &Prepared,
    mut views: Vec<View>,
    refine: &Refinement,
    advance: &mut Advance<'_>,
) -> Result<(ViewpointChannel, Convergence), ChannelError> {
    let distance = refine.distance;
    let cos_a = (1.0 - 1.0 / (distance * distance)).max(0.0).sqrt();
    let cone = std::f64::consts::TAU * (1.0 - cos_a);
    loop {
        let ch = assemble(prepared, &views, distance, cone);
        let an = ViewpointAnalysis::new(&ch, refine.weights, refine.background).map_err(ChannelError::Measure)?;
        let mut p_o = vec![0.0; an.outputs()];
        an.channel().and_then(|c| c.output_into(&mut p_o)).map_err(ChannelError::Measure)?;
        // Each seen viewpoint's VMI from the core (nats); unseen ones have none.
        let mut seen_vmi = vec![0.0; an.rows()];
        an.channel()
            .and_then(|c| c.specific_information_into(&p_o, itgfx_core::Base::Nats, &mut seen_vmi))
            .map_err(ChannelError::Measure)?;
        let vmi = an.expand(&seen_vmi, 0.0);
        let se = vmi_stderr(prepared, &ch, &views, &p_o, &vmi);
        let met: Vec<bool> = (0..views.len()).map(|v| 2.0 * se[v] <= refine.tolerance * vmi[v].abs()).collect();
        let todo: Vec<usize> = (0..views.len()).filter(|&v| !met[v] && views[v].m < refine.max).collect();
        if todo.is_empty() {
            let conv = Convergence {
                vmi_stderr: se,
                met,
                subdivision: views.iter().map(|v| v.m).collect(),
                rays: views.iter().map(|v| v.rays).sum(),
                boundary_triangles: views.iter().map(|v| v.sampled.len() as u64).sum(),
            };
            return Ok((ch, conv));
        }
        advance(&mut views, &todo)?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_angles_of_known_triangles() {
        // An octant of the unit sphere subtends 4π/8.
        let o = triangle_solid_angle(DVec3::X, DVec3::Y, DVec3::Z);
        assert!((o - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // A tiny triangle far away: area · cos / r².
        let (a, b, c) = (DVec3::new(0.0, 0.0, 10.0), DVec3::new(1e-3, 0.0, 10.0), DVec3::new(0.0, 1e-3, 10.0));
        assert!((triangle_solid_angle(a, b, c) / (0.5e-6 / 100.0) - 1.0).abs() < 1e-5);
        // Edge-on: zero.
        assert_eq!(triangle_solid_angle(DVec3::X, DVec3::X * 2.0, DVec3::X * 3.0), 0.0);
    }

    #[test]
    fn ladder_levels_double_up_to_the_cap() {
        assert_eq!(ladder_levels(4, 32), [4, 8, 16, 32]);
        assert_eq!(ladder_levels(4, 20), [4, 8, 16, 20]);
        assert_eq!(ladder_levels(4, 4), [4]);
        assert_eq!(ladder_levels(8, 4), [8], "first above the cap: no refinement, as build_solid_angle");
        assert_eq!(ladder_levels(0, 2), [1, 2]);
    }

    #[test]
    fn sub_centroids_are_m_squared_and_average_to_the_centroid() {
        let v = [DVec3::ZERO, DVec3::X, DVec3::Y];
        for m in [1, 2, 4, 7] {
            let pts: Vec<DVec3> = sub_centroids(&v, m).collect();
            assert_eq!(pts.len() as u32, m * m);
            let mean = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
            assert!((mean - DVec3::new(1.0 / 3.0, 1.0 / 3.0, 0.0)).length() < 1e-12, "{m}: {mean}");
            assert!(pts.iter().all(|p| p.x > 0.0 && p.y > 0.0 && p.x + p.y < 1.0));
        }
    }
}
