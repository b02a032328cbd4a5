//! Backend conformance: every backend against the brute-force reference
//! tracer on the same lines, degenerate scenes first.

use glam::DVec3;
use itgfx_backends::lines::{Line, LineRng, global_line};
use itgfx_backends::scene::{Scene, built_in};
use itgfx_backends::tracer::{CrossingBuffer, Hit, Prepared, Tracer};
use itgfx_backends::visibility::SPHERE_SCALE;
use itgfx_backends::{BackendChoice, open};

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

/// Rays from points inside the scene's box in random directions, cut short
/// at a random `tmax`: closest hits that stop early, and occlusion that is
/// often false.
fn inner_rays(n: u64, seed: u64) -> Vec<Line> {
    (0..n)
        .map(|i| {
            let r = LineRng::new(seed, i);
            let o = DVec3::new(r.uniform(0), r.uniform(1), r.uniform(2)) - 0.5;
            let d = r.sphere_point(3);
            Line::ray(o, d, 0.0, 0.05 + 2.0 * r.uniform(40))
        })
        .collect()
}

/// Shadow rays as the viewpoint channel casts them, in coherent groups of
/// eight from one eye (outside the scene or inside its box) towards points
/// of one triangle each: its vertices (where edge functions are exactly
/// zero), edge midpoints, centroid and random points, stopping just short
/// of the point, at it, or beyond it. Groups of eight are what the CPU
/// backend walks as one packet.
fn coherent_rays(p: &Prepared, n: u64, seed: u64) -> Vec<Line> {
    let tris = &p.triangles;
    if tris.is_empty() {
        return Vec::new(); // the analytic sphere
    }
    let d = |v: glam::Vec3A| DVec3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z));
    (0..n.div_ceil(8))
        .flat_map(|g| {
            let r = LineRng::new(seed, g);
            let eye = if g % 3 == 0 {
                DVec3::new(r.uniform(0), r.uniform(1), r.uniform(2)) - 0.5
            } else {
                r.sphere_point(10) * 3.0
            };
            let t = tris[(r.uniform(5) * tris.len() as f64) as usize % tris.len()].map(d);
            let stop = [1.0 - 1e-5, 1.0, 1.5][(g % 3) as usize];
            (0..8).map(move |i| {
                let q = match i {
                    0..3 => t[i],
                    3..6 => (t[i - 3] + t[(i - 2) % 3]) * 0.5,
                    6 => (t[0] + t[1] + t[2]) / 3.0,
                    _ => {
                        let (a, b) = (r.uniform(6), r.uniform(7));
                        let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                        t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b
                    }
                };
                let to = q - eye;
                let len = to.length().max(1e-9);
                Line::ray(eye, to / len, 0.0, len * stop)
            })
        })
        .take(n as usize)
        .collect()
}

/// Rays with exactly zero direction components, positive and negative
/// (along the axes and in the coordinate planes), from points whose
/// coordinates are often on a grid of eighths: boxes flat across an axis
/// seen head-on, and the slab test's sign-of-zero cases.
fn axis_rays(n: u64, seed: u64) -> Vec<Line> {
    let dirs: Vec<DVec3> = {
        let mut d = Vec::new();
        for a in [-1.0, -0.0, 0.0, 1.0] {
            for b in [-1.0, -0.0, 0.0, 1.0] {
                for c in [-1.0, -0.0, 0.0, 1.0] {
                    let v = DVec3::new(a, b, c);
                    if v.length() > 0.0 {
                        // Keep each zero's sign: normalise the non-zero parts only.
                        let n = v.length();
                        d.push(DVec3::new(a / n, b / n, c / n));
                    }
                }
            }
        }
        d
    };
    (0..n)
        .map(|i| {
            let r = LineRng::new(seed, i);
            // Each coordinate on a grid of eighths half the time, random otherwise.
            let c = |k: u32| {
                let u = r.uniform(k);
                if r.uniform(k + 10) < 0.5 { (u * 8.0).floor() / 8.0 - 0.5 } else { u - 0.5 }
            };
            let o = DVec3::new(c(0), c(1), c(2));
            let d = dirs[(r.uniform(3) * dirs.len() as f64) as usize % dirs.len()];
            Line::ray(o, d, 0.0, 4.0)
        })
        .collect()
}

