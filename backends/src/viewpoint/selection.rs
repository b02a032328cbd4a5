//! Choosing views from the viewpoint channel (Part V): best-n views,
//! a guided exploration path and importance-driven selection.
//!
//! Merging a set of views `S` gives the view `p(O|v̂) = Σ_{v∈S} p(v) p(O|v) / Σ_{v∈S} p(v)`;
//! its VMI `I(v̂;O) = D_KL(p(O|v̂) ‖ p(O))` (eq. (7)) is 0 when the merged
//! views show the object as all viewpoints together do. Both the best-n
//! greedy selection and the exploration path add, at each step, the view that
//! brings `I(v̂;O)` lowest.

use itgfx_core::{Base, Error, kl_nats_of_sums, kl_term, kl_terms_into, ln};
use rayon::prelude::*;

use super::{ViewpointAnalysis, ViewpointMeasures};

/// A merged view kept densely over the outputs, with `A = Σ_o m_o ln(m_o/p(o))`
/// for `m = Σ_{v∈S} p(v) p(O|v)`, so the VMI of adding one more view costs
/// the length of that view's row.
struct Merged<'a> {
    an: &'a ViewpointAnalysis,
    m: Vec<f64>,
    /// `m_o ln(m_o/p(o))` of every output, kept so that each candidate's
    /// [`Merged::kl_with`] reads its rows' old terms instead of taking
    /// their logarithms again (the same values).
    terms: Vec<f64>,
    w: f64,
    a: f64,
}

impl<'a> Merged<'a> {
    fn new(an: &'a ViewpointAnalysis) -> Self {
        Self { an, m: vec![0.0; an.outputs()], terms: vec![0.0; an.outputs()], w: 0.0, a: 0.0 }
    }

    /// `I(v̂;O)` in nats of the merged view with row `x` added. The row is
    /// read in batches whose KL terms are taken in one vectorised pass
    /// ([`kl_terms_into`], [`itgfx_core::kl_term`]'s bits); every sum runs
    /// in row order.
    fn kl_with(&self, x: usize) -> f64 {
        const BATCH: usize = 256;
        let (cols, p) = self.an.row(x);
        let pv = self.an.p_v[x];
        let w2 = self.w + pv;
        let (mut a_out, mut m_out, mut inside) = (self.a, self.w, 0.0);
        let (mut mn, mut po, mut t) = ([0.0; BATCH], [0.0; BATCH], [0.0; BATCH]);
        for (cols, p) in cols.chunks(BATCH).zip(p.chunks(BATCH)) {
            let n = cols.len();
            for (k, (&o, &q)) in cols.iter().zip(p).enumerate() {
                let mo = self.m[o as usize];
                po[k] = self.an.p_o[o as usize];
                a_out -= self.terms[o as usize];
                m_out -= mo;
                mn[k] = (mo + pv * q) / w2;
            }
            kl_terms_into(&mn[..n], &po[..n], &mut t[..n]);
            for &t in &t[..n] {
                inside += t;
            }
        }
        ((a_out - m_out * ln(w2)) / w2 + inside).max(0.0)
    }

    fn add(&mut self, x: usize) {
        let (cols, p) = self.an.row(x);
        let pv = self.an.p_v[x];
        for (&o, &q) in cols.iter().zip(p) {
            self.m[o as usize] += pv * q;
        }
        self.w += pv;
        // Recomputed in full: no drift from incremental updates (each term
        // alone, so on every thread; the sum below stays in order).
        self.terms.par_chunks_mut(4096).zip(self.m.par_chunks(4096)).zip(self.an.p_o.par_chunks(4096)).for_each(
            |((t, m), q)| {
                kl_terms_into(m, q, t);
            },
        );
        self.a = self.terms.iter().sum();
    }

    fn kl(&self) -> f64 {
        kl_nats_of_sums(self.a, self.w)
    }

    /// The candidate row with the lowest merged VMI (ties: lowest index).
    fn best_of(&self, candidates: &[usize]) -> Option<usize> {
        candidates
            .par_iter()
            .map(|&x| (self.kl_with(x), x))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .map(|(_, x)| x)
    }
}

/// Best-n views, greedily.
#[derive(Clone, Debug, PartialEq)]
pub struct BestViews {
    /// Selected viewpoints (indices into the sampled channel), best first.
    pub views: Vec<usize>,
    /// `I(v̂;O)` of the merged selection after each addition.
    pub merged_information: Vec<f64>,
    /// `I(V̂;O)/I(V;O)` after each addition, where `V̂` clusters every
    /// viewpoint with the selected view it is least dissimilar to
    /// (Jensen–Shannon, Part II eq. (17)).
    pub captured: Vec<f64>,
}

