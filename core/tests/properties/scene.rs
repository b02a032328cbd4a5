use itgfx_core::oracle::{DivergenceKernel, divergence_oracle, mutual_information_oracle};
use itgfx_core::{
    Base, Channel, PairCount, discretisation_error_area_sampling, mutual_information_matrix_into, scene_measures,
    scene_measures_from_counts,
};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Reciprocal form factors (Part III eq. (8)): H(Y|X) = H(X|Y) (§2.3),
    /// H_J = H_P + H_S = 2H_P − I_S = 2H_S + I_S, I_S = Σ I_ij with
    /// I_ij = I_ji (eqs. (63)-(66)), and I_i ≥ 0.
    #[test]
    fn reversibility((a, f) in reciprocal_scene(12)) {
        let n = a.len();
        let m = scene_measures(&a, &f, Base::Bits).unwrap();
        let ch = Channel::new(&a, &f, n).unwrap().measures(Base::Bits);
        prop_assert!(close(ch.h_y_given_x, ch.h_x_given_y, 1e-9));
        prop_assert!(close(m.scene_entropy, ch.h_y_given_x, 1e-9));
        prop_assert!(close(m.mutual_information, ch.mutual_information, 1e-9));
        prop_assert!(close(m.joint_entropy, m.positional_entropy + m.scene_entropy, 1e-12));
        prop_assert!(close(m.joint_entropy, 2.0 * m.positional_entropy - m.mutual_information, 1e-9));
        prop_assert!(close(m.joint_entropy, 2.0 * m.scene_entropy + m.mutual_information, 1e-9));
        let mut mi = vec![0.0; n * n];
        let mut per = vec![0.0; n];
        mutual_information_matrix_into(&a, &f, Base::Bits, &mut mi, &mut per).unwrap();
        for i in 0..n {
            prop_assert!(per[i] >= -1e-12);
            for j in 0..n {
                prop_assert!(close(mi[i * n + j], mi[j * n + i], 1e-9));
            }
        }
        prop_assert!(close(per.iter().sum::<f64>(), m.mutual_information, 1e-9));
        prop_assert!((0.0..=1.0 + TOL).contains(&m.normalized_entropy));
    }

    /// Counts and dense form factors agree: F_ij = N_ij / N_i (Part III eq. (31)).
    #[test]
    fn counts_match_dense(a in weights(2..10), counts in prop::collection::vec(0u64..50, 100)) {
        let n = a.len();
        let mut pairs = Vec::new();
        let mut f = vec![0.0; n * n];
        for i in 0..n {
            let row: Vec<u64> = (0..n).map(|j| counts[(i * n + j) % counts.len()] + u64::from(j == (i + 1) % n)).collect();
            let t: u64 = row.iter().sum();
            for j in 0..n {
                f[i * n + j] = row[j] as f64 / t as f64;
                if row[j] > 0 {
                    // split the count in two records to exercise merging
                    pairs.push(PairCount { from: i as u32, to: j as u32, count: row[j] / 2 });
                    pairs.push(PairCount { from: i as u32, to: j as u32, count: row[j] - row[j] / 2 });
                }
            }
        }
        let mut totals = vec![0; n];
        let sparse = scene_measures_from_counts(&a, &pairs, &mut totals, Base::Bits).unwrap();
        let dense = scene_measures(&a, &f, Base::Bits).unwrap();
        prop_assert!(close(sparse.scene_entropy, dense.scene_entropy, 1e-9));
        prop_assert!(close(sparse.mutual_information, dense.mutual_information, 1e-9));
    }

    /// δ_ij ≥ 0 for area sampling (Part III eq. (73)), zero for a constant
    /// kernel (two spherical patches, §8.2), and the KL oracle equals
    /// A_T N_s ρ_i B_j δ_ij (Part III-IV eq. (13)).
    #[test]
    fn discretisation_error(samples in prop::collection::vec(0.0..10.0f64, 1..30), ai in 0.1..5.0f64, aj in 0.1..5.0f64, extra in 0.1..20.0f64, c in 0.01..3.0f64) {
        let at = ai + aj + extra;
        let d = discretisation_error_area_sampling(ai, aj, at, &samples, Base::Nats).unwrap();
        prop_assert!(d >= 0.0);
        let flat = vec![c; samples.len()];
        prop_assert!(discretisation_error_area_sampling(ai, aj, at, &flat, Base::Nats).unwrap().abs() < 1e-12);
        let (rho, b) = (0.7, 3.0);
        let kl = divergence_oracle(DivergenceKernel::KullbackLeibler, rho, ai, aj, &samples, b).unwrap();
        let mi = mutual_information_oracle(rho, ai, aj, at, &samples, b, Base::Nats).unwrap();
        prop_assert!(close(kl / (at * samples.len() as f64), mi, 1e-9));
    }
}
