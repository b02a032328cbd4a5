//! Lavapipe (or any Vulkan device) against the CPU backend in one run:
//! `cargo run --release -p itgfx-backends --example vulkan_bench -- [LINES] [ELEMENTS]`.
//! Prints lines/s for tracing global lines through cube-enclosure:10 and
//! elements/s for the entropy and KL divergence of f32 arrays and the mutual
//! information of a 4096 x 4096 channel, core (f64, one thread) and device.

use std::time::Instant;

use itgfx_backends::lines::global_line;
use itgfx_backends::scene::built_in;
use itgfx_backends::tracer::{CrossingBuffer, Prepared};
use itgfx_backends::visibility::SPHERE_SCALE;
use itgfx_backends::vulkan::reduce::Reducer;
use itgfx_backends::{BackendChoice, open};
use rayon::prelude::*;

/// f32 values renormalised in f64 (the core wants sums within 1e-9 of 1).
fn renorm(v: &[f32]) -> Vec<f64> {
    let t: f64 = v.iter().map(|&x| f64::from(x)).sum();
    v.iter().map(|&x| f64::from(x) / t).collect()
}

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
    // KL of two 2^24 arrays and I(X;Y) of a 4096 x 4096 channel.
    let norm = |v: Vec<f32>| {
        let t: f64 = v.iter().map(|&x| f64::from(x)).sum();
        v.iter().map(|&x| (f64::from(x) / t) as f32).collect::<Vec<f32>>()
    };
    let p = norm(w.clone());
    let q = norm((0..elements).map(|i| ((i as u32).wrapping_mul(2_246_822_519) >> 8) as f32 + 1.0).collect());
    let (p64, q64): (Vec<f64>, Vec<f64>) = (renorm(&p), renorm(&q));
    let t0 = Instant::now();
    let d = itgfx_core::kl_divergence(&p64, &q64, itgfx_core::Base::Bits).expect("kl");
    let s = t0.elapsed().as_secs_f64();
    println!(
        "kl core(f64, 1 thread) {elements} elements  {s:.4} s  {:.0} Melem/s  D = {d:.9}",
        elements as f64 / s / 1e6
    );
    let side = 4096usize;
    let input = norm((0..side).map(|i| (i % 97 + 1) as f32).collect());
    let mut m = Vec::with_capacity(side * side);
    for x in 0..side {
        m.extend(norm((0..side).map(|j| (((x * 31 + j * 17) % 101) + 1) as f32).collect()));
    }
    let m64: Vec<f64> = m.chunks(side).flat_map(renorm).collect();
    let in64 = renorm(&input);
    let t0 = Instant::now();
    let cm = itgfx_core::Channel::new(&in64, &m64, side).expect("channel").measures(itgfx_core::Base::Bits);
    let s = t0.elapsed().as_secs_f64();
    println!(
        "channel core(f64, 1 thread) {side}x{side}  {s:.4} s  {:.0} Melem/s  I = {:.9}",
        (side * side) as f64 / s / 1e6,
        cm.mutual_information
    );
    match Reducer::new() {
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
            let t0 = Instant::now();
            let dv = r.kl_divergence(&p, &q, itgfx_core::Base::Bits).expect("kl");
            let s = t0.elapsed().as_secs_f64();
            println!("kl vulkan  {elements} elements  {s:.4} s  {:.0} Melem/s  D = {dv:.9}", elements as f64 / s / 1e6);
            let t0 = Instant::now();
            let c = r.channel(&input, &m, side, itgfx_core::Base::Bits).expect("channel");
            let s = t0.elapsed().as_secs_f64();
            println!(
                "channel vulkan {side}x{side}  {s:.4} s  {:.0} Melem/s  I = {:.9}",
                (side * side) as f64 / s / 1e6,
                c.mutual_information
            );
        }
        Err(e) => println!("vulkan entropy: {e}"),
    }
}
