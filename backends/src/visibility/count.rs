//! Casting lines and counting them into per-block pair counts (Part III
//! §1.4, eqs. (30) and (59)); see the module above for what is counted.
//!
//! Block `b` of `B` holds the lines `i ≡ b (mod B)` of the range cast. The
//! blocks are traced one after another into one pair accumulator, in waves
//! of chunks of [`CHUNK`] lines traced by rayon; each wave is merged while
//! the next one traces, across block ends too. Every count and sum is
//! exact, so the result is the same for any thread count and chunking.

use glam::DVec3;
use rayon::prelude::*;

use super::counts_valid::SceneFingerprint;
pub use super::counts_valid::block_lines;
use super::pairs::{Accumulator, key, sym_key};
use super::{BlockCounts, ContinuousSums, CountsError, FixedSum, LineOptions, MAX_BLOCKS, VisibilityCounts};
use crate::lines::{Line, LineRng, SeedHash, cosine_direction, global_lines_of, sample_cdf};
use crate::scene::Scene;
use crate::tracer::{Crossing, CrossingBuffer, Prepared, Tracer};

/// Lines per work unit.
pub const CHUNK: u64 = 65_536;

/// Radius of the line sphere relative to the scene's half-diagonal: 0.9 for
/// the unit cube (half-diagonal √3/2), where 59.0% of global lines cross the
/// cube and Part III Table 6's rows are reproduced with every line counted.
pub const SPHERE_SCALE: f64 = 0.9 / 0.866_025_403_784_438_6;

/// Per-chunk endpoint sums: dense arrays for up to [`DENSE_ENDPOINTS`]
/// patches, a list of `(patch, log)` above (a 10^6-patch mesh would make
/// each chunk allocate 24 MB).
enum Endpoints {
    Dense(Vec<FixedSum>, Vec<u64>),
    List(Vec<(u32, FixedSum)>),
}

const DENSE_ENDPOINTS: usize = 16_384;

impl Endpoints {
    fn new(n: usize) -> Self {
        if n <= DENSE_ENDPOINTS {
            Endpoints::Dense(vec![FixedSum::default(); n], vec![0; n])
        } else {
            Endpoints::List(Vec::new())
        }
    }

    #[inline]
    fn add(&mut self, i: u32, l: FixedSum) {
        match self {
            Endpoints::Dense(s, c) => {
                s[i as usize].0 += l.0;
                c[i as usize] += 1;
            }
            Endpoints::List(v) => v.push((i, l)),
        }
    }

    fn add_into(self, sums: &mut [FixedSum], counts: &mut [u64]) -> Option<()> {
        let mut one = |i: usize, l: FixedSum, c: u64| -> Option<()> {
            sums[i] = sums[i].checked_add(l)?;
            counts[i] = counts[i].checked_add(c)?;
            Some(())
        };
        match self {
            Endpoints::Dense(s, c) => {
                for (i, (l, c)) in s.into_iter().zip(c).enumerate() {
                    if c > 0 {
                        one(i, l, c)?;
                    }
                }
            }
            Endpoints::List(v) => {
                for (i, l) in v {
                    one(i as usize, l, 1)?;
                }
            }
        }
        Some(())
    }
}

struct ChunkResult {
    /// One pair key per segment, in the order the lines gave them.
    keys: Vec<u64>,
    background: Vec<(u32, u64)>,
    cont: ContinuousSums,
    /// Segment endpoints: `log(A_T F)` summed per patch.
    endpoint: Endpoints,
    segments: u64,
    escaped: u64,
}

/// Area sampler for local lines (normalised coordinates).
struct Sampler {
    patch_cdf: Vec<f64>,
    tris: Vec<Vec<u32>>,
    tri_cdf: Vec<Vec<f64>>,
}

