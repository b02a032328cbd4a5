//! The render shard file: the pixel rows `[⌊i·H/n⌋, ⌊(i+1)·H/n⌋)` of a
//! run, saved as versioned JSON (serde), so that the shards of one run
//! (`--shard i/n`, one per job-array task) merge into the frame the single
//! run renders, bit for bit.
//!
//! Rows, not sample ranges: a pixel's value is the mean of its samples
//! summed in index order, and its samples are a pure function of (seed,
//! pixel), so whole rows merge exactly for every sampler (partial sums of
//! sample ranges would round differently). Adaptive thresholds are tuned
//! on the whole image's pilot grid in every shard (the same threshold, which
//! the merge checks), and `es` traces the whole 8-spp oracle in every shard
//! (its shares depend on every pixel's contrast).
//!
//! Version 3 (earlier versions are refused as "written by an older itgfx":
//! version 2 had its own header, and in version 1 `--spp` of an unbiased
//! run counted its image samples only) holds the shard header of
//! [`crate::shards::header`] (format, version, place `i/n`, fingerprint, the
//! scene's [`MeshFingerprint`] and the settings the pixels depend on,
//! [`RenderSettings`]), then its rows, the threshold used, and per pixel
//! the mean radiance (f64, written so it reads back exactly), the samples
//! in the image and the pilot samples. Everything is checked on reading;
//! foreign, duplicate and missing shards are refused with one line (see
//! [`crate::shards::order`](mod@crate::shards::order)).

use serde::{Deserialize, Serialize};

use super::frame::Frame;
pub use crate::shards::MeshFingerprint;
use crate::shards::{Difference, Foreign, Header, Kind, Place, Setting, ShardError, ShardFile};

/// The `format` field of a render shard file.
pub const FORMAT_NAME: &str = "itgfx-render-shard";
/// The version written and read.
pub const FORMAT_VERSION: u32 = 3;

/// The settings a shard's pixels depend on: every shard of a run must agree on all of them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSettings {
    /// `--sampler`.
    pub sampler: String,
    /// `--spp`.
    pub spp: u32,
    /// Cap on a pixel's samples (adaptive samplers and `es`; 0 otherwise).
    pub max_spp: u32,
    /// `--threshold` as given (`None`: tuned).
    pub threshold: Option<f64>,
    /// Decisions on samples kept out of the image (the default of every
    /// adaptive sampler); false for `--tutorial-form` and `uniform`.
    pub unbiased: bool,
    /// `--delta`.
    pub delta: f64,
    /// `--binary-contrast`.
    pub binary_contrast: bool,
    /// Samples per tree node `N_s^r` (`--node-samples`; 0 for the other samplers).
    #[serde(default)]
    pub node_samples: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// `--seed`.
    pub seed: u64,
    /// The camera: eye, forward, up (normalised coordinates) and vertical field of view (radians).
    pub camera: [f64; 10],
    /// The tracing backend's name.
    pub backend: String,
}

impl crate::shards::Settings for RenderSettings {
    /// The first setting that differs from `other`'s.
    fn difference(&self, other: &Self) -> Option<Difference> {
        let d = |s: Setting, a: String, b: String| Difference::of(s, a, b, "there");
        // A tree's samples per node are part of its sampler.
        let sampler = |s: &Self| match s.node_samples {
            0 => s.sampler.clone(),
            n => format!("{} with {n} samples a node", s.sampler),
        };
        d(Setting::Sampler, sampler(self), sampler(other))
            .or_else(|| d(Setting::SamplesPerPixel, self.spp.to_string(), other.spp.to_string()))
            .or_else(|| d(Setting::MaxSamplesPerPixel, self.max_spp.to_string(), other.max_spp.to_string()))
            .or_else(|| d(Setting::Threshold, format!("{:?}", self.threshold), format!("{:?}", other.threshold)))
            .or_else(|| d(Setting::TutorialForm, (!self.unbiased).to_string(), (!other.unbiased).to_string()))
            .or_else(|| d(Setting::Delta, format!("{:?}", self.delta), format!("{:?}", other.delta)))
            .or_else(|| d(Setting::BinaryContrast, self.binary_contrast.to_string(), other.binary_contrast.to_string()))
            .or_else(|| {
                let size = |s: &Self| format!("{}x{}", s.width, s.height);
                d(Setting::ImageSize, size(self), size(other))
            })
            .or_else(|| d(Setting::Seed, self.seed.to_string(), other.seed.to_string()))
            .or_else(|| d(Setting::Camera, format!("{:?}", self.camera), format!("{:?}", other.camera)))
            .or_else(|| d(Setting::Backend, self.backend.clone(), other.backend.clone()))
    }
}

