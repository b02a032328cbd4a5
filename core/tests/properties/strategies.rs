use proptest::prelude::*;

/// Non-negative weights with a chance of exact zeros, never all zero.
pub fn weights(n: impl Into<proptest::sample::SizeRange>) -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(prop_oneof![1 => Just(0.0), 4 => 1e-6..1.0f64], n).prop_map(|mut w| {
        if w.iter().all(|&x| x == 0.0) {
            w[0] = 1.0;
        }
        w
    })
}

/// Normalises weights to a distribution.
pub fn normalize(mut w: Vec<f64>) -> Vec<f64> {
    let s: f64 = w.iter().sum();
    w.iter_mut().for_each(|x| *x /= s);
    w
}

/// A distribution over 1..=max outcomes.
pub fn pmf(max: usize) -> impl Strategy<Value = Vec<f64>> {
    weights(1..=max).prop_map(normalize)
}

/// Two distributions of the same length `2..=max`.
pub fn pmf_pair(max: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (2..=max).prop_flat_map(|n| (weights(n).prop_map(normalize), weights(n).prop_map(normalize)))
}

/// Two distributions of one length drawn from `len`.
pub fn pmf_pair_len(len: std::ops::RangeInclusive<usize>) -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    len.prop_flat_map(|n| (weights(n).prop_map(normalize), weights(n).prop_map(normalize)))
}

/// Strictly positive distribution pairs (no infinities), length `2..=max`.
pub fn positive_pair(max: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (2..=max).prop_flat_map(|n| {
        (
            prop::collection::vec(1e-3..1.0f64, n).prop_map(normalize),
            prop::collection::vec(1e-3..1.0f64, n).prop_map(normalize),
        )
    })
}

/// A joint distribution `(data, rows, cols)`.
pub fn joint(max: usize) -> impl Strategy<Value = (Vec<f64>, usize, usize)> {
    (1..=max, 1..=max).prop_flat_map(|(r, c)| weights(r * c).prop_map(move |w| (normalize(w), r, c)))
}

/// A row-stochastic `r × c` matrix.
pub fn stochastic(r: usize, c: usize) -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(weights(c).prop_map(normalize), r).prop_map(|rows| rows.concat())
}

/// A channel `(input, matrix, rows, cols)`.
pub fn channel(max: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>, usize, usize)> {
    (1..=max, 1..=max).prop_flat_map(|(r, c)| (weights(r).prop_map(normalize), stochastic(r, c), Just(r), Just(c)))
}

/// A distribution with a partition of its outcomes into `groups` labels.
pub fn partitioned(max: usize) -> impl Strategy<Value = (Vec<f64>, Vec<usize>, usize)> {
    (1..=max, 1..=max).prop_flat_map(|(n, g)| (weights(n).prop_map(normalize), prop::collection::vec(0..g, n), Just(g)))
}

/// A symmetric joint `p_ij = p_ji` with positive marginals: a reciprocal
/// scene (`a_i = Σ_j p_ij`, `F_ij = p_ij / a_i`).
pub fn reciprocal_scene(max: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (2..=max).prop_flat_map(|n| {
        prop::collection::vec(prop_oneof![1 => Just(0.0), 4 => 1e-4..1.0f64], n * n).prop_map(move |w| {
            let mut s = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    s[i * n + j] = w[i * n + j] + w[j * n + i];
                }
            }
            for i in 0..n {
                // keep every patch seeing something, symmetrically
                s[i * n + (i + 1) % n] += 1e-3;
                s[((i + 1) % n) * n + i] += 1e-3;
            }
            let joint = normalize(s);
            let areas: Vec<f64> = (0..n).map(|i| joint[i * n..(i + 1) * n].iter().sum()).collect();
            let f: Vec<f64> = (0..n * n).map(|k| joint[k] / areas[k / n]).collect();
            (areas, f)
        })
    })
}

/// `|a − b| ≤ tol · max(1, |a|, |b|)`.
pub fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * 1f64.max(a.abs()).max(b.abs())
}

pub const TOL: f64 = 1e-10;
