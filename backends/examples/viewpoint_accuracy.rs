//! How close the viewpoint channel's estimates come to a brute-force one.
//!
//! `cargo run --release -p itgfx-backends --example viewpoint_accuracy -- MESH [LEVEL] [R_REF] [R...]`
//!
//! Builds the channel of MESH (OBJ or built-in) at the icosphere LEVEL
//! (default 2: 162 viewpoints) with the exact-solid-angle estimator (its
//! default tolerance) and with the ray grid at each R, and compares every
//! viewpoint's VMI with a brute-force reference: the ray grid at R_REF
//! (default 2048) and at R_REF/2, extrapolated to infinite resolution by
//! Richardson's rule (the grid's bias falls as 1/R², the number of rays:
//! `(4 V(R) − V(R/2)) / 3`). Prints the max and mean relative difference,
//! `I(V;O)`, the best view, seconds.

use std::time::Instant;

use itgfx_backends::tracer::Prepared;
use itgfx_backends::viewpoint::solid_angle::Refinement;
use itgfx_backends::viewpoint::{ViewpointAnalysis, ViewpointChannel, ViewpointWeights, icosphere};
use itgfx_backends::{BackendChoice, open};
use itgfx_core::Base;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spec = args.first().expect("MESH");
    let level: u32 = args.get(1).map_or(2, |s| s.parse().expect("LEVEL"));
    let r_ref: u32 = args.get(2).map_or(2048, |s| s.parse().expect("R_REF"));
    let grids: Vec<u32> = args.iter().skip(3).map(|s| s.parse().expect("R")).collect();
    let scene = if spec.ends_with(".obj") {
        itgfx_backends::obj::load_obj(std::path::Path::new(spec)).expect("mesh")
    } else {
        itgfx_backends::scene::built_in(spec).expect("scene")
    };
    let p = Prepared::new(&scene);
    let tracer = open(BackendChoice::Cpu, &p).expect("backend");
    let dirs = icosphere(level);
    let areas = scene.areas();
    let measure = |ch: &ViewpointChannel| {
        let an = ViewpointAnalysis::new(ch, ViewpointWeights::ProjectedArea, false).expect("seen");
        an.measures(&areas, Base::Bits).expect("measures")
    };
    let t = Instant::now();
    let grid = |r: u32| measure(&ViewpointChannel::build(&p, tracer.as_ref(), &dirs, 3.0, r, &mut |_, _| {}).unwrap());
    let (fine, half) = (grid(r_ref), grid(r_ref / 2));
    let extrapolate = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (4.0 * x - y) / 3.0).collect::<Vec<f64>>();
    let mut reference = fine.clone();
    reference.mutual_information = extrapolate(&fine.mutual_information, &half.mutual_information);
    reference.total_mutual_information = (4.0 * fine.total_mutual_information - half.total_mutual_information) / 3.0;
    reference.best = (0..dirs.len())
        .min_by(|&a, &b| reference.mutual_information[a].total_cmp(&reference.mutual_information[b]))
        .unwrap_or(0);
    println!(
        "{spec}: {} triangles, {} viewpoints; reference: grids R={r_ref} and R={} (I(V;O) {:.4} and {:.4} bits) extrapolated: I(V;O) {:.4} bits, best view {}, {:.1} s",
        p.triangles.len(),
        dirs.len(),
        r_ref / 2,
        fine.total_mutual_information,
        half.total_mutual_information,
        reference.total_mutual_information,
        reference.best,
        t.elapsed().as_secs_f64()
    );
    let compare = |name: String, m: &itgfx_backends::viewpoint::ViewpointMeasures, secs: f64| {
        let rel: Vec<f64> =
            m.mutual_information.iter().zip(&reference.mutual_information).map(|(a, b)| ((a - b) / b).abs()).collect();
        let max = rel.iter().copied().fold(0.0, f64::max);
        let mean = rel.iter().sum::<f64>() / rel.len() as f64;
        println!(
            "{name:>24}: VMI rel. diff max {:.2}% mean {:.2}%, I(V;O) {:.4} bits, best view {}, {secs:.1} s",
            100.0 * max,
            100.0 * mean,
            m.total_mutual_information,
            m.best
        );
    };
    for r in grids {
        let t = Instant::now();
        let m = measure(&ViewpointChannel::build(&p, tracer.as_ref(), &dirs, 3.0, r, &mut |_, _| {}).unwrap());
        compare(format!("grid R={r}"), &m, t.elapsed().as_secs_f64());
    }
    let t = Instant::now();
    let (ch, conv) =
        ViewpointChannel::build_solid_angle(&p, tracer.as_ref(), &dirs, &Refinement::default(), &mut |_, _| {})
            .unwrap();
    let secs = t.elapsed().as_secs_f64();
    let m = measure(&ch);
    compare("solid angle (default)".into(), &m, secs);
    let met = conv.met.iter().filter(|&&x| x).count();
    let se_rel = conv
        .vmi_stderr
        .iter()
        .zip(&m.mutual_information)
        .map(|(s, v)| s / std::f64::consts::LN_2 / v)
        .fold(0.0, f64::max);
    println!(
        "{:>24}  tolerance met at {met}/{} viewpoints, max SE/VMI {:.3}%, {} rays, {} boundary triangles",
        "",
        conv.met.len(),
        100.0 * se_rel,
        conv.rays,
        conv.boundary_triangles
    );
}
