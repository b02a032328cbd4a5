//! `--shard i/n` and `--merge` end to end: the shards of a run, merged in
//! any order, give the single run's output bit for bit; missing, duplicate
//! and foreign shards are refused with one line and exit code 2.

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

/// A file in a directory of the calling test's own (tests run in parallel).
fn path(name: &str) -> String {
    let t = std::thread::current();
    let d: PathBuf = std::env::temp_dir()
        .join(format!("itgfx-shard-{}", std::process::id()))
        .join(t.name().unwrap_or("main").replace("::", "-"));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name).to_str().unwrap().to_string()
}

/// The JSON output without the wall-clock time.
fn json_of(args: &[&str]) -> Value {
    let out = itgfx(args);
    assert!(out.status.success(), "itgfx {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut v: Value = serde_json::from_slice(&out.stdout).unwrap();
    v.as_object_mut().unwrap().remove("seconds");
    v
}

/// Exit code 2, one stderr line containing `needle`, nothing on stdout.
fn refused(args: &[&str], needle: &str) {
    let out = itgfx(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    assert!(err.contains(needle), "{args:?}: {err:?} lacks {needle:?}");
    assert!(out.stdout.is_empty());
}

const SCENE: &str = "cube-enclosure:2";
const LINES: &str = "20001";

/// Shard `i` of `n` of the 20001-line run with seed `seed`, saved.
fn complexity_shard(i: u64, n: u64, seed: &str) -> String {
    let p = path(&format!("c{i}of{n}s{seed}.counts"));
    let s = format!("{i}/{n}");
    let a = ["complexity", SCENE, "--lines", LINES, "--seed", seed, "--shard", &s, "--save-counts", &p, "--json"];
    let v = json_of(&a);
    assert_eq!(v["shard"], s.as_str());
    p
}

fn complexity_merge(files: &[&String], extra: &[&str]) -> Vec<String> {
    let list = files.iter().map(|f| f.as_str()).collect::<Vec<_>>().join(",");
    let mut a: Vec<String> = ["complexity", SCENE, "--merge", &list, "--json"].map(String::from).into();
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// Three uneven shards (20001 lines), merged in any order, with or without
/// `--lines`, equal the single run bit for bit: the counts are integers and
/// fixed-point sums, so the merge is exact.
#[test]
fn complexity_shards_merge_into_the_single_run_bit_for_bit() {
    let single = json_of(&["complexity", SCENE, "--lines", LINES, "--seed", "5", "--json"]);
    let s: Vec<String> = (0..3).map(|i| complexity_shard(i, 3, "5")).collect();
    for order in [[0, 1, 2], [2, 0, 1], [1, 2, 0]] {
        let files = order.map(|k| &s[k]);
        assert_eq!(json_of(&strs(&complexity_merge(&files, &[]))), single, "{order:?}");
        assert_eq!(json_of(&strs(&complexity_merge(&files, &["--lines", LINES]))), single, "{order:?}");
    }
    // A shard traces the lines it says: 6667 lines from index 6667.
    let v = json_of(&["complexity", SCENE, "--lines", LINES, "--seed", "5", "--shard", "1/3", "--json"]);
    assert_eq!((v["lines"].as_u64(), v["first_line"].as_u64()), (Some(6667), Some(6667)));
}

/// Missing (a gap or the last shard), duplicate and foreign shards are refused.
#[test]
fn complexity_merge_refuses_missing_duplicate_and_foreign_shards() {
    let s: Vec<String> = (0..3).map(|i| complexity_shard(i, 3, "5")).collect();
    let seed = complexity_shard(2, 3, "6");
    let m = |f: &[&String], e: &[&str]| complexity_merge(f, e);
    refused(&strs(&m(&[&s[0], &s[2]], &["--lines", LINES])), "lines 6667..13334 of --lines 20001 are missing");
    refused(&strs(&m(&[&s[0], &s[1]], &["--lines", LINES])), "lines 13334..20001 of --lines 20001 are missing");
    refused(&strs(&m(&[&s[0], &s[1], &s[2]], &["--lines", "20000"])), "past --lines 20000");
    refused(&strs(&m(&[&s[0], &s[1], &s[1]], &[])), "lines 6667..13334 are counted twice");
    refused(&strs(&m(&[&s[0], &s[1], &seed], &[])), "seed 5 and seed 6");
    let other = ["complexity", "cube-enclosure:3", "--merge", &s[0], "--json"];
    refused(&other, "the counts are of scene \"cube-enclosure:2\"");
}

/// Bad `--shard` values and combinations are refused before any work.
#[test]
fn bad_shards_are_refused() {
    for (args, needle) in [
        (&["complexity", SCENE, "--shard", "3/3"][..], "shards are numbered 0..=2"),
        (&["complexity", SCENE, "--shard", "1/0"], "1..=4294967296"),
        (&["complexity", SCENE, "--shard", "1"], "expected i/n"),
        (&["complexity", SCENE, "--shard", "x/2"], "not a non-negative integer"),
        (&["complexity", SCENE, "--shard", "0/2", "--offset", "5"], "--offset"),
        (&["complexity", SCENE, "--shard", "0/2", "--merge", "a,b"], "--merge"),
        (&["complexity", SCENE, "--lines", "10", "--shard", "0/11"], "give at most 10 shards"),
    ] {
        refused(args, needle);
    }
}
