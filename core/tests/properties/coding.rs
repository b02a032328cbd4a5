use itgfx_core::{Base, entropy, huffman_block_length, huffman_expected_length};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// H ≤ ℓ̄ < H + 1 for Huffman codes (Part II eq. (24)); equality for dyadic p.
    #[test]
    fn huffman_bounds(p in pmf(64)) {
        let mut s = vec![0.0; p.len()];
        let l = huffman_expected_length(&p, &mut s).unwrap();
        let h = entropy(&p, Base::Bits).unwrap();
        prop_assert!(h <= l + 1e-9);
        prop_assert!(l < h + 1.0);
    }

    #[test]
    fn dyadic_equality(k in 1usize..20) {
        // p = (1/2, 1/4, ..., 2^-k, 2^-k)
        let mut p: Vec<f64> = (1..=k).map(|i| 0.5f64.powi(i as i32)).collect();
        p.push(0.5f64.powi(k as i32));
        let mut s = vec![0.0; p.len()];
        let l = huffman_expected_length(&p, &mut s).unwrap();
        prop_assert!(close(l, entropy(&p, Base::Bits).unwrap(), 1e-12));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Block codes: H ≤ ℓ̄_k / k < H + 1/k (Part II eq. (25)).
    #[test]
    fn block_bounds(p in pmf(6), k in 1u32..5) {
        let l = huffman_block_length(&p, k).unwrap();
        let h = entropy(&p, Base::Bits).unwrap();
        prop_assert!(h <= l + 1e-9);
        prop_assert!(l < h + 1.0 / f64::from(k) + 1e-12);
    }
}