/// Greedy best-n views: start from the minimum-VMI view (`measures.best`);
/// add the view that makes the merged view closest to `p(O)` until the
/// clustering by the selected views captures `fraction` of `I(V;O)` or
/// `max_views` are chosen. `measures` are [`ViewpointAnalysis::measures`]
/// in `base`. `logs` ([`ViewpointAnalysis::entry_logs`]), when given, spares
/// every dissimilarity the rows' logarithms (the same bits; 8 bytes per
/// channel entry that the caller holds); `None` takes them per pair.
///
/// # Errors
/// [`Error::InvalidParameter`] if the best view sees nothing (measures of
/// another analysis); [`Error::LengthMismatch`] if `logs` is not one per
/// entry; core errors.
pub fn best_views(
    an: &ViewpointAnalysis,
    measures: &ViewpointMeasures,
    fraction: f64,
    max_views: usize,
    base: Base,
    logs: Option<&[f64]>,
) -> Result<BestViews, Error> {
    let n = an.rows();
    let total = measures.total_mutual_information / base.per_nat();
    let first =
        an.row_of(measures.best).ok_or(Error::InvalidParameter { name: "best", value: measures.best as f64 })?;
    let mut merged = Merged::new(an);
    let mut chosen = vec![false; n];
    let mut nearest = vec![(f64::INFINITY, 0usize); n];
    let mut out = BestViews { views: Vec::new(), merged_information: Vec::new(), captured: Vec::new() };
    let mut next = Some(first);
    while let Some(s) = next {
        merged.add(s);
        chosen[s] = true;
        // A chosen row (`s` too, now) is its own nearest at 0, which no
        // dissimilarity undercuts: its divergence to `s` is not needed.
        let d: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|x| match logs {
                _ if chosen[x] => Ok(f64::INFINITY),
                Some(l) => an.dissimilarity_logs(x, s, l, Base::Nats),
                None => an.dissimilarity(x, s, Base::Nats),
            })
            .collect::<Result<_, _>>()?;
        for (x, dx) in d.into_iter().enumerate() {
            if dx < nearest[x].0 || x == s {
                nearest[x] = (if x == s { 0.0 } else { dx }, s);
            }
        }
        let captured = if total > 0.0 { clustered_information(an, &nearest) / total } else { 1.0 };
        out.views.push(an.seen[s]);
        out.merged_information.push(merged.kl() * base.per_nat());
        out.captured.push(captured);
        if captured >= fraction || out.views.len() >= max_views.min(n) {
            break;
        }
        let candidates: Vec<usize> = (0..n).filter(|&x| !chosen[x]).collect();
        next = merged.best_of(&candidates);
    }
    Ok(out)
}

/// Outputs per block of [`clustered_information`]'s passes side by side.
const CLUSTER_BLOCK: usize = 1 << 14;

/// `I(V̂;O)` in nats for the clustering of rows given by `nearest[x].1`:
/// `Σ_c Σ_o p(c) kl_term(m_o/p(c), p(o))` (Part V eq. (6) over the merged
/// views, `m_o = Σ_{v∈c} p(v) p(o|v)`), clusters in order, each cluster's
/// outputs in the order its rows first show them (by the first row, in row
/// order, that sees the output, then by output), one plain sum. Each
/// cluster's `m` and terms are computed on blocks of outputs side by side
/// (each `m_o` summed over the cluster's rows in row order); only the sum
/// of the terms, in that order, runs on one thread.
fn clustered_information(an: &ViewpointAnalysis, nearest: &[(f64, usize)]) -> f64 {
    let mut clusters: Vec<(usize, usize)> = nearest.iter().enumerate().map(|(x, &(_, c))| (c, x)).collect();
    clusters.sort_unstable();
    let (mut terms, mut first) = (vec![0.0; an.outputs()], vec![u32::MAX; an.outputs()]);
    let mut total = 0.0;
    for group in clusters.chunk_by(|a, b| a.0 == b.0) {
        let rows: Vec<usize> = group.iter().map(|&(_, x)| x).collect();
        let mut pc = 0.0;
        for &x in &rows {
            pc += an.p_v[x];
        }
        terms
            .par_chunks_mut(CLUSTER_BLOCK)
            .zip(first.par_chunks_mut(CLUSTER_BLOCK))
            .enumerate()
            .for_each(|(k, (terms, first))| cluster_terms(an, &rows, pc, k * CLUSTER_BLOCK, terms, first));
        for o in first_shown_order(&first, rows.len()) {
            total += terms[o];
        }
    }
    total.max(0.0)
}

