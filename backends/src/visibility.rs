//! The scene visibility channel from lines (Part III §1.4, §2–§8).
//!
//! **Global lines**: every pair of consecutive crossings along a line whose
//! first end faces forward (`n·d > 0`) and second end faces back (`n·d < 0`)
//! is a segment joining two patches that see each other; it counts once for
//! `i → j` and once for `j → i` (Part III Fig. 8), and gives one sample of
//! `log(A_T F(x, y))` for `I_S^c` (eq. (59)). A crossing whose partner is
//! missing (the line leaves the scene, or meets a back face) is counted
//! against the *background*: reported, never silently lost. In a closed,
//! consistently oriented scene traced watertight, the background count is 0.
//!
//! **Local lines** (`--local`): origins uniform on the surface (patches by
//! area), cosine directions; the nearest crossing, if it faces back, is the
//! destination (`F_ij = N_ij / N_i`, eq. (30)).
//!
//! Lines are split into `blocks` contiguous index ranges. Counts are kept per
//! block (sparse: one entry per distinct pair hit), which gives the
//! delete-one-block jackknife: a standard error for `I_S` and `I_S^c`, and a
//! bias-corrected `I_S` (the plug-in estimate is biased upwards at low line
//! counts, as Part III Table 6 shows). Work within a block is split into
//! fixed chunks processed by rayon and merged in chunk order, so every number
//! is the same for any thread count.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::DVec3;
use itgfx_core::{Base, ContinuousMutualInformation, PairCount, SceneMeasures, scene_measures_from_counts};
use rayon::prelude::*;

use crate::lines::{Line, LineRng, cosine_direction, global_line, sample_cdf};
use crate::scene::Scene;
use crate::tracer::{BackendError, CrossingBuffer, Prepared, Tracer};

/// Lines per work unit (fixed: results must not depend on scheduling).
pub const CHUNK: u64 = 16_384;

/// Radius of the line sphere relative to the scene's half-diagonal: 0.9 for
/// the unit cube (half-diagonal √3/2), where 59.0% of global lines cross the
/// cube and Part III Table 6's rows are reproduced with every line counted.
pub const SPHERE_SCALE: f64 = 0.9 / 0.866_025_403_784_438_6;

/// How to cast lines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineOptions {
    /// Lines to cast (global lines that miss the scene count too).
    pub lines: u64,
    /// Seed of the counter-based generator.
    pub seed: u64,
    /// Local lines instead of global ones.
    pub local: bool,
    /// Jackknife blocks (1 disables the standard errors).
    pub blocks: u32,
    /// Index of the first line (shards of one run use disjoint ranges).
    pub offset: u64,
}

/// Counts of one block of lines.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlockCounts {
    /// Lines cast.
    pub lines: u64,
    /// Segments (global) or lines reaching a patch (local).
    pub segments: u64,
    /// Crossings counted against the background.
    pub escaped: u64,
    /// `N_ij`, sorted by `(from, to)`, one entry per pair.
    pub pairs: Vec<PairCount>,
    /// Background counts per patch.
    pub background: Vec<u64>,
    /// `Σ log(A_T F)` over samples, in chunk order.
    pub continuous: ContinuousMutualInformation,
    /// `Σ log(A_T F)` over the endpoints on each patch (nats).
    pub endpoint_log: Vec<f64>,
    /// Endpoints on each patch.
    pub endpoints: Vec<u64>,
}

/// All counts of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct VisibilityCounts {
    /// Patch areas (scene units).
    pub areas: Vec<f64>,
    /// Whether local lines were used.
    pub local: bool,
    /// Per-block counts.
    pub blocks: Vec<BlockCounts>,
}

/// A tiny multiplicative hasher for `u64` pair keys.
#[derive(Default)]
struct KeyHasher(u64);
impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(5) ^ u64::from(b)).wrapping_mul(0x51_7C_C1_B7_27_22_0A_95);
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (v ^ (v >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9) ^ (v >> 32);
    }
}
type KeyMap = HashMap<u64, u64, BuildHasherDefault<KeyHasher>>;

