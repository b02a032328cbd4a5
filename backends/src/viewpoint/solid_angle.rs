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
//! 2. visibility can change across a triangle only where the projection of
//!    a contour edge in front of it (a fold or a boundary of the surface as
//!    seen from the eye) crosses it, or where it cuts through another
//!    triangle (`contours.rs`); each triangle so flagged is sampled at
//!    `m²` stratified points (the centroids of its `m × m` subdivision) and
//!    its visible fraction is the ratio estimate `f_t = Σ v_i w_i / Σ w_i`
//!    with the solid-angle density `w_i = |cos θ_i| / r_i²`; every other
//!    triangle is seen or hidden whole, as its centroid is;
//! 3. `a_o = Σ_{t ∈ o} Ω_t f_t`, exact for triangles entirely visible or
//!    hidden (a convex object is exact), and the standard error of each
//!    viewpoint's VMI follows by the delta method from the binomial
//!    variance of the sampled fractions; viewpoints whose VMI misses the
//!    tolerance get `m` doubled until it holds or `m` reaches its cap.
//!
//! The result is an ordinary [`ViewpointChannel`]: every measure downstream
//! is the same code as for the ray grid.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use super::coherent::morton_order;
use super::contours::{Contours, MeshEdges, contour_tiles, cutting};
use super::{ViewpointAnalysis, ViewpointChannel, ViewpointWeights};
use crate::lines::Line;
use crate::tracer::{BackendError, Prepared, Tracer};

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
    towards_along(eye, d, d.length())
}

/// [`towards`] from `d = p − eye` and its length `r`.
fn towards_along(eye: DVec3, d: DVec3, r: f64) -> Line {
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
/// centroids, the coherent order their shadow rays are traced in
/// ([`morton_order`]), the mesh's edges and the triangles that cut others.
struct Shared {
    tris: Vec<[DVec3; 3]>,
    centroids: Vec<DVec3>,
    order: Vec<u32>,
    edges: MeshEdges,
    /// Triangles cutting through another ([`cutting`]): sampled in every view.
    cuts: Vec<bool>,
}

impl Shared {
    fn new(p: &Prepared) -> Self {
        let tris: Vec<[DVec3; 3]> = p.triangles.iter().map(as_d).collect();
        let centroids: Vec<DVec3> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        // Three independent pure functions of the mesh, side by side: run
        // one after another they were a serial ~2.5% of a bunny run.
        let ((order, cuts), edges) = rayon::join(
            || rayon::join(|| morton_order(&centroids), || cutting(&tris)),
            || MeshEdges::new(&p.triangles, &tris),
        );
        Self { tris, centroids, order, edges, cuts }
    }
}

/// Each triangle's component label (its smallest member) under `links`,
/// joining only triangles not `flagged`: union by smaller index, so the
/// labels do not depend on the order of the links.
fn components(n: usize, links: impl IntoIterator<Item = [u32; 2]>, flagged: &[bool]) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let up = parent[parent[x as usize] as usize];
            parent[x as usize] = up;
            x = up;
        }
        x
    }
    for [a, b] in links {
        if flagged[a as usize] || flagged[b as usize] {
            continue;
        }
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi as usize] = lo;
    }
    (0..n as u32).map(|x| root(&mut parent, x)).collect()
}

/// The unflagged triangles grouped by `label` (labels increasing, each
/// group's triangles increasing): a counting sort, the order of a stable
/// sort by label in linear time.
fn by_label(label: &[u32], flag: &[bool]) -> Vec<u32> {
    let mut starts = vec![0u32; label.len() + 1];
    for (&l, &f) in label.iter().zip(flag) {
        if !f {
            starts[l as usize + 1] += 1;
        }
    }
    for k in 1..starts.len() {
        starts[k] += starts[k - 1];
    }
    let mut out = vec![0u32; starts[label.len()] as usize];
    for (t, (&l, &f)) in label.iter().zip(flag).enumerate() {
        if !f {
            out[starts[l as usize] as usize] = t as u32;
            starts[l as usize] += 1;
        }
    }
    out
}