impl Sampler {
    fn new(p: &Prepared) -> Self {
        let mut tris = vec![Vec::new(); p.patches];
        let mut tri_cdf = vec![Vec::new(); p.patches];
        let mut area = vec![0.0; p.patches];
        for (t, v) in p.triangles.iter().enumerate() {
            let i = p.triangle_patch[t] as usize;
            let a = 0.5 * f64::from((v[1] - v[0]).cross(v[2] - v[0]).length());
            area[i] += a;
            tris[i].push(t as u32);
            tri_cdf[i].push(area[i]);
        }
        if let Some(s) = &p.sphere {
            area.iter_mut().for_each(|a| *a = 4.0 * std::f64::consts::PI * s.radius * s.radius / p.patches as f64);
        }
        let mut acc = 0.0;
        let patch_cdf = area
            .iter()
            .map(|a| {
                acc += a;
                acc
            })
            .collect();
        Self { patch_cdf, tris, tri_cdf }
    }

    /// Local line `index`: (origin patch, point, unit normal, line).
    fn line(&self, p: &Prepared, seed: u64, index: u64) -> (u32, DVec3, DVec3, Line) {
        let rng = LineRng::new(seed, index);
        let uniform = |_: u64, _: u64, k: u32| rng.uniform(k);
        let total = *self.patch_cdf.last().unwrap_or(&1.0);
        let i = sample_cdf(&self.patch_cdf, uniform(seed, index, 0) * total);
        let (x, n) = if let Some(s) = &p.sphere {
            let (b, sct) = (i as u32 / s.sectors, i as u32 % s.sectors);
            let z = 1.0 - 2.0 * (f64::from(b) + uniform(seed, index, 1)) / f64::from(s.bands);
            let phi = std::f64::consts::TAU * (f64::from(sct) + uniform(seed, index, 2)) / f64::from(s.sectors);
            let r = (1.0 - z * z).max(0.0).sqrt();
            let q = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            (q * s.radius, -q)
        } else {
            let cdf = &self.tri_cdf[i];
            let t =
                self.tris[i][sample_cdf(cdf, uniform(seed, index, 1) * cdf.last().copied().unwrap_or(0.0))] as usize;
            let [a, b, c] = p.triangles[t].map(|v| v.as_dvec3());
            let (mut u, mut v) = (uniform(seed, index, 2), uniform(seed, index, 3));
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            (a + (b - a) * u + (c - a) * v, p.normals[t].as_dvec3())
        };
        let d = cosine_direction(n, uniform(seed, index, 4), uniform(seed, index, 5));
        // Start a little behind the surface (obvhs skips crossings nearer
        // than 1e-4); crossings at t <= BACKOFF are ignored.
        let o = x - d * BACKOFF;
        let line = Line { origin: o.as_vec3().to_array(), tmin: 0.0, direction: d.as_vec3().to_array(), tmax: 8.0 };
        (i as u32, x, n, line)
    }
}

const BACKOFF: f64 = 1e-3;

/// Local line `index` of a run with `seed` over a prepared scene: its origin
/// patch and the line (which starts `1e-3` behind the surface; crossings up
/// to that distance belong to the origin).
#[must_use]
pub fn local_line(prepared: &Prepared, seed: u64, index: u64) -> (u32, Line) {
    let (p, _, _, l) = Sampler::new(prepared).line(prepared, seed, index);
    (p, l)
}

/// What every chunk of a run shares: the scene, the tracer, the lines'
/// kind and options, and eq. (59)'s normalisation.
struct RunSetup<'a> {
    p: &'a Prepared,
    tracer: &'a dyn Tracer,
    /// The local lines' origins; `None` for global lines.
    sampler: Option<&'a Sampler>,
    opts: &'a LineOptions,
    /// `A_T` in the prepared scene's units.
    total_area_norm: f64,
    /// The global lines' sphere radius.
    radius: f64,
}

/// Counts the chunk of lines `first + k · stride` (`k < count`) of `run`.
fn process_chunk(run: &RunSetup, span: (u64, u64, u64)) -> Result<ChunkResult, CountsError> {
    // The working buffers of the last chunk on this thread, taken (a
    // nested call, were a tracer ever to run rayon work inside, gets fresh
    // ones) and given back at the end.
    let mut scratch = SCRATCH.with_borrow_mut(std::mem::take);
    let result = chunk_with(run, span, &mut scratch);
    SCRATCH.with_borrow_mut(|s| *s = scratch);
    result
}

