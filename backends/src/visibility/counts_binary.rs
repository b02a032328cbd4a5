//! The binary counts file (format 4): the same counts as the JSON file of
//! [`super::counts_file`], under the same header, little-endian, a few
//! bytes per pair, read with every declared size checked against the bytes
//! left before anything is allocated.
//!
//! Layout (all integers little-endian, no padding):
//!
//! | field | bytes |
//! |---|---|
//! | magic `ITGFXCNT`, version `u32` = 4 (earlier versions: "written by an older itgfx") | 12 |
//! | the header of [`super::counts_header`] as JSON text `{"header": {...}}` (format, version, place, fingerprint, scene name, patches and areas hash, line kind, seed, blocks): length `u32`, UTF-8 bytes | 4 + header |
//! | line ranges: count `u64`, then `[start, end)` as `u64` pairs | 8 + 16 per range |
//! | areas: `f64` per patch | 8 per patch |
//! | endpoints: count `u64` and `Σ ln(A_T F)` `i128` (units of `2^-64` nats) per patch | 24 per patch |
//! | per block: lines, segments, escaped, samples `u64`; `Σ l`, `Σ l²` `i128` | 64 |
//! | per block: pairs `u64`, step width `u8` (1, 2 or 4), count width `u8` (1, 2, 4 or 8) | 10 |
//! | per block: pairs from each patch `u32` per patch; then each pair's step (its `to` less the previous `to` of its row, or its `to` if first; step width bytes); then each count (count width bytes) | 4 per patch + (step width + count width) per pair |
//! | per block: background entries `u64`, then `(patch u32, count u64)` | 8 + 12 per entry |
//!
//! Pairs are stored sparse, row by row (compressed sparse rows): a shard of
//! `10^8 / 16` lines of `cube-enclosure:30` hits about 2% of the `5400²`
//! pairs per block, mostly once, so a pair costs 5 bytes here against
//! 16 bytes in a dense `u32` matrix row and about 16 bytes of JSON text.
//! The file ends exactly after the last block: a truncated file is refused.

use itgfx_core::PairCount;

use super::counts_header::{FORMAT_VERSION, Run, header_text, older, read_header};
use super::counts_valid::SceneFingerprint;
use super::{BlockCounts, ContinuousSums, CountsError, FixedSum, VisibilityCounts};

/// The first 8 bytes of a binary counts file.
pub const MAGIC: &[u8; 8] = b"ITGFXCNT";
/// Bytes of memory per byte of binary file that reading may take: the file,
/// and the parsed pairs (a pair of at least 5 bytes becomes 16 bytes).
pub const BYTES_PER_BINARY_BYTE: u64 = 5;

fn invalid(m: impl Into<String>) -> CountsError {
    CountsError::Invalid(m.into())
}

/// Appends little-endian fields.
struct Writer<'a>(&'a mut Vec<u8>);

impl Writer<'_> {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn i128(&mut self, v: i128) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
}

/// Reads little-endian fields, refusing to read past the end.
struct Reader<'a> {
    rest: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], CountsError> {
        if n > self.rest.len() {
            return Err(CountsError::Format(format!("the binary counts file ends inside {what} (truncated?)")));
        }
        let (head, tail) = self.rest.split_at(n);
        self.rest = tail;
        Ok(head)
    }
    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], CountsError> {
        Ok(self.take(N, what)?.try_into().expect("N bytes"))
    }
    fn u8(&mut self, what: &str) -> Result<u8, CountsError> {
        Ok(self.array::<1>(what)?[0])
    }
    fn u32(&mut self, what: &str) -> Result<u32, CountsError> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }
    fn u64(&mut self, what: &str) -> Result<u64, CountsError> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }
    fn i128(&mut self, what: &str) -> Result<i128, CountsError> {
        Ok(i128::from_le_bytes(self.array(what)?))
    }
    /// A declared number of items of `size` bytes each, checked against the
    /// bytes left: what it returns can be allocated (it is at most the
    /// file's length).
    fn count(&mut self, declared: u64, size: u64, what: &str) -> Result<usize, CountsError> {
        match declared.checked_mul(size) {
            Some(bytes) if bytes <= self.rest.len() as u64 => Ok(declared as usize),
            _ => Err(CountsError::Format(format!(
                "{what}: {declared} declared but only {} bytes are left in the file",
                self.rest.len()
            ))),
        }
    }
}