/// Where a block's pair counts accumulate: a dense `n × n` matrix of `u32`
/// when it fits in [`DENSE_LIMIT`] entries (chunks arrive as sorted runs, so
/// the adds sweep it in order), a hash map of the pairs hit otherwise.
enum Accumulator {
    Dense { n: usize, counts: Vec<u32>, overflow: KeyMap },
    Sparse(KeyMap),
}

/// Largest `n²` counted densely (6000 patches: 144 MB of `u32` per block).
const DENSE_LIMIT: usize = 36_000_000;

impl Accumulator {
    fn new(n: usize) -> Self {
        if n.saturating_mul(n) <= DENSE_LIMIT {
            Accumulator::Dense { n, counts: vec![0; n * n], overflow: KeyMap::default() }
        } else {
            Accumulator::Sparse(KeyMap::default())
        }
    }

    fn add(&mut self, runs: &[(u64, u64)]) {
        match self {
            Accumulator::Dense { n, counts, overflow } => {
                for &(k, c) in runs {
                    let idx = (k >> 32) as usize * *n + (k as u32) as usize;
                    let (sum, carry) = counts[idx].overflowing_add(c as u32);
                    if carry || c > u64::from(u32::MAX) {
                        // Counts past 2^32 for one pair: keep the excess exactly.
                        *overflow.entry(k).or_insert(0) += c;
                    } else {
                        counts[idx] = sum;
                    }
                }
            }
            Accumulator::Sparse(map) => {
                for &(k, c) in runs {
                    *map.entry(k).or_insert(0) += c;
                }
            }
        }
    }

    fn into_pairs(self) -> Vec<PairCount> {
        let mut pairs: Vec<PairCount> = match self {
            Accumulator::Dense { n, counts, overflow } => {
                let mut v: Vec<PairCount> = counts
                    .iter()
                    .enumerate()
                    .filter(|(_, c)| **c > 0)
                    .map(|(idx, &c)| PairCount { from: (idx / n) as u32, to: (idx % n) as u32, count: u64::from(c) })
                    .collect();
                for (k, c) in overflow {
                    let (i, j) = ((k >> 32) as u32, k as u32);
                    match v.binary_search_by_key(&(i, j), |p| (p.from, p.to)) {
                        Ok(pos) => v[pos].count += c,
                        Err(pos) => v.insert(pos, PairCount { from: i, to: j, count: c }),
                    }
                }
                v
            }
            Accumulator::Sparse(map) => {
                map.into_iter().map(|(k, c)| PairCount { from: (k >> 32) as u32, to: k as u32, count: c }).collect()
            }
        };
        pairs.sort_unstable();
        pairs
    }
}

/// Per-chunk endpoint sums: dense arrays for up to [`DENSE_ENDPOINTS`]
/// patches, a list of `(patch, log)` above (a 10^6-patch mesh would make
/// each chunk allocate 16 MB).
enum Endpoints {
    Dense(Vec<f64>, Vec<u64>),
    List(Vec<(u32, f64)>),
}

const DENSE_ENDPOINTS: usize = 16_384;

impl Endpoints {
    fn new(n: usize) -> Self {
        if n <= DENSE_ENDPOINTS { Endpoints::Dense(vec![0.0; n], vec![0; n]) } else { Endpoints::List(Vec::new()) }
    }

    #[inline]
    fn add(&mut self, i: u32, l: f64) {
        match self {
            Endpoints::Dense(s, c) => {
                s[i as usize] += l;
                c[i as usize] += 1;
            }
            Endpoints::List(v) => v.push((i, l)),
        }
    }

