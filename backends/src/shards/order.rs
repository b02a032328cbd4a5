//! Putting the shards of one run in order before an exact merge: every
//! shard file names its place `i/n`; the merge refuses foreign shards
//! (another scene, other settings, another count), duplicates and missing
//! ones, each with one line naming the file(s).

use super::error::{Difference, ShardError};

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
}
