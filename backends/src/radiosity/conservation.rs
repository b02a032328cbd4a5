//! Conservation checks on closed scenes with occluders (tests only): every
//! ray leaving a surface lands on one, so each receiver's form factors sum
//! to 1 and, with uniform `ρ` and `E`, `B = E / (1 − ρ)` everywhere and the
//! power absorbed equals the power emitted.

use glam::DVec3;

use super::Oracle;
use super::element::{ElementId, Hierarchy};
use super::link::{Sampler, Stage, facing};
use super::refine::{Settings, solve};
use crate::scene::{Material, Scene};
use crate::tracer::{CpuTracer, Prepared};

/// The closed unit cube (faces inward) with a block floating inside it
/// (faces outward, 0.05 above the floor): uniform `ρ`, and `E` on every
/// face or, with `ceiling_only`, on the cube's ceiling alone.
fn cube_with_block(rho: f64, ceiling_only: bool) -> Scene {
    cube_with_block_at(rho, ceiling_only, 0.05)
}

/// [`cube_with_block`] with the block's bottom at height `y` (0: standing
/// on the floor, which hides the floor under it).
fn cube_with_block_at(rho: f64, ceiling_only: bool, y: f64) -> Scene {
    let mut s = Scene::named("cube with block");
    let m = |e: f64| Material { name: format!("e{e}"), reflectance: [rho; 3], emittance: [e; 3], mirror: false };
    s.materials = vec![m(if ceiling_only { 0.0 } else { 1.0 }), m(1.0)];
    s.add_box("cube", DVec3::ZERO, DVec3::ONE, 1, true, 0);
    s.add_box("block", DVec3::new(0.2, y, 0.3), DVec3::new(0.6, 0.5, 0.7), 1, false, 0);
    if ceiling_only {
        let c = s.patches.iter().position(|p| p.name.starts_with("cube y+")).expect("the cube has a ceiling");
        s.patches[c].material = 1;
    }
    s
}

/// Every polygon's form factors to the others, at 10 samples per link and
/// averaged over seeds, sum to 1 (each row within 4 standard errors, the
/// area-weighted mean within 0.5 %): half of the cube's faces see the block,
/// so visibility is partial on most links. Before, the visible fraction was
/// counted by area instead of weighted by the kernel and a pair facing away
/// told nothing: the floor-to-ceiling factor came out 14 % low at any
/// sample count.
#[test]
fn rows_of_a_closed_scene_with_an_occluder_sum_to_one_at_ten_samples() {
    let scene = cube_with_block(0.5, false);
    let p = Prepared::new(&scene);
    let t = CpuTracer::new(&p);
    let h = Hierarchy::new(&scene);
    let roots: Vec<ElementId> = h.roots.iter().map(|r| r.element).collect();
    let seeds = 1024;
    let (mut total, mut area) = (0.0, 0.0);
    for &i in &roots {
        let pairs: Vec<(ElementId, ElementId)> = roots.iter().filter(|&&j| facing(&h, i, j)).map(|&j| (i, j)).collect();
        let (mut row, mut square) = (0.0, 0.0);
        for seed in 0..seeds {
            let s = Sampler {
                prepared: &p,
                tracer: &t,
                oracle: Oracle::Power,
                samples: 10,
                seed,
                total_area: scene.total_area(),
            };
            let (links, _) = s.evaluate(&h, &pairs, Stage::Transport).unwrap();
            let r: f64 = links.iter().map(|l| l.form_factor).sum();
            row += r / seeds as f64;
            square += r * r / seeds as f64;
        }
        let se = ((square - row * row) / seeds as f64).sqrt();
        let name = &scene.patches[h.roots[i as usize].patch as usize].name;
        assert!((row - 1.0).abs() < 4.0 * se.max(1e-4), "{name}: row sums to {row} ± {se}");
        let a = h.elements[i as usize].area;
        total += a * row;
        area += a;
    }
    assert!((total / area - 1.0).abs() < 0.005, "mean row {}", total / area);
}