/// Each pair's `to` as a step from the previous pair's `to` in its row
/// (the first of a row: from 0).
fn to_steps(pairs: &[PairCount]) -> Vec<u32> {
    let mut prev = None;
    pairs
        .iter()
        .map(|p| {
            let base = match prev {
                Some((from, to)) if from == p.from => to,
                _ => 0,
            };
            prev = Some((p.from, p.to));
            p.to.wrapping_sub(base)
        })
        .collect()
}

/// Reads a `width`-byte little-endian integer (`width` ≤ 8) at item `i`.
#[inline]
fn le(bytes: &[u8], width: usize, i: usize) -> u64 {
    let at = width * i;
    match width {
        1 => u64::from(bytes[at]),
        2 => u64::from(u16::from_le_bytes([bytes[at], bytes[at + 1]])),
        4 => u64::from(u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))),
        _ => u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes")),
    }
}

/// The smallest of 1, 2, 4, 8 bytes that holds every value.
fn width(values: impl Iterator<Item = u64>) -> u8 {
    match values.max().unwrap_or(0) {
        0..=0xff => 1,
        0x100..=0xffff => 2,
        0x1_0000..=0xffff_ffff => 4,
        _ => 8,
    }
}

impl VisibilityCounts {
    /// The counts as a binary counts file (format [`FORMAT_VERSION`]), with
    /// the scene name `name` in the header.
    #[must_use]
    pub fn to_binary(&self, name: &str) -> Vec<u8> {
        let n = self.areas.len();
        let pairs: usize = self.blocks.iter().map(|b| b.pairs.len()).sum();
        let header = header_text(name, self);
        let mut out = Vec::with_capacity(64 + header.len() + 40 * n + self.blocks.len() * (96 + 4 * n) + 6 * pairs);
        out.extend_from_slice(MAGIC);
        let mut w = Writer(&mut out);
        w.u32(FORMAT_VERSION);
        w.u32(header.len() as u32);
        w.0.extend_from_slice(header.as_bytes());
        w.u64(self.ranges.len() as u64);
        for r in &self.ranges {
            w.u64(r.0);
            w.u64(r.1);
        }
        for a in &self.areas {
            w.u64(a.to_bits());
        }
        for (e, l) in self.endpoints.iter().zip(&self.endpoint_log) {
            w.u64(*e);
            w.i128(l.0);
        }
        for b in &self.blocks {
            for v in [b.lines, b.segments, b.escaped, b.continuous.samples] {
                w.u64(v);
            }
            w.i128(b.continuous.sum.0);
            w.i128(b.continuous.sum_sq.0);
            w.u64(b.pairs.len() as u64);
            let steps = to_steps(&b.pairs);
            let to_width = width(steps.iter().map(|&d| u64::from(d)));
            let width = width(b.pairs.iter().map(|p| p.count));
            w.0.push(to_width);
            w.0.push(width);
            let mut rows = vec![0u32; n];
            for p in &b.pairs {
                rows[p.from as usize] += 1;
            }
            for r in rows {
                w.u32(r);
            }
            for d in steps {
                w.0.extend_from_slice(&d.to_le_bytes()[..usize::from(to_width)]);
            }
            for p in &b.pairs {
                w.0.extend_from_slice(&p.count.to_le_bytes()[..usize::from(width)]);
            }
            w.u64(b.background.len() as u64);
            for &(i, c) in &b.background {
                w.u32(i);
                w.u64(c);
            }
        }
        out
    }