thread_local! {
    /// [`process_chunk`]'s working buffers, kept per thread between chunks.
    static SCRATCH: std::cell::RefCell<ChunkScratch> = std::cell::RefCell::default();
}

/// A chunk's working buffers. Made fresh for every chunk they cost their
/// growth (copies) and a page fault per 4 KiB page each time: over half of
/// a 10^7-line run's page faults.
#[derive(Default)]
struct ChunkScratch {
    lines: Vec<Line>,
    origins: Vec<(u32, DVec3, DVec3)>,
    buf: CrossingBuffer,
    kept: Vec<Crossing>,
    factors: Vec<f64>,
    ends: Vec<[u32; 2]>,
    logs: Vec<f64>,
}

/// [`process_chunk`] with the thread's buffers.
fn chunk_with(
    run: &RunSetup,
    (first, stride, count): (u64, u64, u64),
    scratch: &mut ChunkScratch,
) -> Result<ChunkResult, CountsError> {
    let &RunSetup { p, tracer, sampler, opts, total_area_norm, radius } = run;
    let seed = SeedHash::new(opts.seed);
    let batch = tracer.batch_lines().clamp(1, CHUNK as usize) as u64;
    let ChunkScratch { lines, origins, buf, kept, factors, ends, logs } = scratch;
    // Local lines need only the first crossing past the origin: a closest-hit
    // query from just short of that threshold (see `first_past_origin`).
    let mut nearest: Vec<Option<Crossing>> = Vec::new();
    let mut keys = Vec::new();
    let mut background = Vec::new();
    let mut endpoint = Endpoints::new(p.patches);
    let mut cont = ContinuousSums::default();
    let mut overflow = false;
    // One sample of eq. (59) from a point-to-point form factor `f` and its
    // `l = log_area_form_factor(total_area_norm, f)`.
    let mut sample = |f: f64, l: f64, ends: &[u32], endpoint: &mut Endpoints| {
        if f > 0.0 && l.is_finite() {
            let fixed = FixedSum::of(l);
            overflow |= !cont.add_fixed(fixed, l);
            let l = fixed;
            for &e in ends {
                endpoint.add(e, l);
            }
        }
    };
    let (mut segments, mut escaped) = (0, 0);
    // A batch's global segments: form factors, their ends, and (once the
    // batch is paired) their logarithms, taken in one vectorised pass.
    factors.clear();
    ends.clear();
    // Batches of the tracer's size (the CPU's is a whole chunk: its
    // ray-stream walk fills its vectors better the more lines share a node).
    for b0 in (0..count).step_by(batch as usize) {
        lines.clear();
        origins.clear();
        let end = count.min(b0 + batch);
        if let Some(s) = sampler {
            for i in (b0..end).map(|k| first + k * stride) {
                let (patch, x, n, l) = s.line(p, opts.seed, i);
                origins.push((patch, x, n));
                lines.push(l);
            }
        } else {
            global_lines_of(seed, first + b0 * stride, stride, end - b0, radius, lines);
        }
        if sampler.is_some() {
            nearest = first_past_origin(tracer, lines, origins)?;
        } else {
            tracer.trace_all(lines, buf)?;
            // About one segment per two crossings.
            keys.reserve(buf.crossings.len() / 2);
        }
        for (li, line) in lines.iter().enumerate() {
            if let Some(&(from, _x, n)) = origins.get(li) {
                // Local line: the nearest crossing past the origin, not on it.
                let d = DVec3::from(line.direction.map(f64::from));
                match nearest[li] {
                    Some(h) if h.cos < 0.0 => {
                        keys.push(key(from, h.patch));
                        let r = f64::from(h.t) - BACKOFF;
                        let f = n.dot(d) * f64::from(-h.cos) / (std::f64::consts::PI * r * r);
                        sample(f, itgfx_core::log_area_form_factor(total_area_norm, f), &[from], &mut endpoint);
                        segments += 1;
                    }
                    _ => {
                        background.push((from, 1));
                        escaped += 1;
                    }
                }
                continue;
            }
            let hits = buf.line(li);
            // Global line. Crossings less than 1e-6 apart that face both ways are
            // a touch (the line grazes an edge or clips a corner by < 1e-6):
            // whether it was in free space or not, it still is; drop the cluster.
            // (Nearly every line has no cluster: its crossings are kept as they are.)
            let hits = if hits.windows(2).all(|w| w[1].t - w[0].t > 1e-6) {
                hits
            } else {
                kept.clear();
                let mut a = 0;
                while a < hits.len() {
                    let mut b = a + 1;
                    while b < hits.len() && hits[b].t - hits[b - 1].t <= 1e-6 {
                        b += 1;
                    }
                    let forward = hits[a].cos > 0.0;
                    if hits[a..b].iter().all(|h| (h.cos > 0.0) == forward) {
                        kept.push(hits[a]);
                    }
                    a = b;
                }
                &kept[..]
            };
            // Pair forward-facing crossings with the next backward-facing one.
            let mut k = 0;
            while k < hits.len() {
                let h = hits[k];
                if h.cos > 0.0 {
                    match hits.get(k + 1) {
                        Some(g) if g.cos < 0.0 => {
                            let r = f64::from(g.t - h.t);
                            let f = f64::from(h.cos) * f64::from(-g.cos) / (std::f64::consts::PI * r * r);
                            // Both directions (Part III Fig. 8): one unordered key.
                            keys.push(sym_key(h.patch, g.patch));
                            factors.push(f);
                            ends.push([h.patch, g.patch]);
                            segments += 1;
                            k += 2;
                            continue;
                        }
                        _ => {
                            background.push((h.patch, 1));
                            escaped += 1;
                        }
                    }
                } else {
                    background.push((h.patch, 1));
                    escaped += 1;
                }
                k += 1;
            }
        }
        log_area_form_factors(total_area_norm, factors, logs);
        for ((&f, &l), e) in factors.iter().zip(logs.iter()).zip(ends.iter()) {
            sample(f, l, e, &mut endpoint);
        }
        factors.clear();
        ends.clear();
    }
    if overflow {
        return Err(CountsError::Overflow("the I_S^c sum of a chunk".into()));
    }
    Ok(ChunkResult { keys, background, cont, endpoint, segments, escaped })
}

