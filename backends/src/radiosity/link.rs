//! Links between elements: the form factor and the oracle's geometric part,
//! both estimated from `N_s` random samples whose visibility is asked of
//! [`Tracer::occluded`].
//!
//! Sample `k` joins a uniform point `x_k` on the receiver `i` to a uniform
//! point `y_k` on the source `j`; its point-to-point form factor is
//! `F(x_k, y_k) = V cos θ_x cos θ_y / (π r² + A_j / N_s)` (Wallace et al.'s
//! disc regularisation keeps it bounded where elements touch): these are
//! the oracle's samples (Part III eqs. 26-28). The transported form factor
//! is `F_ij = mean_k a_k · Σ_k w_k V_k / Σ_k w_k`: `a_k` the exact
//! unoccluded factor from `x_k` to the part of `j` in front of it (Lambert's
//! contour formula), times the visible fraction weighted by the kernel
//! (`w_k` an unbiased estimate of `a_k` from the ray's direction; see
//! `Sampler::evaluate`). Exact when nothing occludes, consistent when
//! something does, never above the unoccluded factor. The plain point-pair
//! mean `A_j mean_k F(x_k, y_k)` has infinite variance where elements
//! touch. The oracle is linear in `ρ_i B_j`, so it is evaluated once per
//! link with `ρ_i = B_j = 1` by the core's function and scaled when
//! refining.

use glam::DVec3;
use itgfx_core::Base;
use itgfx_core::oracle::{
    DivergenceKernel, divergence_oracle, kernel_smoothness_average_oracle, kernel_smoothness_oracle,
    mutual_information_oracle, power_oracle,
};
use rayon::prelude::*;

use super::element::{ElementId, Hierarchy};
use super::{Oracle, spherical};
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
    /// How many [`Share`]s of the evaluation's table are this link's (in
    /// link order): where its transport samples landed on the source's
    /// leaves. 0: the link carries `F_ij` times the source's mean.
    pub shares: u16,
}

/// One leaf's part of a final link: the transport samples of link `j → i`
/// whose source points `y_k` fell in `leaf` (a leaf under `j`) carry
/// `form_factor` of `F_ij`, so the link gathers `Σ F_ijℓ B_ℓ` over its
/// shares, `(1/A_i) ∫_i ∫_j K B` estimated with the radiosity where each
/// sample lands (the leaf a ray leaves from carries its own radiosity, as
/// in Bekaert's hierarchical Monte Carlo radiosity, Part III §1.7), instead
/// of `F_ij B̄_j`, which misses the covariance of kernel and radiosity over
/// the source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Share {
    /// The leaf of the source's subtree.
    pub leaf: ElementId,
    /// Its part of the link's form factor.
    pub form_factor: f32,
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

/// One pair's samples before visibility: the oracle's kernel values, each
/// receiver point's analytic factor `a_k`, the clipped source area `|P_k|`
/// and kernel at the visibility point (for the weighted variant), whether
/// ray `k` also joins the oracle's pair, and the segments to trace.
struct PairSamples {
    kernel: Vec<f64>,
    analytic: Vec<f64>,
    weight: Vec<f64>,
    shared: Vec<bool>,
    rays: Vec<(usize, Line)>,
    /// At [`Stage::Transport`] from a split source: the leaf under the
    /// source holding each sample's visibility point (empty otherwise).
    leaf: Vec<ElementId>,
}

/// A link and its shares, as one chunk's evaluation returns them.
type LinkShares = (Link, Vec<Share>);

/// Lines per tracer call.
const BATCH: usize = 8192;

/// Pairs evaluated at once at `N_s ≤ 10`, fewer in proportion above (see
/// [`Sampler::chunk`]): their transient samples and segments (about
/// 1.9 kB a pair at `N_s = 10`) were the whole run's peak memory when every
/// final link was re-estimated in one batch (14.2 GiB at 8.1M links). Each
/// pair draws from its own stream, so the chunking changes no number.
const PAIRS_PER_CHUNK: usize = 1 << 16;