/// A shard: rows `first_row..end_row` of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderShard {
    /// Format, version, place, fingerprint, scene and settings.
    pub header: Header<RenderSettings>,
    /// First row.
    pub first_row: u32,
    /// One past the last row.
    pub end_row: u32,
    /// The threshold the sampler used (tuned or given), if it has one.
    pub threshold_used: Option<f64>,
    /// Mean radiance of each pixel of the rows, row-major.
    pub rgb: Vec<[f64; 3]>,
    /// Samples in each pixel's value.
    pub samples: Vec<u32>,
    /// Decision-only samples of each pixel (the unbiased form).
    pub pilot_samples: Vec<u32>,
}

/// Rows `[⌊i·H/n⌋, ⌊(i+1)·H/n⌋)` of shard `i` of `n` ([`crate::shards::range`]).
#[must_use]
pub fn shard_rows(i: u64, n: u64, height: u32) -> (u32, u32) {
    let r = crate::shards::range(i, n, u64::from(height));
    (r.start as u32, r.end as u32)
}

/// The kind of file.
const KIND: Kind = Kind { format: FORMAT_NAME, version: FORMAT_VERSION, noun: "render shard file" };

impl ShardFile for RenderShard {
    type Settings = RenderSettings;
    const KIND: Kind = KIND;

    fn header(&self) -> &Header<RenderSettings> {
        &self.header
    }

    fn violation(&self) -> Option<String> {
        let (h, st) = (&self.header, &self.header.settings);
        if st.width == 0 || st.height == 0 {
            return Some("an empty image".into());
        }
        if h.shards > u64::from(st.height) {
            return Some(format!("shard {}/{} of {} rows is not a shard", h.shard, h.shards, st.height));
        }
        if (self.first_row, self.end_row) != shard_rows(h.shard, h.shards, st.height) {
            return Some(format!("shard {}/{} holds the wrong rows", h.shard, h.shards));
        }
        let pixels = u64::from(self.end_row - self.first_row) * u64::from(st.width);
        if [self.rgb.len(), self.samples.len(), self.pilot_samples.len()].iter().any(|&l| l as u64 != pixels) {
            return Some(format!("not {pixels} pixels for rows {}..{}", self.first_row, self.end_row));
        }
        if !self.rgb.iter().flatten().all(|v| v.is_finite() && *v >= 0.0) {
            return Some("a pixel's radiance is not finite and non-negative".into());
        }
        None
    }
}

impl RenderShard {
    /// The shard `(i, n)` of `frame` (which holds its rows only).
    #[must_use]
    pub fn new(
        scene: MeshFingerprint,
        settings: RenderSettings,
        (shard, shards): (u64, u64),
        threshold_used: Option<f64>,
        frame: &Frame,
    ) -> Self {
        let (first_row, end_row) = shard_rows(shard, shards, settings.height);
        Self {
            header: Header::new(KIND, Place { index: shard, count: shards }, scene, settings),
            first_row,
            end_row,
            threshold_used,
            rgb: frame.rgb.clone(),
            samples: frame.samples.clone(),
            pilot_samples: frame.pilot_samples.clone(),
        }
    }

    /// The file's text.
    ///
    /// # Errors
    /// As [`crate::shards::to_json`].
    pub fn to_json(&self) -> Result<String, ShardError> {
        crate::shards::to_json(self)
    }

    /// Reads and checks a shard file's text.
    ///
    /// # Errors
    /// One line naming what is wrong ([`crate::shards::from_json`]).
    pub fn from_json(text: &str) -> Result<Self, ShardError> {
        crate::shards::from_json(text)
    }

    /// Checks the invariants the merge relies on.
    ///
    /// # Errors
    /// [`ShardError::Invalid`] naming the first violation.
    pub fn validate(&self) -> Result<(), ShardError> {
        crate::shards::validate(self)
    }
}