    /// Reads a binary counts file and checks it
    /// ([`VisibilityCounts::validate`]); returns the scene name too.
    /// Nothing is allocated from a declared size before that size is
    /// checked against the bytes left in the file.
    ///
    /// # Errors
    /// [`CountsError::Format`] for bytes that are not a binary counts file
    /// of this format (or are truncated, or run on), [`CountsError::Invalid`]
    /// / [`CountsError::Overflow`] for bad contents.
    pub fn from_binary(bytes: &[u8]) -> Result<(String, Self), CountsError> {
        let mut r = Reader { rest: bytes };
        if r.take(8, "the magic").ok() != Some(&MAGIC[..]) {
            return Err(CountsError::Format("not a binary itgfx counts file (no ITGFXCNT magic)".into()));
        }
        version(r.u32("the version")?)?;
        let len = r.u32("the header's length")?;
        let len = r.count(u64::from(len), 1, "the header's bytes")?;
        let text = std::str::from_utf8(r.take(len, "the header")?).map_err(|_| invalid("the header is not UTF-8"))?;
        let Run { scene, local, seed, blocks } = read_header(text)?;
        let (name, patches) = (scene.name.clone(), scene.patches);
        let ranges_declared = r.u64("the range count")?;
        let nr = r.count(ranges_declared, 16, "line ranges")?;
        let mut ranges = Vec::with_capacity(nr);
        for _ in 0..nr {
            ranges.push((r.u64("a line range")?, r.u64("a line range")?));
        }
        // Areas and endpoints take 32 bytes per patch.
        let n = r.count(patches, 32, "patches")?;
        let mut areas = Vec::with_capacity(n);
        for _ in 0..n {
            areas.push(f64::from_bits(r.u64("an area")?));
        }
        let (mut endpoints, mut endpoint_log) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..n {
            endpoints.push(r.u64("an endpoint count")?);
            endpoint_log.push(FixedSum(r.i128("an endpoint sum")?));
        }
        // A block takes at least 74 + 4n bytes.
        let nb = r.count(u64::from(blocks), 74 + 4 * n as u64, "jackknife blocks")?;
        let mut out = Vec::with_capacity(nb);
        for k in 0..nb {
            out.push(read_block(&mut r, n, k)?);
        }
        if !r.rest.is_empty() {
            return Err(CountsError::Format(format!(
                "{} bytes follow the last block of the binary counts file",
                r.rest.len()
            )));
        }
        let counts = Self { scene, areas, local, seed, ranges, blocks: out, endpoints, endpoint_log };
        counts.validate()?;
        Ok((name, counts))
    }
}

/// One block's counts: totals, sums, the pairs row by row, the background.
fn read_block(r: &mut Reader<'_>, n: usize, k: usize) -> Result<BlockCounts, CountsError> {
    let what = |s: &str| format!("block {k}'s {s}");
    let lines = r.u64(&what("line count"))?;
    let segments = r.u64(&what("segment count"))?;
    let escaped = r.u64(&what("background count"))?;
    let samples = r.u64(&what("sample count"))?;
    let sum = FixedSum(r.i128(&what("log sum"))?);
    let sum_sq = FixedSum(r.i128(&what("log square sum"))?);
    let declared = r.u64(&what("pair count"))?;
    let to_width = r.u8(&what("step width"))?;
    let width = r.u8(&what("count width"))?;
    if ![1, 2, 4].contains(&to_width) || ![1, 2, 4, 8].contains(&width) {
        return Err(invalid(format!(
            "block {k}: widths {to_width} and {width}: expected 1, 2 or 4 bytes per step and 1, 2, 4 or 8 per count"
        )));
    }
    let (tw, w) = (usize::from(to_width), usize::from(width));
    let rows = r.take(4 * n, &what("rows"))?;
    let np = r.count(declared, (tw + w) as u64, &what("pairs"))?;
    let (to, counts) = (r.take(tw * np, &what("pairs"))?, r.take(w * np, &what("counts"))?);
    let mut pairs = Vec::with_capacity(np);
    let mut at = 0usize;
    for (from, row) in rows.chunks_exact(4).enumerate() {
        let len = u32::from_le_bytes(row.try_into().expect("4 bytes")) as usize;
        if len > np - at {
            return Err(invalid(format!("block {k}: the rows list more than its {np} pairs")));
        }
        let mut t = 0u64;
        for p in at..at + len {
            t += le(to, tw, p);
            let t = u32::try_from(t).map_err(|_| invalid(format!("block {k}: a patch index is out of range")))?;
            pairs.push(PairCount { from: from as u32, to: t, count: le(counts, w, p) });
        }
        at += len;
    }
    if at != np {
        return Err(invalid(format!("block {k}: the rows list {at} of its {np} pairs")));
    }
    let nbg = r.u64(&what("background entry count"))?;
    let nbg = r.count(nbg, 12, &what("background entries"))?;
    let mut background = Vec::with_capacity(nbg);
    for _ in 0..nbg {
        background.push((r.u32(&what("background entry"))?, r.u64(&what("background entry"))?));
    }
    Ok(BlockCounts { lines, segments, escaped, pairs, background, continuous: ContinuousSums { samples, sum, sum_sq } })
}

