//! What each leaf sees, from `rays` uniform points of it with one
//! cosine-distributed direction each ([`Tracer::closest_hit`]): the
//! fraction of rays that meet the front of a surface (`S*_ℓ`, its true
//! total form factor `Σ_j F_ℓj`, Part III eq. 26 summed over the scene),
//! the back of one (the ray starts hidden: under a box standing on the
//! floor, inside a closed object), or nothing (an opening). Exact (no
//! noise) wherever every ray meets a front face, as in a closed scene
//! away from hidden parts.

use rayon::prelude::*;

use super::element::{ElementId, Hierarchy};
use crate::backend::BackendError;
use crate::lines::{Line, LineRng, cosine_direction};
use crate::tracer::{Prepared, Tracer};

/// Gap off the leaf's own plane (normalised units), as the links use.
const GAP: f64 = 2e-4;

/// Lines per tracer call.
const BATCH: usize = 8192;

/// The stream of the front-fraction rays, apart from the links' own.
const STREAM: u64 = 0x2545_F491_4F6C_DD1D;

/// `[front, back]` fractions of every element in `leaves` from `rays` rays
/// each (the rest met nothing); returns them in order, and the rays cast. The same seed gives the same
/// fractions for any thread count: ray `k` of element `e` draws from
/// `(seed, e, k)` only.
///
/// # Errors
/// Tracing errors.
pub(crate) fn front_fractions(
    h: &Hierarchy,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    leaves: &[ElementId],
    rays: u32,
    seed: u64,
) -> Result<(Vec<[f64; 2]>, u64), BackendError> {
    let per = rays as usize;
    let lines: Vec<Line> = leaves
        .par_iter()
        .flat_map_iter(|&e| {
            let el = &h.elements[e as usize];
            (0..rays).map(move |k| {
                let rng = LineRng::new(seed ^ STREAM, (u64::from(e) << 20) | u64::from(k));
                let x = prepared.to_normalised(el.sample(rng.uniform(0), rng.uniform(1)));
                let d = cosine_direction(el.normal, rng.uniform(2), rng.uniform(3));
                Line::ray(x, d, GAP, 4.0)
            })
        })
        .collect();
    // Per ray: 1 front, 2 back, 0 nothing.
    let seen: Vec<u8> = lines
        .par_chunks(BATCH)
        .map(|c| {
            let mut hits = Vec::new();
            tracer
                .closest_hit(c, &mut hits)
                .map(|()| hits.iter().map(|h| h.map_or(0, |h| if h.cos < 0.0 { 1 } else { 2 })).collect())
        })
        .collect::<Result<Vec<Vec<u8>>, _>>()?
        .into_iter()
        .flatten()
        .collect();
    let n = per.max(1) as f64;
    let fractions = seen
        .chunks(per.max(1))
        .map(|c| [1, 2].map(|kind| c.iter().filter(|&&s| s == kind).count() as f64 / n))
        .collect();
    Ok((fractions, lines.len() as u64))
}
