//! The viewpoint channel of Part V on real geometry.

use glam::DVec3;
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::{BackendChoice, Prepared, open};
use itgfx_backends::viewpoint::{ViewpointChannel, ViewpointWeights, icosphere};
use itgfx_core::Base;

fn solid_cube() -> Scene {
    let mut s = Scene::default();
    s.materials.push(Default::default());
    s.add_box("cube", DVec3::splat(-1.0), DVec3::splat(1.0), 1, false, 0);
    s.validate().unwrap();
    s
}

/// 6 face directions, then 8 corners, then 12 edge midpoints.
fn cube_directions() -> Vec<DVec3> {
    let mut d = Vec::new();
    for k in 0..3 {
        for s in [-1.0, 1.0] {
            let mut v = [0.0; 3];
            v[k] = s;
            d.push(DVec3::from_array(v));
        }
    }
    for x in [-1.0, 1.0] {
        for y in [-1.0, 1.0] {
            for z in [-1.0, 1.0] {
                d.push(DVec3::new(x, y, z).normalize());
            }
        }
    }
    for k in 0..3 {
        for a in [-1.0, 1.0] {
            for b in [-1.0, 1.0] {
                let mut v = [0.0; 3];
                v[(k + 1) % 3] = a;
                v[(k + 2) % 3] = b;
                d.push(DVec3::from_array(v).normalize());
            }
        }
    }
    d
}

#[test]
fn icosphere_sizes() {
    for (level, n) in [(0, 12), (1, 42), (2, 162), (3, 642)] {
        let v = icosphere(level);
        assert_eq!(v.len(), n);
        assert!(v.iter().all(|p| (p.length() - 1.0).abs() < 1e-12));
    }
}

/// Part V (issue 5): a cube's VMI is minimal at the 8 corner directions and
/// maximal at the 6 face-on ones, equal within each symmetry class.
#[test]
fn cube_best_views_are_corners() {
    let scene = solid_cube();
    let p = Prepared::new(&scene);
    let tracer = open(BackendChoice::Cpu, &p).unwrap();
    let dirs = cube_directions();
    let ch = ViewpointChannel::build(&p, tracer.as_ref(), &dirs, 3.0, 96).unwrap();
    let m = ch.measures(&scene.areas(), ViewpointWeights::ProjectedArea, Base::Bits);
    let vmi = &m.mutual_information;
    let faces = &vmi[0..6];
    let corners = &vmi[6..14];
    let spread = |x: &[f64]| {
        x.iter().copied().fold(f64::NEG_INFINITY, f64::max) - x.iter().copied().fold(f64::INFINITY, f64::min)
    };
    assert!(spread(faces) < 1e-3 && spread(corners) < 1e-3, "symmetric views, symmetric measures: {vmi:?}");
    assert!((6..14).contains(&m.best), "best view {} is a corner", m.best);
    assert!(m.worst < 6, "worst view {} is face-on", m.worst);
    // From a face direction one face fills the view: VE = 0; from a corner, three faces.
    assert!(m.entropy[0] < 1e-9);
    assert!((m.entropy[6] - 3f64.log2()).abs() < 0.02, "{}", m.entropy[6]);
    // I(V;O) = Σ p(v) I(v;O) (Part V eq. (6)).
    let s: f64 = m.weight.iter().zip(vmi).filter(|(w, _)| **w > 0.0).map(|(w, i)| w * i).sum();
    assert!((s - m.total_mutual_information).abs() < 1e-9);
    // Identical views are not dissimilar; a face view and its opposite share no polygon.
    assert!(ch.dissimilarity(6, 6, (0.5, 0.5), Base::Bits).abs() < 1e-12);
    assert!((ch.dissimilarity(0, 1, (0.5, 0.5), Base::Bits) - 1.0).abs() < 1e-9);
}

/// The estimate converges as the angular resolution grows.
#[test]
fn converges_with_resolution() {
    let scene = solid_cube();
    let p = Prepared::new(&scene);
    let tracer = open(BackendChoice::Cpu, &p).unwrap();
    let dirs = icosphere(1);
    let vmi = |r: u32| {
        let ch = ViewpointChannel::build(&p, tracer.as_ref(), &dirs, 3.0, r).unwrap();
        ch.measures(&scene.areas(), ViewpointWeights::Uniform, Base::Bits).mutual_information
    };
    let (a, b, c) = (vmi(32), vmi(64), vmi(128));
    let d = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
    assert!(d(&b, &c) < d(&a, &b), "{} then {}", d(&a, &b), d(&b, &c));
    assert!(d(&b, &c) < 0.01);
}
