#![no_main]
use itgfx_core::{Base, entropy, entropy_of_weights, huffman_expected_length, pixel, renyi_entropy, tsallis_entropy};
use libfuzzer_sys::fuzz_target;

fn floats(data: &[u8]) -> Vec<f64> {
    data.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect()
}

fuzz_target!(|data: &[u8]| {
    let p = floats(data);
    let n = p.len().max(1) as f64;
    if let Ok(h) = entropy(&p, Base::Bits) {
        assert!(h.is_finite() && h >= 0.0 && h <= n.log2() + 1e-9, "H = {h}");
    }
    if let Ok(h) = entropy_of_weights(&p, Base::Nats) {
        assert!(h.is_finite() && h >= 0.0 && h <= n.ln() + 1e-9, "H = {h}");
    }
    let alpha = p.first().copied().unwrap_or(2.0);
    if let Ok(h) = renyi_entropy(&p, alpha, Base::Bits) {
        assert!(h.is_finite() && h >= 0.0 && h <= n.log2() + 1e-9, "H_a = {h}");
    }
    if let Ok(s) = tsallis_entropy(&p, alpha) {
        assert!(s.is_finite(), "S_q = {s}");
    }
    let mut scratch = vec![0.0; p.len()];
    if let Ok(l) = huffman_expected_length(&p, &mut scratch) {
        assert!(l.is_finite() && l >= 0.0);
    }
    for v in [pixel::pixel_quality(&p), pixel::binary_contrast(&p), pixel::classic_contrast(&p)].into_iter().flatten() {
        assert!((0.0..=1.0).contains(&v), "{v}");
    }
});
