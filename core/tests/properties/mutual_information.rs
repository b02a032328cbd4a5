use itgfx_core::{
    Base, Channel, entropy_of_weight_sums, entropy_of_weights, jensen_shannon, joint_entropies, kl_divergence,
    mutual_information_of_weight_sums, specific_information_of_weight_sums, weight_log_term,
};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// H(X,Y) ≤ H(X) + H(Y); both chain rules; H(X) ≥ H(X|Y) ≥ 0;
    /// I ≥ 0, I ≤ min(H(X), H(Y)) (Part II §2 properties 1-3, §3 properties 1-4).
    #[test]
    fn joint_identities((j, r, c) in joint(12)) {
        let e = joint_entropies(&j, r, c, Base::Bits).unwrap();
        prop_assert!(e.h_xy <= e.h_x + e.h_y + TOL);
        prop_assert!(close(e.h_xy, e.h_x + e.h_y_given_x, TOL));
        prop_assert!(close(e.h_xy, e.h_y + e.h_x_given_y, TOL));
        prop_assert!(e.h_x + TOL >= e.h_x_given_y && e.h_x_given_y >= 0.0);
        prop_assert!(e.mutual_information >= 0.0);
        prop_assert!(e.mutual_information <= e.h_x.min(e.h_y) + TOL);
        // Symmetry: the transposed joint has the same I.
        let t: Vec<f64> = (0..r * c).map(|k| j[(k % r) * c + k / r]).collect();
        let et = joint_entropies(&t, c, r, Base::Bits).unwrap();
        prop_assert!(close(e.mutual_information, et.mutual_information, TOL));
    }

    /// The normalised variants (Part III §3.2.3): I/H(X,Y) ∈ [0,1],
    /// NMI = (H(X)+H(Y))/H(X,Y) = 1 + I/H(X,Y) ∈ [1,2], ECC = 2 − 2/NMI ∈ [0,1].
    #[test]
    fn normalised_mi((j, r, c) in joint(12)) {
        let e = joint_entropies(&j, r, c, Base::Bits).unwrap();
        let (q, nmi, ecc) = (e.mi_over_joint(), e.studholme_nmi(), e.entropy_correlation());
        prop_assert!((0.0..=1.0).contains(&q) && (1.0..=2.0).contains(&nmi) && (0.0..=1.0).contains(&ecc));
        if e.h_xy > 1e-9 {
            prop_assert!(close(nmi, (e.h_x + e.h_y) / e.h_xy, 1e-9));
            prop_assert!(close(ecc, 2.0 - 2.0 / nmi, 1e-9));
        }
        // The base cancels in every ratio.
        let n = joint_entropies(&j, r, c, Base::Nats).unwrap();
        prop_assert!(close(n.mi_over_joint(), q, 1e-12) && close(n.entropy_correlation(), ecc, 1e-12));
    }

    /// I(X;Y) = D_KL(p(x,y) ‖ p(x)p(y)) (Part II eq. (9)); I = 0 iff independent.
    #[test]
    fn mi_is_kl_to_product((j, r, c) in joint(10)) {
        let e = joint_entropies(&j, r, c, Base::Nats).unwrap();
        let px: Vec<f64> = (0..r).map(|i| j[i * c..(i + 1) * c].iter().sum()).collect();
        let py: Vec<f64> = (0..c).map(|k| (0..r).map(|i| j[i * c + k]).sum()).collect();
        let prod: Vec<f64> = (0..r * c).map(|k| px[k / c] * py[k % c]).collect();
        let kl = kl_divergence(&j, &normalize(prod.clone()), Base::Nats).unwrap();
        prop_assert!(close(e.mutual_information, kl, 1e-9));
        let ind = joint_entropies(&normalize(prod), r, c, Base::Nats).unwrap();
        prop_assert!(ind.mutual_information.abs() < 1e-9);
    }

    /// The channel view agrees with the joint view, and JS with weights p(x)
    /// over rows p(Y|x) equals I(X;Y) (Part II §5).
    #[test]
    fn channel_equals_joint_and_js((input, m, r, c) in channel(10)) {
        let ch = Channel::new(&input, &m, c).unwrap();
        let cm = ch.measures(Base::Bits);
        let mut j = vec![0.0; r * c];
        ch.joint_into(&mut j).unwrap();
        let e = joint_entropies(&j, r, c, Base::Bits).unwrap();
        prop_assert!(close(cm.mutual_information, e.mutual_information, 1e-9));
        prop_assert!(close(cm.h_y, e.h_y, 1e-9));
        prop_assert!(close(cm.h_y_given_x, e.h_y_given_x, 1e-9));
        prop_assert!(close(cm.h_x_given_y, e.h_x_given_y, 1e-9));
        let js = jensen_shannon(&input, &m, c, Base::Bits).unwrap();
        prop_assert!(close(js, cm.mutual_information, 1e-12));
        prop_assert!(close(cm.mutual_information, cm.h_y - cm.h_y_given_x, 1e-9));
    }

    /// A deterministic channel Y = f(X) has I = H(Y) and H(Y|X) = 0;
    /// identical rows give I = 0 (equality cases).
    #[test]
    fn equality_cases(input in pmf(12), targets in prop::collection::vec(0usize..5, 12), row in pmf(5)) {
        let r = input.len();
        let c = 5;
        let mut m = vec![0.0; r * c];
        for i in 0..r { m[i * c + targets[i]] = 1.0; }
        let cm = Channel::new(&input, &m, c).unwrap().measures(Base::Bits);
        prop_assert!(cm.h_y_given_x.abs() < TOL);
        prop_assert!(close(cm.mutual_information, cm.h_y, TOL));
        let mut same = vec![0.0; r * row.len()];
        for i in 0..r { same[i * row.len()..(i + 1) * row.len()].copy_from_slice(&row); }
        let z = Channel::new(&input, &same, row.len()).unwrap().measures(Base::Bits);
        prop_assert!(z.mutual_information < 1e-12);
    }

    /// I(X;Y) and H from running sums of unnormalised weights (Part II
    /// eqs. (2), (7)) equal the normalised joint's, at any scale of the
    /// weights (the simplifier's incremental I(V;O), Part V eq. (6)).
    #[test]
    fn mi_from_weight_sums((j, r, c) in joint(10), scale in 1e-4..1e4f64) {
        let w: Vec<f64> = j.iter().map(|x| x * scale).collect();
        let rows: Vec<f64> = (0..r).map(|i| w[i * c..(i + 1) * c].iter().sum()).collect();
        let cols: Vec<f64> = (0..c).map(|k| (0..r).map(|i| w[i * c + k]).sum()).collect();
        let term = |v: &[f64]| v.iter().map(|&x| weight_log_term(x).unwrap()).sum::<f64>();
        let s: f64 = w.iter().sum();
        let i = mutual_information_of_weight_sums(s, term(&w), term(&rows), term(&cols), Base::Bits).unwrap();
        let e = joint_entropies(&j, r, c, Base::Bits).unwrap();
        prop_assert!(close(i, e.mutual_information, 1e-9));
        let h = entropy_of_weight_sums(rows.iter().sum::<f64>(), term(&rows), Base::Bits).unwrap();
        prop_assert!(close(h, entropy_of_weights(&rows, Base::Bits).unwrap(), 1e-9));
        // Each row's specific information (Part V eq. (7)) against the channel's.
        let p_x: Vec<f64> = rows.iter().map(|x| x / s).collect();
        // An unseen row (p(x) = 0) gets any distribution: the channel needs one.
        let m: Vec<f64> =
            (0..r * c).map(|k| if rows[k / c] > 0.0 { w[k] / rows[k / c] } else { 1.0 / c as f64 }).collect();
        let p_y: Vec<f64> = cols.iter().map(|x| x / s).collect();
        let mut spec = vec![0.0; r];
        Channel::new(&p_x, &m, c).unwrap().specific_information_into(&p_y, Base::Bits, &mut spec).unwrap();
        for x in (0..r).filter(|&x| rows[x] > 0.0) {
            let cross: f64 = (0..c).filter(|&y| w[x * c + y] > 0.0).map(|y| w[x * c + y] * cols[y].ln()).sum();
            let xl = term(&w[x * c..(x + 1) * c]);
            let got = specific_information_of_weight_sums(s, rows[x], xl, cross, Base::Bits).unwrap();
            prop_assert!(close(got, spec[x], 1e-8), "row {x}: {got} vs {}", spec[x]);
        }
    }
}
