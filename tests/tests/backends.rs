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

/// The CPU backend finds exactly the reference's crossings (same patches,
/// same t to the bit: both use the same watertight test; the BVH only prunes).
fn agrees(scene: &Scene, n: u64) {
    let ls = lines(n, 11);
    let cpu = crossings(scene, BackendChoice::Cpu, &ls).unwrap();
    let reference = crossings(scene, BackendChoice::Reference, &ls).unwrap();
    for i in 0..ls.len() {
        let (a, b) = (cpu.line(i), reference.line(i));
        assert_eq!(a, b, "{}: line {i} differs", scene.name);
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
        "sphere:4,8",
    ] {
        agrees(&built_in(spec).unwrap(), 3000);
    }
}

#[test]
fn vulkan_is_a_clear_error_in_this_build() {
    let s = built_in("cube").unwrap();
    match open(BackendChoice::Vulkan, &Prepared::new(&s)) {
        Err(BackendError::Unavailable { backend: "vulkan", reason }) => assert!(reason.contains("--backend cpu")),
        Err(e) => panic!("{e}"),
        Ok(_) => {}
    }
}
