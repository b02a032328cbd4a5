//! Golden tests: the tutorial's worked examples, each citing where it is
//! printed and why its tolerance is what it is.

use itgfx_core::{
    Base, KullbackLeibler, binary_entropy, continuous_mutual_information, entropy, f_term, grouping, scene_measures,
};

/// Part II Fig. 1 (Shannon's grouping example):
/// H(1/2, 1/3, 1/6) = H(1/2, 1/2) + ½ H(2/3, 1/3). Both sides are computed
/// independently; tolerance 1e-15 is a few ulps of a ~1.46-bit value.
#[test]
fn part2_figure1_grouping() {
    let lhs: f64 = entropy(&[0.5, 1.0 / 3.0, 1.0 / 6.0], Base::Bits).unwrap();
    let rhs = binary_entropy(0.5, Base::Bits).unwrap() + 0.5 * entropy(&[2.0 / 3.0, 1.0 / 3.0], Base::Bits).unwrap();
    assert!((lhs - rhs).abs() < 1e-15, "{lhs} vs {rhs}");
    assert!((lhs - 1.459_147_917_027_245).abs() < 1e-14);
}

/// Part IV Fig. 9: the three decompositions (a), (b), (c) of
/// H(1/6, 1/12, 1/12, 1/6, 1/5, 3/10) all equal 2.445 bits. The figure prints
/// three decimals, so the tolerance is half a unit of the last digit (5e-4);
/// the three computed values must agree with each other to 1e-14.
#[test]
fn part4_figure9_recursive_decomposition() {
    let p = [1.0 / 6.0, 1.0 / 12.0, 1.0 / 12.0, 1.0 / 6.0, 1.0 / 5.0, 3.0 / 10.0];
    let a = entropy(&p, Base::Bits).unwrap();
    // (b): groups {1/6}, {1/12, 1/12, 1/6}, {1/5, 3/10}.
    let mut q = [0.0; 3];
    let b = grouping(&p, &[0, 1, 1, 1, 2, 2], 3, &mut q, Base::Bits).unwrap().total();
    let b_printed = entropy(&[1.0 / 6.0, 1.0 / 3.0, 1.0 / 2.0], Base::Bits).unwrap()
        + entropy(&[0.25, 0.25, 0.5], Base::Bits).unwrap() / 3.0
        + entropy(&[0.4, 0.6], Base::Bits).unwrap() / 2.0;
    // (c): the middle group split again into {1/12} and {1/12, 1/6}.
    let c = entropy(&[1.0 / 6.0, 1.0 / 3.0, 1.0 / 2.0], Base::Bits).unwrap()
        + (entropy(&[0.25, 0.75], Base::Bits).unwrap() + 0.75 * entropy(&[1.0 / 3.0, 2.0 / 3.0], Base::Bits).unwrap())
            / 3.0
        + entropy(&[0.4, 0.6], Base::Bits).unwrap() / 2.0;
    for v in [b, b_printed, c] {
        assert!((v - a).abs() < 1e-14, "{v} vs {a}");
    }
    assert!((a - 2.445).abs() < 5e-4, "{a}");
}

/// Part III-IV §3 and Fig. 2a: the KL contribution p log2(p/q) has its
/// minimum −(e ln 2)⁻¹ ≈ −0.531 at (1/e, 1). Checked exactly at the point
/// (1e-15) and as the minimum over a 1001×1001 grid of [0,1]² (the grid
/// spacing bounds how close the grid minimum can come, hence 1e-6).
#[test]
fn part34_kl_contribution_minimum() {
    let contrib = |p: f64, q: f64| f_term(&KullbackLeibler, p, q) / core::f64::consts::LN_2;
    let e = core::f64::consts::E;
    let want = -1.0 / (e * core::f64::consts::LN_2);
    assert!((contrib(1.0 / e, 1.0) - want).abs() < 1e-15);
    assert!((want - -0.531).abs() < 5e-4);
    let mut best = (f64::INFINITY, 0.0, 0.0);
    for i in 0..=1000 {
        for j in 1..=1000 {
            let (p, q) = (i as f64 / 1000.0, j as f64 / 1000.0);
            let v = contrib(p, q);
            if v < best.0 {
                best = (v, p, q);
            }
        }
    }
    assert!((best.0 - want).abs() < 1e-6 && best.2 == 1.0 && (best.1 - 1.0 / e).abs() < 1e-3, "{best:?}");
}

/// Part III Table 8, Fig. 19a: a regular tetrahedron with one patch per face
/// has F_ij = 1/3 (i ≠ j) by symmetry, so I_S = log2(4/3) = 0.415. Exact
/// form factors here (the table used 10^7 local lines), so the check is
/// exact to 1e-15 and against the printed 0.415 to half a unit (5e-4).
#[test]
fn part3_table8_tetrahedron() {
    let t = 1.0 / 3.0;
    let f = [0.0, t, t, t, t, 0.0, t, t, t, t, 0.0, t, t, t, t, 0.0];
    let m = scene_measures(&[1.0; 4], &f, Base::Bits).unwrap();
    assert!((m.mutual_information - (4.0f64 / 3.0).log2()).abs() < 1e-15);
    assert!((m.mutual_information - 0.415).abs() < 5e-4);
    assert!((m.positional_entropy - 2.0).abs() < 1e-15, "H_P = log n_p (Part III eq. (48))");
}

/// Part III §3.1 / eq. (49): the sphere with equal-area patches has
/// F_ij = a_j, so H_S = H_P = log n_p and I_S = 0; every point pair has
/// F(x, y) = 1/A_T, so I_S^c = 0 (eq. (57)).
#[test]
fn part3_sphere_is_independence() {
    let n = 8;
    let f = vec![1.0 / n as f64; n * n];
    let m = scene_measures(&vec![1.0; n], &f, Base::Bits).unwrap();
    assert!(m.mutual_information.abs() < 1e-15);
    assert!((m.scene_entropy - 3.0).abs() < 1e-15);
    let area = 4.0 * core::f64::consts::PI;
    let ic = continuous_mutual_information(area, &[1.0 / area; 100], Base::Bits).unwrap();
    assert!(ic.abs() < 1e-14);
}

/// Accuracy of the entropy of a 10^7-element distribution against a
/// double-double (TwoSum) accumulation of libm terms: the issue asks for
/// 1e-12 relative at 10^8; 10^7 must be well inside it (1e-13).
#[test]
fn entropy_accuracy() {
    let n = 10_000_000;
    let mut s: u64 = 0x2545_F491_4F6C_DD1D;
    let mut w: Vec<f64> = (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect();
    let total = dd_sum(w.iter().copied());
    w.iter_mut().for_each(|x| *x /= total);
    let reference = -dd_sum(w.iter().map(|&p| if p > 0.0 { p * libm::log(p) } else { 0.0 }));
    let got = entropy(&w, Base::Nats).unwrap();
    let rel = ((got - reference) / reference).abs();
    assert!(rel < 1e-13, "relative error {rel:e}");
}

/// Double-double (TwoSum) accumulation.
fn dd_sum(xs: impl Iterator<Item = f64>) -> f64 {
    let (mut hi, mut lo) = (0.0f64, 0.0f64);
    for x in xs {
        let s = hi + x;
        let bp = s - hi;
        let err = (hi - (s - bp)) + (x - bp);
        hi = s;
        lo += err;
        let t = hi + lo;
        lo -= t - hi;
        hi = t;
    }
    hi + lo
}