/// Rays at every triangle of `scene` along its normal, from both sides and
/// just off the surface: a wall met head-on. (obvhs missed axis-aligned walls
/// from rays with a `-0.0` direction component; the radiosity patch check
/// found it on cornell-box.)
fn head_on_rays(scene: &Scene, p: &Prepared, per_triangle: u64) -> Vec<Line> {
    let mut ls = Vec::new();
    for (t, tri) in scene.triangles.iter().enumerate() {
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        let mut back = Vec::new();
        for k in 0..per_triangle {
            let r = LineRng::new(5, k + per_triangle * t as u64);
            let (mut a, mut b) = (r.uniform(0), r.uniform(1));
            if a + b > 1.0 {
                (a, b) = (1.0 - a, 1.0 - b);
            }
            let x = p.to_normalised(tri[0] + (tri[1] - tri[0]) * a + (tri[2] - tri[0]) * b);
            ls.push(Line::ray(x + n * 1e-3, -n, 0.0, 2e-3));
            back.push(Line::ray(x - n * 1e-3, n, 0.0, 2e-3));
        }
        // Parallel runs of one direction: what the CPU walks as packets.
        ls.append(&mut back);
    }
    ls
}

fn queries(t: &dyn Tracer, ls: &[Line]) -> (CrossingBuffer, Vec<Option<Hit>>, Vec<bool>) {
    let (mut all, mut first, mut any) = (CrossingBuffer::default(), Vec::new(), Vec::new());
    t.trace_all(ls, &mut all).unwrap();
    t.closest_hit(ls, &mut first).unwrap();
    t.occluded(ls, &mut any).unwrap();
    (all, first, any)
}

