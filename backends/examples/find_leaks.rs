//! Diagnostic: global lines whose crossings do not pair up in a closed
//! scene, re-traced with the brute-force reference.
//! `cargo run --release -p itgfx-backends --example find_leaks -- SCENE LINES`

use itgfx_backends::lines::global_line;
use itgfx_backends::scene::built_in;
use itgfx_backends::tracer::{CpuTracer, CrossingBuffer, Prepared, ReferenceTracer, Tracer};
use itgfx_backends::visibility::SPHERE_SCALE;
use rayon::prelude::*;

fn unpaired(c: &[itgfx_backends::tracer::Crossing]) -> bool {
    // In a closed scene crossings alternate: forward-facing then backward-facing,
    // once touches (opposite-facing crossings < 1e-6 apart) are dropped.
    let mut kept: Vec<_> = Vec::new();
    let mut a = 0;
    while a < c.len() {
        let mut b = a + 1;
        while b < c.len() && c[b].t - c[b - 1].t <= 1e-6 {
            b += 1;
        }
        if c[a..b].iter().all(|h| (h.cos > 0.0) == (c[a].cos > 0.0)) {
            kept.push(c[a]);
        }
        a = b;
    }
    kept.len() % 2 == 1 || kept.chunks(2).any(|p| !(p[0].cos > 0.0 && p[1].cos < 0.0))
}

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let scene = built_in(a.first().map_or("cube-enclosure:30", String::as_str)).unwrap();
    let n: u64 = a.get(1).and_then(|s| s.parse::<f64>().ok()).map_or(10_000_000, |x| x as u64);
    let p = Prepared::new(&scene);
    let cpu = CpuTracer::new(&p);
    let reference = ReferenceTracer::new(&p);
    let bad: Vec<u64> = (0..n / 65536 + 1)
        .into_par_iter()
        .flat_map_iter(|c| {
            let lines: Vec<_> =
                (c * 65536..((c + 1) * 65536).min(n)).map(|i| global_line(1, i, SPHERE_SCALE)).collect();
            let mut buf = CrossingBuffer::default();
            cpu.trace_all(&lines, &mut buf).unwrap();
            (0..lines.len()).filter(|&i| unpaired(buf.line(i))).map(|i| c * 65536 + i as u64).collect::<Vec<_>>()
        })
        .collect();
    println!("{} of {n} lines do not pair up", bad.len());
    for &i in bad.iter().take(10) {
        let l = global_line(1, i, SPHERE_SCALE);
        let (mut x, mut y) = (CrossingBuffer::default(), CrossingBuffer::default());
        cpu.trace_all(&[l], &mut x).unwrap();
        reference.trace_all(&[l], &mut y).unwrap();
        println!("line {i}: {l:?}\n  cpu       {:?}\n  reference {:?}", x.line(0), y.line(0));
    }
}