/// `itgfx_core::log_area_form_factor(total_area, f)` (eq. (59)) of each of
/// `factors` into `out`, bit for bit: the core's branch-free `ln(A·f)` of
/// every sample in a loop the compiler vectorises (4 lanes with AVX2), then
/// the rare products outside the normal range taken again by the core's
/// function. Each sample's logarithm was a scalar call in the pairing loop.
fn log_area_form_factors(total_area: f64, factors: &[f64], out: &mut Vec<f64>) {
    out.clear();
    out.resize(factors.len(), 0.0);
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 was detected just above.
        unsafe { ln_products_avx2(total_area, factors, out) };
    } else {
        ln_products(total_area, factors, out);
    }
    #[cfg(not(target_arch = "x86_64"))]
    ln_products(total_area, factors, out);
    for (l, &f) in out.iter_mut().zip(factors) {
        if !(f64::MIN_POSITIVE..=f64::MAX).contains(&(total_area * f)) {
            *l = itgfx_core::log_area_form_factor(total_area, f);
        }
    }
}

/// `ln(total_area · f)` of each `f`, the core's [`itgfx_core::ln`].
#[inline(always)]
fn ln_products(total_area: f64, factors: &[f64], out: &mut [f64]) {
    for (l, &f) in out.iter_mut().zip(factors) {
        *l = itgfx_core::ln(total_area * f);
    }
}

/// [`ln_products`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn ln_products_avx2(total_area: f64, factors: &[f64], out: &mut [f64]) {
    ln_products(total_area, factors, out);
}

/// Whether crossing `h` of a local line from patch `from` is where the line
/// lands: past the origin (which the line starts [`BACKOFF`] behind) and on
/// another patch.
fn lands(h: &Crossing, from: u32) -> bool {
    f64::from(h.t) > BACKOFF * (1.0 + 1e-4) && h.patch != from
}