/// Every backend answers all three queries exactly as the reference does
/// (same patches, same t to the bit: all use the same watertight test, the
/// BVH only prunes, and the Vulkan kernel returns the numerator and
/// determinant for the host to finish as the CPU does), and the three
/// queries agree with each other: the closest hit is the first crossing and
/// a line is occluded when it crosses anything.
fn agrees(scene: &Scene, n: u64) {
    let p = Prepared::new(scene);
    let reference = open(BackendChoice::Reference, &p).unwrap();
    let head_on = head_on_rays(scene, &p, (n / scene.triangles.len().max(1) as u64).clamp(2, 50));
    for ls in [lines(n, 11), inner_rays(n, 12), coherent_rays(&p, n, 13), axis_rays(n, 14), head_on] {
        let (r_all, r_first, r_any) = queries(reference.as_ref(), &ls);
        for (i, l) in ls.iter().enumerate() {
            let line = r_all.line(i);
            let first = line.first().map(|c| (c.t, c.patch, c.primitive, c.cos));
            assert_eq!(r_first[i].map(|h| (h.t, h.patch, h.primitive, h.cos)), first, "{}: line {i}", scene.name);
            assert_eq!(r_any[i], !line.is_empty(), "{}: line {i}", scene.name);
            if let (Some(h), None) = (r_first[i], &scene.sphere) {
                // The barycentric point is the hit point.
                let v = p.triangles[h.primitive as usize];
                let [b1, b2] = h.barycentric;
                let at = v[0] * (1.0 - b1 - b2) + v[1] * b1 + v[2] * b2;
                let o = glam::Vec3A::from(l.origin) + glam::Vec3A::from(l.direction) * h.t;
                assert!((at - o).length() < 1e-4, "{}: line {i}: {at} vs {o}", scene.name);
            }
        }
        for choice in backends() {
            let t = open(choice, &p).unwrap();
            let (all, first, any) = queries(t.as_ref(), &ls);
            for i in 0..ls.len() {
                assert_eq!(all.line(i), r_all.line(i), "{} on {choice:?}: line {i} differs", scene.name);
            }
            assert_eq!(first, r_first, "{} on {choice:?}: closest hits differ", scene.name);
            assert_eq!(any, r_any, "{} on {choice:?}: occlusion differs", scene.name);
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
    use itgfx_backends::vulkan::reduce::{ReduceError, Reducer};
    let mut r = Reducer::new().unwrap();
    let n = (1 << 20) + 7;
    let w: Vec<f32> = (0..n).map(|i| ((i as u32).wrapping_mul(2_654_435_761) >> 8) as f32 * 1e-3).collect();
    let core =
        itgfx_core::entropy_of_weights(&w.iter().map(|&x| f64::from(x)).collect::<Vec<_>>(), itgfx_core::Base::Bits)
            .unwrap();
    let gpu = r.entropy(&w, itgfx_core::Base::Bits).unwrap();
    assert!((gpu - core).abs() <= 1e-6 * core, "device {gpu} vs core {core}");
    let mut bad = w.clone();
    bad[777_777] = -1.0;
    assert_eq!(
        r.entropy(&bad, itgfx_core::Base::Bits),
        Err(ReduceError::Measure(itgfx_core::Error::Negative { index: 777_777 }))
    );
    assert_eq!(r.entropy(&[0.0; 10], itgfx_core::Base::Bits), Err(ReduceError::Measure(itgfx_core::Error::ZeroMass)));
}

/// KL and channel information on the device agree with the core's f64
/// measures to 1e-6 of the entropies involved (f32 logarithms on the device);
/// bad input gets the core's kinds of error.
#[test]
fn vulkan_divergence_and_channel_match_the_core() {
    if !backends().contains(&BackendChoice::Vulkan) {
        return;
    }
    use itgfx_backends::vulkan::reduce::{ReduceError, Reducer};
    use itgfx_core::{Base, Channel, kl_divergence};
    let mut r = Reducer::new().unwrap();
    let hash = |i: u32, s: u32| ((i.wrapping_mul(2_654_435_761) ^ s).wrapping_mul(2_246_822_519) >> 9) as f32 + 1.0;
    let norm = |v: Vec<f32>| {
        let t: f64 = v.iter().map(|&x| f64::from(x)).sum();
        v.iter().map(|&x| (f64::from(x) / t) as f32).collect::<Vec<f32>>()
    };
    let n = 300_001;
    let p = norm((0..n).map(|i| if i % 7 == 0 { 0.0 } else { hash(i, 1) }).collect());
    let q = norm((0..n).map(|i| hash(i, 2)).collect());
    let f = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>();
    let core = kl_divergence(&f(&norm(p.clone())), &f(&q), Base::Bits);
    // The core refuses f32-rounded sums beyond 1e-9: renormalise in f64 for it.
    let fp: Vec<f64> = {
        let v = f(&p);
        let t: f64 = v.iter().sum();
        v.iter().map(|x| x / t).collect()
    };
    let fq: Vec<f64> = {
        let v = f(&q);
        let t: f64 = v.iter().sum();
        v.iter().map(|x| x / t).collect()
    };
    let core = core.unwrap_or_else(|_| kl_divergence(&fp, &fq, Base::Bits).unwrap());
    let gpu = r.kl_divergence(&p, &q, Base::Bits).unwrap();
    assert!((gpu - core).abs() <= 1e-6 * (1.0 + core), "KL device {gpu} vs core {core}");
    assert_eq!(r.kl_divergence(&q, &p, Base::Bits).unwrap(), f64::INFINITY);
    let mut bad = q.clone();
    bad[123_456] = f32::NAN;
    assert_eq!(
        r.kl_divergence(&p, &bad, Base::Bits),
        Err(ReduceError::Measure(itgfx_core::Error::NonFinite { index: 123_456 }))
    );
    assert!(matches!(
        r.kl_divergence(&p, &vec![1.0; n as usize], Base::Bits),
        Err(ReduceError::Measure(itgfx_core::Error::NotNormalized { .. }))
    ));

    let (rows, cols) = (700usize, 1500usize);
    let input = norm((0..rows as u32).map(|i| hash(i, 3)).collect());
    let mut m = Vec::with_capacity(rows * cols);
    for x in 0..rows as u32 {
        m.extend(norm((0..cols as u32).map(|j| if (j + x) % 5 == 0 { 0.0 } else { hash(x * 7919 + j, 4) }).collect()));
    }
    let fin: Vec<f64> = {
        let v = f(&input);
        let t: f64 = v.iter().sum();
        v.iter().map(|x| x / t).collect()
    };
    let fm: Vec<f64> = m
        .chunks(cols)
        .flat_map(|row| {
            let v = f(row);
            let t: f64 = v.iter().sum();
            v.into_iter().map(move |x| x / t)
        })
        .collect();
    let cm = Channel::new(&fin, &fm, cols).unwrap().measures(Base::Bits);
    let g = r.channel(&input, &m, cols, Base::Bits).unwrap();
    let tol = 1e-6 * (1.0 + cm.h_y);
    assert!((g.mutual_information - cm.mutual_information).abs() <= tol, "{g:?} vs {cm:?}");
    assert!((g.h_y - cm.h_y).abs() <= tol && (g.h_y_given_x - cm.h_y_given_x).abs() <= tol, "{g:?} vs {cm:?}");
    let mut bad = m.clone();
    bad[5 * cols + 3] *= 2.0;
    assert!(matches!(
        r.channel(&input, &bad, cols, Base::Bits),
        Err(ReduceError::Measure(itgfx_core::Error::RowNotNormalized { row: 5, .. }))
    ));
    bad[5 * cols + 3] = -0.5;
    assert_eq!(
        r.channel(&input, &bad, cols, Base::Bits),
        Err(ReduceError::Measure(itgfx_core::Error::Negative { index: 5 * cols + 3 }))
    );
}
