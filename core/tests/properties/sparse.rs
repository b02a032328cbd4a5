use itgfx_core::{
    Base, Channel, SparseChannel, jensen_shannon, jensen_shannon_sparse, jensen_shannon_sparse_logs, sparse_logs,
};
use proptest::prelude::*;

use crate::strategies::*;

/// The compressed-row form of a dense row-stochastic matrix (zeros dropped).
fn compress(m: &[f64], cols: usize) -> (Vec<usize>, Vec<u32>, Vec<f64>) {
    let mut starts = vec![0];
    let (mut idx, mut val) = (Vec::new(), Vec::new());
    for row in m.chunks(cols) {
        for (j, &p) in row.iter().enumerate() {
            if p > 0.0 {
                idx.push(j as u32);
                val.push(p);
            }
        }
        starts.push(idx.len());
    }
    (starts, idx, val)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// The sparse channel's every measure equals the dense channel's on the
    /// same matrix (Part V eqs. (5)-(7) and the reversed channel).
    #[test]
    fn sparse_equals_dense((input, m, r, c) in channel(10)) {
        let dense = Channel::new(&input, &m, c).unwrap();
        let (starts, idx, val) = compress(&m, c);
        let sparse = SparseChannel::new(&input, &starts, &idx, &val, c).unwrap();
        let (mut po_d, mut po_s) = (vec![0.0; c], vec![0.0; c]);
        dense.output_into(&mut po_d).unwrap();
        sparse.output_into(&mut po_s).unwrap();
        for (a, b) in po_d.iter().zip(&po_s) {
            prop_assert!(close(*a, *b, 1e-12));
        }
        let dm = dense.measures(Base::Bits);
        let sm = sparse.measures(&po_s, Base::Bits).unwrap();
        prop_assert!(close(dm.mutual_information, sm.mutual_information, 1e-9));
        prop_assert!(close(dm.h_y_given_x, sm.h_y_given_x, 1e-9));
        prop_assert!(close(dm.h_y, sm.h_y, 1e-9));
        prop_assert!(close(dm.h_x_given_y, sm.h_x_given_y, 1e-9), "{dm:?} {sm:?}");
        let (mut vd, mut vs) = (vec![0.0; r], vec![0.0; r]);
        dense.specific_information_into(&po_d, Base::Bits, &mut vd).unwrap();
        sparse.specific_information_into(&po_s, Base::Bits, &mut vs).unwrap();
        for (a, b) in vd.iter().zip(&vs) {
            // An input of zero weight may see an output of zero mass: ∞ in both.
            prop_assert!(a == b || close(*a, *b, 1e-9), "{a} {b}");
        }
        let mut rev = vec![0.0; r * c];
        dense.reversed_into(&mut rev).unwrap();
        let (mut od, mut os) = (vec![0.0; c], vec![0.0; c]);
        dense.output_specific_information_into(&rev, Base::Bits, &mut od).unwrap();
        sparse.output_specific_information_into(&po_s, Base::Bits, &mut os).unwrap();
        for (a, b) in od.iter().zip(&os) {
            prop_assert!(close(*a, *b, 1e-8));
        }
        // Σ_y p(y) I(y;X) = I(X;Y).
        let s: f64 = os.iter().zip(&po_s).map(|(i, p)| i * p).sum();
        prop_assert!(close(s, sm.mutual_information, 1e-9));
        let mut hd = vec![0.0; r];
        sparse.row_entropies_into(Base::Bits, &mut hd).unwrap();
        let h: f64 = hd.iter().zip(&input).map(|(h, p)| h * p).sum();
        prop_assert!(close(h, sm.h_y_given_x, 1e-9));
    }

    /// Weighted output specific information: `w ≡ 1` gives `I(y;X)`, and it
    /// is linear in the weights (colour VoMI, one weight vector per channel).
    #[test]
    fn weighted_output_information((input, m, r, c) in channel(10), seed in 0u64..1000) {
        let (starts, idx, val) = compress(&m, c);
        let sparse = SparseChannel::new(&input, &starts, &idx, &val, c).unwrap();
        let mut po = vec![0.0; c];
        sparse.output_into(&mut po).unwrap();
        let (mut plain, mut ones) = (vec![0.0; c], vec![0.0; c]);
        sparse.output_specific_information_into(&po, Base::Bits, &mut plain).unwrap();
        sparse.output_specific_information_weighted_into(&po, &vec![1.0; r], Base::Bits, &mut ones).unwrap();
        for (a, b) in plain.iter().zip(&ones) {
            prop_assert!(close(*a, b.max(0.0), 1e-9), "{a} {b}");
        }
        let w1: Vec<f64> = (0..r).map(|x| ((x as u64 * 7 + seed) % 5) as f64 / 4.0).collect();
        let w2: Vec<f64> = w1.iter().map(|w| 1.0 - w).collect();
        let (mut a, mut b) = (vec![0.0; c], vec![0.0; c]);
        sparse.output_specific_information_weighted_into(&po, &w1, Base::Bits, &mut a).unwrap();
        sparse.output_specific_information_weighted_into(&po, &w2, Base::Bits, &mut b).unwrap();
        for ((x, y), z) in a.iter().zip(&b).zip(&ones) {
            prop_assert!(close(x + y, *z, 1e-9), "{x} + {y} != {z}");
        }
    }

    /// Sparse Jensen–Shannon equals the dense one (Part II eq. (17)).
    #[test]
    fn sparse_js_equals_dense((a, b) in pmf_pair(12), w in 0.0f64..=1.0) {
        let n = a.len();
        let (_, ia, va) = compress(&a, n);
        let (_, ib, vb) = compress(&b, n);
        let d = jensen_shannon(&[w, 1.0 - w], &[a.clone(), b.clone()].concat(), n, Base::Bits).unwrap();
        let s = jensen_shannon_sparse((w, 1.0 - w), (&ia, &va), (&ib, &vb), Base::Bits).unwrap();
        prop_assert!(close(d, s, 1e-12));
    }

    /// With the logarithms given, the divergence is the same to the bit.
    #[test]
    fn sparse_js_with_logs_is_bit_identical((a, b) in pmf_pair(12), w in 0.0f64..=1.0) {
        let n = a.len();
        let (_, ia, va) = compress(&a, n);
        let (_, ib, vb) = compress(&b, n);
        let (mut la, mut lb) = (vec![0.0; va.len()], vec![0.0; vb.len()]);
        sparse_logs(&va, &mut la);
        sparse_logs(&vb, &mut lb);
        let s = jensen_shannon_sparse((w, 1.0 - w), (&ia, &va), (&ib, &vb), Base::Nats).unwrap();
        let l = jensen_shannon_sparse_logs((w, 1.0 - w), (&ia, &va, &la), (&ib, &vb, &lb), Base::Nats).unwrap();
        prop_assert_eq!(s.to_bits(), l.to_bits());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Rows of hundreds of entries (a viewpoint's `p(O|v)`), so that the
    /// merge with logarithms runs over several of its batches (128 merged
    /// indices each), with indices in one row only and both: the batched
    /// merge and the scalar one agree to the bit.
    #[test]
    fn long_sparse_js_with_logs_is_bit_identical((a, b) in pmf_pair_len(300..=700), w in 0.0f64..=1.0) {
        let n = a.len();
        let (_, ia, va) = compress(&a, n);
        let (_, ib, vb) = compress(&b, n);
        let (mut la, mut lb) = (vec![0.0; va.len()], vec![0.0; vb.len()]);
        sparse_logs(&va, &mut la);
        sparse_logs(&vb, &mut lb);
        for w in [w, 0.0, 1.0] {
            let s = jensen_shannon_sparse((w, 1.0 - w), (&ia, &va), (&ib, &vb), Base::Nats).unwrap();
            let l = jensen_shannon_sparse_logs((w, 1.0 - w), (&ia, &va, &la), (&ib, &vb, &lb), Base::Nats).unwrap();
            prop_assert_eq!(s.to_bits(), l.to_bits());
        }
    }
}

#[test]
fn bad_structure_is_refused() {
    let input = [0.5, 0.5];
    // Out-of-order column, column out of range, short starts, unnormalised row.
    assert!(SparseChannel::new(&input, &[0, 2, 3], &[1, 0, 0], &[0.5, 0.5, 1.0], 2).is_err());
    assert!(SparseChannel::new(&input, &[0, 1, 2], &[0, 2], &[1.0, 1.0], 2).is_err());
    assert!(SparseChannel::new(&input, &[0, 1], &[0], &[1.0], 2).is_err());
    assert!(matches!(
        SparseChannel::new(&input, &[0, 1, 2], &[0, 1], &[1.0, 0.5], 2),
        Err(itgfx_core::Error::RowNotNormalized { row: 1, .. })
    ));
    assert!(SparseChannel::new(&input, &[0, 1, 2], &[0, 1], &[1.0, f64::NAN], 2).is_err());
    assert!(jensen_shannon_sparse((0.5, 0.5), (&[1, 0], &[0.5, 0.5]), (&[0], &[1.0]), Base::Bits).is_err());
}
