//! Putting the shards of one run in order before an exact merge: every
//! shard file (viewpoint rows, render rows) names its place `i/n`; the merge
//! refuses foreign shards (another scene, other settings, another count),
//! duplicates and missing ones, each with one line naming the file(s).

/// Orders `named` shards (each with the name used in errors) by their
/// place `position(s) = (i, n)`. `foreign(s)` describes why a shard is not
/// of this run (`None` when it is); it is asked before the place is checked.
///
/// # Errors
/// One line: no shards, a foreign shard, a shard of another count, two
/// shards with one place, or the missing places (the first 8).
pub fn order<T>(
    named: Vec<(String, T)>,
    position: impl Fn(&T) -> (u64, u64),
    foreign: impl Fn(&T) -> Option<String>,
) -> Result<Vec<T>, String> {
    let Some(n) = named.first().map(|s| position(&s.1).1) else {
        return Err("--merge: no shard files".into());
    };
    let mut slots: Vec<Option<(String, T)>> = Vec::new();
    for (name, s) in named {
        if let Some(why) = foreign(&s) {
            return Err(format!("{name}: {why}"));
        }
        let (i, count) = position(&s);
        if count != n {
            return Err(format!("{name}: shard {i}/{count} among shards of {n}"));
        }
        if slots.is_empty() {
            slots.resize_with(n as usize, || None);
        }
        let i = i as usize;
        if let Some((other, _)) = &slots[i] {
            return Err(format!("{name} and {other} are both shard {i}/{n}"));
        }
        slots[i] = Some((name, s));
    }
    let missing: Vec<String> =
        slots.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| format!("{i}/{n}")).collect();
    if !missing.is_empty() {
        let more = if missing.len() > 8 { format!(" and {} more", missing.len() - 8) } else { String::new() };
        return Err(format!("--merge: shard {}{more} missing", missing[..missing.len().min(8)].join(", ")));
    }
    Ok(slots.into_iter().flatten().map(|(_, s)| s).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(v: &[(u64, u64, bool)]) -> Result<Vec<u64>, String> {
        let named = v.iter().enumerate().map(|(k, &s)| (format!("f{k}"), s)).collect();
        order(named, |s| (s.0, s.1), |s| (!s.2).then(|| "foreign".to_string()))
            .map(|o| o.into_iter().map(|s| s.0).collect())
    }

    #[test]
    fn orders_and_refuses() {
        assert_eq!(run(&[(2, 3, true), (0, 3, true), (1, 3, true)]).unwrap(), vec![0, 1, 2]);
        assert_eq!(run(&[(0, 2, true)]).unwrap_err(), "--merge: shard 1/2 missing");
        assert_eq!(run(&[(0, 2, true), (0, 2, true)]).unwrap_err(), "f1 and f0 are both shard 0/2");
        assert_eq!(run(&[(0, 2, true), (1, 2, false)]).unwrap_err(), "f1: foreign");
        assert_eq!(run(&[(0, 2, true), (1, 3, true)]).unwrap_err(), "f1: shard 1/3 among shards of 2");
        assert_eq!(run(&[]).unwrap_err(), "--merge: no shard files");
    }
}
