#![no_main]
use itgfx_core::{Base, Channel, cascade_into, joint_entropies, scene_measures};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if data.len() < 2 {
        return;
    }
    let (r, c) = (usize::from(data[0] % 9), usize::from(data[1] % 9));
    let x: Vec<f64> = data[2..].chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect();
    if let Ok(e) = joint_entropies(&x, r, c, Base::Bits) {
        for v in [e.h_x, e.h_y, e.h_xy, e.h_x_given_y, e.h_y_given_x, e.mutual_information] {
            assert!(v.is_finite() && v >= 0.0, "{e:?}");
        }
        assert!(e.mutual_information <= e.h_x.min(e.h_y) + 1e-9);
    }
    if x.len() >= r {
        let (input, m) = x.split_at(r);
        if let Ok(ch) = Channel::new(input, m, c) {
            let cm = ch.measures(Base::Bits);
            assert!(cm.mutual_information.is_finite() && cm.mutual_information >= 0.0, "{cm:?}");
            let mut out = vec![0.0; r * c];
            if cascade_into(m, r, c, &m[..c * c.min(m.len() / c.max(1))], c, &mut out).is_ok() {
                assert!(out.iter().all(|v| v.is_finite()));
            }
        }
        if let Ok(s) = scene_measures(input, m, Base::Bits) {
            assert!(s.scene_entropy.is_finite() && s.positional_entropy.is_finite());
        }
    }
});
