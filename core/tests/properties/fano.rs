use itgfx_core::{Base, fano_bound, fano_minimum_error, fano_weak_bound, joint_entropies};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// The MAP estimator X̂ = argmax_x p(x|y) has an error P_e with
    /// H(P_e) + P_e log(n−1) ≥ H(X|Y) (Part II eq. (21)) and P_e ≥ eq. (22)'s bound.
    #[test]
    fn map_estimator_obeys_fano((j, r, c) in joint(10)) {
        let e = joint_entropies(&j, r, c, Base::Bits).unwrap();
        // P(correct) = Σ_y max_x p(x, y)
        let correct: f64 = (0..c).map(|y| (0..r).map(|x| j[x * c + y]).fold(0.0, f64::max)).sum();
        let pe = (1.0 - correct).clamp(0.0, 1.0);
        prop_assert!(fano_bound(pe, r, Base::Bits).unwrap() + 1e-9 >= e.h_x_given_y);
        prop_assert!(fano_minimum_error(e.h_x_given_y, r, Base::Bits).unwrap() <= pe + 1e-9);
        if r >= 2 {
            prop_assert!(pe + 1e-9 >= fano_weak_bound(e.h_x_given_y, r).unwrap());
        }
    }

    /// Equality case: the minimum error at H(X|Y) = fano_bound(P_e) is P_e itself.
    #[test]
    fn inverse(n in 2usize..64, t in 0.0..1.0f64) {
        let pe = t * (n - 1) as f64 / n as f64;
        let h = fano_bound(pe, n, Base::Bits).unwrap();
        prop_assert!((fano_minimum_error(h, n, Base::Bits).unwrap() - pe).abs() < 1e-9);
    }
}
