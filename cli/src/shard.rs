//! `--shard i/n`: one of `n` disjoint, contiguous pieces of a run (line
//! ranges of `complexity`, viewpoint ranges of `viewpoints`), so that a job
//! array's task `i` runs `--shard $i/$n` and never computes offsets.

use std::fmt;
use std::ops::Range;

/// Shard `index` of `count` (0-based: `0/4`, `1/4`, `2/4`, `3/4`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// Which shard, `0..count`.
    pub index: u64,
    /// How many shards the run is split into, at least 1.
    pub count: u64,
}

impl Shard {
    /// The range `[⌊i·total/n⌋, ⌊(i+1)·total/n⌋)` of `0..total` this shard
    /// covers: the `n` ranges are disjoint, contiguous, cover `0..total`,
    /// and their lengths differ by at most one.
    #[must_use]
    pub fn range(self, total: u64) -> Range<u64> {
        let at = |k: u64| (u128::from(k) * u128::from(total) / u128::from(self.count)) as u64;
        at(self.index)..at(self.index + 1)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Most shards a run may be split into.
pub const MAX_SHARDS: u64 = 1 << 32;

/// `--shard i/n`: `0 <= i < n <= 2^32`.
///
/// # Errors
/// A reason, for clap to show beside the option.
pub fn parse(s: &str) -> Result<Shard, String> {
    let (i, n) = s.split_once('/').ok_or_else(|| "expected i/n, e.g. 0/16 (shard i of n, 0-based)".to_string())?;
    let num = |t: &str| t.trim().parse::<u64>().map_err(|_| format!("{t:?} is not a non-negative integer"));
    let (index, count) = (num(i)?, num(n)?);
    if count == 0 || count > MAX_SHARDS {
        return Err(format!("the shard count must be in 1..={MAX_SHARDS}"));
    }
    if index >= count {
        return Err(format!("{index}/{count}: shards of {count} are numbered 0..={}", count - 1));
    }
    Ok(Shard { index, count })
}

/// A shard-file error in the CLI's words: each run setting named by the flag
/// that sets it, and the merge's own refusals prefixed with `--merge`.
#[must_use]
pub fn describe(e: &itgfx_backends::shards::ShardError) -> String {
    use itgfx_backends::shards::ShardError;
    let line = e.describe(|s| flag(s).to_string());
    match e {
        ShardError::NoShards | ShardError::Missing { .. } => format!("--merge: {line}"),
        _ => line,
    }
}

/// The flag that sets a run setting.
fn flag(s: itgfx_backends::shards::Setting) -> &'static str {
    use itgfx_backends::shards::Setting;
    match s {
        Setting::Sampler => "--sampler",
        Setting::SamplesPerPixel => "--spp",
        Setting::MaxSamplesPerPixel => "--max-spp",
        Setting::Threshold => "--threshold",
        Setting::TutorialForm => "--tutorial-form",
        Setting::Delta => "--delta",
        Setting::BinaryContrast => "--binary-contrast",
        Setting::ImageSize | Setting::ImageResolution => "--size",
        Setting::Seed => "--seed",
        Setting::Camera => "--camera",
        Setting::Backend => "--backend",
        Setting::Viewpoints => "--viewpoints",
        Setting::Estimator => "--estimator",
        Setting::Distance => "--distance",
        Setting::Levels => "subdivision levels",
        Setting::Resolution => "--resolution",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_tile_the_run() {
        for total in [1u64, 7, 100, 1_000_000_007, u64::MAX] {
            for count in [1u64, 2, 3, 16, 97] {
                if count > total {
                    continue;
                }
                let mut next = 0;
                let (mut lo, mut hi) = (u64::MAX, 0);
                for index in 0..count {
                    let r = Shard { index, count }.range(total);
                    assert_eq!(r.start, next);
                    next = r.end;
                    lo = lo.min(r.end - r.start);
                    hi = hi.max(r.end - r.start);
                }
                assert_eq!(next, total);
                assert!(hi - lo <= 1 && lo >= 1);
            }
        }
    }

    #[test]
    fn parse_refuses_what_is_not_a_shard() {
        assert_eq!(parse("3/16"), Ok(Shard { index: 3, count: 16 }));
        for bad in ["3", "16/16", "1/0", "-1/4", "a/4", "1/4/5", "0/4294967297"] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }
}