/// One view's visibility: which triangles are seen at their centroid
/// (meaningful for the unflagged ones) and which may change across
/// themselves (`flag`), with the visibility rays cast.
struct Visibility {
    visible: Vec<bool>,
    flag: Vec<bool>,
    rays: u64,
}

impl Visibility {
    /// Flags the triangles that cut another or that a contour edge crosses
    /// ([`Contours::crosses`]); the others are seen or hidden whole, and
    /// alike across the edges between them that are no contour, so each
    /// such connected part gets centroid rays to three of its triangles
    /// (first, middle and last by index; every triangle of it when they
    /// disagree, which only rounding at a grazing ray can cause). Contours
    /// whose triangles are all hidden and unflagged are hidden themselves
    /// and cannot bound anything seen, so the flags are tested again
    /// without them (twice: each round can only clear flags, and each flag
    /// it clears is sound given the last round's), and triangles cleared
    /// get their own centroid rays.
    fn new(tracer: &dyn Tracer, shared: &Shared, eye: DVec3) -> Result<Self, BackendError> {
        let (tris, n) = (&shared.tris, shared.tris.len());
        let tiles = contour_tiles(n);
        let mut contours = Contours::new(&shared.edges, eye, tiles);
        let flag: Vec<bool> = tris
            .iter()
            .zip(&shared.cuts)
            .enumerate()
            .map(|(t, (tri, &cut))| cut || contours.crosses(shared.edges.corners(t), tri))
            .collect();
        let label = components(n, contours.links(&shared.edges), &flag);
        let members = by_label(&label, &flag);
        let mut vis = Self { visible: vec![false; n], flag, rays: 0 };
        let mut want = vec![false; n];
        for part in members.chunk_by(|a, b| label[*a as usize] == label[*b as usize]) {
            for i in [0, part.len() / 2, part.len() - 1] {
                want[part[i] as usize] = true;
            }
        }
        vis.probe(tracer, shared, eye, &mut want)?;
        for part in members.chunk_by(|a, b| label[*a as usize] == label[*b as usize]) {
            let v = vis.visible[part[0] as usize];
            let reps = [0, part.len() / 2, part.len() - 1];
            if reps.iter().all(|&i| vis.visible[part[i] as usize] == v) {
                part.iter().for_each(|&t| vis.visible[t as usize] = v);
            } else {
                part.iter().for_each(|&t| want[t as usize] = true);
                reps.iter().for_each(|&i| want[part[i] as usize] = false);
            }
        }
        vis.probe(tracer, shared, eye, &mut want)?;
        for _ in 0..2 {
            let hidden: Vec<bool> = vis.flag.iter().zip(&vis.visible).map(|(&f, &v)| !f && !v).collect();
            contours.hide(&shared.edges, &hidden);
            for t in 0..n {
                if vis.flag[t] && !shared.cuts[t] && !contours.crosses(shared.edges.corners(t), &tris[t]) {
                    vis.flag[t] = false;
                    want[t] = true;
                }
            }
            vis.probe(tracer, shared, eye, &mut want)?;
        }
        Ok(vis)
    }

    /// Centroid rays to the triangles `want`ed (cleared), in coherent order.
    fn probe(
        &mut self,
        tracer: &dyn Tracer,
        shared: &Shared,
        eye: DVec3,
        want: &mut [bool],
    ) -> Result<(), BackendError> {
        let which: Vec<u32> = shared.order.iter().copied().filter(|&t| want[t as usize]).collect();
        let lines: Vec<Line> = which.iter().map(|&t| towards(eye, shared.centroids[t as usize])).collect();
        for (&t, seen) in which.iter().zip(unoccluded(tracer, &lines)?) {
            self.visible[t as usize] = seen;
            want[t as usize] = false;
        }
        self.rays += lines.len() as u64;
        Ok(())
    }
}