/// For each local line, the first of its crossings that [`lands`], exactly
/// as a scan of every crossing ([`Tracer::trace_all`]) finds it, but by a
/// closest-hit query: the query starts at the largest `f32` not above the
/// threshold, so every landing crossing lies in its range. When its hit
/// lands, nothing before it did (it is the first crossing in range); when it
/// does not (the origin patch again), or lies within 1e-5 of the threshold,
/// that line falls back to the full scan.
fn first_past_origin(
    tracer: &dyn Tracer,
    lines: &[Line],
    origins: &[(u32, DVec3, DVec3)],
) -> Result<Vec<Option<Crossing>>, CountsError> {
    let threshold = BACKOFF * (1.0 + 1e-4);
    let mut start = threshold as f32;
    if f64::from(start) > threshold {
        start = start.next_down();
    }
    let probes: Vec<Line> = lines.iter().map(|l| Line { tmin: start.max(l.tmin), ..*l }).collect();
    let mut hits = Vec::new();
    tracer.closest_hit(&probes, &mut hits)?;
    let mut out = Vec::with_capacity(lines.len());
    let mut retrace = Vec::new();
    for (li, (hit, &(from, _, _))) in hits.iter().zip(origins).enumerate() {
        let c = hit.map(|h| Crossing { t: h.t, patch: h.patch, cos: h.cos, primitive: h.primitive });
        match c {
            // Within 1e-5 of the threshold a scan could have merged the
            // crossing into an earlier one (crossings 1e-6 apart are one).
            Some(c) if !lands(&c, from) || f64::from(c.t) <= threshold + 1e-5 => {
                retrace.push(li);
                out.push(None);
            }
            c => out.push(c),
        }
    }
    if !retrace.is_empty() {
        let again: Vec<Line> = retrace.iter().map(|&li| lines[li]).collect();
        let mut buf = CrossingBuffer::default();
        tracer.trace_all(&again, &mut buf)?;
        for (k, &li) in retrace.iter().enumerate() {
            out[li] = buf.line(k).iter().find(|h| lands(h, origins[li].0)).copied();
        }
    }
    Ok(out)
}

/// One wave of chunks, all of one block: the block's lines (`first`,
/// stride `blocks`, `count` of them) and the chunks' starts in it.
struct Wave {
    first: u64,
    count: u64,
    /// Line offsets in the block (multiples of [`CHUNK`]) of the chunks.
    chunks: Vec<u64>,
    /// Whether this is the block's last wave (an empty block has one, empty).
    last: bool,
}

/// The waves of a run, block after block, made one at a time: memory stays
/// bounded whatever the line count (10^18 lines would list 5e14 chunks).
struct WavePlan {
    start: u64,
    end: u64,
    blocks: u64,
    /// Most chunks per wave.
    wave: u64,
    /// Chunks of the run's last wave, the one whose merge nothing overlaps.
    tail: u64,
    block: u64,
    /// The next chunk's line offset in `block`.
    next: u64,
}

impl WavePlan {
    fn next_wave(&mut self) -> Option<Wave> {
        if self.block >= self.blocks {
            return None;
        }
        let (first, count) = block_lines(self.start, self.end, self.block, self.blocks);
        let left = (count - self.next).div_ceil(CHUNK);
        // The run's last chunks are cut off into a short wave of their own:
        // its merge is the only one no tracing overlaps.
        let take = if self.block + 1 == self.blocks && left <= self.wave && left > self.tail {
            left - self.tail
        } else {
            left.min(self.wave)
        };
        let chunks: Vec<u64> = (0..take).map(|j| self.next + j * CHUNK).collect();
        let w = Wave { first, count, chunks, last: take == left };
        if w.last {
            (self.block, self.next) = (self.block + 1, 0);
        } else {
            self.next += take * CHUNK;
        }
        Some(w)
    }
}

/// What the waves' results are merged into: the pair accumulator (one for
/// the run), the per-patch endpoint sums, and the open block's counts.
struct Merger {
    acc: Accumulator,
    endpoints: Vec<u64>,
    endpoint_log: Vec<FixedSum>,
    /// The open block's background counts per patch (zeroed when it closes).
    background: Vec<u64>,
    block: BlockCounts,
    out: Vec<BlockCounts>,
}

