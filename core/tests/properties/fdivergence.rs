use itgfx_core::{
    ArithmeticGeometric, Base, ChiSquare, FGenerator, Hellinger, KullbackLeibler, Square, TotalVariation, ULogU,
    bregman, burbea_rao, chi_square, divergences, f_divergence, hellinger, jensen_shannon, kl_divergence, l_alpha,
    vasershtein_ornstein,
};
use proptest::prelude::*;

use crate::strategies::*;

/// `f(u) = u ln u + r (u − 1)`: differs from KL's generator by a multiple of `u − 1`.
struct ShiftedKl(f64);
impl FGenerator for ShiftedKl {
    fn f(&self, u: f64) -> f64 {
        KullbackLeibler.f(u) + self.0 * (u - 1.0)
    }
    fn f_at_zero(&self) -> f64 {
        -self.0
    }
    fn slope_at_infinity(&self) -> f64 {
        f64::INFINITY
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Joint convexity of D_f (Part III-IV eq. (6)) for KL, χ², Hellinger, TV, AG.
    #[test]
    fn convexity((p, q) in positive_pair(16), (p2, q2) in positive_pair(16), lambda in 0.0..=1.0f64) {
        let n = p.len().min(p2.len());
        let (p, q, p2, q2) = (normalize(p[..n].to_vec()), normalize(q[..n].to_vec()), normalize(p2[..n].to_vec()), normalize(q2[..n].to_vec()));
        let mix = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| lambda * x + (1.0 - lambda) * y).collect() };
        let (pm, qm) = (mix(&p, &p2), mix(&q, &q2));
        let gens: [&dyn FGenerator; 5] = [&KullbackLeibler, &ChiSquare, &Hellinger, &TotalVariation, &ArithmeticGeometric];
        for g in gens {
            let lhs = lambda * f_divergence(&p, &q, g).unwrap() + (1.0 - lambda) * f_divergence(&p2, &q2, g).unwrap();
            let rhs: f64 = f_divergence(&pm, &qm, g).unwrap();
            prop_assert!(lhs + 1e-10 >= rhs, "convexity failed: {} < {}", lhs, rhs);
        }
    }

    /// Uniqueness (Part III-IV §3): generators differing by r(u − 1) give the same divergence.
    #[test]
    fn uniqueness((p, q) in pmf_pair(16), r in -5.0..5.0f64) {
        let a: f64 = f_divergence(&p, &q, &KullbackLeibler).unwrap();
        let b: f64 = f_divergence(&p, &q, &ShiftedKl(r)).unwrap();
        prop_assert!(a == b || close(a, b, 1e-9));
    }

    /// The three bounds of Part III-IV Fig. 3 (KL in nats):
    /// D_h² ≤ ½ D_KL, D_h² ≤ √D_χ², D_KL ≤ ln(1 + D_χ²).
    #[test]
    fn figure3_bounds((p, q) in pmf_pair(32)) {
        let kl: f64 = kl_divergence(&p, &q, Base::Nats).unwrap();
        let chi: f64 = chi_square(&p, &q).unwrap();
        let h: f64 = hellinger(&p, &q).unwrap();
        prop_assert!(h <= 0.5 * kl + TOL);
        prop_assert!(h <= chi.sqrt() + TOL);
        prop_assert!(kl <= (1.0 + chi).ln() + TOL);
        prop_assert!((0.0..=1.0 + TOL).contains(&h));
    }

    /// Equality case: every divergence of Table 1 vanishes at p = q, and KL as an
    /// f-divergence equals the direct KL; VO = ½ L₁ = 1 − Σ min.
    #[test]
    fn table1_links((p, q) in pmf_pair(32)) {
        let d = divergences(&p, &p, Base::Nats).unwrap();
        for v in [d.kl, d.chi_square, d.hellinger, d.arithmetic_geometric, d.vasershtein_ornstein, d.l1, d.l2] {
            prop_assert!(v.abs() < 1e-12);
        }
        let fkl: f64 = f_divergence(&p, &q, &KullbackLeibler).unwrap();
        let kl: f64 = kl_divergence(&p, &q, Base::Nats).unwrap();
        prop_assert!(fkl == kl || close(fkl, kl, 1e-9));
        let vo: f64 = vasershtein_ornstein(&p, &q).unwrap();
        let mins: f64 = 1.0 - p.iter().zip(&q).map(|(x, y)| x.min(*y)).sum::<f64>();
        prop_assert!(close(vo, mins, 1e-12));
        prop_assert!(close(vo, 0.5 * l_alpha(&p, &q, 1.0).unwrap(), 1e-12));
    }

    /// Bregman with u ln u is KL and with u² the squared L2 distance;
    /// Burbea–Rao with u ln u is the equal-weight Jensen–Shannon divergence.
    #[test]
    fn bregman_burbea_rao((p, q) in pmf_pair(24)) {
        let b: f64 = bregman(&p, &q, &ULogU).unwrap();
        let kl: f64 = kl_divergence(&p, &q, Base::Nats).unwrap();
        prop_assert!(b == kl || close(b, kl, 1e-9));
        let sq: f64 = bregman(&p, &q, &Square).unwrap();
        prop_assert!(close(sq, l_alpha(&p, &q, 2.0).unwrap(), 1e-12));
        let br: f64 = burbea_rao(&p, &q, &ULogU).unwrap();
        let js: f64 = jensen_shannon(&[0.5, 0.5], &[p.clone(), q.clone()].concat(), p.len(), Base::Nats).unwrap();
        prop_assert!(close(br, js, 1e-9));
    }
}
