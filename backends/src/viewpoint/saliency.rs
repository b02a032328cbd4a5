//! Mesh saliency from the reversed viewpoint channel (Part V): a polygon is
//! salient when the viewpoints that see it differ from those that see its
//! neighbours. With `p(V|o)` the reversed channel,
//! `S(o) = (1/|N(o)|) Σ_{o' ∈ N(o)} JS(p(o)/(p(o)+p(o')), p(o')/(p(o)+p(o')); p(V|o), p(V|o'))`
//! (Part II eq. (17) for the weighted Jensen–Shannon divergence), and the
//! saliency of a viewpoint is `S(v) = Σ_o p(o|v) S(o)`.

use itgfx_core::{Base, Error, jensen_shannon_sparse_logs, sparse_logs};
use rayon::prelude::*;

use super::ViewpointAnalysis;
use crate::scene::Scene;

/// Patches that share an edge with each patch (sorted, without itself).
/// Vertices are identified by their exact coordinates; for the analytic
/// sphere the cells' grid neighbours are used.
#[must_use]
pub fn patch_adjacency(scene: &Scene) -> Vec<Vec<u32>> {
    let n = scene.patches.len();
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    if let Some(s) = scene.sphere {
        for b in 0..s.bands {
            for c in 0..s.sectors {
                let id = (b * s.sectors + c) as usize;
                let mut push = |bb: u32, cc: u32| adj[id].push(bb * s.sectors + cc);
                if b > 0 {
                    push(b - 1, c);
                }
                if b + 1 < s.bands {
                    push(b + 1, c);
                }
                if s.sectors > 1 {
                    push(b, (c + 1) % s.sectors);
                    push(b, (c + s.sectors - 1) % s.sectors);
                }
            }
        }
    } else {
        // Vertex ids by exact position (-0.0 is 0.0).
        let key = crate::scene::vertex_key;
        let mut verts: Vec<([u64; 3], u32)> = Vec::with_capacity(scene.triangles.len() * 3);
        for (t, tri) in scene.triangles.iter().enumerate() {
            for (k, p) in tri.iter().enumerate() {
                verts.push((key(*p), (3 * t + k) as u32));
            }
        }
        verts.sort_unstable();
        let mut id = vec![0u32; verts.len()];
        let mut next = 0u32;
        for (i, (k, slot)) in verts.iter().enumerate() {
            if i > 0 && verts[i - 1].0 != *k {
                next += 1;
            }
            id[*slot as usize] = next;
        }
        // Edges (low id, high id, patch), grouped.
        let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(scene.triangles.len() * 3);
        for (t, &p) in scene.triangle_patch.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (id[3 * t + k], id[3 * t + (k + 1) % 3]);
                edges.push((a.min(b), a.max(b), p));
            }
        }
        edges.sort_unstable();
        for group in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            for x in group {
                for y in group {
                    if x.2 != y.2 {
                        adj[x.2 as usize].push(y.2);
                    }
                }
            }
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    adj
}

/// Outputs per block of [`reversed_columns`]: each block of columns is
/// filled by one task, which writes only inside its own part of the arrays.
const COLUMN_BLOCK: usize = 1 << 14;

/// The reversed channel `p(V|o)` as compressed columns: for each output,
/// the rows that see it (increasing) and `p(v|o) = p(v) p(o|v) / p(o)`.
/// Blocks of [`COLUMN_BLOCK`] columns are counted, filled and renormalised
/// side by side, each block reading its part of every row in row order: the
/// same entries in the same places, the same operations on each (a serial
/// scatter of every entry over the whole arrays was ~4% of the 1.1M-triangle
/// bunny's run, on one thread).
fn reversed_columns(an: &ViewpointAnalysis) -> (Vec<usize>, Vec<u32>, Vec<f64>) {
    let m = an.outputs();
    let block = |k: usize| k * COLUMN_BLOCK..((k + 1) * COLUMN_BLOCK).min(m);
    let mut starts = vec![0usize; m + 1];
    starts[1..].par_chunks_mut(COLUMN_BLOCK).enumerate().for_each(|(k, count)| {
        let cols = block(k);
        for x in 0..an.rows() {
            for &o in an.row_part(x, &cols).0 {
                count[o as usize - cols.start] += 1;
            }
        }
    });
    for o in 0..m {
        starts[o + 1] += starts[o];
    }
    let nnz = starts[m];
    let (mut rows, mut vals) = (vec![0u32; nnz], vec![0.0; nnz]);
    // Each block's slices of `rows` and `vals`, cut in block order.
    let mut parts = Vec::with_capacity(m.div_ceil(COLUMN_BLOCK));
    let (mut rest_r, mut rest_v) = (&mut rows[..], &mut vals[..]);
    for k in 0..m.div_ceil(COLUMN_BLOCK) {
        let cols = block(k);
        let len = starts[cols.end] - starts[cols.start];
        let (r, rr) = std::mem::take(&mut rest_r).split_at_mut(len);
        let (v, rv) = std::mem::take(&mut rest_v).split_at_mut(len);
        (rest_r, rest_v) = (rr, rv);
        parts.push((cols, r, v));
    }
    parts.into_par_iter().for_each(|(cols, r, v)| {
        let base = starts[cols.start];
        let mut fill: Vec<usize> = starts[cols.clone()].iter().map(|s| s - base).collect();
        for x in 0..an.rows() {
            let (c, p) = an.row_part(x, &cols);
            for (&o, &q) in c.iter().zip(p) {
                let k = &mut fill[o as usize - cols.start];
                r[*k] = x as u32;
                v[*k] = an.p_v[x] * q / an.p_o[o as usize];
                *k += 1;
            }
        }
        // Renormalise each column against rounding (Σ_v p(v|o) = 1 exactly in maths).
        for o in cols {
            let col = &mut v[starts[o] - base..starts[o + 1] - base];
            let s: f64 = col.iter().sum();
            if s > 0.0 {
                col.iter_mut().for_each(|v| *v /= s);
            }
        }
    });
    (starts, rows, vals)
}