/// One cluster's terms `p(c) kl_term(m_o/p(c), p(o))` of the outputs from
/// `start` on (`terms.len()` of them), and for each the position in `rows`
/// of the first row that sees it (`u32::MAX` for none, whose term is 0).
fn cluster_terms(an: &ViewpointAnalysis, rows: &[usize], pc: f64, start: usize, terms: &mut [f64], first: &mut [u32]) {
    let cols = start..start + terms.len();
    terms.fill(0.0);
    first.fill(u32::MAX);
    for (at, &x) in rows.iter().enumerate() {
        let (c, p) = an.row_part(x, &cols);
        for (&o, &q) in c.iter().zip(p) {
            let k = o as usize - start;
            terms[k] += an.p_v[x] * q;
            first[k] = first[k].min(at as u32);
        }
    }
    for (k, t) in terms.iter_mut().enumerate() {
        if first[k] != u32::MAX {
            *t = pc * kl_term(*t / pc, an.p_o[start + k]);
        }
    }
}

/// The outputs that `first` marks as seen, ordered by the first row that
/// sees them (`first[o] < rows`), then by output: a counting sort.
fn first_shown_order(first: &[u32], rows: usize) -> Vec<usize> {
    let mut at = vec![0usize; rows + 1];
    for &f in first.iter().filter(|&&f| f != u32::MAX) {
        at[f as usize + 1] += 1;
    }
    for k in 0..rows {
        at[k + 1] += at[k];
    }
    let mut order = vec![0; at[rows]];
    for (o, &f) in first.iter().enumerate().filter(|&(_, &f)| f != u32::MAX) {
        order[at[f as usize]] = o;
        at[f as usize] += 1;
    }
    order
}

/// A guided tour over neighbouring viewpoints.
#[derive(Clone, Debug, PartialEq)]
pub struct Exploration {
    /// Viewpoints visited, in order (indices into the sampled channel).
    pub path: Vec<usize>,
    /// `I(v̂;O)` of the views visited so far, after each step.
    pub merged_information: Vec<f64>,
}

/// Guided exploration: from `start` (a viewpoint that sees the object), move
/// each step to the unvisited neighbour whose addition brings the merged
/// view of the path closest to `p(O)`; when every neighbour of the current
/// view is visited, continue from the latest path view that has an unvisited
/// neighbour. Stops after `steps` moves or when no unvisited neighbour is left.
///
/// # Errors
/// [`Error::InvalidParameter`] if `start` sees nothing.
pub fn exploration(
    an: &ViewpointAnalysis,
    neighbours: &[Vec<usize>],
    start: usize,
    steps: usize,
    base: Base,
) -> Result<Exploration, Error> {
    let first = an.row_of(start).ok_or(Error::InvalidParameter { name: "start", value: start as f64 })?;
    let mut merged = Merged::new(an);
    let mut visited = vec![false; an.rows()];
    merged.add(first);
    visited[first] = true;
    let mut out = Exploration { path: vec![start], merged_information: vec![merged.kl() * base.per_nat()] };
    for _ in 0..steps {
        let mut next = None;
        for &from in out.path.iter().rev() {
            let cand: Vec<usize> =
                neighbours[from].iter().filter_map(|&u| an.row_of(u)).filter(|&x| !visited[x]).collect();
            if let Some(x) = merged.best_of(&cand) {
                next = Some(x);
                break;
            }
        }
        let Some(x) = next else { break };
        merged.add(x);
        visited[x] = true;
        out.path.push(an.seen[x]);
        out.merged_information.push(merged.kl() * base.per_nat());
    }
    Ok(out)
}

/// Share of `p(o)` every polygon keeps in the importance-driven target, so a
/// polygon of zero importance (a flat region, whose neighbours see it alike,
/// or a polygon with no neighbour) does not make every view that shows it
/// infinitely bad.
pub const IMPORTANCE_FLOOR: f64 = 0.01;

