//! Global-line tracing throughput of the CPU backend, stage by stage:
//!
//! ```sh
//! cargo bench -p itgfx-backends --bench trace -- SCENE [LINES] [--export DIR]
//! ```
//! SCENE is a built-in name or an .obj path (`--subdivide K` via `SCENE@K`).
//! Prints lines/s for generation, tracing (all crossings), and the whole
//! visibility count, as JSON lines. `--export DIR` writes `DIR/scene.obj`
//! (normalised coordinates) and `DIR/lines.f32` (origin, direction, tmax as
//! 7 little-endian f32 per line) so other tracers can trace the same lines.

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use itgfx_backends::lines::{Line, global_line};
use itgfx_backends::obj::load_obj;
use itgfx_backends::scene::built_in;
use itgfx_backends::tracer::{CpuTracer, CrossingBuffer, Prepared, Tracer};
use itgfx_backends::visibility::{CHUNK, LineOptions, SPHERE_SCALE, count_visibility};
use rayon::prelude::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    let spec = args.first().cloned().unwrap_or_else(|| "cube-enclosure:30".into());
    let lines: u64 = args.get(1).and_then(|s| s.parse::<f64>().ok()).map_or(10_000_000, |x| x as u64);
    let export = args.iter().position(|a| a == "--export").and_then(|i| args.get(i + 1)).cloned();
    let (name, k) = spec.split_once('@').map_or((spec.as_str(), 1), |(a, b)| (a, b.parse().unwrap_or(1)));
    let scene = if name.ends_with(".obj") { load_obj(Path::new(name)).unwrap() } else { built_in(name).unwrap() };
    let scene = scene.subdivided(k).unwrap();
    let t = Instant::now();
    let prepared = Prepared::new(&scene);
    let tracer = CpuTracer::new(&prepared);
    let build = t.elapsed().as_secs_f64();
    let seed = 1;
    let chunks: Vec<u64> = (0..lines).step_by(CHUNK as usize).collect();
    let gen_lines =
        |c: u64| -> Vec<Line> { (c..(c + CHUNK).min(lines)).map(|i| global_line(seed, i, SPHERE_SCALE)).collect() };
    let t = Instant::now();
    let n: usize = chunks.par_iter().map(|&c| gen_lines(c).len()).sum();
    let gen_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let crossings: usize = chunks
        .par_iter()
        .map(|&c| {
            let mut buf = CrossingBuffer::default();
            tracer.trace_all(&gen_lines(c), &mut buf).unwrap();
            buf.crossings.len()
        })
        .sum();
    let trace_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let counts = count_visibility(
        &scene,
        &prepared,
        &tracer,
        &LineOptions { lines, seed, local: false, blocks: 1, offset: 0 },
        &mut |_, _| {},
    )
    .unwrap();
    let full_s = t.elapsed().as_secs_f64();
    let segs: u64 = counts.blocks.iter().map(|b| b.segments).sum();
    println!(
        "{{\"impl\":\"itgfx-cpu\",\"scene\":\"{spec}\",\"triangles\":{},\"patches\":{},\"lines\":{n},\"crossings\":{crossings},\"segments\":{segs},\"threads\":{},\"build_s\":{build:.3},\"generate_s\":{gen_s:.3},\"trace_s\":{trace_s:.3},\"count_s\":{full_s:.3},\"trace_mlines_per_s\":{:.2},\"count_mlines_per_s\":{:.2},\"count_msegments_per_s\":{:.2}}}",
        prepared.triangles.len(),
        prepared.patches,
        rayon::current_num_threads(),
        n as f64 / trace_s / 1e6,
        n as f64 / full_s / 1e6,
        segs as f64 / full_s / 1e6
    );
    if let Some(dir) = export {
        std::fs::create_dir_all(&dir).unwrap();
        let mut f = std::io::BufWriter::new(std::fs::File::create(Path::new(&dir).join("scene.obj")).unwrap());
        writeln!(f, "# {spec}, normalised as traced by itgfx").unwrap();
        for t in &prepared.triangles {
            for v in t {
                writeln!(f, "v {} {} {}", v.x, v.y, v.z).unwrap();
            }
        }
        for i in 0..prepared.triangles.len() {
            writeln!(f, "f {} {} {}", 3 * i + 1, 3 * i + 2, 3 * i + 3).unwrap();
        }
        let mut f = std::io::BufWriter::new(std::fs::File::create(Path::new(&dir).join("lines.f32")).unwrap());
        for i in 0..lines {
            let l = global_line(seed, i, SPHERE_SCALE);
            for x in l.origin.iter().chain(l.direction.iter()).chain(std::iter::once(&l.tmax)) {
                f.write_all(&x.to_le_bytes()).unwrap();
            }
        }
    }
}