/// The fraction of each polygon's emitted power that the final links carry
/// (`Σ A_i F_ij / A_j` over the links leaving it and its ancestors,
/// area-weighted over the polygon): 1 in a closed scene with nothing hidden,
/// at any refinement, in expectation.
fn carried(s: &super::Solution) -> Vec<f64> {
    let h = &s.hierarchy;
    let mut out = vec![0.0f64; h.elements.len()];
    for l in &s.links {
        let (ri, sj) = (&h.elements[l.receiver as usize], &h.elements[l.source as usize]);
        out[l.source as usize] += ri.area * l.form_factor / sj.area;
    }
    fn down(h: &Hierarchy, out: &[f64], e: ElementId, above: f64) -> f64 {
        let here = above + out[e as usize];
        match h.elements[e as usize].children {
            None => h.elements[e as usize].area * here,
            Some(c) => (c..c + 4).map(|k| down(h, out, k, here)).sum(),
        }
    }
    h.roots.iter().map(|r| down(h, &out, r.element, 0.0) / h.elements[r.element as usize].area).collect()
}

/// After a solve at 10 samples per link, the final links carry all the power
/// every polygon emits (a closed scene lit by its ceiling, with an
/// occluder): all polygons together within 0.5 %, each within 4 standard
/// errors (16 seeds; a small source's sender row is noisy, its receivers
/// being larger than itself). Before, refinement dropped every link whose
/// 10 samples happened to see nothing (a partly visible pair survived with
/// probability `1 − (1 − p)^10` only) and the estimate weighted visibility
/// by area; the same check on the Cornell box carried 0.92-0.99 of each
/// wall's and block side's power.
#[test]
fn final_links_carry_all_the_power_of_a_closed_scene_at_ten_samples() {
    let scene = cube_with_block(0.5, true);
    let p = Prepared::new(&scene);
    let t = CpuTracer::new(&p);
    let seeds = 16;
    let h = Hierarchy::new(&scene);
    let areas: Vec<f64> = h.roots.iter().map(|r| h.elements[r.element as usize].area).collect();
    let (mut mean, mut square) = (vec![0.0; areas.len()], vec![0.0; areas.len()]);
    let mut total = 0.0;
    for seed in 0..seeds {
        let settings =
            Settings { oracle: Oracle::KullbackLeibler, epsilon: 1e-3, samples: 10, seed, ..Settings::default() };
        let s = solve(&scene, &p, &t, &settings).unwrap();
        assert!(s.leaves().len() > 300, "refined: {} leaves", s.leaves().len());
        let c = carried(&s);
        total += c.iter().zip(&areas).map(|(m, a)| m * a).sum::<f64>() / areas.iter().sum::<f64>() / seeds as f64;
        for r in 0..c.len() {
            mean[r] += c[r] / seeds as f64;
            square[r] += c[r] * c[r] / seeds as f64;
        }
    }
    for r in 0..mean.len() {
        let se = ((square[r] - mean[r] * mean[r]) / (seeds - 1) as f64).sqrt();
        let name = &scene.patches[h.roots[r].patch as usize].name;
        assert!((mean[r] - 1.0).abs() < (4.0 * se).max(0.005), "{name} carries {} ± {se}", mean[r]);
    }
    assert!((total - 1.0).abs() < 0.005, "all together {total}");
}

/// Absorbed over emitted power of a solve.
fn balance(s: &super::Solution) -> f64 {
    let (emitted, absorbed) = s.power_balance();
    absorbed[0] / emitted[0]
}

