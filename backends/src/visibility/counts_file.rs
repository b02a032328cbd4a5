//! The counts file: a run's counts saved as JSON (serde), so that shards
//! of a run (disjoint line ranges, `--offset`) can be merged and evaluated
//! later. What identifies the scene, and the checks every loaded file
//! passes, are in `counts_valid`; the header is the one shard header
//! ([`super::counts_header`]).
//!
//! Format 4 holds the header (format, version, place `0/1`, fingerprint,
//! the scene's name, patch count and areas hash, and the settings: line
//! kind, seed, jackknife blocks and their assignment, line `i` in block
//! `i mod B`), then the areas, the line index ranges covered, and per block
//! the line, segment and background totals, the `I_S^c` sums (fixed point,
//! units of `2^-64` nats) and the sparse pair and background counts; per
//! patch the endpoint counts and log sums. Every value is checked on
//! reading: a file either loads into counts that evaluate to finite
//! numbers, or is refused with one line. Nothing is allocated from a
//! declared size: what is allocated is bounded by the length of the text.

use serde::{Deserialize, Serialize};

use super::counts_binary::{BYTES_PER_BINARY_BYTE, MAGIC};
use super::counts_header::{CountsSettings, KIND, header_error, header_of, older, run_of};
use super::counts_valid::{check_sparse, invalid};
use super::{BlockCounts, ContinuousSums, CountsError, FixedSum, VisibilityCounts};
use crate::shards::{Header, Kind, ShardFile};
use itgfx_core::PairCount;

/// A fixed-point sum written as a decimal string: JSON readers that hold
/// numbers as `f64` would round an integer past `2^53`.
#[derive(Clone, Copy)]
struct Fixed(i128);

impl Serialize for Fixed {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(&self.0)
    }
}

impl<'de> Deserialize<'de> for Fixed {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = <std::borrow::Cow<'de, str>>::deserialize(d)?;
        text.parse()
            .map(Fixed)
            .map_err(|_| serde::de::Error::custom("expected a fixed-point sum: a decimal integer string"))
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileBlock {
    lines: u64,
    segments: u64,
    escaped: u64,
    samples: u64,
    /// `Σ ln(A_T F)` in units of `2^-64` nats.
    log_sum: Fixed,
    /// `Σ ln²(A_T F)` in units of `2^-64` nats².
    log_sq_sum: Fixed,
    /// `[from, to, N_ij]`, sorted.
    pairs: Vec<(u32, u32, u64)>,
    /// `[patch, count]`, sorted.
    background: Vec<(u32, u64)>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    header: Header<CountsSettings>,
    areas: Vec<f64>,
    /// `[start, end)` line indices.
    ranges: Vec<(u64, u64)>,
    blocks: Vec<FileBlock>,
    /// `[patch, endpoints, Σ ln(A_T F) in units of 2^-64 nats]`, sorted.
    endpoints: Vec<(u32, u64, Fixed)>,
}

impl ShardFile for File {
    type Settings = CountsSettings;
    const KIND: Kind = KIND;

    fn header(&self) -> &Header<CountsSettings> {
        &self.header
    }

    /// The counts' own invariants are checked once they are built
    /// ([`VisibilityCounts::validate`]).
    fn violation(&self) -> Option<String> {
        None
    }
}

impl VisibilityCounts {
    /// Writes the counts as a counts file (JSON, format
    /// [`super::FORMAT_VERSION`]) with the scene name `name` in the header
    /// (the name of the scene counted).
    ///
    /// # Errors
    /// I/O errors.
    pub fn save(&self, name: &str, out: &mut impl std::io::Write) -> std::io::Result<()> {
        let file = File {
            header: header_of(name, self),
            areas: self.areas.clone(),
            ranges: self.ranges.clone(),
            blocks: self
                .blocks
                .iter()
                .map(|b| FileBlock {
                    lines: b.lines,
                    segments: b.segments,
                    escaped: b.escaped,
                    samples: b.continuous.samples,
                    log_sum: Fixed(b.continuous.sum.0),
                    log_sq_sum: Fixed(b.continuous.sum_sq.0),
                    pairs: b.pairs.iter().map(|p| (p.from, p.to, p.count)).collect(),
                    background: b.background.clone(),
                })
                .collect(),
            endpoints: self
                .endpoints
                .iter()
                .zip(&self.endpoint_log)
                .enumerate()
                .filter(|(_, (e, _))| **e > 0)
                .map(|(i, (&e, l))| (i as u32, e, Fixed(l.0)))
                .collect(),
        };
        serde_json::to_writer(&mut *out, &file).map_err(std::io::Error::other)?;
        writeln!(out)
    }

