//! A merge of counts files as one job (`complexity --merge`): planned from
//! the binary files' headers before any counts are read (one run, line
//! ranges that join, the lines asked for covered exactly, the peak memory
//! estimated by [`merge_memory`] and checked against the budget), then each
//! file read, checked against the scene, and summed exactly.

use std::fmt;
use std::path::PathBuf;

use super::counts_binary::CountsHeader;
use super::merge::{join_ranges, merge_memory};
use super::{CountsError, VisibilityCounts};
use crate::memory::OutOfMemory;
use crate::scene::Scene;

/// A merge of the counts files `files`.
#[derive(Clone, Copy, Debug)]
pub struct CountsMerge<'a> {
    /// The files, in the order given.
    pub files: &'a [PathBuf],
    /// Lines the merged counts must cover exactly (`0..lines`), if given.
    pub lines: Option<u64>,
    /// Whether the merged counts are saved (the estimate includes the file).
    pub save: bool,
    /// Whether the measures are evaluated (the estimate includes them).
    pub measures: bool,
}

/// Where the merged line ranges fall short of or pass `0..lines`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Coverage {
    /// Lines `from..to` of `0..lines` are in no file.
    Missing {
        /// First missing line.
        from: u64,
        /// One past the last missing line of the gap.
        to: u64,
        /// The lines asked for.
        lines: u64,
        /// The ranges the files cover, `a..b, c..d`.
        covered: String,
    },
    /// The files cover lines past `lines`.
    Past {
        /// The lines asked for.
        lines: u64,
        /// The ranges the files cover.
        covered: String,
    },
}

/// Why a merge is refused.
#[derive(Debug)]
pub enum MergeError {
    /// No files.
    NoFiles,
    /// A file that cannot be read, is not of the run or the scene, or
    /// counts a line another file counts.
    File {
        /// The file, as `{path:?}`.
        file: String,
        /// Why.
        error: CountsError,
    },
    /// The files do not cover exactly the lines asked for.
    Coverage(Coverage),
    /// The estimated peak passes the memory budget.
    Memory(OutOfMemory),
}

impl fmt::Display for MergeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MergeError::NoFiles => f.write_str("no counts files"),
            MergeError::File { file, error } => write!(f, "{file}: {error}"),
            MergeError::Coverage(Coverage::Missing { from, to, lines, covered }) => {
                write!(
                    f,
                    "lines {from}..{to} of {lines} lines are missing (a shard is missing?); the files cover {covered}"
                )
            }
            MergeError::Coverage(Coverage::Past { lines, covered }) => {
                write!(f, "the files cover {covered}, past {lines} lines (a shard of another run?)")
            }
            MergeError::Memory(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for MergeError {}

/// Checks that `ranges` (sorted, joined) are exactly `0..lines`.
///
/// # Errors
/// The first gap, or the lines past `lines`.
pub fn check_coverage(ranges: &[(u64, u64)], lines: u64) -> Result<(), Coverage> {
    if ranges == [(0, lines)] {
        return Ok(());
    }
    let covered = ranges.iter().map(|r| format!("{}..{}", r.0, r.1)).collect::<Vec<_>>().join(", ");
    let mut at = 0;
    for r in ranges {
        if r.0 > at && at < lines {
            return Err(Coverage::Missing { from: at, to: r.0.min(lines), lines, covered });
        }
        at = at.max(r.1);
    }
    if at < lines {
        return Err(Coverage::Missing { from: at, to: lines, lines, covered });
    }
    Err(Coverage::Past { lines, covered })
}

impl CountsMerge<'_> {
    /// Plans the merge from the files' headers alone: of one run, their
    /// ranges joined (no line counted twice), the lines asked for covered,
    /// and the peak memory ([`merge_memory`]) within the budget. `None`
    /// when a file is JSON (no header to read: it is checked as it is read,
    /// and gives no estimate).
    ///
    /// # Errors
    /// The first refusal.
    pub fn plan(&self) -> Result<Option<u64>, MergeError> {
        let mut heads: Vec<CountsHeader> = Vec::with_capacity(self.files.len());
        for f in self.files {
            let fail = |error| MergeError::File { file: format!("{f:?}"), error };
            let Some(h) = VisibilityCounts::peek(f).map_err(fail)? else { return Ok(None) };
            if let Some(first) = heads.first() {
                first.same_run(&h).map_err(fail)?;
            }
            heads.push(h);
        }
        let mut ranges = Vec::new();
        for (f, h) in self.files.iter().zip(&heads) {
            ranges =
                join_ranges(&ranges, &h.ranges).map_err(|error| MergeError::File { file: format!("{f:?}"), error })?;
        }
        if let Some(n) = self.lines {
            check_coverage(&ranges, n).map_err(MergeError::Coverage)?;
        }
        let need = merge_memory(&heads, self.save, self.measures);
        let n = self.files.len();
        crate::memory::check(|| format!("a merge of these {n} files (estimated from their headers)"), need)
            .map_err(MergeError::Memory)?;
        Ok(Some(need))
    }

    /// Plans ([`CountsMerge::plan`]), then reads every file, checks it
    /// against `scene` and sums the counts: the counts one run over the
    /// files' lines gives, bit for bit, and the plan's memory estimate.
    ///
    /// # Errors
    /// The first refusal.
    pub fn run(&self, scene: &Scene) -> Result<(VisibilityCounts, Option<u64>), MergeError> {
        let estimate = self.plan()?;
        let mut merged: Option<VisibilityCounts> = None;
        for f in self.files {
            let fail = |error| MergeError::File { file: format!("{f:?}"), error };
            let (_, c) = VisibilityCounts::read(f).map_err(fail)?;
            c.check_scene(scene).map_err(fail)?;
            match &mut merged {
                None => merged = Some(c),
                Some(m) => m.merge(c).map_err(fail)?,
            }
        }
        let merged = merged.ok_or(MergeError::NoFiles)?;
        if let Some(n) = self.lines {
            check_coverage(&merged.ranges, n).map_err(MergeError::Coverage)?;
        }
        Ok((merged, estimate))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_names_the_first_gap_or_the_excess() {
        assert_eq!(check_coverage(&[(0, 10)], 10), Ok(()));
        let gap = check_coverage(&[(0, 3), (5, 10)], 10).unwrap_err();
        assert_eq!(gap, Coverage::Missing { from: 3, to: 5, lines: 10, covered: "0..3, 5..10".into() });
        let end = check_coverage(&[(0, 7)], 10).unwrap_err();
        assert_eq!(end, Coverage::Missing { from: 7, to: 10, lines: 10, covered: "0..7".into() });
        assert_eq!(check_coverage(&[(0, 12)], 10).unwrap_err(), Coverage::Past { lines: 10, covered: "0..12".into() });
    }
}
