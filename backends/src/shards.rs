//! Putting the shards of one run in order before an exact merge: every
//! shard file (viewpoint rows, render rows) names its place `i/n`; the merge
//! refuses foreign shards (another scene, other settings, another count),
//! duplicates and missing ones, each with one line naming the file(s).
//!
//! Errors are a [`ShardError`]; a setting that differs between two shards is
//! a [`Setting`], which the engine names in words and a front end may map to
//! its own option names ([`ShardError::describe`]).

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
}

impl ShardError {
    /// The error in one line, with each [`Setting`] named by `name` (a front
    /// end passes its option names; [`fmt::Display`] uses the words).
    pub fn describe(&self, name: impl Fn(Setting) -> String) -> String {
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
            ShardError::Format { why } | ShardError::Invalid(why) => why.clone(),
        }
    }
}

impl fmt::Display for ShardError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.describe(|s| s.words().to_string()))
    }
}

impl std::error::Error for ShardError {}

/// Why a shard is not of this run, as [`order`] asks it.
pub enum Foreign {
    /// Another run: a setting differs.
    Run(Difference),
    /// Anything else, in words.
    Other(String),
}

/// Orders `named` shards (each with the name used in errors) by their
/// place `position(s) = (i, n)`. `foreign(s)` says why a shard is not of
/// this run (`None` when it is); it is asked before the place is checked.
///
/// # Errors
/// No shards, a foreign shard, a shard of another count, two shards with
/// one place, or the missing places (the first 8).
pub fn order<T>(
    named: Vec<(String, T)>,
    position: impl Fn(&T) -> (u64, u64),
    foreign: impl Fn(&T) -> Option<Foreign>,
) -> Result<Vec<T>, ShardError> {
    let Some(n) = named.first().map(|s| position(&s.1).1) else {
        return Err(ShardError::NoShards);
    };
    let mut slots: Vec<Option<(String, T)>> = Vec::new();
    for (name, s) in named {
        match foreign(&s) {
            Some(Foreign::Run(difference)) => return Err(ShardError::OtherRun { file: name, difference }),
            Some(Foreign::Other(why)) => return Err(ShardError::Foreign { file: name, why }),
            None => {}
        }
        let (i, count) = position(&s);
        if count != n {
            return Err(ShardError::Foreign { file: name, why: format!("shard {i}/{count} among shards of {n}") });
        }
        if slots.is_empty() {
            slots.resize_with(n as usize, || None);
        }
        let i = i as usize;
        if let Some((other, _)) = &slots[i] {
            return Err(ShardError::Duplicate { file: name, other: other.clone(), place: format!("{i}/{n}") });
        }
        slots[i] = Some((name, s));
    }
    let missing: Vec<String> =
        slots.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| format!("{i}/{n}")).collect();
    if !missing.is_empty() {
        let more = missing.len().saturating_sub(8);
        return Err(ShardError::Missing { places: missing[..missing.len().min(8)].to_vec(), more });
    }
    Ok(slots.into_iter().flatten().map(|(_, s)| s).collect())
}

/// Reads a shard file's JSON text: checks its `format` name and `version`
/// first (so a file of another kind or version gets a line saying so, not a
/// serde message), then parses it whole. `kind` names the file in errors
/// ("render shard file").
///
/// # Errors
/// [`ShardError::Format`]: not JSON, another format, another version, or a
/// field serde rejects.
pub fn read_json<T: serde::de::DeserializeOwned>(
    text: &str,
    kind: &str,
    format: &str,
    version: u32,
) -> Result<T, ShardError> {
    #[derive(serde::Deserialize)]
    struct Head {
        format: Option<String>,
        version: Option<u32>,
    }
    let bad = |why: String| ShardError::Format { why };
    let head: Head = serde_json::from_str(text).map_err(|_| bad(format!("not a {kind} (JSON)")))?;
    if head.format.as_deref() != Some(format) {
        return Err(bad(format!("not a {kind} (format {:?})", head.format.unwrap_or_default())));
    }
    if head.version != Some(version) {
        return Err(bad(format!(
            "{kind} version {}: this itgfx reads version {version}",
            head.version.map_or("none".into(), |v| v.to_string())
        )));
    }
    serde_json::from_str(text).map_err(|e| bad(format!("{kind}: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(v: &[(u64, u64, bool)]) -> Result<Vec<u64>, String> {
        let named = v.iter().enumerate().map(|(k, &s)| (format!("f{k}"), s)).collect();
        order(named, |s| (s.0, s.1), |s| (!s.2).then(|| Foreign::Other("foreign".to_string())))
            .map(|o| o.into_iter().map(|s| s.0).collect())
            .map_err(|e| e.to_string())
    }

    #[test]
    fn orders_and_refuses() {
        assert_eq!(run(&[(2, 3, true), (0, 3, true), (1, 3, true)]).unwrap(), vec![0, 1, 2]);
        assert_eq!(run(&[(0, 2, true)]).unwrap_err(), "shard 1/2 missing");
        assert_eq!(run(&[(0, 2, true), (0, 2, true)]).unwrap_err(), "f1 and f0 are both shard 0/2");
        assert_eq!(run(&[(0, 2, true), (1, 2, false)]).unwrap_err(), "f1: foreign");
        assert_eq!(run(&[(0, 2, true), (1, 3, true)]).unwrap_err(), "f1: shard 1/3 among shards of 2");
        assert_eq!(run(&[]).unwrap_err(), "no shard files");
        let many: Vec<(u64, u64, bool)> = vec![(0, 12, true)];
        assert_eq!(run(&many).unwrap_err(), "shard 1/12, 2/12, 3/12, 4/12, 5/12, 6/12, 7/12, 8/12 and 3 more missing");
    }

    #[test]
    fn a_front_end_names_settings_its_own_way() {
        let d = Difference::of(Setting::Seed, "1".into(), "2".into(), "there").unwrap();
        let e = ShardError::OtherRun { file: "b".into(), difference: d };
        assert_eq!(e.to_string(), "b: a shard of another run (seed 1 here, 2 there)");
        assert_eq!(e.describe(|_| "--seed".into()), "b: a shard of another run (--seed 1 here, 2 there)");
        assert!(Difference::of(Setting::Seed, "1".into(), "1".into(), "there").is_none());
    }
}
