//! Regression tests for the core defects of issue 9, each with its expected
//! value worked out by hand in the comment above it.

use itgfx_core::{
    Base, ContinuousMutualInformation, Error, ULogU, arithmetic_geometric, bregman, divergences, entropy_rate,
    grouping, grouping_by_label, hellinger, kl_divergence, markov_excess_entropy, mutual_information_matrix_into,
    renyi_entropy, stationary_distribution_into, vasershtein_ornstein,
};

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * 1f64.max(a.abs()).max(b.abs())
}

/// `itgfx measure renyi --alpha 2000 0.5,0.25,0.25` gave 0.539 bits (Σ p^α
/// underflowed to 0 and ln 0 was −746). H_α = α/(α−1) bits here.
#[test]
fn renyi_alpha_2000() {
    let h = renyi_entropy(&[0.5f64, 0.25, 0.25], 2000.0, Base::Bits).unwrap();
    assert!(close(h, 2000.0 / 1999.0, 1e-14), "{h}");
}

/// `itgfx measure scene` on two patches, the second of area 0 but seen with
/// F_01 = 1, gave I_0 = 1077 bits (= 746.5 / ln 2, from ln 0 = −746.5).
/// By Part III eq. (64), I_01 = a_0 F_01 log(F_01 / 0) = +∞.
#[test]
fn information_transfer_to_a_zero_area_patch() {
    let (mut out, mut per) = ([0.0f64; 4], [0.0f64; 2]);
    mutual_information_matrix_into(&[1.0f64, 0.0], &[0.0, 1.0, 1.0, 0.0], Base::Bits, &mut out, &mut per).unwrap();
    assert_eq!(per[0], f64::INFINITY);
    assert_eq!(out[1], f64::INFINITY);
    assert_eq!(per[1], 0.0, "a zero-area patch transfers nothing");
    // A reciprocal two-patch scene stays finite: a = (¼, ¾), F_01 = 1,
    // F_10 = ⅓, F_11 = ⅔: I_0 = ¼ log₂(1/¾), I_1 = ¾(⅓ log₂(⅓/¼) + ⅔ log₂(⅔/¾)).
    let f = [0.0, 1.0, 1.0 / 3.0, 2.0 / 3.0];
    mutual_information_matrix_into(&[0.25f64, 0.75], &f, Base::Bits, &mut out, &mut per).unwrap();
    assert!(close(per[0], 0.25 * (4.0f64 / 3.0).log2(), 1e-14), "{}", per[0]);
    let i1 = 0.75 * ((1.0 / 3.0) * (4.0f64 / 3.0).log2() + (2.0 / 3.0) * (8.0f64 / 9.0).log2());
    assert!(close(per[1], i1, 1e-14), "{}", per[1]);
    // a_1 = 1e-300/1e308 underflows to 0, but the log is finite:
    // I_01 = a_0 · 1 · (ln 1 − ln(1e-300/1e308)) with a_0 = 1 (to 1e-608).
    let f = [0.0, 1.0, 1.0, 0.0];
    mutual_information_matrix_into(&[1e308f64, 1e-300], &f, Base::Nats, &mut out, &mut per).unwrap();
    let want = (1e308f64).ln() - (1e-300f64).ln();
    assert!(close(per[0], want, 1e-14), "{} vs {want}", per[0]);
}

/// A_T F(x, y) rounding to 0 took ln 0 = −746.5 (finite garbage); the sample
/// is ln A_T + ln F = ln(1e-200) + ln(1e-200).
#[test]
fn continuous_mi_sample_whose_product_underflows() {
    let mut c = ContinuousMutualInformation::new(1e-200).unwrap();
    assert!(c.add_form_factor(1e-200));
    let e = c.estimate(Base::Nats).unwrap();
    assert!(close(e, 2.0 * (1e-200f64).ln(), 1e-14), "{e}");
}

