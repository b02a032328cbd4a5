//! Adaptive sampling must not bias (issue 10's acceptance): on `mirror-room`,
//! whose caustics the tutorial's shared-sample form darkens, every sampler's
//! image mean in the default (unbiased) form equals the uniform image's
//! within 3 standard errors, while the tutorial form (`--tutorial-form`)
//! fails that same test; the default form gives one EXR for 1 and 2 threads.
//!
//! The standard error is taken over pixels: with the threshold tuned on a
//! pilot of another seed, and the two images rendered with different seeds,
//! the per-pixel differences `d_p = Y_sampler(p) − Y_uniform(p)` are
//! independent (for `es`: given its oracle), each of mean 0 when the
//! sampler is unbiased, so `mean(d) / (sd(d) / √P)` is a z-score.

use std::path::{Path, PathBuf};

mod common;
use common::z_score;

fn temp(name: &str) -> PathBuf {
    common::temp("render-bias", name)
}

/// Every adaptive sampler: the batch criteria, the trees, the supersampler.
const SAMPLERS: [&str; 14] =
    ["cc", "ct", "kl", "cs", "hl", "kl-sqrt", "cs-sqrt", "hl-sqrt", "ec-batch", "rel", "ec", "ic", "cc-tree", "es"];

/// Renders `mirror-room:1` into `out` with `extra` arguments; returns the JSON and each pixel's luminance.
fn render(out: &Path, extra: &[&str]) -> (serde_json::Value, Vec<f64>) {
    common::render_luminance("mirror-room:1", out, extra)
}

#[test]
fn every_sampler_keeps_the_uniform_mean_and_the_tutorial_form_does_not() {
    let dir = temp("means");
    let (_, uniform) = render(&dir.join("uniform"), &["--seed", "1"]);
    let mean_u = uniform.iter().sum::<f64>() / uniform.len() as f64;
    let mut report = Vec::new();
    let mut dark = 0;
    for sampler in SAMPLERS {
        let (v, y) = render(&dir.join(sampler), &["--sampler", sampler, "--seed", "2"]);
        assert_eq!(v["form"], "unbiased", "{sampler}: the default form");
        let traced = v["spp_traced_mean"].as_f64().unwrap();
        // Tuned on a pilot of 576 pixels of another seed; a tree's split costs 56 rays or more.
        assert!((traced - 32.0).abs() < 8.0, "{sampler}: traced {traced} a pixel for --spp 32, pilot included");
        assert!(v["spp_mean"].as_f64().unwrap() < traced, "{sampler}: decision samples are not in the image");
        let z = z_score(&y, &uniform);
        let (t, yt) =
            render(&dir.join(format!("{sampler}-tutorial")), &["--sampler", sampler, "--seed", "2", "--tutorial-form"]);
        assert_eq!(t["form"], "tutorial");
        let zt = z_score(&yt, &uniform);
        let ratio = |y: &[f64]| y.iter().sum::<f64>() / y.len() as f64 / mean_u;
        report.push(format!(
            "{sampler}: z {z:.2} (mean/uniform {:.4}), tutorial z {zt:.2} ({:.4})",
            ratio(&y),
            ratio(&yt)
        ));
        if zt < -3.0 {
            dark += 1;
        }
        assert!(
            z.abs() < 3.0,
            "{sampler}: the default form's mean is {z:.2} standard errors from uniform's\n{}",
            report.join("\n")
        );
    }
    eprintln!("{}", report.join("\n"));
    // The same test can fail: the tutorial form is found dark.
    assert!(dark >= 12, "the tutorial form is > 3 SE dark for only {dark} of 14 samplers\n{}", report.join("\n"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_default_form_gives_one_exr_for_one_and_two_threads() {
    let dir = temp("threads");
    for sampler in ["hl-sqrt", "ec", "es"] {
        let exr = |threads: &str| {
            let out = dir.join(format!("{sampler}-{threads}"));
            render(&out, &["--sampler", sampler, "--threads", threads]);
            std::fs::read(out.join("image.exr")).unwrap()
        };
        assert!(exr("1") == exr("2"), "{sampler}: the EXR differs between 1 and 2 threads");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
