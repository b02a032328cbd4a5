//! Camera paths on the viewpoint sphere (Part VI §2.2 and §3.1).
//!
//! * [`static_view`]: the best single view for a whole time series, the
//!   one whose cost (VMI, Part V eq. (7), lower is better) averaged over the
//!   frames is least;
//! * [`dynamic_path`]: one view per frame (Ji and Shen 2006's dynamic view
//!   selection), the sequence of sampled viewpoints with the least total
//!   cost such that the camera turns by at most `max_turn` between two
//!   frames, found exactly by dynamic programming over (frame, viewpoint);
//! * [`geodesic`]: the great-circle path between two views, the smooth
//!   viewpoint change of importance-driven focus of attention (Viola et
//!   al. 2006) from one object's characteristic view to another's.
//!
//! Costs are per frame and viewpoint; `∞` (a viewpoint that sees nothing
//! in that frame) is never chosen while a finite choice exists.

use glam::DVec3;

/// The view with the least mean cost over the frames (`cost[f][v]`), and
/// that mean; ties go to the lowest index. The sum runs over the frames in
/// order, as in [`dynamic_path`], so a constant path costs the same bits.
/// `None` if every view has an infinite cost in some frame.
#[must_use]
pub fn static_view(cost: &[Vec<f64>]) -> Option<(usize, f64)> {
    let views = cost.first()?.len();
    (0..views)
        .map(|v| (v, cost.iter().fold(0.0, |a, c| a + c[v])))
        .filter(|(_, t)| t.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
        .map(|(v, t)| (v, t / cost.len() as f64))
}

/// The angle between two directions, in radians (`[0, π]`).
#[must_use]
pub fn turn(a: DVec3, b: DVec3) -> f64 {
    // atan2 of |a × b| and a · b: accurate near 0 and π, where acos is not.
    let (a, b) = (a.normalize(), b.normalize());
    a.cross(b).length().atan2(a.dot(b))
}

/// The least-cost sequence of viewpoints, one per frame, whose consecutive
/// directions are at most `max_turn` radians apart, and its mean cost per
/// frame. Exact: `best_f(v) = cost_f(v) + min over u within max_turn of v of
/// best_{f−1}(u)` (staying is always allowed), then back from the least
/// `best_F`; ties go to the lowest index. `None` if no such path has a
/// finite cost (e.g. `max_turn` 0 and no view sees the volume in every
/// frame).
///
/// # Panics
/// If a frame's costs are not one per direction.
#[must_use]
pub fn dynamic_path(cost: &[Vec<f64>], dirs: &[DVec3], max_turn: f64) -> Option<(Vec<usize>, f64)> {
    let n = dirs.len();
    assert!(cost.iter().all(|c| c.len() == n), "one cost per viewpoint and frame");
    let first = cost.first()?;
    // Who may come before v: every u within max_turn (v itself included), by index.
    let reach: Vec<Vec<usize>> =
        (0..n).map(|v| (0..n).filter(|&u| u == v || turn(dirs[u], dirs[v]) <= max_turn + 1e-12).collect()).collect();
    let mut best = first.clone();
    let mut back: Vec<Vec<usize>> = Vec::with_capacity(cost.len());
    for c in &cost[1..] {
        let mut next = vec![f64::INFINITY; n];
        let mut from = vec![0; n];
        for v in 0..n {
            let mut m = (f64::INFINITY, reach[v][0]);
            for &u in &reach[v] {
                if best[u] < m.0 {
                    m = (best[u], u);
                }
            }
            // The same order of additions as `static_view`: the earlier frames' sum, then this frame.
            next[v] = m.0 + c[v];
            from[v] = m.1;
        }
        back.push(from);
        best = next;
    }
    let end = (0..n).filter(|&v| best[v].is_finite()).min_by(|&a, &b| best[a].total_cmp(&best[b]).then(a.cmp(&b)))?;
    let mut path = vec![end];
    for from in back.iter().rev() {
        path.push(from[*path.last().unwrap_or(&end)]);
    }
    path.reverse();
    Some((path, best[end] / cost.len() as f64))
}

/// `k ≥ 2` directions on the great circle from `a` to `b` (unit), equally
/// spaced in angle, `a` and `b` included: spherical linear interpolation
/// `(sin((1−s)θ) a + sin(sθ) b)/sin θ`, `θ` the angle between them. For
/// (nearly) equal directions every step is `a`; for (nearly) opposite ones
/// the half circle through the axis least aligned with `a` is taken.
#[must_use]
pub fn geodesic(a: DVec3, b: DVec3, k: usize) -> Vec<DVec3> {
    let (a, b) = (a.normalize(), b.normalize());
    let theta = turn(a, b);
    let k = k.max(2);
    if theta < 1e-9 {
        return vec![a; k];
    }
    // Near π the plane of the arc is undefined: rotate about a fixed axis ⟂ a.
    let (plane, theta) = if std::f64::consts::PI - theta < 1e-6 {
        let axis = [DVec3::X, DVec3::Y, DVec3::Z]
            .into_iter()
            .min_by(|x, y| x.dot(a).abs().total_cmp(&y.dot(a).abs()))
            .unwrap_or(DVec3::X);
        ((axis - a * axis.dot(a)).normalize(), std::f64::consts::PI)
    } else {
        ((b - a * a.dot(b)).normalize(), theta)
    };
    (0..k)
        .map(|i| {
            if i + 1 == k {
                return b;
            }
            let s = i as f64 / (k - 1) as f64 * theta;
            (a * s.cos() + plane * s.sin()).normalize()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewpoint::icosphere;

    #[test]
    fn static_view_is_the_least_mean() {
        let cost = vec![vec![1.0, 2.0, f64::INFINITY], vec![3.0, 1.0, 0.0]];
        assert_eq!(static_view(&cost), Some((1, 1.5)));
        assert_eq!(static_view(&[vec![f64::INFINITY]]), None);
    }

    #[test]
    fn dynamic_path_is_exact_and_respects_the_turn() {
        let dirs = icosphere(1);
        let n = dirs.len();
        // Deterministic pseudo-random costs (an LCG), 5 frames.
        let mut x = 12345u64;
        let mut rnd = || {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let cost: Vec<Vec<f64>> = (0..5).map(|_| (0..n).map(|_| rnd()).collect()).collect();
        let max_turn = 0.7;
        let (path, mean) = dynamic_path(&cost, &dirs, max_turn).unwrap();
        assert_eq!(path.len(), 5);
        for w in path.windows(2) {
            assert!(turn(dirs[w[0]], dirs[w[1]]) <= max_turn + 1e-12);
        }
        let total: f64 = path.iter().enumerate().map(|(f, &v)| cost[f][v]).sum();
        assert!((total / 5.0 - mean).abs() < 1e-12);
        // Exact: no path within the turn limit is cheaper (brute force over 3 frames).
        let short = &cost[..3];
        let (p3, m3) = dynamic_path(short, &dirs, max_turn).unwrap();
        let mut least = f64::INFINITY;
        for a in 0..n {
            for b in 0..n {
                for c in 0..n {
                    let ok = |u: usize, v: usize| u == v || turn(dirs[u], dirs[v]) <= max_turn + 1e-12;
                    if ok(a, b) && ok(b, c) {
                        least = least.min(short[0][a] + short[1][b] + short[2][c]);
                    }
                }
            }
        }
        assert!((m3 * 3.0 - least).abs() < 1e-12, "{p3:?}");
        // No turn: the static view; any turn: every frame's own best.
        let (p0, m0) = dynamic_path(&cost, &dirs, 0.0).unwrap();
        let (s, ms) = static_view(&cost).unwrap();
        assert!(p0.iter().all(|&v| v == s));
        assert_eq!(m0, ms);
        let (pa, _) = dynamic_path(&cost, &dirs, std::f64::consts::PI).unwrap();
        for (f, &v) in pa.iter().enumerate() {
            assert!(cost[f].iter().all(|&c| c >= cost[f][v]));
        }
        // Bounds: per-frame minima <= path <= static.
        let lower: f64 = cost.iter().map(|c| c.iter().copied().fold(f64::INFINITY, f64::min)).sum::<f64>() / 5.0;
        assert!(lower <= mean + 1e-15 && mean <= ms);
        // Unreachable: a view finite in frame 0 only, another in frame 1 only, no turn.
        let inf = f64::INFINITY;
        let mut c2 = vec![vec![inf; n], vec![inf; n]];
        c2[0][0] = 1.0;
        c2[1][1] = 1.0;
        assert_eq!(dynamic_path(&c2, &dirs, 0.0), None);
    }

    #[test]
    fn geodesic_steps_are_equal_and_end_at_the_views() {
        let (a, b) = (DVec3::new(1.0, 0.2, -0.3).normalize(), DVec3::new(-0.2, 0.9, 0.4).normalize());
        let g = geodesic(a, b, 7);
        assert_eq!(g.len(), 7);
        assert!((g[0] - a).length() < 1e-15 && g[6] == b);
        let step = turn(a, b) / 6.0;
        for w in g.windows(2) {
            assert!((turn(w[0], w[1]) - step).abs() < 1e-9);
            assert!((w[0].length() - 1.0).abs() < 1e-12);
        }
        let opposite = geodesic(DVec3::Z, -DVec3::Z, 5);
        assert!((turn(opposite[0], opposite[2]) - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert_eq!(geodesic(a, a, 3), vec![a.normalize(); 3]);
    }
}