/// Importance-driven VMI (Part V, viewpoint selection with importance):
/// `I'(v;O) = D_KL(p(O|v) ‖ p'(O))` with the target
/// `p'(o) = (1 - η) p(o) i(o) / Σ p(o) i(o) + η p(o)`, `η =` [`IMPORTANCE_FLOOR`],
/// so the best view (minimum) shows each polygon in proportion to its
/// importance-weighted share; with `i = S(o)` (mesh saliency) it prefers
/// views of salient parts. The pure `p(o) i(o)` target of the notes is zero
/// on polygons of zero saliency, which made `I'` infinite for every view
/// seeing one (35 of the bunny's 42 views); the floor keeps `p'` positive
/// wherever `p(o) > 0`, hence `I'` finite for every view that sees anything.
/// When no polygon has positive importance (a single triangle, two coplanar
/// quads: every polygon equally salient) the target is `p(O)` and `I'` is the
/// VMI. Over all viewpoints (`∞` for those that see nothing). The
/// background, if an output, has importance 1.
///
/// # Errors
/// [`Error::LengthMismatch`] for a wrong `importance` length;
/// [`Error::NonFinite`]/[`Error::Negative`] for a bad importance value.
pub fn importance_information(an: &ViewpointAnalysis, importance: &[f64], base: Base) -> Result<Vec<f64>, Error> {
    if importance.len() != an.patches {
        return Err(Error::LengthMismatch { expected: an.patches, found: importance.len() });
    }
    for (i, &x) in importance.iter().enumerate() {
        if !x.is_finite() {
            return Err(Error::NonFinite { index: i });
        }
        if x < 0.0 {
            return Err(Error::Negative { index: i });
        }
    }
    let weighted: Vec<f64> =
        an.p_o.iter().enumerate().map(|(o, p)| p * importance.get(o).copied().unwrap_or(1.0)).collect();
    let t: f64 = weighted.iter().sum();
    let target: Vec<f64> = if t > 0.0 {
        weighted.iter().zip(&an.p_o).map(|(w, p)| (1.0 - IMPORTANCE_FLOOR) * w / t + IMPORTANCE_FLOOR * p).collect()
    } else {
        an.p_o.clone()
    };
    Ok(an.expand(&an.row_information(&target, base)?, f64::INFINITY))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewpoint::{ViewpointChannel, ViewpointWeights};
    use glam::DVec3;

    /// Three viewpoints over four polygons, uneven rows.
    fn analysis() -> ViewpointAnalysis {
        let ch = ViewpointChannel {
            positions: vec![DVec3::X, DVec3::Y, DVec3::Z],
            starts: vec![0, 3, 5, 8],
            patch: vec![0, 1, 3, 1, 2, 0, 2, 3],
            solid_angle: vec![0.3, 0.1, 0.05, 0.2, 0.25, 0.02, 0.07, 0.4],
            background: vec![0.0; 3],
            patches: 4,
            rays_per_viewpoint: 1,
        };
        ViewpointAnalysis::from_channel(ch, ViewpointWeights::ProjectedArea).unwrap()
    }

    /// The merged view's `p(O|v̂)` over all outputs, normalised.
    fn merged_pmf(an: &ViewpointAnalysis, views: &[usize]) -> Vec<f64> {
        let mut m = vec![0.0; an.outputs()];
        for &x in views {
            let (cols, p) = an.row(x);
            for (&o, &q) in cols.iter().zip(p) {
                m[o as usize] += an.p_v[x] * q;
            }
        }
        let w: f64 = m.iter().sum();
        m.iter().map(|x| x / w).collect()
    }

    #[test]
    fn merged_vmi_is_the_cores_kl_divergence() {
        let an = analysis();
        let mut merged = Merged::new(&an);
        let mut views = Vec::new();
        for x in [2, 0, 1] {
            let with = merged.kl_with(x);
            merged.add(x);
            views.push(x);
            let core = itgfx_core::kl_divergence(&merged_pmf(&an, &views), &an.p_o, Base::Nats).unwrap();
            assert!((merged.kl() - core).abs() <= 1e-12, "{views:?}: {} vs core {core}", merged.kl());
            assert!((with - core).abs() <= 1e-12, "{views:?}: kl_with {with} vs core {core}");
        }
        assert!(merged.kl() <= 1e-12, "all views merged show p(O)");
    }

    #[test]
    fn clustered_information_is_the_cores_mutual_information() {
        let an = analysis();
        // Every viewpoint its own cluster: I(V̂;O) = I(V;O).
        let own: Vec<(f64, usize)> = (0..an.rows()).map(|x| (0.0, x)).collect();
        let mut joint = Vec::new();
        for x in 0..an.rows() {
            let mut row = vec![0.0; an.outputs()];
            let (cols, p) = an.row(x);
            for (&o, &q) in cols.iter().zip(p) {
                row[o as usize] = an.p_v[x] * q;
            }
            joint.extend(row);
        }
        let core = itgfx_core::mutual_information(&joint, an.rows(), an.outputs(), Base::Nats).unwrap();
        let ours = clustered_information(&an, &own);
        assert!((ours - core).abs() <= 1e-12, "{ours} vs core {core}");
        // One cluster: the merged view is p(O), no information.
        let one: Vec<(f64, usize)> = (0..an.rows()).map(|_| (0.0, 0)).collect();
        assert!(clustered_information(&an, &one).abs() <= 1e-12);
    }
}
