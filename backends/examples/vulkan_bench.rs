//! Lavapipe (or any Vulkan device) against the CPU backend in one run:
//! `cargo run --release -p itgfx-backends --example vulkan_bench -- [LINES] [ELEMENTS]`.
//! Prints lines/s for tracing global lines through cube-enclosure:10 and
//! elements/s for the entropy of an f32 array.

use std::time::Instant;

use itgfx_backends::lines::global_line;
use itgfx_backends::scene::built_in;
use itgfx_backends::tracer::{BackendChoice, CrossingBuffer, Prepared, open};
use itgfx_backends::visibility::SPHERE_SCALE;
use itgfx_backends::vulkan::reduce::EntropyReducer;
use rayon::prelude::*;

fn main() {
    let mut args = std::env::args().skip(1);
    let lines: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(1_000_000);
    let elements: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1 << 24);
    let scene = built_in("cube-enclosure:10").expect("scene");
    let p = Prepared::new(&scene);
    let ls: Vec<_> = (0..lines).map(|i| global_line(1, i, SPHERE_SCALE)).collect();
    for choice in [BackendChoice::Cpu, BackendChoice::Vulkan] {
        let t = match open(choice, &p) {
            Ok(t) => t,
            Err(e) => {
                println!("{choice:?}: {e}");
                continue;
            }
        };
        // Warm-up (shader compilation happens at the first dispatch).
        let mut buf = CrossingBuffer::default();
        t.trace_all(&ls[..1024], &mut buf).expect("trace");
        let t0 = Instant::now();
        let crossings: usize = ls
            .par_chunks(16_384)
            .map(|c| {
                let mut buf = CrossingBuffer::default();
                t.trace_all(c, &mut buf).expect("trace");
                buf.crossings.len()
            })
            .sum();
        let s = t0.elapsed().as_secs_f64();
        println!(
            "trace {:<9} {lines} lines  {s:.3} s  {:.3} Mlines/s  {crossings} crossings",
            t.name(),
            lines as f64 / s / 1e6
        );
    }
    let w: Vec<f32> = (0..elements).map(|i| ((i as u32).wrapping_mul(2_654_435_761) >> 8) as f32).collect();
    let w64: Vec<f64> = w.iter().map(|&x| f64::from(x)).collect();
    let t0 = Instant::now();
    let h = itgfx_core::entropy_of_weights(&w64, itgfx_core::Base::Bits).expect("entropy");
    let s = t0.elapsed().as_secs_f64();
    println!(
        "entropy core(f64, 1 thread) {elements} elements  {s:.4} s  {:.0} Melem/s  H = {h:.9}",
        elements as f64 / s / 1e6
    );
    match EntropyReducer::new() {
        Ok(mut r) => {
            r.entropy(&w[..1024], itgfx_core::Base::Bits).expect("warm-up");
            let t0 = Instant::now();
            let hv = r.entropy(&w, itgfx_core::Base::Bits).expect("entropy");
            let s = t0.elapsed().as_secs_f64();
            println!(
                "entropy vulkan ({})  {elements} elements  {s:.4} s  {:.0} Melem/s  H = {hv:.9}",
                r.device().name,
                elements as f64 / s / 1e6
            );
        }
        Err(e) => println!("vulkan entropy: {e}"),
    }
}
