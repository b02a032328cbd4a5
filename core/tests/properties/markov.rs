use itgfx_core::{
    Base, entropy, entropy_rate, excess_entropy_from_blocks, markov_excess_entropy, stationary_distribution_into,
};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// For a reversible chain built from a symmetric joint: the stationary
    /// distribution is the marginal (wP = w), h = H(X_2|X_1) ≤ H(w), and the
    /// block entropies H_n = H(w) + (n−1)h give back h and E = H(w) − h
    /// (Part II eqs. (13)-(14)).
    #[test]
    fn reversible_chain((w, p) in reciprocal_scene(10)) {
        let n = w.len();
        let mut out = vec![0.0; n];
        let mut scratch = vec![0.0; n * n];
        stationary_distribution_into(&p, n, &mut out, &mut scratch).unwrap();
        for (a, b) in out.iter().zip(&w) {
            prop_assert!((a - b).abs() <= 1e-12 * b, "{a} vs {b}");
        }
        let h = entropy_rate(&p, &w, Base::Bits).unwrap();
        let hw = entropy(&w, Base::Bits).unwrap();
        prop_assert!(h <= hw + TOL && h >= 0.0);
        let e = markov_excess_entropy(&p, &w, Base::Bits).unwrap();
        prop_assert!(close(e, hw - h, TOL));
        let blocks: Vec<f64> = (1..=6).map(|k| hw + (k as f64 - 1.0) * h).collect();
        let (hn, en) = excess_entropy_from_blocks(&blocks).unwrap();
        prop_assert!(close(hn, h, 1e-9) && close(en, e, 1e-9));
    }

    /// One closed class anywhere, transient states anywhere (state 0 among
    /// them or not): the stationary distribution is the closed class's,
    /// zero on the transient states, and w = wP (issue 24: refused when
    /// state 0 was transient).
    #[test]
    fn transient_states_anywhere(
        closed in 1usize..6,
        transient in 1usize..5,
        rows in prop::collection::vec(prop::collection::vec(0.05..1.0f64, 10), 10),
        order in Just((0..10).collect::<Vec<usize>>()).prop_shuffle(),
    ) {
        let n = closed + transient;
        // Positions: the first `closed` of the shuffled states are closed.
        let place: Vec<usize> = order.iter().copied().filter(|&i| i < n).collect();
        let mut p = vec![0.0; n * n];
        for (a, &i) in place.iter().enumerate() {
            // Closed states lead only among themselves, transient states anywhere.
            let targets = if a < closed { closed } else { n };
            let row = &rows[a][..targets];
            let s: f64 = row.iter().sum();
            for (b, &j) in place.iter().take(targets).enumerate() {
                p[i * n + j] = row[b] / s;
            }
        }
        let mut out = vec![0.0; n];
        let mut scratch = vec![0.0; n * n];
        stationary_distribution_into(&p, n, &mut out, &mut scratch).unwrap();
        for &i in &place[closed..] {
            prop_assert_eq!(out[i], 0.0);
        }
        for j in 0..n {
            let wp: f64 = (0..n).map(|i| out[i] * p[i * n + j]).sum();
            prop_assert!((wp - out[j]).abs() <= 1e-12, "{:?}", out);
        }
        prop_assert!((out.iter().sum::<f64>() - 1.0).abs() <= 1e-12);
    }
}

/// An i.i.d. chain (every row equal to w) has h = H(w) and E = 0.
#[test]
fn iid_chain_equality() {
    let w = [0.5, 0.3, 0.2];
    let p: Vec<f64> = w.iter().cycle().take(9).copied().collect();
    let h = entropy_rate(&p, &w, Base::Bits).unwrap();
    assert!((h - entropy(&w, Base::Bits).unwrap()).abs() < 1e-14);
    assert!(markov_excess_entropy(&p, &w, Base::Bits).unwrap().abs() < 1e-14);
}