    /// Reads a counts file written by [`VisibilityCounts::save`] and checks
    /// it ([`VisibilityCounts::validate`]); returns the scene name too.
    ///
    /// # Errors
    /// [`CountsError::Format`] for text that is not a counts file of this
    /// format (an older one: "written by an older itgfx (format N); re-run"),
    /// [`CountsError::Invalid`] / [`CountsError::Overflow`] for bad contents.
    pub fn load(text: &str) -> Result<(String, Self), CountsError> {
        if text.starts_with("itgfx-counts 1") {
            return Err(older(1));
        }
        let f: File = crate::shards::from_json(text).map_err(header_error)?;
        let run = run_of(&f.header)?;
        if run.blocks as usize != f.blocks.len() {
            return Err(invalid(format!(
                "jackknife: expected {} blocks assigned by {:?}, found {} blocks",
                run.blocks,
                f.header.settings.assignment,
                f.blocks.len()
            )));
        }
        // Every allocation below is at most a constant times the text's length.
        let n = f.areas.len();
        if run.scene.patches != n as u64 {
            return Err(invalid(format!("the scene has {} patches but {n} areas are listed", run.scene.patches)));
        }
        let mut endpoints = vec![0u64; n];
        let mut endpoint_log = vec![FixedSum::default(); n];
        check_sparse("endpoints", f.endpoints.iter().map(|e| (e.0, e.1)), |i| (i as usize) < n)?;
        for &(i, e, l) in &f.endpoints {
            endpoints[i as usize] = e;
            endpoint_log[i as usize] = FixedSum(l.0);
        }
        let blocks = f
            .blocks
            .into_iter()
            .map(|b| BlockCounts {
                lines: b.lines,
                segments: b.segments,
                escaped: b.escaped,
                pairs: b.pairs.into_iter().map(|(from, to, count)| PairCount { from, to, count }).collect(),
                background: b.background,
                continuous: ContinuousSums {
                    samples: b.samples,
                    sum: FixedSum(b.log_sum.0),
                    sum_sq: FixedSum(b.log_sq_sum.0),
                },
            })
            .collect();
        let name = run.scene.name.clone();
        let counts = Self {
            scene: run.scene,
            areas: f.areas,
            local: run.local,
            seed: run.seed,
            ranges: f.ranges,
            blocks,
            endpoints,
            endpoint_log,
        };
        counts.validate()?;
        Ok((name, counts))
    }

    /// Reads and checks a counts file from `path`, binary
    /// ([`super::counts_binary`]) or JSON, refusing before
    /// reading one whose parsed form would not fit in the memory available
    /// (at most [`BYTES_PER_FILE_BYTE`] bytes per byte of JSON,
    /// [`BYTES_PER_BINARY_BYTE`] per byte of binary, the file included).
    ///
    /// # Errors
    /// As [`VisibilityCounts::load`] and [`VisibilityCounts::from_binary`];
    /// I/O errors as [`CountsError::Format`] with the path; [`CountsError::TooLarge`].
    pub fn read(path: &std::path::Path) -> Result<(String, Self), CountsError> {
        use std::io::Read;
        let io = |e: std::io::Error| CountsError::Format(format!("{}: {e}", path.display()));
        let mut file = crate::files::open_regular(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let mut head = Vec::with_capacity(MAGIC.len());
        (&mut file).take(MAGIC.len() as u64).read_to_end(&mut head).map_err(io)?;
        let binary = head == MAGIC;
        let needed = len.saturating_mul(if binary { BYTES_PER_BINARY_BYTE } else { BYTES_PER_FILE_BYTE });
        crate::memory::check(|| format!("reading {}", path.display()), needed).map_err(CountsError::TooLarge)?;
        // The length is a hint only (the file may grow); it fits in memory.
        let mut bytes = crate::memory::try_vec(usize::try_from(len).unwrap_or(usize::MAX).saturating_add(1), || {
            format!("reading {}", path.display())
        })
        .map_err(CountsError::TooLarge)?;
        bytes.extend_from_slice(&head);
        file.read_to_end(&mut bytes).map_err(io)?;
        if binary {
            return Self::from_binary(&bytes);
        }
        let text = String::from_utf8(bytes).map_err(|_| {
            CountsError::Format("not an itgfx counts file: neither binary (ITGFXCNT) nor JSON text".into())
        })?;
        Self::load(&text)
    }
}

/// Bytes of memory per byte of counts file that reading may take: the text,
/// the parsed entries (a pair of at least 8 bytes of text becomes 16 bytes,
/// twice that while its vector grows) and the per-patch arrays (an area of
/// at least 2 bytes of text becomes 8 + 24 bytes).
pub const BYTES_PER_FILE_BYTE: u64 = 24;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::visibility::SceneFingerprint;

