//! Golden tests of Part III Tables 1, 3, 4, 7 and 9 (docs/TABLES.md; Tables
//! 2, 6 and 8's first row are in `scene_golden.rs`).
//!
//! Two kinds of tolerance. Where the paper's scene is known exactly (the
//! enclosure, the solids) the tolerance is the run's own standard error.
//! Where it is not (the random cubes: the paper's placement rule and
//! positions are not published; ours are seed 1 of our placement), the
//! sampling error is negligible (standard error ≤ 0.0008 bits at 10^7
//! lines) and the difference is the layout's: over our placements 1-6 the
//! mean `I_S` is 0.5% (27 cubes), 1.2% (64) and 0.9% (512) below the
//! paper's, with standard deviations 0.015, 0.011 and 0.004 bits
//! (docs/TABLES.md). Those rows are held to 2% (the threshold above which
//! docs/TABLES.md must explain a difference): a change of the estimator or
//! of the scene by more than that fails them. Every run is deterministic
//! (seed 1). Rows whose values are held out of the specification are tested
//! only for the orderings the text states.

use itgfx_backends::BackendChoice;
use itgfx_backends::scene::built_in;
use itgfx_backends::visibility::Complexity;
use itgfx_tests::{run, run_scene};

fn complexity(spec: &str, lines: u64) -> Complexity {
    run(spec, lines, 1, false, BackendChoice::Cpu).2
}

fn within_2_percent(got: f64, want: f64, what: &str) {
    assert!((got - want).abs() <= 0.02 * want, "{what}: {got} vs {want} (2% = {})", 0.02 * want);
}

/// Part III Tables 1 and 3, Fig. 11a (512 random cubes of side 0.05 in the
/// 10×10-per-face enclosure, 10^7 global lines): `H_P` = 11.541 (the cube
/// side and count are what make it so: to the printed digit), `H_S` = 6.761,
/// `I_S` = 4.779, within 2% (module docs).
#[test]
fn table1_random_512_cubes() {
    let c = complexity("cubes-room:512", 10_000_000);
    let m = c.measures;
    assert!((m.positional_entropy - 11.541).abs() < 5e-4, "H_P {}", m.positional_entropy);
    within_2_percent(m.mutual_information, 4.779, "I_S");
    within_2_percent(m.scene_entropy, 6.761, "H_S");
    assert_eq!(c.escaped, 0);
}

/// Part III Table 3, Figs. 15a and 16a (27 and 64 random cubes, 10^7
/// global lines): `I_S` = 1.669 and 2.009, `H_S` = 7.780 and 7.709, within
/// 2% (module docs); `H_P = H_S + I_S` = 9.449 and 9.718 to the printed digit.
#[test]
fn table3_random_cubes() {
    for (k, i_s, h_s) in [(27, 1.669, 7.780), (64, 2.009, 7.709)] {
        let m = complexity(&format!("cubes-room:{k}"), 10_000_000).measures;
        within_2_percent(m.mutual_information, i_s, &format!("{k} cubes: I_S"));
        within_2_percent(m.scene_entropy, h_s, &format!("{k} cubes: H_S"));
        assert!((m.positional_entropy - (i_s + h_s)).abs() < 1.5e-3, "{k} cubes: H_P {}", m.positional_entropy);
    }
}

/// Part III Table 4's ordering (10^6 global lines, as the table): the
/// sphere's complexity is the least, then the icosahedron, dodecahedron,
/// octahedron, cube and tetrahedron (fewer faces, more complex), and the
/// Cornell box is above the empty cube. Each step by more than 3 combined
/// standard errors. The cube is also the enclosure of Table 6 (one patch per
/// face instead of 100: `I_S^c` does not depend on the patches), so the two
/// agree within 3 combined standard errors.
#[test]
fn table4_ordering() {
    let order = ["sphere", "icosahedron", "dodecahedron", "octahedron", "cube", "tetrahedron"];
    let runs: Vec<Complexity> = order.iter().map(|s| complexity(s, 1_000_000)).collect();
    let value = |c: &Complexity| (c.continuous.unwrap(), c.continuous_stderr.unwrap());
    for (k, w) in runs.windows(2).enumerate() {
        let ((a, sa), (b, sb)) = (value(&w[0]), value(&w[1]));
        assert!(b - a > 3.0 * sa.hypot(sb), "{} {a} then {} {b}", order[k], order[k + 1]);
    }
    let cube = value(&runs[4]);
    let cornell = value(&complexity("cornell-box", 1_000_000));
    assert!(cornell.0 - cube.0 > 3.0 * cornell.1.hypot(cube.1), "Cornell {cornell:?} vs cube {cube:?}");
    let enclosure = value(&complexity("cube-enclosure:10", 1_000_000));
    assert!((enclosure.0 - cube.0).abs() < 3.0 * enclosure.1.hypot(cube.1), "{enclosure:?} vs {cube:?}");
}

/// Part III Table 7's pattern (512 random cubes, 10^4 to 10^6 global
/// lines): the discrete `I_S` falls as lines are added (few lines a patch
/// overstate the correlation), by more than 3 standard errors a step, while
/// `I_S^c` stays put within 3 combined standard errors.
#[test]
fn table7_discrete_falls_continuous_stays() {
    let runs: Vec<Complexity> = [10_000, 100_000, 1_000_000].iter().map(|&l| complexity("cubes-room:512", l)).collect();
    for w in runs.windows(2) {
        let (a, b) = (w[0].measures.mutual_information, w[1].measures.mutual_information);
        let se = w[0].mutual_information_stderr.unwrap().hypot(w[1].mutual_information_stderr.unwrap());
        assert!(a - b > 3.0 * se, "I_S {a} then {b}");
        let (ca, cb) = (w[0].continuous.unwrap(), w[1].continuous.unwrap());
        let cse = w[0].continuous_stderr.unwrap().hypot(w[1].continuous_stderr.unwrap());
        assert!((ca - cb).abs() < 3.0 * cse, "I_S^c {ca} then {cb}");
    }
}

/// Part III Table 9's pattern (the Cornell box refined): `I_S` grows with
/// the mesh refinement and stays below `I_S^c` (eq. (60)). Uniform 1×1,
/// 2×2, 4×4 splits, 10^6 global lines, bias-corrected `I_S`, each step by
/// more than 3 standard errors.
#[test]
fn table9_refinement_increases_information() {
    let mut last = 0.0;
    for k in [1, 2, 4] {
        let scene = built_in("cornell-box").unwrap().subdivided(k).unwrap();
        let c = run_scene(scene, 1_000_000, 1, false, BackendChoice::Cpu).2;
        let (i, se) = (c.mutual_information_corrected.unwrap(), c.mutual_information_stderr.unwrap());
        assert!(i > last + 3.0 * se, "{k}x{k}: I_S {i} after {last}");
        assert!(i + 3.0 * se < c.continuous.unwrap(), "{k}x{k}: I_S {i} vs I_S^c {:?}", c.continuous);
        last = i;
    }
}
