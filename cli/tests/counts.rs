//! The counts file end to end (`--save-counts`, `--merge`): the binary
//! and JSON (`F.json`) formats, both under the one shard header (format 4), round-trip bit for
//! bit, shards merge in any order and across formats, and every broken or
//! hostile file is refused with one line and exit code 2.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::{Value, json};

fn itgfx(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_itgfx")).args(args).output().expect("run itgfx")
}

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("itgfx-counts-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A file in a directory of the calling test's own (tests run in parallel).
fn path(name: &str) -> String {
    let t = std::thread::current();
    let d = dir().join(t.name().unwrap_or("main").replace("::", "-"));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name).to_str().unwrap().to_string()
}

/// The JSON output without the wall-clock time and a merge's memory
/// estimate (binary inputs only: a merge of JSON files has none).
fn json_of(args: &[&str]) -> Value {
    let out = itgfx(args);
    assert!(out.status.success(), "itgfx {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut v: Value = serde_json::from_slice(&out.stdout).unwrap();
    v.as_object_mut().unwrap().remove("seconds");
    if let Some(m) = v.as_object_mut().unwrap().remove("merge_memory_estimate_MiB") {
        assert!(m.as_f64().is_some_and(|m| m > 0.0) && args.contains(&"--merge"), "{m}");
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

/// Saves the counts of `cube-enclosure:1` (`extra` options added) as JSON
/// (the tests below edit it) and returns the file.
fn save(name: &str, extra: &[&str]) -> String {
    let p = path(&format!("{name}.json"));
    let mut a = vec!["complexity", "cube-enclosure:1", "--lines", "2000", "--save-counts", &p];
    a.extend_from_slice(extra);
    if !extra.contains(&"--blocks") {
        a.extend_from_slice(&["--blocks", "4"]);
    }
    let out = itgfx(&a);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    p
}

fn read(p: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn write(name: &str, v: &Value) -> String {
    let p = path(name);
    std::fs::write(&p, serde_json::to_string(v).unwrap()).unwrap();
    p
}

fn merge(files: &[&str]) -> Vec<String> {
    vec!["complexity".into(), "cube-enclosure:1".into(), "--merge".into(), files.join(","), "--json".into()]
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// Merging one saved run reproduces it bit for bit (I_S_cont_stderr used to
/// differ in the last digits), and shards merge into the run whatever their
/// order (I_S_corrected used to depend on it).
#[test]
fn saved_runs_and_shards_reproduce_the_run_bit_for_bit() {
    let p = path("whole.counts");
    let whole =
        json_of(&["complexity", "cube-enclosure:2", "--lines", "30000", "--seed", "4", "--save-counts", &p, "--json"]);
    let again = json_of(&["complexity", "cube-enclosure:2", "--merge", &p, "--json"]);
    assert_eq!(again, whole);
    let shard = |name: &str, off: &str, n: &str| {
        let p = path(name);
        let a = ["complexity", "cube-enclosure:2", "--lines", n, "--offset", off, "--seed", "4", "--save-counts", &p];
        assert!(itgfx(&a).status.success());
        p
    };
    let (a, b, c) = (shard("s1", "0", "7000"), shard("s2", "7000", "13001"), shard("s3", "20001", "9999"));
    for order in [[&a, &b, &c], [&c, &a, &b], [&b, &c, &a]] {
        let list = format!("{},{},{}", order[0], order[1], order[2]);
        let m = json_of(&["complexity", "cube-enclosure:2", "--merge", &list, "--json"]);
        assert_eq!(m, whole, "{list}");
    }
}

/// `--merge` refuses shards of another scene, seed, line kind or block
/// count, the same range twice and overlapping ranges.
#[test]
fn merge_refuses_what_is_not_one_run() {
    let a = save("a.counts", &[]);
    let b = save("b.counts", &["--offset", "2000"]);
    let seed = save("seed.counts", &["--offset", "4000", "--seed", "9"]);
    let local = save("local.counts", &["--offset", "4000", "--local"]);
    let blocks = save("blocks.counts", &["--offset", "4000", "--blocks", "3"]);
    let overlap = save("overlap.counts", &["--offset", "1000"]);
    let other = path("other.counts");
    let o = ["complexity", "cube-enclosure:2", "--lines", "100", "--offset", "5000", "--save-counts", &other];
    assert!(itgfx(&o).status.success());
    assert!(itgfx(&strs(&merge(&[&a, &b]))).status.success());
    refused(&strs(&merge(&[&a, &seed])), "seed 1 and seed 9");
    refused(&strs(&merge(&[&a, &local])), "local-line and global-line");
    refused(&strs(&merge(&[&a, &blocks])), "4 and 3 jackknife blocks");
    refused(&strs(&merge(&[&a, &a])), "lines 0..2000 are counted twice");
    refused(&strs(&merge(&[&a, &b, &a])), "lines 0..2000 are counted twice");
    refused(&strs(&merge(&[&a, &overlap])), "line ranges 0..2000 and 1000..3000 overlap");
    refused(&strs(&merge(&[&a, &other])), "\"cube-enclosure:2\"");
}

/// Areas of -0.25, 0, NaN and inf used to panic (exit 101) in the
/// evaluation; now the file is refused.
#[test]
fn bad_areas_are_refused() {
    let v1 = "itgfx-counts 1\nscene cube-enclosure:1\npatches 6 local 0\narea -0.25\narea 1.0\narea 1.0\narea 1.0\n\
              area 1.0\narea 1.0\nblock 10 1 0 6.0 1 0.5 0.25 2\n0 1 1\n1 0 1\nend\n";
    let p = path("v1.counts");
    std::fs::write(&p, v1).unwrap();
    refused(&strs(&merge(&[&p])), "written by an older itgfx (format 1); re-run");
    let good = read(&save("good.counts", &[]));
    for (area, needle) in [
        (json!(-0.25), "patch 0 has area -0.25"),
        (json!(0.0), "patch 0 has area 0"),
        (json!(null), "invalid type: null"),
        (json!("NaN"), "invalid type: string"),
    ] {
        let mut v = good.clone();
        v["areas"][0] = area;
        refused(&strs(&merge(&[&write("area.counts", &v)])), needle);
    }
    let text =
        std::fs::read_to_string(save("inf.counts", &[])).unwrap().replacen("\"areas\":[1.0", "\"areas\":[1e999", 1);
    let p = path("inf.counts");
    std::fs::write(&p, text).unwrap();
    refused(&strs(&merge(&[&p])), "number out of range");
}

/// `patches 999999999999` and a huge pair count used to abort on allocation
/// (exit 134); a file's contents are bounded by its length, and declared
/// sizes are checked against what is listed.
#[test]
fn huge_declared_sizes_are_refused_without_allocating() {
    let p = path("huge-v1.counts");
    std::fs::write(&p, "itgfx-counts 1\nscene x\npatches 999999999999 local 0\n").unwrap();
    refused(&strs(&merge(&[&p])), "older itgfx (format 1)");
    // The header's sizes are under its fingerprint: an edit is refused as one.
    let edited = "does not match the scene and settings";
    let mut v = read(&save("huge.counts", &[]));
    v["header"]["scene"]["patches"] = json!(999_999_999_999u64);
    refused(&strs(&merge(&[&write("huge.counts", &v)])), edited);
    let mut v = read(&save("blocks.counts", &[]));
    v["header"]["settings"]["blocks"] = json!(4_000_000_000u64);
    refused(&strs(&merge(&[&write("blocks.counts", &v)])), edited);
}

/// A pair count of 2^64-1 used to wrap when merged: sums are checked.
#[test]
fn pair_counts_past_64_bits_are_refused() {
    let mut v = read(&save("big.counts", &["--blocks", "1"]));
    let set = |v: &mut Value, pairs: Value, segments: u64| {
        v["blocks"][0]["pairs"] = pairs;
        v["blocks"][0]["segments"] = json!(segments);
        v["blocks"][0]["samples"] = json!(0);
        v["blocks"][0]["log_sum"] = json!("0");
        v["blocks"][0]["log_sq_sum"] = json!("0");
        v["blocks"][0]["background"] = json!([]);
        v["blocks"][0]["escaped"] = json!(0);
        v["endpoints"] = json!([]);
    };
    set(&mut v, json!([[0, 1, u64::MAX], [1, 0, 1]]), 1 << 63);
    refused(&strs(&merge(&[&write("max.counts", &v)])), "overflows 64 bits");
    set(&mut v, json!([[0, 1, u64::MAX - 1]]), u64::MAX / 2);
    let a = write("a-big.counts", &v);
    let mut w = read(&save("b-big.counts", &["--blocks", "1", "--offset", "2000"]));
    set(&mut w, json!([[0, 1, 2]]), 1);
    let b = write("b-big.counts", &w);
    refused(&strs(&merge(&[&a, &b])), "a pair count overflows 64 bits");
}

/// Inconsistent sums (what NaN and inf in a version-1 file became) are
/// refused before any output is written: no PLY, no PNG.
#[test]
fn nothing_non_finite_reaches_the_outputs() {
    let ply = path("bad.ply");
    let mut v = read(&save("sum.counts", &[]));
    v["blocks"][0]["log_sum"] = json!(i128::MAX.to_string());
    let p = write("sum.counts", &v);
    refused(&["complexity", "cube-enclosure:1", "--merge", &p, "--export-ply", &ply], "I_S^c sums are out of range");
    let mut v = read(&save("end.counts", &[]));
    v["endpoints"][0][2] = json!(i128::MIN.to_string());
    let p = write("end.counts", &v);
    refused(&["complexity", "cube-enclosure:1", "--merge", &p, "--export-ply", &ply], "endpoint log sum");
    assert!(!Path::new(&ply).exists());
    // A good file exports finite values only.
    let p = save("fine.counts", &[]);
    let out = itgfx(&["complexity", "cube-enclosure:1", "--merge", &p, "--export-ply", &ply, "--color-by", "delta"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&std::fs::read(&ply).unwrap()).to_lowercase();
    assert!(!text.contains("nan") && !text.contains("inf"));
}

/// A scene whose name holds a newline (an OBJ path) round-trips: the old
/// line-based file broke at the newline.
#[test]
fn a_scene_name_with_a_newline_round_trips() {
    let d = dir().join("two\nlines");
    std::fs::create_dir_all(&d).unwrap();
    let obj = d.join("cube.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n",
    )
    .unwrap();
    let o = obj.to_str().unwrap();
    let p = path("newline.counts.json");
    let run = json_of(&["complexity", o, "--lines", "3000", "--save-counts", &p, "--json"]);
    assert_eq!(read(&p)["header"]["scene"]["name"], json!(o));
    assert_eq!(json_of(&["complexity", o, "--merge", &p, "--json"]), run);
}

/// The binary file (the default) and the JSON file (`.json`) hold the same
/// counts: shards saved in either format merge into the single run bit for
/// bit, the binary file is the smaller, and a JSON shard converts to binary
/// by merging it alone.
#[test]
fn binary_and_json_shards_merge_into_the_run() {
    let run = ["complexity", "cube-enclosure:3", "--lines", "20000", "--seed", "5", "--json"];
    let whole = json_of(&run);
    let shard = |i: u32, name: &str| {
        let p = path(name);
        let s = format!("{i}/3");
        let mut a = run.to_vec();
        a.extend_from_slice(&["--shard", &s, "--save-counts", &p]);
        assert!(itgfx(&a).status.success());
        p
    };
    let (a, b, c) = (shard(0, "a.counts"), shard(1, "b.counts.json"), shard(2, "c.counts"));
    let bin = std::fs::read(&a).unwrap();
    assert_eq!(&bin[..8], b"ITGFXCNT");
    let b_bin = path("b-converted.counts");
    let convert = ["complexity", "cube-enclosure:3", "--merge", &b, "--save-counts", &b_bin];
    assert!(itgfx(&convert).status.success());
    assert!(std::fs::metadata(&b_bin).unwrap().len() < std::fs::metadata(&b).unwrap().len());
    for list in [format!("{a},{b},{c}"), format!("{c},{b_bin},{a}")] {
        let m = json_of(&["complexity", "cube-enclosure:3", "--lines", "20000", "--merge", &list, "--json"]);
        assert_eq!(m, whole, "{list}");
    }
}

/// A hostile binary file (a huge declared size, a truncation, bytes after
/// the end, another version, garbage) is refused with one line, exit 2,
/// and no huge allocation.
#[test]
fn hostile_binary_files_are_refused() {
    let p = path("good.counts");
    let a = ["complexity", "cube-enclosure:1", "--lines", "2000", "--blocks", "2", "--save-counts", &p];
    assert!(itgfx(&a).status.success());
    let good = std::fs::read(&p).unwrap();
    // The header's length, then the header, then the count of line ranges.
    let header_len = u32::from_le_bytes(good[12..16].try_into().unwrap()) as usize;
    let ranges_at = 16 + header_len;
    let edit = |name: &str, f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = good.clone();
        f(&mut b);
        let q = path(name);
        std::fs::write(&q, b).unwrap();
        q
    };
    let huge = edit("huge.counts", &|b| b[ranges_at..ranges_at + 8].copy_from_slice(&u64::MAX.to_le_bytes()));
    refused(&strs(&merge(&[&huge])), "line ranges: 18446744073709551615 declared but only");
    let v3 = edit("v3.counts", &|b| b[8..12].copy_from_slice(&3u32.to_le_bytes()));
    refused(&strs(&merge(&[&v3])), "written by an older itgfx (format 3); re-run");
    let cut = edit("cut.counts", &|b| b.truncate(b.len() - 3));
    refused(&strs(&merge(&[&cut])), "(truncated?)");
    let more = edit("more.counts", &|b| b.extend_from_slice(b"x"));
    refused(&strs(&merge(&[&more])), "1 bytes follow the last block");
    let v9 = edit("v9.counts", &|b| b[8..12].copy_from_slice(&9u32.to_le_bytes()));
    refused(&strs(&merge(&[&v9])), "version 9");
    let garbage = edit("garbage.counts", &|b| {
        b[0] = 0xff;
    });
    refused(&strs(&merge(&[&garbage])), "neither binary (ITGFXCNT) nor JSON");
}