/// A closed scene absorbs what it emits, within 0.5 %, in one solve at the
/// tutorial's 10 samples per link: the cube lit by its ceiling, with a block
/// standing on the floor (hiding the floor under it) or floating. Measured:
/// 0.9996-0.9998; plain push-pull (`front_rays: 0`) 0.983-0.998 on the same
/// four solves (the floor's coarse elements spread what they receive over
/// the hidden part too, and leaves send through their ancestors' links the
/// ancestors' mean form factor, not their own); see `gather::Conservation`.
#[test]
fn a_closed_scene_absorbs_what_it_emits_within_half_a_percent() {
    for y in [0.0, 0.05] {
        let scene = cube_with_block_at(0.5, true, y);
        let p = Prepared::new(&scene);
        let t = CpuTracer::new(&p);
        for seed in [1, 2] {
            let settings =
                Settings { oracle: Oracle::KullbackLeibler, epsilon: 1e-3, samples: 10, seed, ..Settings::default() };
            let s = solve(&scene, &p, &t, &settings).unwrap();
            let plain = solve(&scene, &p, &t, &Settings { front_rays: 0, ..settings }).unwrap();
            eprintln!(
                "block at {y}, seed {seed}: {} leaves, balance {} (plain push-pull {})",
                s.leaves().len(),
                balance(&s),
                balance(&plain)
            );
            assert!(s.leaves().len() > 300, "refined: {} leaves", s.leaves().len());
            assert!((balance(&s) - 1.0).abs() < 0.005, "block at {y}, seed {seed}: {}", balance(&s));
            // With shares (each transport sample gathers its source leaf's
            // radiosity; the weights count each share at its leaf).
            let shared = solve(&scene, &p, &t, &Settings { shares: true, ..settings }).unwrap();
            eprintln!("  with shares: balance {}", balance(&shared));
            assert!((balance(&shared) - 1.0).abs() < 0.005, "shares, block at {y}, seed {seed}: {}", balance(&shared));
        }
    }
}

/// The glowing cube (`ρ = 0.5`, `E = 1` everywhere) has `B = 2` exactly;
/// with many samples per link (form factors near exact) plain push-pull
/// gave a mean `B` above 2 by more than its noise (2.012 at 625 elements,
/// 1,000 samples), because each leaf gathers and sends through its
/// ancestors' links with the ancestors' mean form factor. Measured here
/// (96 leaves, 400 samples per link): plain 2.0198, conserving 2.0000 (in a
/// closed scene `T_ℓ = 1`, so the mean is `E / (1 − ρ)` at convergence
/// whatever the form factors' noise).
#[test]
fn the_glowing_cube_keeps_its_mean_with_near_exact_form_factors() {
    let scene = super::refine::tests::glowing_cube(1, 0.5, 1.0);
    let p = Prepared::new(&scene);
    let t = CpuTracer::new(&p);
    let mean = |s: &super::Solution| {
        let (mut ab, mut a) = (0.0, 0.0);
        for &e in &s.leaves() {
            let el = &s.hierarchy.elements[e as usize];
            ab += el.area * s.radiosity[e as usize][0];
            a += el.area;
        }
        ab / a
    };
    let settings = Settings { epsilon: 3e-3, samples: 400, seed: 5, ..Settings::default() };
    let s = solve(&scene, &p, &t, &settings).unwrap();
    let plain = solve(&scene, &p, &t, &Settings { front_rays: 0, ..settings }).unwrap();
    eprintln!(
        "{} leaves: mean B {} balance {} (plain: {} leaves, mean B {}, balance {})",
        s.leaves().len(),
        mean(&s),
        balance(&s),
        plain.leaves().len(),
        mean(&plain),
        balance(&plain)
    );
    assert!(s.leaves().len() > 50, "refined: {}", s.leaves().len());
    assert!((mean(&s) - 2.0).abs() < 0.004, "mean B {}", mean(&s));
    assert!((balance(&s) - 1.0).abs() < 0.002, "balance {}", balance(&s));
}

