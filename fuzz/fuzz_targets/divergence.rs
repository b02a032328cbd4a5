#![no_main]
use itgfx_core::{Base, ULogU, bregman, burbea_rao, divergences, jensen_shannon, kl_divergence, log_sum_terms};
use libfuzzer_sys::fuzz_target;

fn floats(data: &[u8]) -> Vec<f64> {
    data.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect()
}

fn ok(v: f64) -> bool {
    !v.is_nan() && v >= 0.0
}

fuzz_target!(|data: &[u8]| {
    let x = floats(data);
    let (p, q) = x.split_at(x.len() / 2);
    let q = &q[..p.len()];
    if let Ok(d) = kl_divergence(p, q, Base::Bits) {
        assert!(ok(d), "KL = {d}");
    }
    if let Ok(d) = divergences(p, q, Base::Nats) {
        for v in [d.kl, d.chi_square, d.hellinger, d.arithmetic_geometric, d.vasershtein_ornstein, d.l1, d.l2] {
            assert!(ok(v), "{d:?}");
        }
        assert!(d.hellinger <= 1.0 + 1e-9 && d.vasershtein_ornstein <= 1.0 + 1e-9);
    }
    if let Ok(v) = bregman(p, q, &ULogU) {
        assert!(ok(v));
    }
    if let Ok(v) = burbea_rao(p, q, &ULogU) {
        assert!((0.0..=1.0 + 1e-9).contains(&v));
    }
    if let Ok((l, r)) = log_sum_terms(p, q, Base::Bits) {
        assert!(!l.is_nan() && !r.is_nan());
    }
    if p.len() >= 2 {
        let m = p.len() / 2;
        if let Ok(js) = jensen_shannon(&q[..2], &p[..2 * m], m, Base::Bits) {
            assert!((0.0..=1.0 + 1e-9).contains(&js), "JS = {js}");
        }
    }
});