    fn add_into(self, sums: &mut [f64], counts: &mut [u64]) {
        match self {
            Endpoints::Dense(s, c) => {
                for ((a, b), (x, y)) in sums.iter_mut().zip(counts.iter_mut()).zip(s.into_iter().zip(c)) {
                    *a += x;
                    *b += y;
                }
            }
            Endpoints::List(v) => {
                for (i, l) in v {
                    sums[i as usize] += l;
                    counts[i as usize] += 1;
                }
            }
        }
    }
}

struct ChunkResult {
    keys: Vec<(u64, u64)>,
    background: Vec<(u32, u64)>,
    cont: ContinuousMutualInformation,
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

fn key(i: u32, j: u32) -> u64 {
    (u64::from(i) << 32) | u64::from(j)
}

#[allow(clippy::too_many_arguments)]
fn process_chunk(
    p: &Prepared,
    tracer: &dyn Tracer,
    sampler: Option<&Sampler>,
    opts: &LineOptions,
    total_area_norm: f64,
    first: u64,
    count: u64,
    radius: f64,
) -> Result<ChunkResult, BackendError> {
    let mut lines = Vec::with_capacity(count as usize);
    let mut origins = Vec::new();
    for i in first..first + count {
        if let Some(s) = sampler {
            let (patch, x, n, l) = s.line(p, opts.seed, i);
            origins.push((patch, x, n));
            lines.push(l);
        } else {
            lines.push(global_line(opts.seed, i, radius));
        }
    }
    let mut buf = CrossingBuffer::default();
    tracer.trace_all(&lines, &mut buf)?;
    let mut keys = Vec::new();
    let mut background = Vec::new();
    let mut endpoint = Endpoints::new(p.patches);
    let mut cont = ContinuousMutualInformation::new(total_area_norm).map_err(|_| BackendError::DeviceLost)?;
    let (mut segments, mut escaped) = (0, 0);
    for (li, line) in lines.iter().enumerate() {
        let hits = buf.line(li);
        if let Some(&(from, _x, n)) = origins.get(li) {
            // Local line: the nearest crossing past the origin, not on it.
            let d = DVec3::from(line.direction.map(f64::from));
            let next = hits.iter().find(|h| f64::from(h.t) > BACKOFF * (1.0 + 1e-4) && h.patch != from);
            match next {
                Some(h) if h.cos < 0.0 => {
                    keys.push(key(from, h.patch));
                    let r = f64::from(h.t) - BACKOFF;
                    let l = (total_area_norm * n.dot(d) * f64::from(-h.cos) / (std::f64::consts::PI * r * r)).ln();
                    if cont.add_form_factor(n.dot(d) * f64::from(-h.cos) / (std::f64::consts::PI * r * r)) {
                        endpoint.add(from, l);
                    }
                    segments += 1;
                }
                _ => {
                    background.push((from, 1));
                    escaped += 1;
                }
            }
            continue;
        }
        // Global line. Crossings less than 1e-6 apart that face both ways are
        // a touch (the line grazes an edge or clips a corner by < 1e-6):
        // whether it was in free space or not, it still is; drop the cluster.
        let mut kept = Vec::with_capacity(hits.len());
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
        let hits = &kept[..];
        // Pair forward-facing crossings with the next backward-facing one.
        let mut k = 0;
        while k < hits.len() {
            let h = hits[k];
            if h.cos > 0.0 {
                match hits.get(k + 1) {
                    Some(g) if g.cos < 0.0 => {
                        let r = f64::from(g.t - h.t);
                        let f = f64::from(h.cos) * f64::from(-g.cos) / (std::f64::consts::PI * r * r);
                        keys.push(key(h.patch, g.patch));
                        keys.push(key(g.patch, h.patch));
                        if cont.add_form_factor(f) {
                            let l = (total_area_norm * f).ln();
                            endpoint.add(h.patch, l);
                            endpoint.add(g.patch, l);
                        }
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
    keys.sort_unstable();
    let mut runs: Vec<(u64, u64)> = Vec::new();
    for k in keys {
        match runs.last_mut() {
            Some((last, c)) if *last == k => *c += 1,
            _ => runs.push((k, 1)),
        }
    }
    Ok(ChunkResult { keys: runs, background, cont, endpoint, segments, escaped })
}

/// Casts the lines through `tracer` and counts the visibility channel.
/// `progress(lines_done, lines_total)` is called between waves of chunks.
///
/// # Errors
/// Backend errors.
pub fn count_visibility(
    scene: &Scene,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    opts: &LineOptions,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<VisibilityCounts, BackendError> {
    let n = prepared.patches;
    let blocks = u64::from(opts.blocks.max(1)).min(opts.lines.max(1));
    let total_area_norm = scene.total_area() / (prepared.scale * prepared.scale);
    let sampler = opts.local.then(|| Sampler::new(prepared));
    let radius = SPHERE_SCALE;
    let wave = (rayon::current_num_threads() as u64 * 4).max(4);
    let mut out = Vec::new();
    let mut done = 0;
    for b in 0..blocks {
        let (start, end) = (opts.offset + opts.lines * b / blocks, opts.offset + opts.lines * (b + 1) / blocks);
        let mut acc = Accumulator::new(n);
        let mut block = BlockCounts {
            lines: end - start,
            background: vec![0; n],
            endpoint_log: vec![0.0; n],
            endpoints: vec![0; n],
            continuous: ContinuousMutualInformation::new(total_area_norm).map_err(|_| BackendError::DeviceLost)?,
            ..BlockCounts::default()
        };
        let chunks: Vec<u64> = (start..end).step_by(CHUNK as usize).collect();
        let run_wave = |w: &[u64]| -> Vec<Result<ChunkResult, BackendError>> {
            w.par_iter()
                .map(|&c| {
                    process_chunk(
                        prepared,
                        tracer,
                        sampler.as_ref(),
                        opts,
                        total_area_norm,
                        c,
                        CHUNK.min(end - c),
                        radius,
                    )
                })
                .collect()
        };
        // Merge wave k (in chunk order: deterministic) while wave k+1 traces.
        let mut merge = |results: Vec<Result<ChunkResult, BackendError>>| -> Result<(), BackendError> {
            for r in results {
                let r = r?;
                acc.add(&r.keys);
                for (i, c) in r.background {
                    block.background[i as usize] += c;
                }
                r.endpoint.add_into(&mut block.endpoint_log, &mut block.endpoints);
                block.continuous.merge(&r.cont);
                block.segments += r.segments;
                block.escaped += r.escaped;
            }
            Ok(())
        };
        let waves: Vec<&[u64]> = chunks.chunks(wave as usize).collect();
        let mut pending: Option<Vec<Result<ChunkResult, BackendError>>> = None;
        for w in &waves {
            let (merged, next) = match pending.take() {
                Some(prev) => rayon::join(|| merge(prev), || run_wave(w)),
                None => (Ok(()), run_wave(w)),
            };
            merged?;
            pending = Some(next);
            done += w.iter().map(|&c| CHUNK.min(end - c)).sum::<u64>();
            progress(done, opts.lines);
        }
        if let Some(prev) = pending {
            merge(prev)?;
        }
        block.pairs = acc.into_pairs();
        out.push(block);
    }
    Ok(VisibilityCounts { areas: scene.areas(), local: opts.local, blocks: out })
}

impl VisibilityCounts {
    /// Writes the counts as text (one block after another), so shards of a
    /// run can be merged: `N_ij`, background counts, endpoint sums and the
    /// `I_S^c` sums, floats in shortest round-trip form.
    ///
    /// # Errors
    /// I/O errors.
    pub fn save(&self, name: &str, out: &mut impl std::io::Write) -> std::io::Result<()> {
        writeln!(out, "itgfx-counts 1")?;
        writeln!(out, "scene {name}")?;
        writeln!(out, "patches {} local {}", self.areas.len(), u8::from(self.local))?;
        for a in &self.areas {
            writeln!(out, "area {a:?}")?;
        }
        for b in &self.blocks {
            let (at, n, s, s2) = b.continuous.to_parts();
            writeln!(out, "block {} {} {} {at:?} {n} {s:?} {s2:?} {}", b.lines, b.segments, b.escaped, b.pairs.len())?;
            for p in &b.pairs {
                writeln!(out, "{} {} {}", p.from, p.to, p.count)?;
            }
            for (i, ((bg, e), l)) in b.background.iter().zip(&b.endpoints).zip(&b.endpoint_log).enumerate() {
                if *bg > 0 || *e > 0 {
                    writeln!(out, "p {i} {bg} {e} {l:?}")?;
                }
            }
            writeln!(out, "end")?;
        }
        Ok(())
    }

    /// Reads counts written by [`VisibilityCounts::save`]; returns the scene name too.
    ///
    /// # Errors
    /// A message with the line number for any malformed line.
    pub fn load(text: &str) -> Result<(String, Self), String> {
        let mut lines = text.lines().enumerate().peekable();
        let mut next = |what: &str| {
            lines.next().map(|(i, l)| (i + 1, l)).ok_or_else(|| format!("unexpected end of file, expected {what}"))
        };
        let bad = |n: usize, m: &str| format!("line {n}: {m}");
        let (n1, h) = next("header")?;
        if h != "itgfx-counts 1" {
            return Err(bad(n1, "not an itgfx counts file (expected 'itgfx-counts 1')"));
        }
        let (_, s) = next("scene")?;
        let name = s.strip_prefix("scene ").unwrap_or(s).to_string();
        let (n3, p) = next("patches")?;
        let f: Vec<&str> = p.split_whitespace().collect();
        let (patches, local) = match f.as_slice() {
            ["patches", n, "local", l] => (n.parse::<usize>().map_err(|_| bad(n3, "bad patch count"))?, *l == "1"),
            _ => return Err(bad(n3, "expected 'patches N local 0|1'")),
        };
        let mut areas = Vec::with_capacity(patches);
        for _ in 0..patches {
            let (n, l) = next("area")?;
            areas.push(
                l.strip_prefix("area ")
                    .and_then(|x| x.parse::<f64>().ok())
                    .ok_or_else(|| bad(n, "expected 'area A'"))?,
            );
        }
        let mut blocks = Vec::new();
        while let Ok((n, l)) = next("block") {
            let f: Vec<&str> = l.split_whitespace().collect();
            if f.first() != Some(&"block") || f.len() != 9 {
                return Err(bad(n, "expected 'block ...'"));
            }
            let num = |k: usize| f[k].parse::<f64>().map_err(|_| bad(n, "bad number"));
            let int = |k: usize| f[k].parse::<u64>().map_err(|_| bad(n, "bad integer"));
            let cont = ContinuousMutualInformation::from_parts(num(4)?, int(5)?, num(6)?, num(7)?)
                .map_err(|e| bad(n, &e.to_string()))?;
            let mut b = BlockCounts {
                lines: int(1)?,
                segments: int(2)?,
                escaped: int(3)?,
                continuous: cont,
                background: vec![0; patches],
                endpoints: vec![0; patches],
                endpoint_log: vec![0.0; patches],
                pairs: Vec::with_capacity(int(8)? as usize),
            };
            for _ in 0..int(8)? {
                let (n, l) = next("pair")?;
                let f: Vec<u64> = l.split_whitespace().filter_map(|x| x.parse().ok()).collect();
                match f.as_slice() {
                    [i, j, c] if (*i as usize) < patches && (*j as usize) < patches => {
                        b.pairs.push(PairCount { from: *i as u32, to: *j as u32, count: *c });
                    }
                    _ => return Err(bad(n, "expected 'i j count' with patch indices in range")),
                }
            }
            loop {
                let (n, l) = next("end")?;
                if l == "end" {
                    break;
                }
                let f: Vec<&str> = l.split_whitespace().collect();
                match f.as_slice() {
                    ["p", i, bg, e, lg] => {
                        let i: usize = i
                            .parse()
                            .ok()
                            .filter(|&i| i < patches)
                            .ok_or_else(|| bad(n, "patch index out of range"))?;
                        b.background[i] = bg.parse().map_err(|_| bad(n, "bad integer"))?;
                        b.endpoints[i] = e.parse().map_err(|_| bad(n, "bad integer"))?;
                        b.endpoint_log[i] = lg.parse().map_err(|_| bad(n, "bad number"))?;
                    }
                    _ => return Err(bad(n, "expected 'p i background endpoints logsum' or 'end'")),
                }
            }
            if !b.pairs.windows(2).all(|w| (w[0].from, w[0].to) < (w[1].from, w[1].to)) {
                return Err(format!("block {}: pairs are not sorted", blocks.len()));
            }
            blocks.push(b);
        }
        if blocks.is_empty() {
            return Err("no blocks".into());
        }
        Ok((name, Self { areas, local, blocks }))
    }

    /// Appends the blocks of another run of the same scene (a shard).
    ///
    /// # Errors
    /// A message if the scenes or line kinds differ.
    pub fn merge(&mut self, other: VisibilityCounts) -> Result<(), String> {
        if other.areas.len() != self.areas.len()
            || other.areas.iter().zip(&self.areas).any(|(a, b)| (a - b).abs() > 1e-9 * b.abs())
        {
            return Err("the count files are for different scenes (patch areas differ)".into());
        }
        if other.local != self.local {
            return Err("cannot merge local-line and global-line counts".into());
        }
        self.blocks.extend(other.blocks);
        Ok(())
    }
}

/// What `itgfx complexity` reports.
#[derive(Clone, Debug, PartialEq)]
pub struct Complexity {
    /// Plug-in measures from all lines (Part III eqs. (39)–(51)).
    pub measures: SceneMeasures,
    /// Lines cast.
    pub lines: u64,
    /// Segments (global) or lines that reached a patch (local).
    pub segments: u64,
    /// Crossings counted against the background (0 in a closed scene).
    pub escaped: u64,
    /// `I_S^c` (eq. (59)) in the requested base; `None` without samples.
    pub continuous: Option<f64>,
    /// Jackknife standard error of `I_S`.
    pub mutual_information_stderr: Option<f64>,
    /// Jackknife standard error of `I_S^c`.
    pub continuous_stderr: Option<f64>,
    /// Jackknife bias-corrected `I_S`.
    pub mutual_information_corrected: Option<f64>,
    /// Per-patch information transfer `I_i` (eq. (65)).
    pub patch_information: Vec<f64>,
    /// Per-patch continuous transfer `I_i^c` (eq. (68)) estimated from the endpoints.
    pub patch_continuous: Vec<f64>,
}

fn merge_pairs(blocks: &[&BlockCounts]) -> Vec<PairCount> {
    let mut all: Vec<PairCount> = blocks.iter().flat_map(|b| b.pairs.iter().copied()).collect();
    all.sort_unstable_by_key(|p| (p.from, p.to));
    all
}

fn with_background(areas_n: usize, pairs: Vec<PairCount>, background: &[u64]) -> Vec<PairCount> {
    // The background is patch `n`: a destination without area.
    let mut v = pairs;
    for (i, &c) in background.iter().enumerate() {
        if c > 0 {
            v.push(PairCount { from: i as u32, to: areas_n as u32, count: c });
        }
    }
    v.sort_unstable_by_key(|p| (p.from, p.to));
    v
}

fn measures_of(areas: &[f64], blocks: &[&BlockCounts], base: Base) -> SceneMeasures {
    let n = areas.len();
    let mut bg = vec![0u64; n];
    for b in blocks {
        for (x, y) in bg.iter_mut().zip(&b.background) {
            *x += y;
        }
    }
    let pairs = with_background(n, merge_pairs(blocks), &bg);
    // Areas with a zero-area background column appended.
    let mut a = areas.to_vec();
    a.push(0.0);
    let mut totals = vec![0u64; n + 1];
    let mut m = scene_measures_from_counts(&a, &pairs, &mut totals, base).expect("validated scene");
    m.patches = n;
    m
}

fn jackknife(full: f64, leave_out: &[f64]) -> (f64, f64) {
    let b = leave_out.len() as f64;
    let mean = leave_out.iter().sum::<f64>() / b;
    let var = (b - 1.0) / b * leave_out.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>();
    (var.sqrt(), b * full - (b - 1.0) * mean)
}

impl VisibilityCounts {
    /// Lines cast in all blocks.
    #[must_use]
    pub fn lines(&self) -> u64 {
        self.blocks.iter().map(|b| b.lines).sum()
    }

    /// Evaluates the measures in `base`.
    #[must_use]
    pub fn complexity(&self, base: Base) -> Complexity {
        let all: Vec<&BlockCounts> = self.blocks.iter().collect();
        let measures = measures_of(&self.areas, &all, base);
        let mut cont = self.blocks[0].continuous;
        for b in &self.blocks[1..] {
            cont.merge(&b.continuous);
        }
        let continuous = cont.estimate(base);
        let (mut se, mut corrected, mut cse) = (None, None, None);
        if self.blocks.len() >= 2 {
            let mut mi = Vec::new();
            let mut ci = Vec::new();
            for skip in 0..self.blocks.len() {
                let rest: Vec<&BlockCounts> =
                    self.blocks.iter().enumerate().filter(|(k, _)| *k != skip).map(|(_, b)| b).collect();
                mi.push(measures_of(&self.areas, &rest, base).mutual_information);
                let mut c = rest[0].continuous;
                for b in &rest[1..] {
                    c.merge(&b.continuous);
                }
                if let Some(v) = c.estimate(base) {
                    ci.push(v);
                }
            }
            let (s, c) = jackknife(measures.mutual_information, &mi);
            se = Some(s);
            corrected = Some(c);
            if let (Some(full), true) = (continuous, ci.len() == self.blocks.len()) {
                cse = Some(jackknife(full, &ci).0);
            }
        }
        // Per-patch I_i (eq. (65)) and I_i^c from the endpoint samples.
        let n = self.areas.len();
        let total: f64 = self.areas.iter().sum();
        let mut row = vec![0u64; n];
        let mut bg = vec![0u64; n];
        let mut elog = vec![0.0; n];
        let mut ecount = vec![0u64; n];
        for b in &self.blocks {
            for p in &b.pairs {
                row[p.from as usize] += p.count;
            }
            for i in 0..n {
                bg[i] += b.background[i];
                elog[i] += b.endpoint_log[i];
                ecount[i] += b.endpoints[i];
            }
        }
        let k = base.per_nat();
        let mut info = vec![0.0; n];
        for p in merge_pairs(&all).chunk_by(|a, b| a.from == b.from && a.to == b.to) {
            let (i, j) = (p[0].from as usize, p[0].to as usize);
            let c: u64 = p.iter().map(|x| x.count).sum();
            let ni = (row[i] + bg[i]) as f64;
            let (ai, aj) = (self.areas[i] / total, self.areas[j] / total);
            let f = c as f64 / ni;
            if aj > 0.0 {
                info[i] += ai * f * (f / aj).ln() * k;
            }
        }
        let patch_continuous = (0..n)
            .map(|i| if ecount[i] > 0 { self.areas[i] / total * elog[i] / ecount[i] as f64 * k } else { 0.0 })
            .collect();
        Complexity {
            measures,
            lines: self.lines(),
            segments: self.blocks.iter().map(|b| b.segments).sum(),
            escaped: self.blocks.iter().map(|b| b.escaped).sum(),
            continuous,
            mutual_information_stderr: se,
            continuous_stderr: cse,
            mutual_information_corrected: corrected,
            patch_information: info,
            patch_continuous,
        }
    }
}