/// The frame of the shards of one run (in any order): rows concatenated —
/// the frame the single run renders — and the threshold they used.
///
/// # Errors
/// One line: foreign shards (another scene or settings than the first, or
/// another threshold), duplicates, missing ones.
pub fn merge(named: Vec<(String, RenderShard)>) -> Result<(RenderShard, Frame), ShardError> {
    let first = named.first().map(|s| s.1.clone()).ok_or(ShardError::NoShards)?;
    let threshold = |s: &RenderShard| {
        (s.threshold_used != first.threshold_used).then(|| {
            Foreign::Other(format!(
                "a shard that used threshold {:?}, not {:?}",
                s.threshold_used, first.threshold_used
            ))
        })
    };
    let shards = crate::shards::order_run(named, &first.header, threshold)?;
    let mut frame = Frame {
        width: first.header.settings.width,
        height: first.header.settings.height,
        rgb: Vec::new(),
        samples: Vec::new(),
        pilot_samples: Vec::new(),
        variance: Vec::new(),
    };
    for s in shards {
        frame.rgb.extend_from_slice(&s.rgb);
        frame.samples.extend_from_slice(&s.samples);
        frame.pilot_samples.extend_from_slice(&s.pilot_samples);
    }
    Ok((first, frame))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shard(i: u64, n: u64, seed: u64) -> RenderShard {
        let settings = RenderSettings {
            sampler: "uniform".into(),
            spp: 4,
            max_spp: 0,
            threshold: None,
            unbiased: false,
            delta: 1.0,
            binary_contrast: false,
            node_samples: 0,
            width: 2,
            height: 5,
            seed,
            camera: [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0],
            backend: "cpu".into(),
        };
        let (a, b) = shard_rows(i, n, 5);
        let px = ((b - a) * 2) as usize;
        let frame = Frame {
            width: 2,
            height: b - a,
            rgb: (0..px).map(|k| [f64::from(a) + 0.1 * k as f64, 0.3, 1.0 / 3.0]).collect(),
            samples: vec![4; px],
            pilot_samples: vec![0; px],
            variance: Vec::new(),
        };
        let scene = MeshFingerprint { name: "s".into(), patches: 1, triangles: 1, hash: "0".into() };
        RenderShard::new(scene, settings, (i, n), None, &frame)
    }

    #[test]
    fn round_trip_and_merge() {
        let parts: Vec<RenderShard> = (0..3).map(|i| shard(i, 3, 1)).collect();
        let back: Vec<(String, RenderShard)> = parts
            .iter()
            .rev()
            .map(|s| (format!("f{}", s.header.shard), RenderShard::from_json(&s.to_json().unwrap()).unwrap()))
            .collect();
        assert_eq!(back[0].1, parts[2], "floats read back exactly");
        let (_, frame) = merge(back).unwrap();
        assert_eq!(frame.height, 5);
        let want: Vec<[f64; 3]> = parts.iter().flat_map(|s| s.rgb.clone()).collect();
        assert_eq!(frame.rgb, want);
        let err = merge(vec![("a".into(), shard(0, 3, 1)), ("b".into(), shard(1, 3, 2))]).unwrap_err();
        assert_eq!(err.to_string(), "b: a shard of another run (seed 1 here, 2 there)");
        assert!(merge(vec![("a".into(), shard(0, 3, 1))]).unwrap_err().to_string().contains("1/3, 2/3 missing"));
        let mut bad = shard(1, 3, 1);
        bad.first_row = 0;
        assert!(RenderShard::from_json(&bad.to_json().unwrap()).unwrap_err().to_string().contains("wrong rows"));
        let other = RenderShard::from_json("{\"format\":\"itgfx-counts\"}").unwrap_err();
        assert!(other.to_string().contains("not a render shard"));
        let mut old = serde_json::to_value(shard(0, 3, 1)).unwrap();
        old["header"]["version"] = 2.into();
        let old = RenderShard::from_json(&old.to_string()).unwrap_err();
        assert_eq!(old.to_string(), "render shard file written by an older itgfx (format 2); re-run the shard");
        let mut edited = shard(0, 3, 1);
        edited.header.settings.seed = 7;
        assert!(RenderShard::from_json(&edited.to_json().unwrap()).unwrap_err().to_string().contains("fingerprint"));
    }
}