/// `measure divergences --p 0.5,0.5 --q 1,1e-309` gave Hellinger and
/// Vasershtein–Ornstein "inf" (0.5/1e-309 overflows). By hand:
/// Hellinger = ½[(√½ − 1)² + (√½ − √1e-309)²] = 1 − √½ (the √1e-309 terms
/// are below 1e-154), VO = ½(|½ − 1| + |½ − 1e-309|) = ½.
#[test]
fn bounded_divergences_with_a_subnormal_q() {
    let (p, q) = ([0.5f64, 0.5], [1.0f64, 1e-309]);
    let h = hellinger(&p, &q).unwrap();
    assert!(close(h, 1.0 - 0.5f64.sqrt(), 1e-15), "{h}");
    assert_eq!(vasershtein_ornstein(&p, &q).unwrap(), 0.5);
    let d = divergences(&p, &q, Base::Nats).unwrap();
    assert!(close(d.hellinger, 1.0 - 0.5f64.sqrt(), 1e-15));
    assert_eq!(d.vasershtein_ornstein, 0.5);
    // KL is finite: ½ ln(½/1) + ½ ln(½/1e-309) = ln ½ − ½ ln 1e-309.
    let kl = kl_divergence(&p, &q, Base::Nats).unwrap();
    assert!(close(kl, 0.5f64.ln() - 0.5 * (1e-309f64).ln(), 1e-14), "{kl}");
    assert!(close(d.kl, kl, 0.0));
    // χ² = ¼/1 + (½ − 1e-309)²/1e-309 ≈ 2.5e308 > f64::MAX: +∞ is right.
    assert_eq!(d.chi_square, f64::INFINITY);
    // Arithmetic-geometric: Σ a_i (ln a_i − ½ ln p_i − ½ ln q_i), a = (p+q)/2.
    let ag = |p: f64, q: f64| {
        let a = 0.5 * (p + q);
        a * (a.ln() - 0.5 * (p.ln() + q.ln()))
    };
    let want = ag(0.5, 1.0) + ag(0.5, 1e-309);
    let got = arithmetic_geometric(&p, &q, Base::Nats).unwrap();
    assert!(close(got, want, 1e-14), "{got} vs {want}");
    // q = 0 exactly: still bounded, and KL is +∞ (p > 0 = q).
    let q0 = [1.0f64, 0.0];
    assert!(close(hellinger(&p, &q0).unwrap(), 1.0 - 0.5f64.sqrt(), 1e-15));
    assert_eq!(vasershtein_ornstein(&p, &q0).unwrap(), 0.5);
    assert_eq!(kl_divergence(&p, &q0, Base::Nats).unwrap(), f64::INFINITY);
    assert_eq!(bregman(&p, &q0, &ULogU).unwrap(), f64::INFINITY);
}

fn stationary(p: &[f64], n: usize) -> Result<Vec<f64>, Error> {
    let mut out = vec![0.0; n];
    let mut scratch = vec![0.0; n * n];
    stationary_distribution_into(p, n, &mut out, &mut scratch).map(|()| out)
}

/// A valid nearly-decomposable chain was rejected as "did not converge".
#[test]
fn nearly_decomposable_chain() {
    let e = 1e-12;
    let w = stationary(&[1.0 - e, e, e, 1.0 - e], 2).unwrap();
    assert_eq!(w, [0.5, 0.5]);
    // Unequal leak rates: w = (b, a)/(a + b) for P = [[1−a, a], [b, 1−b]].
    let (a, b) = (1e-12, 3e-12);
    let w = stationary(&[1.0 - a, a, b, 1.0 - b], 2).unwrap();
    assert!(close(w[0], 0.75, 1e-15) && close(w[1], 0.25, 1e-15), "{w:?}");
}

/// Hand-computed chains: two states w = (b, a)/(a+b); the birth-death chain
/// below has detailed balance w_0 ½ = w_1 ¼, w_1 ¼ = w_2 ½, so w = (¼, ½, ¼),
/// h = ¼·1 + ½·1.5 + ¼·1 = 1.25 bits and E = H(w) − h = 1.5 − 1.25 bits.
#[test]
fn small_chains_by_hand() {
    let w = stationary(&[0.7, 0.3, 0.1, 0.9], 2).unwrap();
    assert!(close(w[0], 0.25, 1e-15) && close(w[1], 0.75, 1e-15), "{w:?}");
    let p = [0.5, 0.5, 0.0, 0.25, 0.5, 0.25, 0.0, 0.5, 0.5];
    let w = stationary(&p, 3).unwrap();
    for (a, b) in w.iter().zip([0.25, 0.5, 0.25]) {
        assert!(close(*a, b, 1e-15), "{w:?}");
    }
    assert!(close(entropy_rate(&p, &w, Base::Bits).unwrap(), 1.25, 1e-15));
    assert!(close(markov_excess_entropy(&p, &w, Base::Bits).unwrap(), 0.25, 1e-14));
    // Periodic (period 2): the unique solution of w = wP.
    assert_eq!(stationary(&[0.0, 1.0, 1.0, 0.0], 2).unwrap(), [0.5, 0.5]);
    // One state: trivially w = (1).
    assert_eq!(stationary(&[1.0], 1).unwrap(), [1.0]);
    // Transient state 1 that reaches state 0: w = (1, 0).
    assert_eq!(stationary(&[1.0, 0.0, 0.5, 0.5], 2).unwrap(), [1.0, 0.0]);
    // Issue 24: the mirror image, state 0 transient, was refused as reducible.
    assert_eq!(stationary(&[0.5, 0.5, 0.0, 1.0], 2).unwrap(), [0.0, 1.0]);
    let w = stationary(&[0.0, 1.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.5, 0.5], 3).unwrap();
    assert!(w[0] == 0.0 && close(w[1], 0.5, 1e-15) && close(w[2], 0.5, 1e-15), "{w:?}");
}

