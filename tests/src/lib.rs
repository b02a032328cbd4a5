//! Helpers shared by the cross-crate tests.

use itgfx_backends::scene::{Scene, built_in};
use itgfx_backends::tracer::Prepared;
use itgfx_backends::visibility::{Complexity, LineOptions, VisibilityCounts, count_visibility};
use itgfx_backends::{BackendChoice, open};
use itgfx_core::Base;

/// Counts the visibility channel of a built-in scene on a backend.
///
/// # Panics
/// On a bad spec or a backend failure (test helper).
#[must_use]
pub fn run(
    spec: &str,
    lines: u64,
    seed: u64,
    local: bool,
    backend: BackendChoice,
) -> (Scene, VisibilityCounts, Complexity) {
    let scene = built_in(spec).expect("built-in scene");
    run_scene(scene, lines, seed, local, backend)
}

/// As [`run`] for a scene value.
///
/// # Panics
/// On a backend failure (test helper).
#[must_use]
pub fn run_scene(
    scene: Scene,
    lines: u64,
    seed: u64,
    local: bool,
    backend: BackendChoice,
) -> (Scene, VisibilityCounts, Complexity) {
    let prepared = Prepared::new(&scene);
    let tracer = open(backend, &prepared).expect("backend");
    let counts = count_visibility(
        &scene,
        &prepared,
        tracer.as_ref(),
        &LineOptions { lines, seed, local, blocks: 8, offset: 0 },
        &mut |_, _| {},
    )
    .expect("trace");
    let c = counts.complexity(Base::Bits);
    (scene, counts, c)
}