/// A tiny offset off both surfaces (normalised units) so a segment does
/// not report its own end points.
const GAP: f64 = 2e-4;

impl Sampler<'_> {
    /// Evaluates links for `pairs` (receiver, source). Returns the links and
    /// the rays cast.
    ///
    /// Which links are kept: at [`Stage::Refine`] every pair whose
    /// elements face each other ([`facing`], decided by geometry alone),
    /// even when this estimate is zero; at [`Stage::Transport`] only
    /// those whose estimate is positive. Dropping a link because its own 10
    /// samples happened to see nothing keeps it dropped for good, so a
    /// partly visible pair (visible fraction `p`) would survive refinement
    /// with probability `1 − (1 − p)^N_s` only: the solution came out dark
    /// (Cornell box, 6,585 elements: absorbed/emitted 0.957 → 0.984).
    ///
    /// # Errors
    /// Tracing errors.
    pub fn evaluate(
        &self,
        h: &Hierarchy,
        pairs: &[(ElementId, ElementId)],
        stage: Stage,
    ) -> Result<(Vec<Link>, u64), BackendError> {
        let (links, _, rays) = self.evaluate_with(h, pairs, stage, false)?;
        Ok((links, rays))
    }

    /// [`Self::evaluate`] with, at [`Stage::Transport`], every link's
    /// [`Share`]s (in link order, `Link::shares` each; none for a link whose
    /// source is a leaf): 8 bytes per distinct leaf a link's samples meet,
    /// at most `N_s` per link.
    ///
    /// # Errors
    /// Tracing errors.
    pub fn evaluate_shared(
        &self,
        h: &Hierarchy,
        pairs: &[(ElementId, ElementId)],
        stage: Stage,
    ) -> Result<(Vec<Link>, Vec<Share>, u64), BackendError> {
        self.evaluate_with(h, pairs, stage, true)
    }

    /// [`Self::evaluate_shared`], the source leaves under the samples looked
    /// up only when `want_shares` (the default solve drops them: no tree
    /// descent per sample, no share lists built for nothing).
    fn evaluate_with(
        &self,
        h: &Hierarchy,
        pairs: &[(ElementId, ElementId)],
        stage: Stage,
        want_shares: bool,
    ) -> Result<(Vec<Link>, Vec<Share>, u64), BackendError> {
        let mut links = Vec::with_capacity(pairs.len());
        let mut shares = Vec::new();
        let mut rays = 0;
        for chunk in pairs.chunks(self.chunk()) {
            let (l, r) = self.evaluate_chunk(h, chunk, stage, want_shares)?;
            for (link, s) in l {
                links.push(link);
                shares.extend(s);
            }
            rays += r;
        }
        Ok((links, shares, rays))
    }

    /// Pairs per chunk: [`PAIRS_PER_CHUNK`] scaled by `10 / N_s` above 10
    /// samples, so a chunk's transient memory stays about 125 MB.
    fn chunk(&self) -> usize {
        (PAIRS_PER_CHUNK * 10 / (self.samples as usize).max(10)).max(1)
    }

    /// [`Self::evaluate`] on one chunk of pairs: the samples, segments and
    /// verdicts of every pair of the chunk are held at once (about 1.9 kB
    /// per pair at `N_s = 10`), so chunks bound that memory.
    fn evaluate_chunk(
        &self,
        h: &Hierarchy,
        pairs: &[(ElementId, ElementId)],
        stage: Stage,
        want_shares: bool,
    ) -> Result<(Vec<LinkShares>, u64), BackendError> {
        let per_pair: Vec<PairSamples> =
            pairs.par_iter().map(|&(i, j)| self.unoccluded(h, i, j, stage, want_shares)).collect();
        let mut lines = Vec::new();
        let mut owner = Vec::new();
        for (p, ps) in per_pair.iter().enumerate() {
            for &(k, l) in &ps.rays {
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
        let mut per_pair = per_pair;
        let mut visible: Vec<Vec<bool>> =
            per_pair.iter().map(|ps| ps.analytic.iter().map(|&a| a > 0.0).collect()).collect();
        let mut ray_count = vec![0u32; pairs.len()];
        for ((p, k), b) in owner.iter().zip(blocked.iter().flatten()) {
            ray_count[*p] += 1;
            if *b {
                visible[*p][*k] = false;
                if per_pair[*p].shared[*k] {
                    per_pair[*p].kernel[*k] = 0.0;
                }
            }
        }
        let n = f64::from(self.samples);
        let links = pairs
            .par_iter()
            .zip(per_pair.par_iter())
            .zip(visible.par_iter())
            .zip(ray_count.par_iter())
            .filter_map(|(((&(i, j), ps), vis), &rays)| {
                // F = mean_k a_k · Σ w_k V_k / Σ w_k: the analytic factor times
                // the kernel-weighted visible fraction.
                let (mut num, mut den) = (0.0, 0.0);
                for (w, v) in ps.weight.iter().zip(vis) {
                    den += w;
                    if *v {
                        num += w;
                    }
                }
                let scale = ps.analytic.iter().sum::<f64>() / n;
                let f = if den > 0.0 { scale * (num / den) } else { 0.0 };
                if f <= 0.0 {
                    return (stage == Stage::Refine && facing(h, i, j)).then_some((
                        Link { receiver: i, source: j, form_factor: 0.0, oracle: 0.0, rays, shares: 0 },
                        Vec::new(),
                    ));
                }
                let (ai, aj) = (h.elements[i as usize].area, h.elements[j as usize].area);
                let oracle = if stage == Stage::Refine { self.oracle_value(ai, aj, f, &ps.kernel) } else { 0.0 };
                let shares = shares(&ps.leaf, &ps.weight, vis, scale / den);
                let count = u16::try_from(shares.len()).unwrap_or(0);
                let shares = if count > 0 { shares } else { Vec::new() };
                Some((Link { receiver: i, source: j, form_factor: f, oracle, rays, shares: count }, shares))
            })
            .collect();
        Ok((links, owner.len() as u64))
    }

    /// The samples of one pair before visibility.
    ///
    /// Sample `k`: `x_k` uniform on the receiver and `a_k` the exact
    /// unoccluded factor from `x_k` to `P_k`, the source clipped to the
    /// half-space in front of `x_k` (zero when `x_k` is behind the source's
    /// plane). One visibility ray goes from every `x_k` with `a_k > 0`
    /// towards `P_k`, weighted by an unbiased estimate `w_k` of `a_k`, so
    /// `Σ w_k V_k / Σ w_k` is the kernel-weighted visible fraction:
    ///
    /// * [`Stage::Refine`]: towards `y_k`, uniform on the source, when the
    ///   pair faces (the oracle's sample, Part III eqs. 26-28, whose kernel
    ///   the ray also decides), else towards a uniform point of `P_k`;
    ///   `w_k = |P_k| cos θ_x cos θ_y / (π r²)`;
    /// * [`Stage::Transport`]: towards a direction uniform in `P_k`'s solid
    ///   angle `Ω_k` ([`spherical`](super::spherical)), `w_k = Ω_k cos θ_x / π`,
    ///   bounded where the elements touch.
    ///
    /// Before, a pair facing away told nothing, a link whose `N_s` pairs all
    /// faced away counted as invisible, and the visible fraction was
    /// counted by area rather than weighted by the kernel: an inconsistent
    /// estimate (14 % low for a floor under a floating block, whatever
    /// `N_s`).
    fn unoccluded(&self, h: &Hierarchy, i: ElementId, j: ElementId, stage: Stage, want_shares: bool) -> PairSamples {
        let (ei, ej) = (&h.elements[i as usize], &h.elements[j as usize]);
        let n = self.samples as usize;
        let rng = LineRng::new(self.seed, (u64::from(i) << 32) | u64::from(j));
        let reg = ej.area / n as f64;
        let mut out = PairSamples {
            kernel: vec![0.0; n],
            analytic: vec![0.0; n],
            weight: vec![0.0; n],
            shared: vec![false; n],
            rays: Vec::new(),
            leaf: Vec::new(),
        };
        let split = want_shares && stage == Stage::Transport && ej.children.is_some();
        if split {
            out.leaf = vec![j; n];
        }
        let shape = &h.roots[ej.root as usize].shape;
        let polygon = &ej.points[..usize::from(ej.corners)];
        let kern = |x: DVec3, y: DVec3| {
            let v = y - x;
            let r2 = v.length_squared();
            if r2 <= 0.0 {
                return None;
            }
            let r = r2.sqrt();
            let (cx, cy) = (ei.normal.dot(v) / r, -ej.normal.dot(v) / r);
            (cx > 0.0 && cy > 0.0).then_some((cx * cy, r2))
        };
        for k in 0..n {
            let d = 4 * k as u32;
            let x = ei.sample(rng.uniform(d), rng.uniform(d + 1));
            let pair = if stage == Stage::Refine {
                let y = ej.sample(rng.uniform(d + 2), rng.uniform(d + 3));
                let c = kern(x, y);
                if let Some((c, r2)) = c {
                    out.kernel[k] = c / (std::f64::consts::PI * r2 + reg);
                }
                c.map(|c| (y, c))
            } else {
                None
            };
            // A receiver point behind the source's plane sees only its back.
            if ej.normal.dot(x - ej.points[0]) <= 0.0 {
                continue;
            }
            let clipped = clip_front(x, ei.normal, polygon);
            let a = lambert(x, ei.normal, &clipped);
            if a <= 0.0 {
                continue;
            }
            out.analytic[k] = a;
            let e = 4 * n as u32 + 3 * k as u32;
            let (u0, u1, u2) = (rng.uniform(e), rng.uniform(e + 1), rng.uniform(e + 2));
            let by_area = |y: DVec3, c: Option<(f64, f64)>| {
                (y, c.map_or(0.0, |(c, r2)| polygon_area(&clipped) * c / (std::f64::consts::PI * r2)))
            };
            let (target, w) = match pair {
                Some((y, c)) => {
                    out.shared[k] = true;
                    by_area(y, Some(c))
                }
                None if stage == Stage::Transport => match spherical::sample_polygon(x, &clipped, u0, u1, u2) {
                    Some((y, omega)) => {
                        (y, omega * ei.normal.dot((y - x).normalize_or_zero()).max(0.0) / std::f64::consts::PI)
                    }
                    None => {
                        let y = sample_polygon(&clipped, u0, u1, u2);
                        by_area(y, kern(x, y))
                    }
                },
                None => {
                    let y = sample_polygon(&clipped, u0, u1, u2);
                    by_area(y, kern(x, y))
                }
            };
            out.weight[k] = w;
            if split {
                out.leaf[k] = h.locate_below(j, shape.parameter(target));
            }
            let (a, b) = (self.prepared.to_normalised(x), self.prepared.to_normalised(target));
            let len = (b - a).length();
            if len > 2.0 * GAP {
                let dir: DVec3 = (b - a) / len;
                out.rays.push((k, Line::ray(a, dir, GAP, len - GAP)));
            }
        }
        out
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

/// A link's shares from its samples' leaves (`leaf`, empty when the
/// source is a leaf: no share), weights `w_k` and visibility: sample `k`
/// carries `scale · w_k V_k` (`scale = mean_k a_k / Σ_k w_k`, so the shares
/// sum to the link's form factor), merged per leaf in order of first
/// appearance.
fn shares(leaf: &[ElementId], weight: &[f64], visible: &[bool], scale: f64) -> Vec<Share> {
    let mut out: Vec<(ElementId, f64)> = Vec::new();
    for ((&l, &w), &v) in leaf.iter().zip(weight).zip(visible) {
        if !v || w <= 0.0 {
            continue;
        }
        match out.iter_mut().find(|s| s.0 == l) {
            Some(s) => s.1 += scale * w,
            None => out.push((l, scale * w)),
        }
    }
    out.into_iter().map(|(leaf, f)| Share { leaf, form_factor: f as f32 }).collect()
}

/// What a link evaluation is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Refinement: the oracle's samples (uniform point pairs), a form
    /// factor for the intermediate gathering, and every link between
    /// facing elements kept (a zero estimate is a draw, not a verdict).
    Refine,
    /// The final links' form factors: visibility towards directions
    /// uniform in each receiver point's solid angle of the source; links
    /// whose estimate is zero are dropped. No oracle.
    Transport,
}

/// Whether some corner of `b` lies in front of `a`'s plane.
fn in_front(h: &Hierarchy, a: ElementId, b: ElementId) -> bool {
    let (ea, eb) = (&h.elements[a as usize], &h.elements[b as usize]);
    let c = ea.centre();
    let size = ea.area.sqrt().max(eb.area.sqrt());
    eb.points[..usize::from(eb.corners)].iter().any(|p| (*p - c).dot(ea.normal) > 1e-9 * size)
}

/// Whether elements `a` and `b` can exchange light: each has a corner in
/// front of the other's plane (geometry only, no sample).
#[must_use]
pub fn facing(h: &Hierarchy, a: ElementId, b: ElementId) -> bool {
    a != b && in_front(h, a, b) && in_front(h, b, a)
}

/// `polygon` clipped to the half-space in front of `x` (normal `n`),
/// Sutherland-Hodgman against `n · (p − x) ≥ 0`.
fn clip_front(x: DVec3, n: DVec3, polygon: &[DVec3]) -> Vec<DVec3> {
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
    clipped
}

/// Lambert's contour formula: the form factor from `x` (unit normal `n`)
/// to a planar polygon wholly in front of it.
fn lambert(x: DVec3, n: DVec3, polygon: &[DVec3]) -> f64 {
    let m = polygon.len();
    if m < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for k in 0..m {
        let (a, b) = ((polygon[k] - x), (polygon[(k + 1) % m] - x));
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

/// The unoccluded form factor from a point `x` with unit normal `n` to a
/// planar polygon (Lambert's contour formula), the polygon clipped to the
/// half-space in front of `x` first.
#[must_use]
pub fn point_to_polygon(x: DVec3, n: DVec3, polygon: &[DVec3]) -> f64 {
    lambert(x, n, &clip_front(x, n, polygon))
}

/// Area of a planar convex polygon.
fn polygon_area(p: &[DVec3]) -> f64 {
    (1..p.len().saturating_sub(1)).map(|t| 0.5 * (p[t] - p[0]).cross(p[t + 1] - p[0]).length()).sum()
}

/// A uniform point of a planar convex polygon from three uniforms: a fan
/// triangle chosen by area, then a uniform point in it.
fn sample_polygon(p: &[DVec3], u0: f64, u1: f64, u2: f64) -> DVec3 {
    let area = polygon_area(p);
    let mut target = u0 * area;
    let last = p.len().saturating_sub(2).max(1);
    let mut t = 1;
    while t < last {
        let a = 0.5 * (p[t] - p[0]).cross(p[t + 1] - p[0]).length();
        if target < a {
            break;
        }
        target -= a;
        t += 1;
    }
    let s = u1.sqrt();
    p[0] * (1.0 - s) + p[t] * (s * (1.0 - u2)) + p[t + 1] * (s * u2)
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
            let (links, _) = s.evaluate(&h, &[(0, 1)], Stage::Transport).unwrap();
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

    /// A link from a split source whose radiosity varies over it carries
    /// `(1/A_i) ∫_i ∫_j K B` through its shares, not `F_ij B̄_j`: two
    /// perpendicular unit squares, the source split in four and only the
    /// quarter at the shared edge bright (`B` = 1 there, 0 elsewhere). The
    /// exact value is that quarter's form factor (a 200 × 200 midpoint rule
    /// of Lambert's formula over the receiver); the shares' mean over 4,000
    /// seeds at 10 samples is within 3 standard errors of it, the source's
    /// mean radiosity times `F_ij` more than 20 away (measured: exact
    /// 0.07309, shares 0.0736 ± 0.0007, `F_ij B̄_j` 0.0501; the kernel is
    /// largest at the shared edge).
    #[test]
    fn shares_carry_the_radiosity_where_the_samples_land() {
        let mut s = Scene::named("perpendicular");
        s.add_polygon("a", &[DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y], 0);
        s.add_polygon("b", &[DVec3::ZERO, DVec3::Z, DVec3::new(1.0, 0.0, 1.0), DVec3::X], 0);
        let p = Prepared::new(&s);
        let t = CpuTracer::new(&p);
        let mut h = Hierarchy::new(&s);
        let first = h.split(1);
        // The quarter touching the receiver's plane (z = 0).
        let bright = (first..first + 4)
            .find(|&k| {
                h.elements[k as usize].points.iter().take(4).filter(|q| q.z == 0.0).count() == 2
                    && h.elements[k as usize].points.iter().any(|q| q.x == 0.0)
            })
            .unwrap();
        let radiosity = |e: ElementId| if e == bright { 1.0 } else { 0.0 };
        let m = 200;
        let mut exact = 0.0;
        let el = &h.elements[bright as usize];
        for a in 0..m {
            for b in 0..m {
                let x = DVec3::new((f64::from(a) + 0.5) / f64::from(m), (f64::from(b) + 0.5) / f64::from(m), 0.0);
                exact += point_to_polygon(x, DVec3::Z, &el.points[..4]);
            }
        }
        exact /= f64::from(m * m);
        let seeds = 4000;
        let (mut shared, mut sq, mut mean_based) = (0.0, 0.0, 0.0);
        for seed in 0..seeds {
            let sampler =
                Sampler { prepared: &p, tracer: &t, oracle: Oracle::Power, samples: 10, seed, total_area: 2.0 };
            let (links, shares, _) = sampler.evaluate_shared(&h, &[(0, 1)], Stage::Transport).unwrap();
            let l = links[0];
            assert_eq!(usize::from(l.shares), shares.len());
            assert!(shares.iter().all(|s| (first..first + 4).contains(&s.leaf)), "shares are leaves under the source");
            let total: f64 = shares.iter().map(|s| f64::from(s.form_factor)).sum();
            assert!(
                (total - l.form_factor).abs() < 1e-6 * l.form_factor,
                "shares sum to F: {total} vs {}",
                l.form_factor
            );
            let g: f64 = shares.iter().map(|s| f64::from(s.form_factor) * radiosity(s.leaf)).sum();
            shared += g / seeds as f64;
            sq += g * g / seeds as f64;
            mean_based += l.form_factor * 0.25 / seeds as f64;
        }
        let se = ((sq - shared * shared) / (seeds - 1) as f64).sqrt();
        eprintln!("exact {exact:.5}, shares {shared:.5} ± {se:.5}, F · mean B {mean_based:.5}");
        assert!((shared - exact).abs() < 3.0 * se, "shares {shared} ± {se} vs exact {exact}");
        assert!((mean_based - exact).abs() > 20.0 * se, "the source's mean misses the covariance: {mean_based}");
    }

    /// Link 0 ← 1 of a scene whose first two patches face each other.
    fn oracle_of(scene: &Scene, oracle: Oracle) -> f64 {
        let p = Prepared::new(scene);
        let t = CpuTracer::new(&p);
        let h = Hierarchy::new(scene);
        let s = Sampler { prepared: &p, tracer: &t, oracle, samples: 10, seed: 7, total_area: scene.total_area() };
        let (links, _) = s.evaluate(&h, &[(0, 1)], Stage::Refine).unwrap();
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
