use itgfx_core::pixel::{ChannelContrast, importance_weighted_contrast, pixel_colour_contrast, pixel_colour_quality};
use proptest::prelude::*;

const KINDS: [ChannelContrast; 3] = [ChannelContrast::Entropy, ChannelContrast::Binary, ChannelContrast::Classic];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Part IV eqs. (26)-(27): the importance-weighted contrast of a node is
    /// non-negative, 0 (to rounding) for a flat node, and falls by N_r per level
    /// (q_n = c̄_n / N_r^{n-1}); scaling every sample by k > 0 scales it by k
    /// (the contrasts are scale-free, the importance is linear).
    #[test]
    fn importance_weighted_contrast_laws(
        r in prop::collection::vec(0.0f64..10.0, 2..16),
        flat in 0.0f64..5.0,
        level in 1u32..5,
        k in 0.5f64..4.0,
        kind in 0usize..3,
    ) {
        let kind = KINDS[kind];
        let g: Vec<f64> = r.iter().map(|x| 0.5 * x + 0.1).collect();
        let w = [0.2126, 0.7152];
        let c = importance_weighted_contrast(&[&r, &g], &w, kind, 4, level).unwrap();
        prop_assert!(c >= 0.0);
        let deeper = importance_weighted_contrast(&[&r, &g], &w, kind, 4, level + 1).unwrap();
        prop_assert!((deeper * 4.0 - c).abs() <= 1e-12 * (1.0 + c));
        let rk: Vec<f64> = r.iter().map(|x| x * k).collect();
        let gk: Vec<f64> = g.iter().map(|x| x * k).collect();
        let ck = importance_weighted_contrast(&[&rk, &gk], &w, kind, 4, level).unwrap();
        prop_assert!((ck - k * c).abs() <= 1e-9 * (1.0 + c * k));
        let f = vec![flat; r.len()];
        let cf = importance_weighted_contrast(&[&f, &f], &w, kind, 4, level).unwrap();
        prop_assert!(cf <= 1e-12 * (1.0 + flat), "flat node contrast {}", cf);
        // Eqs. (11), (18): the pixel colour quality and contrast stay in [0, 1].
        let pc = pixel_colour_contrast(&[&r, &g], &w, kind).unwrap();
        prop_assert!((0.0..=1.0).contains(&pc));
        let q = pixel_colour_quality(&[&r, &g], &w).unwrap();
        prop_assert!((0.0..=1.0).contains(&q));
    }
}
