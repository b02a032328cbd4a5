use itgfx_core::{Base, binary_entropy, entropy, entropy_of_weights, renyi_entropy, tsallis_entropy};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// 0 ≤ H ≤ log n (Part II §2 property 1), never NaN.
    #[test]
    fn bounded(p in pmf(64)) {
        let h = entropy(&p, Base::Bits).unwrap();
        prop_assert!(!h.is_nan());
        prop_assert!(h >= 0.0);
        prop_assert!(h <= (p.len() as f64).log2() + TOL);
    }

    /// Equality cases: uniform gives exactly log n in each base; a point mass gives 0.
    #[test]
    fn equality_cases(n in 1usize..200, at in 0usize..200) {
        let u = vec![1.0 / n as f64; n];
        prop_assert!(close(entropy(&u, Base::Bits).unwrap(), (n as f64).log2(), TOL));
        prop_assert!(close(entropy(&u, Base::Nats).unwrap(), (n as f64).ln(), TOL));
        prop_assert!(close(entropy(&u, Base::Hartleys).unwrap(), (n as f64).log10(), TOL));
        let mut d = vec![0.0; n];
        d[at % n] = 1.0;
        prop_assert_eq!(entropy(&d, Base::Bits).unwrap(), 0.0);
    }

    /// Equalising probabilities raises entropy (§2 property 2): H(λp + (1−λ)u) ≥ H(p),
    /// a consequence of concavity.
    #[test]
    fn concave_towards_uniform(p in pmf(32), lambda in 0.0..1.0f64) {
        let n = p.len() as f64;
        let mix: Vec<f64> = p.iter().map(|x| lambda * x + (1.0 - lambda) / n).collect();
        prop_assert!(entropy(&mix, Base::Bits).unwrap() + TOL >= entropy(&p, Base::Bits).unwrap());
    }

    /// Weights and their normalisation have the same entropy; f32 agrees with f64.
    #[test]
    fn weights_and_f32(w in weights(1..40), scale in 1e-3..1e3f64) {
        let p = normalize(w.clone());
        let scaled: Vec<f64> = w.iter().map(|x| x * scale).collect();
        let h = entropy(&p, Base::Bits).unwrap();
        prop_assert!(close(entropy_of_weights(&scaled, Base::Bits).unwrap(), h, 1e-9));
        let p32: Vec<f32> = p.iter().map(|&x| x as f32).collect();
        let h32 = entropy(&p32, Base::Bits).unwrap();
        prop_assert!((f64::from(h32) - h).abs() < 1e-4 * h.max(1.0));
    }

    /// Binary entropy is the two-point entropy and symmetric.
    #[test]
    fn binary(p in 0.0..=1.0f64) {
        let h = binary_entropy(p, Base::Bits).unwrap();
        prop_assert!(close(h, binary_entropy(1.0 - p, Base::Bits).unwrap(), TOL));
        prop_assert!(close(h, entropy(&[p, 1.0 - p], Base::Bits).unwrap(), 1e-9));
        prop_assert!((0.0..=1.0 + TOL).contains(&h));
    }

    /// Rényi entropy is non-increasing in α, equals Shannon at α → 1, and
    /// Tsallis at q = 1 is Shannon in nats.
    #[test]
    fn renyi_tsallis(p in pmf(16), a in 0.0..4.0f64, da in 0.0..4.0f64) {
        let lo = renyi_entropy(&p, a, Base::Bits).unwrap();
        let hi = renyi_entropy(&p, a + da, Base::Bits).unwrap();
        prop_assert!(hi <= lo + 1e-9);
        prop_assert!(renyi_entropy(&p, f64::INFINITY, Base::Bits).unwrap() <= hi + 1e-9);
        let h = entropy(&p, Base::Nats).unwrap();
        prop_assert!(close(tsallis_entropy(&p, 1.0).unwrap(), h, TOL));
        prop_assert!(close(renyi_entropy(&p, 1.0, Base::Nats).unwrap(), h, TOL));
    }

    /// Near α = 1 Rényi's and Tsallis's entropies are Shannon's plus a term
    /// of order ε = α − 1 (issue 24: `--alpha 1.00000000000001` gave 1.5103
    /// bits for 1.5, from the cancellation in `ln Σ p^α / (1 − α)`). With
    /// weights ≥ 1e-6/16, |ln p| < 17 and the ε term is below 300·|ε|.
    #[test]
    fn renyi_tsallis_near_one(p in pmf(16), e in prop_oneof![-1e-9..1e-9f64, Just(1e-14), Just(-1e-15)]) {
        let h = entropy(&p, Base::Nats).unwrap();
        let tol = 1e-13 + 300.0 * e.abs();
        prop_assert!((renyi_entropy(&p, 1.0 + e, Base::Nats).unwrap() - h).abs() <= tol);
        prop_assert!((tsallis_entropy(&p, 1.0 + e).unwrap() - h).abs() <= tol);
    }

    /// Away from 1 the textbook forms `ln Σ p^α / (1 − α)` and
    /// `(1 − Σ p^q)/(q − 1)` lose at most a digit or two, and agree.
    #[test]
    fn renyi_tsallis_exact_form(p in pmf(16), a in prop_oneof![0.05..0.95f64, 1.05..3.0f64]) {
        let sum: f64 = p.iter().filter(|&&x| x > 0.0).map(|x| x.powf(a)).sum();
        let renyi = sum.ln() / (1.0 - a);
        let tsallis = (1.0 - sum) / (a - 1.0);
        prop_assert!(close(renyi_entropy(&p, a, Base::Nats).unwrap(), renyi, 1e-12));
        prop_assert!(close(tsallis_entropy(&p, a).unwrap(), tsallis, 1e-12));
    }
}
