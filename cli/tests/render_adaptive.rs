//! `--sampler adaptive`, `--variance` and `--time-budget` end to end (issue 23).

use std::path::{Path, PathBuf};

mod common;
use common::{fails, itgfx, json, s, z_score};
use itgfx_cli::render::images::read_exr;

fn temp(name: &str) -> PathBuf {
    common::temp("render-adaptive", name)
}

/// Renders `scene` at 48² into `out`; returns the JSON and each pixel's luminance.
fn render(scene: &str, out: &Path, extra: &[&str]) -> (serde_json::Value, Vec<f64>) {
    common::render_luminance(scene, out, extra)
}

#[test]
fn adaptive_keeps_the_uniform_mean_spends_the_budget_and_skips_the_background() {
    let dir = temp("means");
    for scene in ["open-sphere:1", "mirror-room:1"] {
        let (_, uniform) = render(scene, &dir.join(format!("{scene}-u")), &["--seed", "1"]);
        let (v, y) = render(scene, &dir.join(format!("{scene}-a")), &["--sampler", "adaptive", "--seed", "2"]);
        let z = z_score(&y, &uniform);
        assert!(z.abs() < 3.0, "{scene}: adaptive's mean is {z:.2} standard errors from uniform's");
        // Every traced ray is in the image, and the budget is met exactly.
        assert_eq!(v["spp_traced_mean"].as_f64().unwrap(), 32.0, "{scene}");
        assert_eq!(v["spp_mean"].as_f64().unwrap(), 32.0, "{scene}");
        assert_eq!(v["form"], "unbiased");
        let (lo, hi) = (v["spp_min"].as_u64().unwrap(), v["spp_max"].as_u64().unwrap());
        if scene.starts_with("open") {
            // The black background keeps its 8-spp pilot alone; the object takes the rest.
            assert_eq!(lo, 8, "{scene}: spp_min");
            assert!(hi >= 64, "{scene}: spp_max {hi}");
        } else {
            // A closed room: no pixel's neighbourhood is empty.
            assert!(lo > 8, "{scene}: spp_min {lo}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn adaptive_gives_one_exr_for_one_and_two_threads() {
    let dir = temp("threads");
    let exr = |threads: &str| {
        let out = dir.join(threads);
        render("open-blocks", &out, &["--sampler", "adaptive", "--threads", threads]);
        std::fs::read(out.join("image.exr")).unwrap()
    };
    assert!(exr("1") == exr("2"), "adaptive: the EXR differs between 1 and 2 threads");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An emitter (radiance (2, 3, 4), nothing else) covering the left 65% of
/// the view: every sample is exactly 0 or `L`, so a pixel with mean `m` of
/// `n` samples has, per channel, the sample variance `n/(n−1) · m (L − m)`.
fn edge_scene(dir: &Path) -> PathBuf {
    std::fs::write(dir.join("e.mtl"), "newmtl light\nKd 0.5 0.5 0.5\nKe 2 3 4\n").unwrap();
    let obj = dir.join("edge.obj");
    // Facing −z, towards the eye at the origin.
    std::fs::write(&obj, "mtllib e.mtl\nusemtl light\nv -2 -2 1\nv -2 2 1\nv 0.3 2 1\nv 0.3 -2 1\nf 1 2 3 4\n")
        .unwrap();
    obj
}

/// Checks `variance.exr` in `out` against the hand computation for `n` samples a pixel.
fn check_variance(out: &Path, n: f64) {
    let mean = read_exr(&out.join("image.exr")).unwrap();
    let var = read_exr(&out.join("variance.exr")).unwrap();
    let light = [2.0, 3.0, 4.0];
    let mut edge = 0;
    for (m, v) in mean.rgb.iter().zip(&var.rgb) {
        for c in 0..3 {
            let want = n / (n - 1.0) * m[c] * (light[c] - m[c]);
            assert!((v[c] - want).abs() < 1e-4 * light[c] * light[c], "mean {m:?} variance {v:?}, want {want}");
        }
        if m[0] > 0.01 && m[0] < 1.99 {
            edge += 1;
        }
    }
    assert!(edge >= 2, "the edge column is partly covered in {edge} pixels");
}

#[test]
fn variance_matches_the_hand_computation_in_one_run_and_pooled_passes() {
    let dir = temp("variance");
    let obj = edge_scene(&dir);
    let base = ["render", s(&obj), "--size", "4x4", "--camera", "0,0,0,0,0,1,0,1,0,90", "--variance", "--json"];
    let out = dir.join("one");
    let mut args = base.to_vec();
    args.extend(["--out", s(&out), "--spp", "16"]);
    let v = json(&itgfx(&args));
    assert!(v["wrote"].as_array().unwrap().iter().any(|f| f.as_str().unwrap().ends_with("variance.exr")));
    check_variance(&out, 16.0);
    // Passes pooled by --time-budget: the variance of all their samples.
    let out = dir.join("passes");
    let mut args = base.to_vec();
    args.extend(["--out", s(&out), "--spp", "4", "--time-budget", "0.3"]);
    let v = json(&itgfx(&args));
    let passes = v["passes"].as_u64().unwrap();
    assert!(passes >= 2, "{passes} passes in 0.3 s of a 4 x 4 image");
    assert_eq!(v["spp_mean"].as_f64().unwrap(), 4.0 * passes as f64);
    check_variance(&out, 4.0 * passes as f64);
    // The adaptive sampler: a pixel's count n is 8 (its pilot) or more, so its
    // variance lies between m (L − m) and 8/7 of it.
    let out = dir.join("adaptive");
    let mut args = base.to_vec();
    args.extend(["--out", s(&out), "--spp", "16", "--sampler", "adaptive"]);
    itgfx(&args);
    let var = read_exr(&out.join("variance.exr")).unwrap();
    let mean = read_exr(&out.join("image.exr")).unwrap();
    for (m, v) in mean.rgb.iter().zip(&var.rgb) {
        let least = m[2] * (4.0 - m[2]);
        assert!(v[2] >= least - 1e-3 && v[2] <= least * 8.0 / 7.0 + 1e-3, "mean {m:?} variance {v:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_input_for_the_new_options_is_one_line_exit_2() {
    let dir = temp("bad");
    let out = dir.join("o");
    let o = s(&out);
    for t in ["0", "-1", "nan", "inf", "1e300", "700000"] {
        fails(&["render", "cornell-box", "--out", o, "--size", "8x8", &format!("--time-budget={t}")], "--time-budget");
    }
    fails(&["render", "cornell-box", "--size", "8x8", "--variance"], "--out");
    fails(&["render", "cornell-box", "--out", o, "--size", "8x8", "--variance", "--sampler", "ec"], "--variance");
    fails(
        &["render", "cornell-box", "--out", o, "--size", "8x8", "--sampler", "adaptive", "--threshold", "0.1"],
        "no threshold",
    );
    fails(&["render", "cornell-box", "--out", o, "--size", "8x8", "--sampler", "adaptive", "--tutorial-form"], "one");
    fails(&["render", "cornell-box", "--out", o, "--size", "8x8", "--sampler", "adaptive", "--spp", "4"], "pilot");
    fails(&["render", "open-sphere:7", "--out", o, "--size", "8x8"], "open-sphere");
    assert!(!out.exists(), "failed runs leave no --out directory behind");
    std::fs::remove_dir_all(&dir).unwrap();
}