/// Two unoccluded links of the cube with a floating block (the block's top
/// from the ceiling, the cube's `x−` wall from the block's `x−` side): the
/// link estimator at 10 samples (mean of 2,000 seeds), cosine-weighted ray
/// casting (200,000 rays from uniform receiver points, the fraction whose
/// first hit is the source's front) and the exact factor (a 200 × 200
/// midpoint rule over the receiver of Lambert's point-to-polygon formula)
/// agree within 3 standard errors (measured: 0.52189 exact, 0.52177 ±
/// 0.00017 estimator, 0.52097 ± 0.00112 cast; 0.14433, 0.14485 ± 0.00114,
/// 0.14471 ± 0.00079). A 1-3 % gap between exact and ray-cast factors on
/// two unoccluded links of this scene was reported before the link
/// estimator (67fefb5) and the tracer fix for rays with a `−0.0` direction
/// component (6fbfed7, which made axis-aligned rays miss flat boxes); it
/// does not reproduce here. Which of the two removed it was not measured.
#[test]
fn unoccluded_links_agree_with_the_exact_factor_and_with_ray_casting() {
    use crate::lines::{Line, LineRng, cosine_direction};
    use crate::tracer::Tracer;
    let scene = cube_with_block(0.5, false);
    let p = Prepared::new(&scene);
    let t = CpuTracer::new(&p);
    let h = Hierarchy::new(&scene);
    let root = |name: &str| {
        let r = h.roots.iter().position(|r| scene.patches[r.patch as usize].name == name).expect(name);
        (h.roots[r].element, h.roots[r].patch)
    };
    for (receiver, source) in [("block y+[0,0]", "cube y+[0,0]"), ("cube x-[0,0]", "block x-[0,0]")] {
        let ((i, _), (j, pj)) = (root(receiver), root(source));
        let (ei, ej) = (&h.elements[i as usize], &h.elements[j as usize]);
        let m = 200;
        let mut exact = 0.0;
        for a in 0..m {
            for b in 0..m {
                let x = h.roots[ei.root as usize]
                    .shape
                    .point(glam::DVec2::new((f64::from(a) + 0.5) / f64::from(m), (f64::from(b) + 0.5) / f64::from(m)));
                exact += super::link::point_to_polygon(x, ei.normal, &ej.points[..usize::from(ej.corners)]);
            }
        }
        exact /= f64::from(m * m);
        let seeds = 2000;
        let (mut est, mut sq) = (0.0, 0.0);
        for seed in 0..seeds {
            let s = Sampler { prepared: &p, tracer: &t, oracle: Oracle::Power, samples: 10, seed, total_area: 1.0 };
            let (links, _) = s.evaluate(&h, &[(i, j)], Stage::Transport).unwrap();
            let f = links.first().map_or(0.0, |l| l.form_factor);
            est += f / seeds as f64;
            sq += f * f / seeds as f64;
        }
        let se_est = ((sq - est * est) / (seeds - 1) as f64).sqrt();
        let n = 200_000u64;
        let lines: Vec<Line> = (0..n)
            .map(|k| {
                let r = LineRng::new(11, k);
                let x = p.to_normalised(ei.sample(r.uniform(0), r.uniform(1)));
                Line::ray(x, cosine_direction(ei.normal, r.uniform(2), r.uniform(3)), 1e-6, 4.0)
            })
            .collect();
        let mut hits = Vec::new();
        t.closest_hit(&lines, &mut hits).unwrap();
        let cast = hits.iter().filter(|h| h.is_some_and(|h| h.patch == pj && h.cos < 0.0)).count() as f64 / n as f64;
        let se_cast = (cast * (1.0 - cast) / n as f64).sqrt();
        eprintln!(
            "{receiver} <- {source}: exact {exact:.5}, estimator {est:.5} ± {se_est:.5}, cast {cast:.5} ± {se_cast:.5}"
        );
        assert!((est - exact).abs() < 3.0 * se_est, "{receiver} <- {source}: estimator {est} ± {se_est} vs {exact}");
        assert!((cast - exact).abs() < 3.0 * se_cast, "{receiver} <- {source}: cast {cast} ± {se_cast} vs {exact}");
    }
}
