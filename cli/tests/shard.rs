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

/// The JSON output without the wall-clock time and a merge's memory estimate.
fn json_of(args: &[&str]) -> Value {
    let out = itgfx(args);
    assert!(out.status.success(), "itgfx {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut v: Value = serde_json::from_slice(&out.stdout).unwrap();
    v.as_object_mut().unwrap().remove("seconds");
    if let Some(m) = v.as_object_mut().unwrap().remove("merge_memory_estimate_MiB") {
        assert!(m.as_f64().is_some_and(|m| m > 0.0), "{m}");
        assert!(args.contains(&"--merge"), "a memory estimate without --merge");
    }
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

/// A merge tree: partial merges (`--merge … --save-counts`) are counts
/// files that record the ranges they cover, so they merge again; a tree of
/// merges (((0,1),(2,3)),4) and a lopsided one equal the flat merge and the
/// single run bit for bit. A partial merge overlapping another input, or a
/// tree missing a piece, is refused with one line before any counts are read.
#[test]
fn complexity_merge_tree_equals_flat_merge_and_single_run() {
    let single = json_of(&["complexity", SCENE, "--lines", LINES, "--seed", "5", "--json"]);
    let s: Vec<String> = (0..5).map(|i| complexity_shard(i, 5, "5")).collect();
    let flat = json_of(&strs(&complexity_merge(&s.iter().collect::<Vec<_>>(), &["--lines", LINES])));
    assert_eq!(flat, single);
    // A partial merge of `files` saved to `name`: it reports the lines it covers.
    let part = |files: &[&String], name: &str, lines: u64| {
        let p = path(name);
        let v = json_of(&strs(&complexity_merge(files, &["--save-counts", &p])));
        assert_eq!(v["lines"].as_u64(), Some(lines), "{name}");
        p
    };
    let a = part(&[&s[0], &s[1]], "t-a.counts", 8000);
    let b = part(&[&s[2], &s[3]], "t-b.counts", 8000);
    let ab = part(&[&b, &a], "t-ab.counts", 16000);
    // --counts-only saves the same counts, without the measures.
    let p = path("t-ab-only.counts");
    let v = json_of(&strs(&complexity_merge(&[&b, &a], &["--save-counts", &p, "--counts-only"])));
    assert_eq!((v["lines"].as_u64(), v["ranges"].as_str(), v.get("I_S")), (Some(16000), Some("0..16000"), None));
    assert_eq!(std::fs::read(&p).unwrap(), std::fs::read(&ab).unwrap());
    assert_eq!(json_of(&strs(&complexity_merge(&[&ab, &s[4]], &["--lines", LINES]))), single);
    // Lopsided: ((((4,3),2),1),0), JSON partials (the other format) on the way.
    let mut acc = part(&[&s[4], &s[3]], "t-l1.json", 8001);
    for (i, lines) in [(2usize, 12001), (1, 16001)] {
        acc = part(&[&acc, &s[i]], &format!("t-l{i}.counts"), lines);
    }
    assert_eq!(json_of(&strs(&complexity_merge(&[&s[0], &acc], &["--lines", LINES]))), single);
    // A piece twice (a shard inside a partial), or a piece missing.
    let m = |f: &[&String], e: &[&str]| complexity_merge(f, e);
    refused(&strs(&m(&[&ab, &s[1], &s[4]], &[])), "lines 4000..8000 are counted twice");
    refused(&strs(&m(&[&a, &ab], &[])), "are counted twice");
    refused(&strs(&m(&[&a, &s[4]], &["--lines", LINES])), "lines 8000..16000 of --lines 20001 are missing");
    let other = complexity_shard(4, 5, "6");
    refused(&strs(&m(&[&ab, &other], &[])), "seed 5 and seed 6");
}

/// Bad `--shard` values and combinations are refused before any work.
#[test]
fn bad_shards_are_refused() {
    for (args, needle) in [
        (&["complexity", SCENE, "--shard", "3/3"][..], "--shard 3/3: shards of 3 are numbered 0..=2"),
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

const MESH: &str = "table-chairs:1";

/// `viewpoints` options of the run under test.
fn vp(extra: &[&str]) -> Vec<String> {
    let mut a: Vec<String> = ["viewpoints", MESH, "--viewpoints", "12"].map(String::from).into();
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

/// Shard `i/n` of the run with options `extra`, saved.
fn vp_shard(i: u64, n: u64, extra: &[&str], tag: &str) -> String {
    let p = path(&format!("v{tag}{i}of{n}.json"));
    let s = format!("{i}/{n}");
    let mut a = vp(extra);
    a.extend(["--shard", &s, "--save-shard", &p, "--json"].map(String::from));
    let v = json_of(&strs(&a));
    assert_eq!(v["shard"], s.as_str());
    p
}

fn vp_merge(files: &[&String], extra: &[&str]) -> Vec<String> {
    let list = files.iter().map(|f| f.as_str()).collect::<Vec<_>>().join(",");
    let mut a = vp(extra);
    a.extend(["--merge", &list, "--json"].map(String::from));
    a
}

/// The views channel, without its wall-clock times.
fn vp_json(args: &[String]) -> Value {
    let mut v = json_of(&strs(args));
    v.as_object_mut().unwrap().remove("channel_seconds");
    v
}

/// Shards of both estimators merge, in any order, into the single run's
/// output bit for bit: every measure, the refinement's standard errors,
/// ray counts and selections. The table and chairs occlude each other, so
/// the solid-angle refinement passes several levels (the merge replays it).
#[test]
fn viewpoint_shards_merge_into_the_single_run_bit_for_bit() {
    for (tag, extra) in [("s", &[][..]), ("g", &["--estimator", "grid", "--resolution", "24"][..])] {
        let single = vp_json(&vp(&[extra, &["--json", "--per-polygon"]].concat()));
        if tag == "s" {
            assert!(single["max_subdivision_used"].as_u64().unwrap() > 4, "refinement exercised: {single}");
        }
        let s: Vec<String> = (0..3).map(|i| vp_shard(i, 3, extra, tag)).collect();
        for order in [[0, 1, 2], [2, 1, 0]] {
            let files = order.map(|k| &s[k]);
            assert_eq!(vp_json(&vp_merge(&files, &[extra, &["--per-polygon"]].concat())), single, "{tag} {order:?}");
        }
        // Shards that keep more refinement levels (16: all of them, the merge traces nothing).
        if tag == "s" {
            for k in ["2", "16"] {
                let s: Vec<String> = (0..3).map(|i| vp_shard(i, 3, &["--shard-levels", k], &format!("k{k}"))).collect();
                let files = [&s[2], &s[0], &s[1]];
                assert_eq!(vp_json(&vp_merge(&files, &["--per-polygon"])), single, "--shard-levels {k}");
            }
        }
        // The measures follow the merging command's options (p(V) here), the rows the shards'.
        let uniform = vp_json(&vp(&[extra, &["--json", "--uniform-input"]].concat()));
        assert_eq!(vp_json(&vp_merge(&[&s[1], &s[0], &s[2]], &[extra, &["--uniform-input"]].concat())), uniform);
    }
}

/// Missing, duplicate and foreign shards (another mesh, distance,
/// estimator, viewpoint count or shard count) and broken files are refused.
#[test]
fn viewpoint_merge_refuses_missing_duplicate_and_foreign_shards() {
    let s: Vec<String> = (0..3).map(|i| vp_shard(i, 3, &[], "s")).collect();
    let far = vp_shard(2, 3, &["--distance", "4"], "far");
    let two = vp_shard(1, 2, &[], "two");
    let grid = vp_shard(2, 3, &["--estimator", "grid"], "grid");
    let m = |f: &[&String], e: &[&str]| vp_merge(f, e);
    refused(&strs(&m(&[&s[0], &s[2]], &[])), "shard 1/3 missing");
    refused(&strs(&m(&[&s[0], &s[1], &s[1]], &[])), "are both shard 1/3");
    refused(&strs(&m(&[&s[0], &s[1], &far], &[])), "a shard of another run (--distance 3.0 here, 4.0 in the shard)");
    refused(&strs(&m(&[&s[0], &s[1], &grid], &[])), "--estimator solid-angle here, grid in the shard");
    refused(&strs(&m(&[&s[0], &s[1], &two], &[])), "shard 1/2 among shards of 3");
    refused(&strs(&m(&[&s[0], &s[1], &s[2]], &["--max-subdivision", "16"])), "subdivision levels");
    let other = ["viewpoints", "torus", "--viewpoints", "12", "--merge", &s[0], "--json"];
    refused(&other, "a shard of another scene (\"table-chairs:1\"");
    let more = ["viewpoints", MESH, "--viewpoints", "42", "--merge", &s[0]];
    refused(&more, "--viewpoints 42 here, 12 in the shard");
    // Broken and tampered files.
    let text = std::fs::read_to_string(&s[1]).unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["header"]["version"] = 9.into();
    let bad = path("version.json");
    std::fs::write(&bad, v.to_string()).unwrap();
    refused(&strs(&m(&[&s[0], &bad, &s[2]], &[])), "viewpoint shard file version 9");
    // A file of the format before the one shard header: its name and version at the top.
    let mut old: Value = serde_json::from_str(&text).unwrap();
    let header = old["header"].take();
    old["format"] = header["format"].clone();
    old["version"] = 1.into();
    std::fs::write(&bad, old.to_string()).unwrap();
    let older = format!("--merge {bad:?}: viewpoint shard file written by an older itgfx (format 1); re-run the shard");
    refused(&strs(&m(&[&s[0], &bad, &s[2]], &[])), &older);
    // Settings edited by hand no longer match the fingerprint.
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["header"]["settings"]["distance"] = 4.0.into();
    std::fs::write(&bad, v.to_string()).unwrap();
    refused(&strs(&m(&[&s[0], &bad, &s[2]], &[])), "does not match the scene and settings");
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["first"] = 3.into();
    std::fs::write(&bad, v.to_string()).unwrap();
    refused(&strs(&m(&[&s[0], &bad, &s[2]], &[])), "shard 1/3 holds the wrong viewpoint range");
    std::fs::write(&bad, &text[..text.len() / 2]).unwrap();
    refused(&strs(&m(&[&s[0], &bad, &s[2]], &[])), "viewpoint shard file");
    refused(&strs(&m(&[&s[0], &s[1], &"/nonexistent/s.json".to_string()], &[])), "/nonexistent/s.json");
}

/// Bad shard options of `viewpoints` are refused before any work.
#[test]
fn bad_viewpoint_shards_are_refused() {
    let p = path("x.json");
    for (args, needle) in [
        (vec!["--shard", "0/2"], "--save-shard"),
        (vec!["--save-shard", &p], "--shard"),
        (vec!["--shard", "0/13", "--save-shard", &p], "give at most 12"),
        (vec!["--shard", "0/2", "--save-shard", &p, "--best-image", "b.png"], "--best-image: a --shard run"),
        (vec!["--shard", "0/2", "--save-shard", &p, "--out", "d"], "--out: a --shard run"),
        (vec!["--shard", "0/2", "--save-shard", &p, "--per-polygon"], "--per-polygon"),
        (vec!["--shard", "0/2", "--save-shard", &p, "--merge", &p], "--merge"),
        (vec!["--shard-levels", "2"], "--shard"),
        (vec!["--shard", "0/2", "--save-shard", &p, "--shard-levels", "0"], "--shard-levels"),
        (
            vec!["--shard", "0/2", "--save-shard", &p, "--estimator", "grid", "--shard-levels", "2"],
            "no refinement levels",
        ),
    ] {
        refused(&strs(&vp(&args)), needle);
    }
    assert!(!std::path::Path::new(&p).exists() && !std::path::Path::new("d").exists());
}
