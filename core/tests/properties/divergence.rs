use itgfx_core::{Base, Error, kl_divergence, log_sum_terms};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// Information inequality: KL ≥ 0, with equality for p = q (Part II §3).
    #[test]
    fn information_inequality((p, q) in pmf_pair(48)) {
        let d = kl_divergence(&p, &q, Base::Bits).unwrap();
        prop_assert!(!d.is_nan());
        prop_assert!(d >= 0.0);
        prop_assert!(kl_divergence(&p, &p, Base::Bits).unwrap().abs() < TOL);
    }

    /// KL is +∞ exactly when p has mass where q has none, finite otherwise;
    /// the value matches the textbook sum in each base.
    #[test]
    fn support_and_value((p, q) in pmf_pair(24)) {
        let d = kl_divergence(&p, &q, Base::Nats).unwrap();
        let escapes = p.iter().zip(&q).any(|(x, y)| *x > 0.0 && *y == 0.0);
        prop_assert_eq!(d.is_infinite(), escapes);
        if !escapes {
            let direct: f64 = p.iter().zip(&q).filter(|(x, _)| **x > 0.0).map(|(x, y)| x * (x / y).ln()).sum();
            prop_assert!(close(d, direct.max(0.0), 1e-9));
            prop_assert!(close(kl_divergence(&p, &q, Base::Bits).unwrap(), d / std::f64::consts::LN_2, 1e-12));
        }
    }

    /// KL strictly positive when p ≠ q with common support (Jensen strictness).
    #[test]
    fn strict((p, q) in positive_pair(24)) {
        let d = kl_divergence(&p, &q, Base::Nats).unwrap();
        let l1: f64 = p.iter().zip(&q).map(|(x, y)| (x - y).abs()).sum();
        // Pinsker: KL ≥ ½ ‖p − q‖₁² (nats): strictness with a margin.
        prop_assert!(d + 1e-12 >= 0.5 * l1 * l1);
    }

    /// Log-sum inequality (Part II eq. (18)) with its equality case a_i/b_i constant.
    #[test]
    fn log_sum(a in weights(1..32), b in weights(1..32), k in 1e-3..1e3f64) {
        let n = a.len().min(b.len());
        let (a, b) = (&a[..n], &b[..n]);
        let (l, r) = log_sum_terms(a, b, Base::Bits).unwrap();
        prop_assert!(l + 1e-9 >= r);
        let bk: Vec<f64> = a.iter().map(|x| x * k).collect();
        let (l, r) = log_sum_terms(a, &bk, Base::Bits).unwrap();
        prop_assert!(close(l, r, 1e-9));
    }
}

#[test]
fn bad_input_table() {
    let cases: &[(&[f64], &[f64], Error)] = &[
        (&[], &[], Error::Empty),
        (&[1.0], &[0.5, 0.5], Error::LengthMismatch { expected: 1, found: 2 }),
        (&[f64::NAN, 1.0], &[0.5, 0.5], Error::NonFinite { index: 0 }),
        (&[0.5, 0.5], &[1.5, -0.5], Error::Negative { index: 1 }),
        (&[0.0, 0.0], &[0.5, 0.5], Error::ZeroMass),
    ];
    for (p, q, e) in cases {
        assert_eq!(kl_divergence(p, q, Base::Bits), Err(*e));
    }
}