/// Reducible chains are a clear error, not an iteration that never ends.
#[test]
fn reducible_chains_are_refused() {
    assert_eq!(stationary(&[1.0, 0.0, 0.0, 1.0], 2), Err(Error::ReducibleChain { state: 1 }));
    let p = [0.5, 0.5, 0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 1.0];
    assert_eq!(stationary(&p, 3), Err(Error::ReducibleChain { state: 2 }));
    let mut scratch = [0.0; 3];
    let mut out = [0.0; 2];
    assert!(matches!(
        stationary_distribution_into(&[0.5, 0.5, 0.5, 0.5], 2, &mut out, &mut scratch),
        Err(Error::LengthMismatch { expected: 4, found: 3 })
    ));
}

/// `measure markov` on a dense 1000-state chain ran past 60 s. GTH is
/// O(n³) ≈ 3·10^8 multiply-adds here. The chain is reversible (a
/// symmetric joint J: P_ij = J_ij / r_i), so w = r / Σr is known exactly.
#[test]
fn dense_thousand_state_chain() {
    let n = 1000;
    let mut s: u64 = 0x2545_F491_4F6C_DD1D;
    let mut joint = vec![0.0f64; n * n];
    for i in 0..n {
        for j in 0..=i {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let v = 0.01 + (s >> 11) as f64 / (1u64 << 53) as f64;
            joint[i * n + j] = v;
            joint[j * n + i] = v;
        }
    }
    let rows: Vec<f64> = joint.chunks(n).map(|r| r.iter().sum()).collect();
    let total: f64 = rows.iter().sum();
    let p: Vec<f64> = (0..n * n).map(|k| joint[k] / rows[k / n]).collect();
    let w = stationary(&p, n).unwrap();
    for (a, r) in w.iter().zip(&rows) {
        assert!(close(*a, r / total, 1e-12), "{a} vs {}", r / total);
    }
}

/// `measure grouping --groups 0,99999999` aborted allocating 10^8 group
/// masses: the scratch of [`grouping`] is sized by the largest label.
/// [`grouping_by_label`] sizes it by the number of outcomes.
#[test]
fn grouping_with_a_huge_label() {
    let p = [0.25f64, 0.75];
    let (mut order, mut q) = ([0usize; 2], [0.0f64; 2]);
    let (g, groups) = grouping_by_label(&p, &[0, 99_999_999], &mut order, &mut q, Base::Bits).unwrap();
    assert_eq!(groups, 2);
    assert_eq!(q, [0.25, 0.75]);
    let h = -(0.25f64 * 0.25f64.log2() + 0.75 * 0.75f64.log2());
    assert!(close(g.h_out, h, 1e-15) && g.h_in == 0.0, "{g:?}");
    // Same decomposition as the compact labels give, in label order.
    let p = [0.1f64, 0.2, 0.3, 0.4];
    let (mut order, mut q) = ([0usize; 4], [0.0f64; 4]);
    let (g, groups) = grouping_by_label(&p, &[usize::MAX, 7, usize::MAX, 7], &mut order, &mut q, Base::Bits).unwrap();
    let mut compact = [0.0f64; 2];
    let want = grouping(&p, &[1, 0, 1, 0], 2, &mut compact, Base::Bits).unwrap();
    assert_eq!(groups, 2);
    assert!(close(q[0], compact[0], 1e-15) && close(q[1], compact[1], 1e-15), "{q:?} vs {compact:?}");
    assert!(close(g.h_in, want.h_in, 1e-15) && close(g.h_out, want.h_out, 1e-15));
}
