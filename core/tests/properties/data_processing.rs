use itgfx_core::{Base, Channel, cascade_into};
use proptest::prelude::*;

use crate::strategies::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// X → Y → Z: I(X;Z) ≤ I(X;Y) (Part II eq. (19)); the cascade is stochastic.
    #[test]
    fn data_processing((input, a, x, y) in channel(8), z in 1usize..8, seed in any::<u64>()) {
        let b = stochastic_from_seed(y, z, seed);
        let mut c = vec![0.0; x * z];
        cascade_into(&a, x, y, &b, z, &mut c).unwrap();
        let ixy = Channel::new(&input, &a, y).unwrap().measures(Base::Bits).mutual_information;
        let ixz = Channel::new(&input, &c, z).unwrap().measures(Base::Bits).mutual_information;
        prop_assert!(ixz <= ixy + 1e-9);
        // The identity channel preserves I exactly.
        let eye: Vec<f64> = (0..y * y).map(|k| if k / y == k % y { 1.0 } else { 0.0 }).collect();
        let mut same = vec![0.0; x * y];
        cascade_into(&a, x, y, &eye, y, &mut same).unwrap();
        prop_assert!(close(Channel::new(&input, &same, y).unwrap().measures(Base::Bits).mutual_information, ixy, 1e-12));
    }

    /// Bayes reversal (Part II eq. (6)) gives a channel with the same I and
    /// swapped conditional entropies; Σ p(x) I(x;Y) = I = Σ p(y) I(y;X) (Part V eqs. (6)-(7)).
    #[test]
    fn reversal((input, m, r, c) in channel(8)) {
        let ch = Channel::new(&input, &m, c).unwrap();
        let cm = ch.measures(Base::Bits);
        let mut py = vec![0.0; c];
        ch.output_into(&mut py).unwrap();
        let mut rev = vec![0.0; r * c];
        ch.reversed_into(&mut rev).unwrap();
        let back = Channel::new(&py, &rev, r).unwrap().measures(Base::Bits);
        prop_assert!(close(back.mutual_information, cm.mutual_information, 1e-9));
        prop_assert!(close(back.h_y_given_x, cm.h_x_given_y, 1e-9));
        let mut ix = vec![0.0; r];
        ch.specific_information_into(&py, Base::Bits, &mut ix).unwrap();
        let s: f64 = ix.iter().zip(&input).filter(|(_, p)| **p > 0.0).map(|(i, p)| i * p).sum();
        prop_assert!(close(s, cm.mutual_information, 1e-9));
        let mut iy = vec![0.0; c];
        ch.output_specific_information_into(&rev, Base::Bits, &mut iy).unwrap();
        let s: f64 = iy.iter().zip(&py).filter(|(_, p)| **p > 0.0).map(|(i, p)| i * p).sum();
        prop_assert!(close(s, cm.mutual_information, 1e-9));
    }
}

fn stochastic_from_seed(r: usize, c: usize, seed: u64) -> Vec<f64> {
    let mut s = seed | 1;
    let mut m: Vec<f64> = (0..r * c)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 + 1e-9
        })
        .collect();
    for row in m.chunks_mut(c) {
        let t: f64 = row.iter().sum();
        row.iter_mut().for_each(|x| *x /= t);
    }
    m
}