impl Merger {
    /// Merges a wave's results into its block; the block's last wave closes
    /// it (its pairs taken, the accumulator empty for the next).
    fn merge(&mut self, w: &Wave, results: Vec<Result<ChunkResult, CountsError>>) -> Result<(), CountsError> {
        let overflow = |what: &str| CountsError::Overflow(what.into());
        let block = &mut self.block;
        block.lines = w.count;
        for r in results {
            let r = r?;
            self.acc.add_keys(&r.keys);
            for (i, c) in r.background {
                let x = &mut self.background[i as usize];
                *x = x.checked_add(c).ok_or_else(|| overflow("a background count"))?;
            }
            r.endpoint
                .add_into(&mut self.endpoint_log, &mut self.endpoints)
                .ok_or_else(|| overflow("an endpoint sum"))?;
            block.continuous =
                block.continuous.checked_add(&r.cont).ok_or_else(|| overflow("the I_S^c sum of a block"))?;
            block.segments = block.segments.checked_add(r.segments).ok_or_else(|| overflow("segments"))?;
            block.escaped = block.escaped.checked_add(r.escaped).ok_or_else(|| overflow("escaped"))?;
        }
        if w.last {
            let mut block = std::mem::take(&mut self.block);
            block.pairs = self.acc.take_pairs()?;
            block.background = self
                .background
                .iter_mut()
                .enumerate()
                .filter(|(_, c)| **c > 0)
                .map(|(i, c)| (i as u32, std::mem::take(c)))
                .collect();
            self.out.push(block);
        }
        Ok(())
    }
}

