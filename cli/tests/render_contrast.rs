//! `itgfx render` with the contrast samplers of Part IV: the importance-weighted
//! and classic contrast trees (`ic`, `cc-tree`, §6.4), geometry contrast in the
//! tree (`--delta`, eq. (28)), entropy-based supersampling (`es`, §5) and the
//! quality and contrast maps (`--maps`, §3–§4). Small images only.

use std::path::{Path, PathBuf};

mod common;
use common::{fails, itgfx, json, s};

fn temp(name: &str) -> PathBuf {
    common::temp("contrast", name)
}

fn render(out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["render", "mirror-room:1", "--out", s(out), "--size", "24x24", "--json"];
    args.extend_from_slice(extra);
    json(&itgfx(&args))
}

#[test]
fn tree_samplers_spend_the_budget_and_geometry_contrast_refines_edges() {
    let dir = temp("tree");
    for sampler in ["ic", "cc-tree", "ec-binary"] {
        // The default form: the pilot tree (8 a node) decides, 8 fresh samples a leaf estimate.
        let v = render(&dir.join(sampler), &["--spp", "32", "--sampler", sampler]);
        let traced = v["spp_traced_mean"].as_f64().unwrap();
        // Tuned on 144 pilot pixels of another seed, and a split costs 56 rays (4 pilot nodes,
        // 3 more leaves): within a quarter.
        assert!((traced - 32.0).abs() < 8.0, "{sampler}: traced {traced} for a budget of 32");
        let (lo, hi) = (v["spp_min"].as_u64().unwrap(), v["spp_max"].as_u64().unwrap());
        assert!(lo >= 8 && hi <= 680 && hi > lo && hi % 8 == 0, "{sampler}: {lo}..{hi}");
        assert!(v["threshold"].as_f64().unwrap() > 0.0);
    }
    // Geometry contrast alone (δ = 0 in eq. (28)): only nodes whose rays hit
    // different surfaces (or one at very different distances) split, so the
    // tree refines a few edge pixels and leaves the rest at 8.
    let geometry = render(&dir.join("g"), &["--spp", "8", "--sampler", "ec", "--threshold", "0.05", "--delta", "0"]);
    assert!(geometry["spp_max"].as_u64().unwrap() > 8, "geometry edges split");
    let mean = geometry["spp_mean"].as_f64().unwrap();
    assert!(mean > 8.0 && mean < 16.0, "only the edges split: {mean}");
    assert_eq!(geometry["delta"].as_f64().unwrap(), 0.0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn supersampling_spends_exactly_the_budget_and_any_thread_count_gives_one_image() {
    let dir = temp("es");
    let run = |sub: &str, threads: &str| {
        let out = dir.join(sub);
        let v = render(&out, &["--spp", "24", "--sampler", "es", "--delta", "0.5", "--threads", threads]);
        (v, std::fs::read(out.join("image.exr")).unwrap())
    };
    let (v, one) = run("one", "1");
    // The default form: the oracle's 8 only decide; 8 fresh a pixel and N_p (N_s − 16)
    // more shared by contrast: exactly N_s traced, N_s − 8 in the image.
    assert_eq!(v["form"], "unbiased");
    assert_eq!(v["spp_traced_mean"].as_f64().unwrap(), 24.0);
    assert_eq!(v["spp_mean"].as_f64().unwrap(), 16.0);
    assert_eq!(v["spp_min"], 8, "flat pixels keep 8 fresh samples");
    assert!(v["spp_max"].as_u64().unwrap() > 32, "high-contrast pixels take far more");
    assert_eq!(v["oracle_spp"], 8);
    // The tutorial form: N_p (N_s − 8) shared, the oracle's samples kept in the image.
    let t = render(&dir.join("tutorial"), &["--spp", "24", "--sampler", "es", "--delta", "0.5", "--tutorial-form"]);
    assert_eq!((t["spp_mean"].as_f64().unwrap(), t["spp_traced_mean"].as_f64().unwrap()), (24.0, 24.0));
    // No pixel of this scene is exactly flat: the lowest-contrast ones keep the
    // oracle's 8 and at most a few more from the largest remainders (8 with
    // the integrator before stratified vertices, 9 since).
    let min = t["spp_min"].as_u64().unwrap();
    assert!((8..12).contains(&min), "low-contrast pixels keep about the oracle's 8: {min}");
    let (_, two) = run("two", "2");
    assert_eq!(one, two, "same seed, same EXR with 1 and 2 threads");
    // The cap holds and the budget is still met where the caps leave room.
    let c = render(&dir.join("cap"), &["--spp", "24", "--sampler", "es", "--max-spp", "24"]);
    assert!(c["spp_max"].as_u64().unwrap() <= 24);
    assert_eq!(c["spp_traced_mean"].as_f64().unwrap(), 24.0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn maps_are_written_and_mark_edges() {
    let dir = temp("maps");
    let out = dir.join("m");
    let v = render(&out, &["--spp", "8", "--maps", "--delta", "0.5"]);
    for f in [
        "quality.png",
        "geometry-quality.png",
        "contrast.png",
        "colour-contrast.png",
        "binary-contrast.png",
        "geometry-contrast.png",
        "priority-colour.png",
        "depth-difference.png",
        "priority-value.png",
    ] {
        assert_eq!(&std::fs::read(out.join(f)).unwrap()[1..4], b"PNG", "{f}");
    }
    // Simmons' p_c, p_d, p_v (Part IV eqs. (2)-(4)) beside them: their own values.
    let pri = out.join("priority.exr");
    let pc = json(&itgfx(&["compare", s(&pri), s(&out.join("contrast.exr")), "--json"]));
    assert!(pc["RMSE_a"].as_f64().unwrap() > 0.0);
    let q = v["mean_colour_quality"].as_f64().unwrap();
    let g = v["mean_geometry_quality"].as_f64().unwrap();
    let c = v["mean_contrast"].as_f64().unwrap();
    assert!((0.0..1.0).contains(&q) && q > 0.5, "colour quality {q}");
    assert!(g > 0.9 && g < 1.0, "geometry is homogeneous but at the edges: {g}");
    assert!(c > 0.0 && c < 0.5, "contrast {c}");
    // contrast.exr holds (C^c, C_b^c, C^g): readable, in [0, 1], not all flat.
    let exr = out.join("contrast.exr");
    let same = json(&itgfx(&["compare", s(&exr), s(&exr), "--json"]));
    assert_eq!(same["relMSE"].as_f64().unwrap(), 0.0);
    let other = json(&itgfx(&["compare", s(&exr), s(&out.join("quality.exr")), "--json"]));
    assert!(other["RMSE_a"].as_f64().unwrap() > 0.0);
    // The supersampler's maps are its own oracle: no extra pass, the same values.
    let es = render(&dir.join("es"), &["--spp", "16", "--maps", "--delta", "0.5", "--sampler", "es"]);
    assert_eq!(es["mean_contrast"], v["mean_contrast"], "es and a uniform run share the 8-spp oracle");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn contrast_options_are_checked() {
    let dir = temp("bad");
    let o = dir.join("o");
    let o = s(&o);
    fails(&["render", "cornell-box", "--out", o, "--delta", "1.5", "--sampler", "ec"], "--delta");
    fails(&["render", "cornell-box", "--out", o, "--delta", "0.5"], "--delta is for");
    fails(&["render", "cornell-box", "--out", o, "--delta", "0.5", "--sampler", "kl"], "--delta is for");
    fails(&["render", "cornell-box", "--out", o, "--binary-contrast"], "--binary-contrast");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "es", "--threshold", "0.1"], "no --threshold");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "es", "--unbiased"], "the default now");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "ic", "--max-spp", "64"], "depth");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "es", "--spp", "4"], "at least 8");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "es", "--spp", "12"], "--tutorial-form");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn node_samples_change_the_tree_and_bad_values_are_refused() {
    // N_s^r (Part IV §6): the default is 8, so `--node-samples 8` is the
    // default image byte for byte; 4 (Fig. 13's) and 16 give other trees,
    // every pixel's samples a multiple of N_s^r (the unbiased form: N_s^r
    // fresh samples a leaf).
    let dir = temp("nodes");
    let exr = |sub: &str| std::fs::read(dir.join(sub).join("image.exr")).unwrap();
    let common = ["--spp", "32", "--sampler", "ec", "--threshold", "0.01"];
    let base = render(&dir.join("default"), &common);
    assert_eq!(base["node_samples"].as_u64(), Some(8));
    for n in [4u64, 8, 16] {
        let sub = format!("n{n}");
        let ns = n.to_string();
        let v = render(&dir.join(&sub), &[&common[..], &["--node-samples", &ns]].concat());
        assert_eq!(v["node_samples"].as_u64(), Some(n));
        let (lo, hi) = (v["spp_min"].as_u64().unwrap(), v["spp_max"].as_u64().unwrap());
        assert!(lo == n && hi > lo && hi % n == 0 && hi <= 85 * n, "N_s^r {n}: {lo}..{hi}");
        if n == 8 {
            assert_eq!(exr(&sub), exr("default"), "--node-samples 8 is the default");
        } else {
            assert_ne!(exr(&sub), exr("default"), "--node-samples {n} changes nothing");
        }
    }
    let o = dir.join("bad");
    let o = s(&o);
    for bad in ["0", "2", "6", "1028", "4096", "x"] {
        fails(&["render", "cornell-box", "--out", o, "--sampler", "ec", "--node-samples", bad], "--node-samples");
    }
    fails(&["render", "cornell-box", "--out", o, "--sampler", "es", "--node-samples", "4"], "refinement trees");
    fails(&["render", "cornell-box", "--out", o, "--node-samples", "4"], "refinement trees");
    // A misspelt sampler names the nearest one; a far-off name lists them only.
    fails(&["render", "cornell-box", "--out", o, "--sampler", "adaptiv"], "did you mean adaptive?");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "hl-sqr"], "did you mean hl-sqrt?");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "zzzzzzzz"], "uniform, adaptive, es");
    std::fs::remove_dir_all(&dir).unwrap();
}
