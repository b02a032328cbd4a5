//! Backend conformance: every backend against the brute-force reference
//! tracer on the same lines, degenerate scenes first.

use glam::DVec3;
use itgfx_backends::lines::{Line, global_line};
use itgfx_backends::scene::{Scene, built_in};
use itgfx_backends::tracer::{BackendChoice, BackendError, CrossingBuffer, Prepared, open};
use itgfx_backends::visibility::SPHERE_SCALE;

fn crossings(scene: &Scene, choice: BackendChoice, lines: &[Line]) -> Result<CrossingBuffer, BackendError> {
    let p = Prepared::new(scene);
    let t = open(choice, &p)?;
    let mut out = CrossingBuffer::default();
    t.trace_all(lines, &mut out)?;
    Ok(out)
}

fn lines(n: u64, seed: u64) -> Vec<Line> {
    (0..n).map(|i| global_line(seed, i, SPHERE_SCALE)).collect()
}

/// Whether Vulkan tests must run (`ITGFX_REQUIRE_VULKAN=1`, set by CI after
/// installing lavapipe) or may be skipped with a printed reason.
fn vulkan_required() -> bool {
    std::env::var_os("ITGFX_REQUIRE_VULKAN").is_some_and(|v| v == "1")
}

/// The backends to check: CPU always; Vulkan when a device opens (or when required).
fn backends() -> Vec<BackendChoice> {
    let probe = built_in("cube").unwrap();
    match open(BackendChoice::Vulkan, &Prepared::new(&probe)) {
        Ok(_) => vec![BackendChoice::Cpu, BackendChoice::Vulkan],
        Err(e) if vulkan_required() => panic!("ITGFX_REQUIRE_VULKAN=1 but Vulkan is unavailable: {e}"),
        Err(e) => {
            eprintln!("skipping the Vulkan backend: {e}");
            vec![BackendChoice::Cpu]
        }
    }
}

/// Every backend finds exactly the reference's crossings (same patches,
/// same t to the bit: all use the same watertight test, the BVH only prunes,
/// and the Vulkan kernel returns the numerator and determinant for the host
/// to finish as the CPU does).
fn agrees(scene: &Scene, n: u64) {
    let ls = lines(n, 11);
    let reference = crossings(scene, BackendChoice::Reference, &ls).unwrap();
    for choice in backends() {
        let got = crossings(scene, choice, &ls).unwrap();
        for i in 0..ls.len() {
            assert_eq!(got.line(i), reference.line(i), "{} on {choice:?}: line {i} differs", scene.name);
        }
    }
}

#[test]
fn degenerate_scenes() {
    // Empty: refused when built, not when traced.
    let empty = Scene::default();
    assert!(empty.validate().is_err());
    // One triangle.
    let mut one = Scene::default();
    one.materials.push(Default::default());
    one.add_polygon("tri", &[DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, -1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)], 0);
    one.validate().unwrap();
    agrees(&one, 2000);
    // Huge and tiny coordinates: normalisation makes them the same scene.
    for s in [1e-6, 1e6] {
        let mut sc = built_in("cube-enclosure:2").unwrap();
        for t in &mut sc.triangles {
            for v in t.iter_mut() {
                *v *= s;
            }
        }
        agrees(&sc, 2000);
    }
    // Degenerate triangle and NaN vertex are refused with the patch named.
    let mut bad = one.clone();
    bad.add_polygon("flat", &[DVec3::ZERO, DVec3::X, DVec3::X * 2.0], 0);
    assert!(bad.validate().unwrap_err().to_string().contains("degenerate"));
    let mut nan = one.clone();
    nan.triangles[0][0].x = f64::NAN;
    assert!(nan.validate().unwrap_err().to_string().contains("non-finite"));
}

#[test]
fn cpu_matches_reference_on_every_built_in() {
    for spec in [
        "cube-enclosure:3",
        "tetrahedron",
        "cube",
        "octahedron",
        "dodecahedron",
        "icosahedron",
        "cornell-box",
        "cubes-room:8",
        "cubes-room:512",
        "sphere:4,8",
        "geosphere:4",
        "torus:48,24",
        "table-chairs",
    ] {
        agrees(&built_in(spec).unwrap(), 3000);
    }
}

/// `itgfx complexity` gives the same numbers on both backends for the same
/// seed (the acceptance command, at 10^5 lines to keep CI short).
#[test]
fn complexity_is_the_same_on_cpu_and_vulkan() {
    if !backends().contains(&BackendChoice::Vulkan) {
        return;
    }
    let scene = built_in("cube-enclosure:10").unwrap();
    let p = Prepared::new(&scene);
    let opts = itgfx_backends::visibility::LineOptions { lines: 100_000, seed: 1, local: false, blocks: 8, offset: 0 };
    let run = |choice| {
        let t = open(choice, &p).unwrap();
        let c = itgfx_backends::visibility::count_visibility(&scene, &p, t.as_ref(), &opts, &mut |_, _| {}).unwrap();
        c.complexity(itgfx_core::Base::Bits)
    };
    assert_eq!(run(BackendChoice::Cpu), run(BackendChoice::Vulkan));
}

/// The device entropy of 2^20 + 7 weights (two invocation tails) agrees with
/// the core's f64 entropy to 1e-6 relative (f32 logarithms on the device), and
/// bad input is refused with its index.
#[test]
fn vulkan_entropy_matches_the_core() {
    if !backends().contains(&BackendChoice::Vulkan) {
        return;
    }
    use itgfx_backends::vulkan::reduce::{EntropyReducer, ReduceError};
    let mut r = EntropyReducer::new().unwrap();
    let n = (1 << 20) + 7;
    let w: Vec<f32> = (0..n).map(|i| ((i as u32).wrapping_mul(2_654_435_761) >> 8) as f32 * 1e-3).collect();
    let core =
        itgfx_core::entropy_of_weights(&w.iter().map(|&x| f64::from(x)).collect::<Vec<_>>(), itgfx_core::Base::Bits)
            .unwrap();
    let gpu = r.entropy(&w, itgfx_core::Base::Bits).unwrap();
    assert!((gpu - core).abs() <= 1e-6 * core, "device {gpu} vs core {core}");
    let mut bad = w.clone();
    bad[777_777] = -1.0;
    assert_eq!(r.entropy(&bad, itgfx_core::Base::Bits), Err(ReduceError::Invalid { index: 777_777 }));
    assert_eq!(r.entropy(&[0.0; 10], itgfx_core::Base::Bits), Err(ReduceError::ZeroMass));
}
