#![no_main]
use itgfx_cli::input::parse_matrix_text;
use itgfx_core::{Base, joint_entropies};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    for sep in [None, Some(';')] {
        if let Ok(m) = parse_matrix_text("fuzz", text, sep) {
            assert_eq!(m.data.len(), m.rows * m.cols);
            if let Ok(e) = joint_entropies(&m.data, m.rows, m.cols, Base::Bits) {
                assert!(e.mutual_information.is_finite());
            }
        }
    }
});