/// Mesh saliency `S(o)` of every patch; patches never seen (or with no seen
/// neighbour) get 0. `adjacency` is read as undirected (an edge listed at
/// either end counts at both).
///
/// # Errors
/// Core errors (none in practice).
///
/// # Panics
/// If `adjacency` does not have one list per patch.
pub fn mesh_saliency(an: &ViewpointAnalysis, adjacency: &[Vec<u32>], base: Base) -> Result<Vec<f64>, Error> {
    assert_eq!(adjacency.len(), an.patches, "one adjacency list per patch");
    let (starts, rows, vals) = reversed_columns(an);
    // Each column meets about six neighbours: its logarithms are taken once
    // (the same values the divergence would take, so the same bits).
    let mut logs = vec![0.0; vals.len()];
    logs.par_chunks_mut(4096).zip(vals.par_chunks(4096)).for_each(|(l, v)| sparse_logs(v, l));
    let col = |o: usize| {
        let r = starts[o]..starts[o + 1];
        (&rows[r.clone()], &vals[r.clone()], &logs[r])
    };
    // The divergence is symmetric (swap both weights and columns), so each
    // edge between seen patches is evaluated once and counted at both ends.
    let mut edges: Vec<(u32, u32)> = adjacency
        .iter()
        .enumerate()
        .flat_map(|(o, near)| near.iter().map(move |&n| ((o as u32).min(n), (o as u32).max(n))))
        .filter(|&(a, b)| a != b && an.p_o[a as usize] > 0.0 && an.p_o[b as usize] > 0.0)
        .collect();
    edges.par_sort_unstable();
    edges.dedup();
    let js: Vec<f64> = edges
        .par_iter()
        .map(|&(a, b)| {
            let (pa, pb) = (an.p_o[a as usize], an.p_o[b as usize]);
            let t = pa + pb;
            jensen_shannon_sparse_logs((pa / t, pb / t), col(a as usize), col(b as usize), base)
        })
        .collect::<Result<_, _>>()?;
    let mut sum = vec![0.0; an.patches];
    let mut count = vec![0u32; an.patches];
    for (&(a, b), d) in edges.iter().zip(&js) {
        for o in [a as usize, b as usize] {
            sum[o] += d;
            count[o] += 1;
        }
    }
    Ok(sum.iter().zip(&count).map(|(s, &k)| if k == 0 { 0.0 } else { s / f64::from(k) }).collect())
}

/// Viewpoint saliency `S(v) = Σ_o p(o|v) S(o)` over all viewpoints (0 for
/// those that see nothing; the background has no saliency).
#[must_use]
pub fn viewpoint_saliency(an: &ViewpointAnalysis, saliency: &[f64]) -> Vec<f64> {
    let rows: Vec<f64> = (0..an.rows())
        .map(|x| {
            let (c, p) = an.row(x);
            c.iter().zip(p).filter(|(o, _)| (**o as usize) < an.patches).map(|(&o, &q)| q * saliency[o as usize]).sum()
        })
        .collect();
    an.expand(&rows, 0.0)
}

/// Averages each patch's value with its neighbours' `rounds` times (for
/// display: sampled per-polygon fields are noisy where polygons are small
/// next to the ray spacing). Non-finite values are left out of averages.
#[must_use]
pub fn smooth(values: &[f64], adjacency: &[Vec<u32>], rounds: u32) -> Vec<f64> {
    let mut cur = values.to_vec();
    for _ in 0..rounds {
        cur = (0..cur.len())
            .into_par_iter()
            .map(|o| {
                let (mut s, mut k) = (0.0, 0.0);
                for &x in std::iter::once(&(o as u32)).chain(&adjacency[o]) {
                    let v = cur[x as usize];
                    if v.is_finite() {
                        s += v;
                        k += 1.0;
                    }
                }
                if k > 0.0 { s / k } else { cur[o] }
            })
            .collect();
    }
    cur
}
