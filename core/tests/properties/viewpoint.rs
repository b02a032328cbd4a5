use itgfx_core::{Base, Channel, row_entropies_into};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Part V §3.2: splitting polygon `o` into two halves with
    /// p(o1|v) = p(o2|v) = p(o|v)/2 for every v leaves every VMI I(v;O)
    /// (eq. (7)) unchanged and raises every VE H(O|v) (eq. (2)) by exactly
    /// p(o|v) bits. Also VE ≤ log2(visible polygons) and VMI ≥ 0.
    #[test]
    fn split_invariance((input, m, r, c) in channel(8), o in 0usize..8) {
        let o = o % c;
        let split: Vec<f64> = (0..r).flat_map(|i| {
            let row = &m[i * c..(i + 1) * c];
            let mut v = row.to_vec();
            v[o] = row[o] / 2.0;
            v.push(row[o] / 2.0);
            v
        }).collect();
        let measure = |mat: &[f64], cols: usize| {
            let ch = Channel::new(&input, mat, cols).unwrap();
            let mut po = vec![0.0; cols];
            ch.output_into(&mut po).unwrap();
            let mut vmi = vec![0.0; r];
            ch.specific_information_into(&po, Base::Bits, &mut vmi).unwrap();
            let mut ve = vec![0.0; r];
            row_entropies_into(mat, r, cols, Base::Bits, &mut ve).unwrap();
            (vmi, ve)
        };
        let (vmi0, ve0) = measure(&m, c);
        let (vmi1, ve1) = measure(&split, c + 1);
        for i in 0..r {
            if input[i] > 0.0 {
                prop_assert!(close(vmi0[i], vmi1[i], 1e-9), "VMI changed: {} -> {}", vmi0[i], vmi1[i]);
                prop_assert!(vmi0[i] >= 0.0);
            }
            prop_assert!(close(ve1[i] - ve0[i], m[i * c + o], 1e-9), "VE rose by {} not {}", ve1[i] - ve0[i], m[i * c + o]);
            let visible = m[i * c..(i + 1) * c].iter().filter(|&&x| x > 0.0).count();
            prop_assert!(ve0[i] <= (visible as f64).log2() + 1e-9);
        }
    }
}