impl View {
    fn new(p: &Prepared, tracer: &dyn Tracer, shared: &Shared, eye: DVec3, m: u32) -> Result<Self, BackendError> {
        let tris = &shared.tris;
        let Visibility { visible, flag, rays } = Visibility::new(tracer, shared, eye)?;
        // Sized first (two passes over the flags are cheaper than the lists'
        // regrowth: ~400k entries a view of the 1.1M-triangle bunny).
        let flagged = flag.iter().filter(|&&f| f).count();
        let whole = visible.iter().zip(&flag).filter(|&(&v, &f)| v && !f).count();
        let mut view = View { eye, whole: Vec::with_capacity(whole), sampled: Vec::with_capacity(flagged), m, rays };
        for (t, tri) in tris.iter().enumerate() {
            if !flag[t] && !visible[t] {
                continue;
            }
            let omega = triangle_solid_angle(tri[0] - eye, tri[1] - eye, tri[2] - eye);
            if flag[t] {
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
        let points = self.sampled.len() * (self.m * self.m) as usize;
        let (mut lines, mut weights) = (Vec::with_capacity(points), Vec::with_capacity(points));
        for s in &self.sampled {
            let v = &tris[s.tri as usize];
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            for q in sub_centroids(v, self.m) {
                // One length for the weight and the ray (the same value).
                let d = q - self.eye;
                let r = d.length();
                weights.push(n.dot(d).abs() / r.powi(3));
                lines.push(towards_along(self.eye, d, r));
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

    /// The row: patches seen (increasing) and their solid angles. The
    /// pairs are put in `(patch, Ω)` order (`Ω` by `total_cmp` within a
    /// patch) and each patch's angles added in that order. `whole` and the
    /// sampled triangles are each in triangle order, so where patch numbers
    /// grow with the triangles (a mesh file: one patch per triangle) a
    /// merge of the two gives that order and only runs of one patch are
    /// sorted; otherwise the pairs are sorted. Either way the same
    /// sequence (the order is total up to identical pairs), so the same sums.
    fn row(&self, p: &Prepared) -> (Vec<u32>, Vec<f64>) {
        let sampled: Vec<(u32, f64)> = self
            .sampled
            .iter()
            .filter(|s| s.fraction > 0.0 && s.omega > 0.0)
            .map(|s| (p.triangle_patch[s.tri as usize], s.omega * s.fraction))
            .collect();
        let by_pair = |a: &(u32, f64), b: &(u32, f64)| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1));
        let mut all: Vec<(u32, f64)> = Vec::with_capacity(self.whole.len() + sampled.len());
        let (mut i, mut j) = (0, 0);
        while i < self.whole.len() && j < sampled.len() {
            if sampled[j].0 < self.whole[i].0 {
                all.push(sampled[j]);
                j += 1;
            } else {
                all.push(self.whole[i]);
                i += 1;
            }
        }
        all.extend_from_slice(&self.whole[i..]);
        all.extend_from_slice(&sampled[j..]);
        if all.windows(2).all(|w| w[0].0 <= w[1].0) {
            for run in all.chunk_by_mut(|a, b| a.0 == b.0).filter(|r| r.len() > 1) {
                run.sort_unstable_by(by_pair);
            }
        } else {
            all.sort_unstable_by(by_pair);
        }
        let (mut patch, mut angle) = (Vec::new(), Vec::new());
        for run in all.chunk_by(|a, b| a.0 == b.0) {
            patch.push(run[0].0);
            angle.push(run.iter().map(|x| x.1).sum());
        }
        (patch, angle)
    }
}

fn assemble(p: &Prepared, views: &[View], distance: f64, cone: f64) -> ViewpointChannel {
    let mut starts = Vec::with_capacity(views.len() + 1);
    starts.push(0);
    // A row has at most one entry per triangle it holds: the entries are
    // written once into blocks of that size (grown by doubling, the 1.1M
    // bunny's 67M entries were copied ~2 times over, on one thread); the
    // pages past the end are never touched.
    let most: usize = views.iter().map(|v| v.whole.len() + v.sampled.len()).sum();
    let (mut patch, mut solid_angle) = (Vec::with_capacity(most), Vec::with_capacity(most));
    let mut background = Vec::with_capacity(views.len());
    // The views' rows sorted side by side (a serial step of the refinement
    // loop before), a few at a time so that only those are held twice,
    // and joined in view order.
    for wave in views.chunks((2 * rayon::current_num_threads()).max(2)) {
        let rows: Vec<(Vec<u32>, Vec<f64>)> = wave.par_iter().map(|v| v.row(p)).collect();
        let len: usize = rows.iter().map(|r| r.0.len()).sum();
        append_rows(&mut patch, &rows, |r| &r.0, len);
        append_rows(&mut solid_angle, &rows, |r| &r.1, len);
        for (_, a) in &rows {
            background.push((cone - a.iter().sum::<f64>()).max(0.0));
            starts.push(starts[starts.len() - 1] + a.len());
        }
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

/// Appends `part(row)` of every row, in order (`len` entries in all, within
/// `out`'s capacity), each row copied on its own thread: the copies' page
/// faults (the 1.1M-triangle bunny's 67M entries, ~800 MB) were a serial
/// second of the refinement loop.
fn append_rows<T: Copy + Send + Sync, R: Sync>(
    out: &mut Vec<T>,
    rows: &[R],
    part: impl Fn(&R) -> &[T] + Sync,
    len: usize,
) {
    assert!(out.capacity() - out.len() >= len && rows.iter().map(|r| part(r).len()).sum::<usize>() == len);
    let mut rest = &mut out.spare_capacity_mut()[..len];
    let mut pieces = Vec::with_capacity(rows.len());
    for r in rows {
        let (piece, tail) = std::mem::take(&mut rest).split_at_mut(part(r).len());
        pieces.push(piece);
        rest = tail;
    }
    pieces.into_par_iter().zip(rows).for_each(|(piece, r)| {
        for (slot, &x) in piece.iter_mut().zip(part(r)) {
            slot.write(x);
        }
    });
    // SAFETY: the `len` slots after the old length are within the capacity
    // (checked above) and each was written once: the pieces cover them
    // exactly (their lengths are the rows', summing to `len`).
    unsafe { out.set_len(out.len() + len) };
}

/// Standard error (nats) of each viewpoint's VMI by the delta method:
/// `∂ VMI_v / ∂ a_o = (ln(q_o / p_o) − VMI_v) / A_v` with `q_o = a_o / A_v`,
/// and `Var(a_t) = Ω_t² f_t (1 − f_t) / k` for each sampled triangle.
fn vmi_stderr(p: &Prepared, ch: &ViewpointChannel, views: &[View], p_o: &[f64], vmi: &[f64]) -> Vec<f64> {
    views
        .par_iter()
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
                itgfx_core::ln(q / p_o[patch as usize])
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
    /// Rays of the centroid probes.
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
    // Every view in one parallel pass (waves of views, each ending at a
    // join where a thread waited for the slowest view, left a core idle
    // at each join), made on a helper thread while this one reports the
    // views done as they finish. Where several views fail, the first
    // view's error in view order is the one returned, whatever ran first.
    let done = AtomicU64::new(0);
    let make = || -> Result<Vec<View>, BackendError> {
        let views: Vec<Result<View, BackendError>> = directions
            .par_iter()
            .map(|d| {
                let view = View::new(prepared, tracer, &shared, d.normalize() * distance, m);
                done.fetch_add(1, Ordering::Relaxed);
                view
            })
            .collect();
        views.into_iter().collect()
    };
    // Called on a worker of a rayon pool (a library caller's
    // `pool.install`), a helper thread would leave that pool for the global
    // one, and block a worker of a one-thread pool while it waits: the
    // views are then made here and reported once, at the end.
    if rayon::current_thread_index().is_some() {
        let views = make()?;
        progress(n, n);
        return Ok(views);
    }
    let views = std::thread::scope(|s| {
        let me = std::thread::current();
        let worker = s.spawn(move || {
            let views = make();
            me.unpark();
            views
        });
        let mut reported = 0;
        loop {
            let finished = worker.is_finished();
            let d = done.load(Ordering::Relaxed);
            if d != reported {
                progress(d, n);
                reported = d;
            }
            if finished {
                break;
            }
            std::thread::park_timeout(std::time::Duration::from_millis(200));
        }
        worker.join().unwrap_or_else(|e| std::panic::resume_unwind(e))
    })?;
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
        // `an.p_o` is the core's `output_into` of this channel, taken when
        // `an` was made; each seen viewpoint's VMI from the core (nats);
        // unseen ones have none.
        let seen_vmi = an.row_information(&an.p_o, itgfx_core::Base::Nats).map_err(ChannelError::Measure)?;
        let vmi = an.expand(&seen_vmi, 0.0);
        let se = vmi_stderr(prepared, &ch, &views, &an.p_o, &vmi);
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
    fn grouping_by_label_is_the_stable_sort() {
        let label = [0, 1, 0, 3, 1, 0, 6, 3, 1];
        let flag = [false, false, true, false, false, false, false, false, true];
        let mut sorted: Vec<u32> = (0..9).filter(|&t| !flag[t as usize]).collect();
        sorted.sort_by_key(|&t| label[t as usize]);
        assert_eq!(by_label(&label, &flag), sorted);
        assert_eq!(sorted, [0, 5, 1, 4, 3, 7, 6]);
    }

    #[test]
    fn components_join_unflagged_triangles_by_smallest_index() {
        let links = [[3, 1], [1, 2], [4, 5], [5, 0]];
        assert_eq!(components(6, links, &[false; 6]), [0, 1, 1, 1, 0, 0]);
        // Flagging 5 cuts 4 and 0 apart; flagged triangles stay alone.
        assert_eq!(components(6, links, &[false, false, false, false, false, true]), [0, 1, 1, 1, 4, 5]);
    }

    /// The visibility of every unflagged triangle, though most take it from
    /// three rays into their part of the mesh, is what its own centroid ray
    /// says (except for triangles seen almost edge-on, where that ray grazes
    /// the neighbours: on the convex geosphere the parts are right and the
    /// ray is not); and the parts save rays.
    #[test]
    fn parts_of_the_mesh_see_what_each_centroid_sees() {
        for spec in ["table-chairs:2", "geosphere:2", "cubes-room:16"] {
            let p = Prepared::new(&crate::scene::built_in(spec).unwrap());
            let tracer = crate::tracer::CpuTracer::new(&p);
            let shared = Shared::new(&p);
            let (mut checked, mut saved) = (0, 0);
            for d in super::super::fibonacci_sphere(6) {
                let eye = d * 3.0;
                let vis = Visibility::new(&tracer, &shared, eye).unwrap();
                let lines: Vec<Line> = shared.centroids.iter().map(|&c| towards(eye, c)).collect();
                let each = unoccluded(&tracer, &lines).unwrap();
                let grazing = |t: usize| {
                    let v = &shared.tris[t];
                    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                    n.dot((shared.centroids[t] - eye).normalize()).abs() < 0.05
                };
                for t in (0..each.len()).filter(|&t| !vis.flag[t] && !grazing(t)) {
                    assert_eq!(vis.visible[t], each[t], "{spec}: eye {eye}, triangle {t}");
                    checked += 1;
                }
                saved += each.len() as u64 - vis.rays;
            }
            assert!(checked > 100 && saved > 0, "{spec}: {checked} checked, {saved} rays saved");
        }
    }

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
