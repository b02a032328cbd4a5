//! Regression tests for issue 24's defects of outputs, hangs, options, small
//! inputs and numerics, each run where the user sees it: the `itgfx` binary.

mod common;

use common::*;

/// Rényi near α = 1 and Tsallis near q = 1 cancelled: `--alpha
/// 1.00000000000001` on (½, ¼, ¼) gave 1.5103 bits, not 1.5.
#[test]
fn renyi_and_tsallis_next_to_one() {
    let v = json(&itgfx(&["measure", "renyi", "--alpha", "1.00000000000001", "0.5,0.25,0.25", "--json"]));
    let h = v["renyi_entropy"].as_f64().unwrap();
    assert!((h - 1.5).abs() < 1e-12, "{h}");
    let v = json(&itgfx(&["measure", "renyi", "--alpha", "0.999999999999999", "0.25,0.25,0.25,0.25", "--json"]));
    let h = v["renyi_entropy"].as_f64().unwrap();
    assert!((h - 2.0).abs() < 1e-12, "{h}");
    let v = json(&itgfx(&["measure", "tsallis", "--q", "1.00000000000001", "0.25,0.25,0.25,0.25", "--json"]));
    let s = v["tsallis_entropy"].as_f64().unwrap();
    assert!((s - 4f64.ln()).abs() < 1e-12, "{s}");
}
