//! `itgfx render --shard i/n --save-shard F` and `itgfx render --merge`:
//! the merged EXR is the single run's, byte for byte, for every kind of
//! sampler (uniform, a tuned batch criterion, the refinement tree, the
//! supersampler); missing, duplicate and foreign shards are refused.

use std::path::{Path, PathBuf};

mod common;
use common::{fails, itgfx, json as ok, s};

fn temp(name: &str) -> PathBuf {
    common::temp("render-shard", name)
}

// 24 rays a pixel: the default (unbiased) form's 16 a pixel to decide and estimate, and 8 more to share.
const BASE: [&str; 6] = ["render", "mirror-room:1", "--size", "20x17", "--spp", "24"];

fn shards(dir: &Path, sampler: &str, n: u32, seed: &str) -> Vec<PathBuf> {
    (0..n)
        .map(|i| {
            let f = dir.join(format!("{sampler}-{seed}-{i}of{n}.json"));
            let shard = format!("{i}/{n}");
            let mut args = BASE.to_vec();
            args.extend(["--sampler", sampler, "--seed", seed, "--shard", &shard, "--save-shard", s(&f), "--json"]);
            let v = ok(&itgfx(&args));
            assert_eq!(v["shard"], shard.as_str());
            f
        })
        .collect()
}

#[test]
fn merged_shards_give_the_single_run_exr_for_every_sampler() {
    let dir = temp("exact");
    for sampler in ["uniform", "hl-sqrt", "ec", "es"] {
        let single = dir.join(format!("single-{sampler}"));
        let mut args = BASE.to_vec();
        args.extend(["--sampler", sampler, "--out", s(&single), "--json"]);
        let one = ok(&itgfx(&args));
        if sampler != "uniform" {
            assert_eq!(one["form"], "unbiased", "{sampler}: the default form");
            assert!(one["spp_max"].as_u64() > one["spp_min"].as_u64(), "{sampler}: the pixels' counts vary");
        }
        let files = shards(&dir, sampler, 3, "1");
        // Any order, comma- or space-separated.
        let merged = dir.join(format!("merged-{sampler}"));
        let list = format!("{},{}", s(&files[2]), s(&files[0]));
        let m = ok(&itgfx(&["render", "--merge", &list, s(&files[1]), "--out", s(&merged), "--json"]));
        let a = std::fs::read(single.join("image.exr")).unwrap();
        let b = std::fs::read(merged.join("image.exr")).unwrap();
        assert!(a == b, "{sampler}: the merged EXR differs from the single run's");
        assert_eq!(m["spp_mean"], one["spp_mean"], "{sampler}");
        assert_eq!(m["threshold"], one["threshold"], "{sampler}: every shard tuned the same threshold");
        assert_eq!(m["shards"], 3);
        let d = std::fs::read(merged.join("density.png")).unwrap();
        assert_eq!(d, std::fs::read(single.join("density.png")).unwrap(), "{sampler}: density map");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn missing_duplicate_and_foreign_shards_are_refused() {
    let dir = temp("refuse");
    let f = shards(&dir, "uniform", 2, "1");
    let other = shards(&dir, "uniform", 2, "2");
    let out = dir.join("out");
    let o = s(&out);
    fails(&["render", "--merge", s(&f[0]), "--out", o], "shard 1/2 missing");
    fails(&["render", "--merge", s(&f[0]), s(&f[0]), s(&f[1]), "--out", o], "both shard 0/2");
    fails(&["render", "--merge", s(&f[0]), s(&other[1]), "--out", o], "--seed 1 here, 2 there");
    let three = shards(&dir, "uniform", 3, "1");
    fails(&["render", "--merge", s(&f[0]), s(&three[1]), "--out", o], "among shards of 2");
    let junk = dir.join("junk.json");
    std::fs::write(&junk, "{\"format\":\"itgfx-counts\",\"version\":2}").unwrap();
    fails(&["render", "--merge", s(&f[0]), s(&junk), "--out", o], "not a render shard file");
    std::fs::write(&junk, "not json").unwrap();
    fails(&["render", "--merge", s(&junk), "--out", o], "not a render shard file");
    assert!(!out.exists(), "refused merges leave no --out directory");
    // Shard options are checked before any work.
    let save = dir.join("x.json");
    let mut a = BASE.to_vec();
    a.extend(["--shard", "0/18", "--save-shard", s(&save)]);
    fails(&a, "more shards than the 17 rows");
    let mut a = BASE.to_vec();
    a.extend(["--shard", "0/2", "--save-shard", s(&save), "--out", o]);
    fails(&a, "--merge run");
    let mut a = BASE.to_vec();
    a.extend(["--shard", "2/2", "--save-shard", s(&save)]);
    fails(&a, "--shard");
    fails(&["render", "--merge", s(&f[0]), s(&f[1]), "--sampler", "kl", "--out", o], "--merge");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_tree_s_samples_per_node_are_a_shard_setting() {
    // `--node-samples` (N_s^r) changes every tree pixel: the shards of a run
    // must agree on it, and shards that do merge to the single run's EXR.
    let dir = temp("nodes");
    let run = |name: &str, extra: &[&str]| {
        let mut args = BASE.to_vec();
        args.extend(["--sampler", "ec", "--threshold", "0.01"]);
        args.extend_from_slice(extra);
        let f = dir.join(name);
        args.extend(["--save-shard", s(&f), "--json"]);
        ok(&itgfx(&args));
        f
    };
    let a = run("a.json", &["--node-samples", "4", "--shard", "0/2"]);
    let b = run("b.json", &["--node-samples", "4", "--shard", "1/2"]);
    let c = run("c.json", &["--shard", "1/2"]);
    let out = dir.join("out");
    fails(&["render", "--merge", s(&a), s(&c), "--out", s(&out)], "4 samples a node");
    let single = dir.join("single");
    let mut args = BASE.to_vec();
    args.extend(["--sampler", "ec", "--threshold", "0.01", "--node-samples", "4", "--out", s(&single), "--json"]);
    ok(&itgfx(&args));
    ok(&itgfx(&["render", "--merge", s(&a), s(&b), "--out", s(&out), "--json"]));
    let (x, y) = (std::fs::read(single.join("image.exr")).unwrap(), std::fs::read(out.join("image.exr")).unwrap());
    assert!(x == y, "the merged EXR differs from the single run's");
    std::fs::remove_dir_all(&dir).unwrap();
}