/// Casts the lines `offset .. offset + lines` through `tracer` and counts
/// the visibility channel. `progress(lines_done, lines_total)` is called
/// between waves of chunks.
///
/// # Errors
/// [`CountsError::Invalid`] for no lines, a block count outside
/// `1..=MAX_BLOCKS` or a line range past `2^64`; backend errors; an
/// overflowing sum.
pub fn count_visibility(
    scene: &Scene,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    opts: &LineOptions,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<VisibilityCounts, CountsError> {
    if opts.lines == 0 {
        return Err(CountsError::Invalid("no lines to cast".into()));
    }
    if !(1..=MAX_BLOCKS).contains(&opts.blocks) {
        return Err(CountsError::Invalid(format!("{} jackknife blocks: expected 1..={MAX_BLOCKS}", opts.blocks)));
    }
    let Some(end) = opts.offset.checked_add(opts.lines) else {
        return Err(CountsError::Invalid(format!(
            "lines {}..{}+{} run past the last line index 2^64-1",
            opts.offset, opts.offset, opts.lines
        )));
    };
    let start = opts.offset;
    let n = prepared.patches;
    let blocks = u64::from(opts.blocks);
    let total_area_norm = scene.total_area() / (prepared.scale * prepared.scale);
    let sampler = opts.local.then(|| Sampler::new(prepared));
    let radius = SPHERE_SCALE;
    // Chunks per wave: a wave ends at a join (the merge of the last one, its
    // own tracing), where a thread may wait up to a chunk (~7 ms of
    // cube-enclosure:30). 64 chunks a thread make 2 joins a block at 10^8
    // lines and 8 blocks; at most 256 chunks (~0.45 MB of results each on
    // cube-enclosure:30, two waves alive at a time).
    let threads = rayon::current_num_threads() as u64;
    let wave = (threads * 64).clamp(16, 256);
    let mut plan = WavePlan { start, end, blocks, wave, tail: (2 * threads).min(wave), block: 0, next: 0 };
    let run = RunSetup { p: prepared, tracer, sampler: sampler.as_ref(), opts, total_area_norm, radius };
    let run_wave = |w: &Wave| -> Vec<Result<ChunkResult, CountsError>> {
        w.chunks
            .par_iter()
            .map(|&k| process_chunk(&run, (w.first + k * blocks, blocks, CHUNK.min(w.count - k))))
            .collect()
    };
    let mut merger = Merger {
        acc: Accumulator::new(n, !opts.local),
        endpoints: vec![0; n],
        endpoint_log: vec![FixedSum::default(); n],
        background: vec![0; n],
        block: BlockCounts::default(),
        out: Vec::with_capacity(blocks as usize),
    };
    // Merge wave k while wave k+1 traces (exact sums: order-free), across
    // blocks too: a block's last merge and the reading of its pairs overlap
    // the next block's first wave.
    let mut pending: Option<(Wave, Vec<Result<ChunkResult, CountsError>>)> = None;
    let mut done = 0;
    while let Some(w) = plan.next_wave() {
        let (merged, next) = match pending.take() {
            Some((pw, prev)) => rayon::join(|| merger.merge(&pw, prev), || run_wave(&w)),
            None => (Ok(()), run_wave(&w)),
        };
        merged?;
        done += w.chunks.iter().map(|&k| CHUNK.min(w.count - k)).sum::<u64>();
        progress(done, opts.lines);
        pending = Some((w, next));
    }
    if let Some((pw, prev)) = pending {
        merger.merge(&pw, prev)?;
    }
    let areas = scene.areas();
    Ok(VisibilityCounts {
        scene: SceneFingerprint::of(&scene.name, &areas),
        areas,
        local: opts.local,
        seed: opts.seed,
        ranges: vec![(start, end)],
        blocks: merger.out,
        endpoints: merger.endpoints,
        endpoint_log: merger.endpoint_log,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::built_in;
    use crate::tracer::CpuTracer;

    /// The batched logarithms of eq. (59) are the core's, bit for bit, on
    /// ordinary form factors and on products outside the normal range
    /// (zero, subnormal, overflowing, infinite, NaN).
    #[test]
    fn batched_logarithms_are_the_cores() {
        let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut factors: Vec<f64> = (0..10_007)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                f64::from_bits(s & 0x7fef_ffff_ffff_ffff)
            })
            .collect();
        factors.extend([0.0, 1e-310, 5e-324, 1e300, f64::MAX, f64::INFINITY, f64::NAN, -1.0, 0.3]);
        for total in [1.0, 12.566_370_614_359_172, 1e-5, 3e7] {
            let mut out = vec![7.0; 3];
            log_area_form_factors(total, &factors, &mut out);
            assert_eq!(out.len(), factors.len());
            for (&f, &l) in factors.iter().zip(&out) {
                let core = itgfx_core::log_area_form_factor(total, f);
                assert_eq!(l.to_bits(), core.to_bits(), "A = {total}, f = {f:e}: {l} vs {core}");
            }
        }
    }

    /// The closest-hit query finds, for every local line, the crossing a scan
    /// of all crossings finds (the same patch, `t` and cosine), on scenes with
    /// occluders, open edges, non-planar patches (the sphere's cells) and
    /// patches meeting at edges.
    #[test]
    fn local_lines_land_where_the_full_scan_says() {
        for spec in ["cubes-room:64", "cornell-box", "sphere", "dodecahedron", "table-chairs:2", "cube-enclosure:4"] {
            let scene = built_in(spec).unwrap();
            let p = Prepared::new(&scene);
            let tracer = CpuTracer::new(&p);
            let sampler = Sampler::new(&p);
            let (mut lines, mut origins) = (Vec::new(), Vec::new());
            for i in 0..20_000 {
                let (patch, x, n, l) = sampler.line(&p, 7, i);
                lines.push(l);
                origins.push((patch, x, n));
            }
            let fast = first_past_origin(&tracer, &lines, &origins).unwrap();
            let mut buf = CrossingBuffer::default();
            tracer.trace_all(&lines, &mut buf).unwrap();
            let mut landed = 0;
            for (li, f) in fast.iter().enumerate() {
                let scan = buf.line(li).iter().find(|h| lands(h, origins[li].0)).copied();
                assert_eq!(f.map(|c| (c.t, c.patch, c.cos)), scan.map(|c| (c.t, c.patch, c.cos)), "{spec} line {li}");
                landed += usize::from(scan.is_some());
            }
            // Closed scenes land nearly every line; table-chairs is open.
            assert!(landed > 2_000, "{spec}: only {landed} of 20000 lines landed");
        }
    }
}
