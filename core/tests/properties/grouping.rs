use itgfx_core::{Base, entropy, grouping};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// H(X) = H_in + H_out on random partitions (Part IV eq. (24)), with H_out
    /// the entropy of the group masses and 0 ≤ H_in ≤ H.
    #[test]
    fn decomposition((p, labels, g) in partitioned(48)) {
        let mut q = vec![0.0; g];
        let d = grouping(&p, &labels, g, &mut q, Base::Bits).unwrap();
        let h = entropy(&p, Base::Bits).unwrap();
        prop_assert!(close(d.total(), h, 1e-10));
        prop_assert!(close(d.h_out, entropy(&q, Base::Bits).unwrap(), 1e-10));
        prop_assert!(d.h_in >= -1e-12 && d.h_in <= h + 1e-10);
    }

    /// Equality cases: one group (H_in = H, H_out = 0) and singletons (H_in = 0).
    #[test]
    fn extremes(p in pmf(32)) {
        let n = p.len();
        let mut q1 = vec![0.0; 1];
        let one = grouping(&p, &vec![0; n], 1, &mut q1, Base::Bits).unwrap();
        let h = entropy(&p, Base::Bits).unwrap();
        prop_assert!(close(one.h_in, h, 1e-10) && one.h_out.abs() < 1e-12);
        let mut qn = vec![0.0; n];
        let ids: Vec<usize> = (0..n).collect();
        let all = grouping(&p, &ids, n, &mut qn, Base::Bits).unwrap();
        prop_assert!(all.h_in.abs() < 1e-12 && close(all.h_out, h, 1e-10));
    }
}