/// What a binary counts file says about itself without its counts: the run
/// (scene, line kind, seed, blocks), the line ranges it covers and each
/// block's pair and background entry counts. A merge reads these of every
/// file first, to refuse overlapping or missing ranges and to estimate its
/// memory ([`super::merge::merge_memory`]) before reading any counts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CountsHeader {
    /// The scene the counts are of.
    pub scene: SceneFingerprint,
    /// Local lines (else global).
    pub local: bool,
    /// The run's seed.
    pub seed: u64,
    /// The line ranges the counts cover.
    pub ranges: Vec<(u64, u64)>,
    /// Per jackknife block: (pairs, background entries).
    pub blocks: Vec<(u64, u64)>,
    /// The file's size in bytes.
    pub bytes: u64,
}

impl VisibilityCounts {
    /// Reads the header of the binary counts file at `path` and steps over
    /// each block's counts (seeking, reading only the sizes): `None` for a
    /// JSON counts file. Every declared size is checked against the file's
    /// length; the counts themselves are checked when read.
    ///
    /// # Errors
    /// [`CountsError::Format`] for an unreadable, foreign or truncated file,
    /// [`CountsError::Invalid`] for a bad block count or width.
    pub fn peek(path: &std::path::Path) -> Result<Option<CountsHeader>, CountsError> {
        let io = |e: std::io::Error| CountsError::Format(format!("{}: {e}", path.display()));
        let file = crate::files::open_regular(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let mut f = Peek { file: std::io::BufReader::new(file), at: 0, len };
        if len < 8 || f.bytes(8, "the magic")? != MAGIC {
            return Ok(None);
        }
        version(f.u32("the version")?)?;
        let header_len = f.u32("the header's length")?;
        let text = String::from_utf8(f.bytes(u64::from(header_len), "the header")?)
            .map_err(|_| invalid("the header is not UTF-8"))?;
        let Run { scene, local, seed, blocks } = read_header(&text)?;
        let patches = scene.patches;
        let nr = f.u64("the range count")?;
        let raw = f.bytes(f.declared(nr, 16, "line ranges")?, "line ranges")?;
        let at = |b: &[u8], i: usize| u64::from_le_bytes(b[i..i + 8].try_into().expect("8 bytes"));
        let ranges = raw.chunks_exact(16).map(|r| (at(r, 0), at(r, 8))).collect();
        f.skip(f.declared(patches, 32, "patches")?, "the areas and endpoints")?;
        let mut sizes = Vec::with_capacity(blocks as usize);
        for k in 0..blocks {
            f.skip(64, &format!("block {k}'s totals"))?;
            let pairs = f.u64(&format!("block {k}'s pair count"))?;
            let w = f.bytes(2, &format!("block {k}'s widths"))?;
            let (tw, cw) = (u64::from(w[0]), u64::from(w[1]));
            if ![1, 2, 4].contains(&tw) || ![1, 2, 4, 8].contains(&cw) {
                return Err(invalid(format!(
                    "block {k}: widths {tw} and {cw}: expected 1, 2 or 4 bytes per step and 1, 2, 4 or 8 per count"
                )));
            }
            f.skip(patches.saturating_mul(4), &format!("block {k}'s rows"))?;
            let what = format!("block {k}'s pairs");
            f.skip(f.declared(pairs, tw + cw, &what)?, &what)?;
            let bg = f.u64(&format!("block {k}'s background entry count"))?;
            let what = format!("block {k}'s background entries");
            f.skip(f.declared(bg, 12, &what)?, &what)?;
            sizes.push((pairs, bg));
        }
        Ok(Some(CountsHeader { scene, local, seed, ranges, blocks: sizes, bytes: len }))
    }
}

/// Refuses a binary file of another version: an earlier one as written by
/// an older itgfx.
fn version(v: u32) -> Result<(), CountsError> {
    match v {
        FORMAT_VERSION => Ok(()),
        v if v < FORMAT_VERSION => Err(older(v)),
        v => Err(CountsError::Format(format!(
            "a binary counts file of version {v}: this itgfx reads version {FORMAT_VERSION}"
        ))),
    }
}

/// Reads a file front to back by pieces, each checked against its length.
struct Peek {
    file: std::io::BufReader<std::fs::File>,
    at: u64,
    len: u64,
}

impl Peek {
    /// The bytes of `declared` items of `size` bytes, refused (as the
    /// reader does) if past the bytes left.
    fn declared(&self, declared: u64, size: u64, what: &str) -> Result<u64, CountsError> {
        let left = self.len - self.at;
        match declared.checked_mul(size) {
            Some(bytes) if bytes <= left => Ok(bytes),
            _ => Err(CountsError::Format(format!(
                "{what}: {declared} declared but only {left} bytes are left in the file"
            ))),
        }
    }
    fn check(&self, n: u64, what: &str) -> Result<(), CountsError> {
        if n > self.len - self.at {
            return Err(CountsError::Format(format!("the binary counts file ends inside {what} (truncated?)")));
        }
        Ok(())
    }
    fn bytes(&mut self, n: u64, what: &str) -> Result<Vec<u8>, CountsError> {
        use std::io::Read;
        self.check(n, what)?;
        let mut buf = vec![0; usize::try_from(n).map_err(|_| invalid(format!("{what}: too large")))?];
        self.file.read_exact(&mut buf).map_err(|e| CountsError::Format(format!("{what}: {e}")))?;
        self.at += n;
        Ok(buf)
    }
    fn skip(&mut self, n: u64, what: &str) -> Result<(), CountsError> {
        self.check(n, what)?;
        let step = i64::try_from(n).map_err(|_| invalid(format!("{what}: too large")))?;
        self.file.seek_relative(step).map_err(|e| CountsError::Format(format!("{what}: {e}")))?;
        self.at += n;
        Ok(())
    }
    fn u32(&mut self, what: &str) -> Result<u32, CountsError> {
        Ok(u32::from_le_bytes(self.bytes(4, what)?.try_into().expect("4 bytes")))
    }
    fn u64(&mut self, what: &str) -> Result<u64, CountsError> {
        Ok(u64::from_le_bytes(self.bytes(8, what)?.try_into().expect("8 bytes")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::built_in;
    use crate::tracer::{CpuTracer, Prepared};
    use crate::visibility::{LineOptions, count_visibility};

    fn counts(lines: u64, local: bool) -> VisibilityCounts {
        let scene = built_in("cube-enclosure:2").unwrap();
        let prepared = Prepared::new(&scene);
        let tracer = CpuTracer::new(&prepared);
        let opts = LineOptions { lines, seed: 3, local, blocks: 3, offset: 5 };
        count_visibility(&scene, &prepared, &tracer, &opts, &mut |_, _| {}).unwrap()
    }

    /// Saved and read back, the counts are the same, for global and local
    /// lines.
    #[test]
    fn round_trips_bit_for_bit() {
        for local in [false, true] {
            let c = counts(4000, local);
            let bytes = c.to_binary("cube-enclosure:2");
            assert_eq!(bytes[..8], MAGIC[..]);
            assert_eq!(VisibilityCounts::from_binary(&bytes).unwrap(), ("cube-enclosure:2".into(), c));
        }
    }

    /// A count past 2^32 takes 8 bytes and reads back exactly (2^34 local
    /// lines from patch 0, all reaching patch 1).
    #[test]
    fn wide_counts_round_trip() {
        let areas = vec![1.0, 0.5];
        let lines = 1u64 << 34;
        let block = BlockCounts {
            lines,
            segments: lines,
            escaped: 0,
            pairs: vec![PairCount { from: 0, to: 1, count: lines }],
            background: Vec::new(),
            continuous: ContinuousSums::default(),
        };
        let c = VisibilityCounts {
            scene: SceneFingerprint::of("wide", &areas),
            areas,
            local: true,
            seed: 7,
            ranges: vec![(0, lines)],
            blocks: vec![block],
            endpoints: vec![0, 0],
            endpoint_log: vec![FixedSum::default(); 2],
        };
        c.validate().unwrap();
        assert_eq!(width(c.blocks[0].pairs.iter().map(|p| p.count)), 8);
        let bytes = c.to_binary("wide");
        assert_eq!(VisibilityCounts::from_binary(&bytes).unwrap(), ("wide".into(), c));
    }

    /// Every prefix of a file is refused with a message (no panic, no huge
    /// allocation), and so is a byte appended.
    #[test]
    fn truncated_and_extended_files_are_refused() {
        let c = counts(300, false);
        let bytes = c.to_binary("cube-enclosure:2");
        for cut in 0..bytes.len() {
            assert!(VisibilityCounts::from_binary(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let mut more = bytes.clone();
        more.push(0);
        let e = VisibilityCounts::from_binary(&more).unwrap_err().to_string();
        assert!(e.contains("1 bytes follow"), "{e}");
    }

    /// Declared sizes of 2^32-1 header bytes or 2^64-1 ranges or patches
    /// are refused before anything is allocated; an edited header by its
    /// fingerprint; another version by its number, an earlier one as older.
    #[test]
    fn huge_declared_sizes_are_refused() {
        let c = counts(300, false);
        let bytes = c.to_binary("cube-enclosure:2");
        let header_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let ranges_at = 16 + header_len;
        let mut b = bytes.clone();
        b[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = VisibilityCounts::from_binary(&b).unwrap_err().to_string();
        assert!(e.contains("the header's bytes") && e.contains("declared"), "{e}");
        let mut b = bytes.clone();
        b[ranges_at..ranges_at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        let e = VisibilityCounts::from_binary(&b).unwrap_err().to_string();
        assert!(e.contains("line ranges") && e.contains("declared"), "{e}");
        let text = std::str::from_utf8(&bytes[16..ranges_at]).unwrap();
        let patches = format!("\"patches\":{},", c.scene.patches);
        assert!(text.contains(&patches), "{text}");
        let edited = text.replace(&patches, &format!("\"patches\":{},", c.scene.patches + 1));
        let mut b = bytes[..16].to_vec();
        b.extend_from_slice(edited.as_bytes());
        b.extend_from_slice(&bytes[ranges_at..]);
        let e = VisibilityCounts::from_binary(&b).unwrap_err().to_string();
        assert!(e.contains("does not match the scene and settings"), "{e}");
        let mut b = bytes.clone();
        b[8..12].copy_from_slice(&3u32.to_le_bytes());
        let e = VisibilityCounts::from_binary(&b).unwrap_err().to_string();
        assert!(e.contains("written by an older itgfx (format 3); re-run"), "{e}");
        let mut b = bytes;
        b[8..12].copy_from_slice(&9u32.to_le_bytes());
        assert!(VisibilityCounts::from_binary(&b).unwrap_err().to_string().contains("version 9"));
    }

    /// `peek` reads what the file says without its counts: the header
    /// matches the counts, each block's sizes too; a JSON file gives
    /// `None`; every truncation within the header or a block's sizes, or
    /// short of a block's counts, is refused.
    #[test]
    fn peek_reads_the_header_and_block_sizes() {
        let c = counts(300, true);
        let bytes = c.to_binary("cube-enclosure:2");
        let dir = std::env::temp_dir().join(format!("itgfx-peek-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("c.counts");
        std::fs::write(&p, &bytes).unwrap();
        let h = VisibilityCounts::peek(&p).unwrap().unwrap();
        assert_eq!((h.local, h.seed, &h.ranges, h.bytes), (true, 3, &c.ranges, bytes.len() as u64));
        assert_eq!(h.scene, c.scene);
        let sizes: Vec<(u64, u64)> =
            c.blocks.iter().map(|b| (b.pairs.len() as u64, b.background.len() as u64)).collect();
        assert_eq!(h.blocks, sizes);
        assert!(sizes.iter().any(|s| s.0 > 0));
        for cut in [9, 30, 60, bytes.len() / 2, bytes.len() - 1] {
            std::fs::write(&p, &bytes[..cut]).unwrap();
            let e = VisibilityCounts::peek(&p).unwrap_err().to_string();
            // Cut inside a field, or short of what a declared size needs.
            assert!(e.contains("truncated") || e.contains("declared but only"), "cut at {cut}: {e}");
        }
        let mut json = Vec::new();
        c.save("cube-enclosure:2", &mut json).unwrap();
        std::fs::write(&p, &json).unwrap();
        assert_eq!(VisibilityCounts::peek(&p).unwrap(), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
