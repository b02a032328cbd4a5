//! Spatially coherent tracing order for a view's shadow rays.
//!
//! A view casts one shadow ray from the eye to each triangle's centroid.
//! Traced in the mesh's own triangle order, consecutive rays can head for
//! opposite ends of the object and walk unrelated parts of the BVH; sorted
//! along a Morton (Z-order) curve of the targets, consecutive rays walk
//! nearly the same nodes and triangles, which stay in cache. Each ray's
//! answer depends only on the ray, so the order changes the time, never
//! the result.

use glam::DVec3;

/// Bits per axis of the Morton code.
const BITS: u32 = 21;

/// Spreads the low 21 bits of `x` to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// Indices of `points` sorted along a Morton curve of their bounding box
/// (ties by index, so the order is deterministic).
#[must_use]
pub(super) fn morton_order(points: &[DVec3]) -> Vec<u32> {
    let (lo, hi) = points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let scale = f64::from((1u32 << BITS) - 1) / (hi - lo).max_element().max(f64::MIN_POSITIVE);
    let q = |v: f64| (v * scale).clamp(0.0, f64::from((1u32 << BITS) - 1)) as u64;
    let mut keyed: Vec<(u64, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let d = p - lo;
            (spread(q(d.x)) | spread(q(d.y)) << 1 | spread(q(d.z)) << 2, i as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_order_is_a_permutation_that_keeps_neighbours_close() {
        // A 16^3 grid, shuffled: the order visits every point once, and
        // consecutive points are mostly within a 2×2×2 cell of each other
        // (a random order would almost never be).
        let mut pts = Vec::new();
        for i in 0..4096u32 {
            let j = i.wrapping_mul(2_654_435_761) % 4096; // a bijection on 0..4096
            pts.push(DVec3::new(f64::from(j % 16), f64::from(j / 16 % 16), f64::from(j / 256)));
        }
        let order = morton_order(&pts);
        let mut seen = vec![false; pts.len()];
        order.iter().for_each(|&i| seen[i as usize] = true);
        assert!(seen.iter().all(|&s| s));
        let near = order.windows(2).filter(|w| pts[w[0] as usize].distance(pts[w[1] as usize]) <= 2.0).count();
        assert!(near * 10 > order.len() * 8, "only {near} of {} steps between neighbours", order.len());
        assert!(morton_order(&[]).is_empty());
    }
}