    /// A hand-made run of one local line per block over two patches.
    fn tiny(name: &str, start: u64) -> VisibilityCounts {
        let areas = vec![1.0, 0.5];
        let block = BlockCounts {
            lines: 1,
            segments: 1,
            escaped: 0,
            pairs: vec![PairCount { from: 0, to: 1, count: 1 }],
            background: Vec::new(),
            continuous: ContinuousSums { samples: 1, sum: FixedSum::of(0.5), sum_sq: FixedSum::of(0.25) },
        };
        VisibilityCounts {
            scene: SceneFingerprint::of(name, &areas),
            areas,
            local: true,
            seed: 1,
            ranges: vec![(start, start + 2)],
            blocks: vec![block.clone(), block],
            endpoints: vec![2, 0],
            endpoint_log: vec![FixedSum::of(1.0), FixedSum::default()],
        }
    }

    /// JSON strings carry any name: the line-based version 1 broke at a newline.
    #[test]
    fn a_name_with_a_newline_round_trips() {
        let c = tiny("two\nlines \"quoted\"", 0);
        c.validate().unwrap();
        let mut out = Vec::new();
        c.save(&c.scene.name, &mut out).unwrap();
        let (name, back) = VisibilityCounts::load(std::str::from_utf8(&out).unwrap()).unwrap();
        assert_eq!(name, "two\nlines \"quoted\"");
        assert_eq!(back, c);
    }

    /// A file of an earlier format (JSON version 2, the line-based
    /// version 1) is refused as older, with the way out; the header is the
    /// one shard header, format 4.
    #[test]
    fn older_formats_are_refused_as_older() {
        let c = tiny("s", 0);
        let mut out = Vec::new();
        c.save("s", &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.starts_with("{\"header\":{\"format\":\"itgfx-counts\",\"version\":4,"), "{text}");
        let v2 = r#"{"format":"itgfx-counts","version":2,"scene":{}}"#;
        for (old, n) in [(v2, 2), ("itgfx-counts 1\nscene x\n", 1)] {
            let e = VisibilityCounts::load(old).unwrap_err().to_string();
            assert!(e.contains(&format!("written by an older itgfx (format {n}); re-run")), "{e}");
        }
    }

    /// A refused merge leaves the counts as they were; ranges join.
    #[test]
    fn merges_check_first_and_join_ranges() {
        let mut a = tiny("s", 0);
        let before = a.clone();
        let mut far = tiny("s", 2);
        far.blocks[0].pairs[0].count = u64::MAX;
        assert!(a.merge(far).is_err());
        assert!(matches!(a.merge(tiny("t", 2)), Err(CountsError::Mismatch(_))));
        assert!(matches!(a.merge(tiny("s", 1)), Err(CountsError::Mismatch(m)) if m.contains("overlap")));
        assert_eq!(a, before);
        a.merge(tiny("s", 2)).unwrap();
        assert_eq!(a.ranges, vec![(0, 4)]);
        assert_eq!(a.blocks[0].pairs[0].count, 2);
    }
}
