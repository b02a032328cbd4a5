//! The shard errors: a [`ShardError`] for every refusal of a shard file;
//! a setting that differs between two shards is a [`Setting`], which the
//! engine names in words and a front end may map to its own option names
//! ([`ShardError::describe`]).

use std::fmt;

/// A run setting that every shard of the run must share.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Setting {
    /// The render sampler.
    Sampler,
    /// Samples per pixel (the first batch).
    SamplesPerPixel,
    /// Most samples a pixel may take.
    MaxSamplesPerPixel,
    /// The sampler's threshold.
    Threshold,
    /// The tutorial's (biased) form of adaptive sampling.
    TutorialForm,
    /// The weight of colour against geometry in the refinement tree.
    Delta,
    /// The binary colour contrast of the refinement tree.
    BinaryContrast,
    /// Image size in pixels.
    ImageSize,
    /// The seed of every random draw.
    Seed,
    /// The camera.
    Camera,
    /// The tracing backend.
    Backend,
    /// Number of viewpoints.
    Viewpoints,
    /// The viewpoint channel's estimator.
    Estimator,
    /// Viewpoint distance.
    Distance,
    /// Subdivision levels.
    Levels,
    /// Rays per side of a viewpoint's image (a volume's).
    ImageResolution,
    /// Grid resolution of the ray-grid estimator.
    Resolution,
    /// Global or local lines (counts files).
    LineKind,
    /// Jackknife blocks (counts files).
    Blocks,
}

impl Setting {
    /// The setting in words.
    #[must_use]
    pub const fn words(self) -> &'static str {
        match self {
            Setting::Sampler => "sampler",
            Setting::SamplesPerPixel => "samples per pixel",
            Setting::MaxSamplesPerPixel => "most samples per pixel",
            Setting::Threshold => "threshold",
            Setting::TutorialForm => "tutorial form",
            Setting::Delta => "delta",
            Setting::BinaryContrast => "binary contrast",
            Setting::ImageSize => "image size",
            Setting::Seed => "seed",
            Setting::Camera => "camera",
            Setting::Backend => "backend",
            Setting::Viewpoints => "viewpoints",
            Setting::Estimator => "estimator",
            Setting::Distance => "distance",
            Setting::Levels => "subdivision levels",
            Setting::ImageResolution => "image size",
            Setting::Resolution => "resolution",
            Setting::LineKind => "line kind",
            Setting::Blocks => "jackknife blocks",
        }
    }
}

/// The first setting two shards (or a run and a shard) disagree on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Difference {
    /// Which setting.
    pub setting: Setting,
    /// Its value here (the run, or the first shard).
    pub here: String,
    /// Its value in the other shard.
    pub there: String,
    /// How `there` is said: "there" between shards, "in the shard" between a run and a shard.
    pub where_: &'static str,
}

impl Difference {
    /// `Some` when `here != there`.
    #[must_use]
    pub fn of(setting: Setting, here: String, there: String, where_: &'static str) -> Option<Self> {
        (here != there).then_some(Self { setting, here, there, where_ })
    }
}

/// Why shard files cannot be read or merged.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShardError {
    /// No shard files at all.
    NoShards,
    /// Places of the run no file holds: the first 8, and how many more.
    Missing {
        /// `i/n` of the first missing places.
        places: Vec<String>,
        /// How many more are missing.
        more: usize,
    },
    /// A file of another run: one setting differs.
    OtherRun {
        /// The file.
        file: String,
        /// The setting and its two values.
        difference: Difference,
    },
    /// Two files hold one place.
    Duplicate {
        /// The later file.
        file: String,
        /// The earlier one.
        other: String,
        /// The place, `i/n`.
        place: String,
    },
    /// A file that belongs elsewhere (another scene, threshold, count of
    /// shards).
    Foreign {
        /// The file (or the two files).
        file: String,
        /// Why, in words.
        why: String,
    },
    /// Text that is not a shard file of this kind and version.
    Format {
        /// Why, in words (not JSON, another format, another version).
        why: String,
    },
    /// A shard file whose contents break an invariant the merge relies on.
    Invalid(String),
    /// A shard file of this kind in an earlier format, which this itgfx no
    /// longer reads.
    Older {
        /// The kind of file, in words ("render shard file").
        kind: &'static str,
        /// The format version it was written in.
        version: u32,
    },
    /// A file that could not be read (I/O, not UTF-8 text, too large).
    Unreadable(String),
    /// An error in one file of several: the file and what is wrong with it.
    InFile {
        /// The file, as named in errors.
        file: String,
        /// What is wrong.
        error: Box<ShardError>,
    },
}

impl ShardError {
    /// The error in one line, with each [`Setting`] named by `name` (a front
    /// end passes its option names; [`fmt::Display`] uses the words).
    pub fn describe(&self, name: &dyn Fn(Setting) -> String) -> String {
        match self {
            ShardError::NoShards => "no shard files".into(),
            ShardError::Missing { places, more } => {
                let more = if *more > 0 { format!(" and {more} more") } else { String::new() };
                format!("shard {}{more} missing", places.join(", "))
            }
            ShardError::OtherRun { file, difference: d } => {
                format!(
                    "{file}: a shard of another run ({} {} here, {} {})",
                    name(d.setting),
                    d.here,
                    d.there,
                    d.where_
                )
            }
            ShardError::Duplicate { file, other, place } => format!("{file} and {other} are both shard {place}"),
            ShardError::Foreign { file, why } => format!("{file}: {why}"),
            ShardError::Format { why } | ShardError::Invalid(why) | ShardError::Unreadable(why) => why.clone(),
            ShardError::Older { kind, version } => {
                format!("{kind} written by an older itgfx (format {version}); re-run the shard")
            }
            ShardError::InFile { file, error } => format!("{file}: {}", error.describe(name)),
        }
    }
}

impl fmt::Display for ShardError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.describe(&|s| s.words().to_string()))
    }
}

impl std::error::Error for ShardError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_front_end_names_settings_its_own_way() {
        let d = Difference::of(Setting::Seed, "1".into(), "2".into(), "there").unwrap();
        let e = ShardError::OtherRun { file: "b".into(), difference: d };
        assert_eq!(e.to_string(), "b: a shard of another run (seed 1 here, 2 there)");
        assert_eq!(e.describe(&|_| "--seed".into()), "b: a shard of another run (--seed 1 here, 2 there)");
        assert!(Difference::of(Setting::Seed, "1".into(), "1".into(), "there").is_none());
        let older =
            ShardError::InFile { file: "f".into(), error: Box::new(ShardError::Older { kind: "k", version: 1 }) };
        assert_eq!(older.to_string(), "f: k written by an older itgfx (format 1); re-run the shard");
    }
}
