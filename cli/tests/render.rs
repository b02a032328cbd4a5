//! `itgfx render` and `itgfx compare` end to end: small images (≤ 32², ≤ 16 spp).

use std::path::{Path, PathBuf};

mod common;
use common::{fails, itgfx, json, refused_for_memory, s, under_ulimit};

fn temp(name: &str) -> PathBuf {
    common::temp("render", name)
}

/// A closed cube seen from inside, every face diffuse with albedo `a` and
/// emitting `e`: the radiance is `e / (1 − a)` everywhere (the furnace).
fn furnace(dir: &Path, a: f64, e: f64) -> PathBuf {
    std::fs::write(dir.join("f.mtl"), format!("newmtl grey\nKd {a} {a} {a}\nKe {e} {e} {e}\n")).unwrap();
    let obj = dir.join("furnace.obj");
    // Faces wound to face inwards.
    std::fs::write(
        &obj,
        "mtllib f.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n",
    )
    .unwrap();
    obj
}

#[test]
fn furnace_is_unbiased() {
    let dir = temp("furnace");
    let obj = furnace(&dir, 0.6, 1.0);
    let out = dir.join("out");
    let camera = "0.5,0.5,0.5,0.5,0.5,1,0,1,0,90";
    let v = json(&itgfx(&[
        "render",
        s(&obj),
        "--out",
        s(&out),
        "--size",
        "24x24",
        "--spp",
        "8",
        "--camera",
        camera,
        "--json",
    ]));
    // Per-pixel scatter gives the standard error of the image mean.
    let exr = out.join("image.exr");
    let mean = v["mean_luminance"].as_f64().unwrap();
    let cmp = json(&itgfx(&["compare", s(&exr), s(&exr), "--json"]));
    assert_eq!(cmp["relMSE"].as_f64().unwrap(), 0.0);
    assert_eq!(cmp["PSNR_a"], "inf");
    // Radiance e/(1-a) = 2.5; 576 pixel means of 8 paths each. The spread of one
    // path's value is below its mean here (RR weights ≤ 1/0.6): SE < 2.5/sqrt(4608) ≈ 0.037.
    let want = 1.0 / (1.0 - 0.6);
    assert!((mean - want).abs() < 3.0 * want / (576.0f64 * 8.0).sqrt(), "furnace mean {mean}, want {want}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn adaptive_sampling_keeps_the_furnace_mean() {
    let dir = temp("furnace-adaptive");
    let obj = furnace(&dir, 0.6, 1.0);
    let camera = "0.5,0.5,0.5,0.5,0.5,1,0,1,0,90";
    let want = 1.0 / (1.0 - 0.6);
    for (sampler, threshold) in [("ct", "0.2"), ("kl-sqrt", "0.002"), ("ec", "0.01")] {
        let out = dir.join(sampler);
        let v = json(&itgfx(&[
            "render",
            s(&obj),
            "--out",
            s(&out),
            "--size",
            "24x24",
            "--spp",
            "8",
            "--camera",
            camera,
            "--sampler",
            sampler,
            "--threshold",
            threshold,
            "--json",
        ]));
        // The default form: decisions on a pilot set, the image from fresh samples.
        assert_eq!(v["form"], "unbiased", "{sampler}");
        let (image, traced) = (v["spp_mean"].as_f64().unwrap(), v["spp_traced_mean"].as_f64().unwrap());
        assert!(image > 8.0, "{sampler}: some pixels refined ({image})");
        if sampler == "ec" {
            assert!(traced > image, "ec: the pilot tree and the fresh leaves");
        } else {
            assert_eq!(traced, 2.0 * image, "{sampler}: pilot and image sets are the same size");
        }
        // At least 8 fresh paths a pixel: the SE bound of the uniform test holds.
        let mean = v["mean_luminance"].as_f64().unwrap();
        assert!((mean - want).abs() < 3.0 * want / (576.0f64 * 8.0).sqrt(), "{sampler}: mean {mean}, want {want}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn adaptive_samplers_spend_the_budget() {
    let dir = temp("adaptive");
    // The threshold tuned to an average of 32 rays traced (pilot: every pixel of 22 x 22, another seed),
    // decisions included: the default form decides on as many samples as the image takes.
    let out = dir.join("hl");
    let v = json(&itgfx(&[
        "render",
        "mirror-room:1",
        "--out",
        s(&out),
        "--size",
        "22x22",
        "--spp",
        "32",
        "--sampler",
        "hl-sqrt",
        "--json",
    ]));
    let traced = v["spp_traced_mean"].as_f64().unwrap();
    assert!((traced - 32.0).abs() < 4.0, "traced {traced} a pixel for a budget of 32");
    assert_eq!(traced, 2.0 * v["spp_mean"].as_f64().unwrap(), "pilot and image sets are the same size");
    assert!(v["spp_min"].as_u64().unwrap() >= 8 && v["spp_max"].as_u64().unwrap() <= 512);
    assert!(v["spp_max"].as_u64().unwrap() > v["spp_min"].as_u64().unwrap(), "the density varies");
    assert!(v["threshold"].as_f64().unwrap() > 0.0);
    assert_eq!(&std::fs::read(out.join("density.png")).unwrap()[1..4], b"PNG");
    // Every criterion runs with a given threshold.
    for c in ["cc", "ct", "kl", "cs", "hl", "kl-sqrt", "cs-sqrt", "ec-batch", "rel"] {
        let out = dir.join(c);
        let v = json(&itgfx(&[
            "render",
            "cornell-box",
            "--out",
            s(&out),
            "--size",
            "12x12",
            "--spp",
            "8",
            "--sampler",
            c,
            "--threshold",
            "0.01",
            "--max-spp",
            "24",
            "--json",
        ]));
        assert!(v["spp_min"].as_u64().unwrap() >= 8 && v["spp_max"].as_u64().unwrap() <= 24, "{c}");
    }
    // The refinement tree: 8 samples a node, at most 1 + 4 + 16 + 64 nodes a pixel.
    let out = dir.join("ec");
    let v = json(&itgfx(&[
        "render",
        "cornell-box",
        "--out",
        s(&out),
        "--size",
        "12x12",
        "--spp",
        "8",
        "--sampler",
        "ec",
        "--threshold",
        "0.001",
        "--json",
    ]));
    let (lo, hi) = (v["spp_min"].as_u64().unwrap(), v["spp_max"].as_u64().unwrap());
    assert!(lo >= 8 && hi <= 680 && hi > lo && hi % 8 == 0, "{lo}..{hi}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn cornell_box_images_json_and_threads() {
    let dir = temp("cornell");
    let run = |sub: &str, threads: &str| {
        let out = dir.join(sub);
        let v = json(&itgfx(&[
            "render",
            "cornell-box",
            "--out",
            s(&out),
            "--size",
            "32x24",
            "--spp",
            "8",
            "--threads",
            threads,
            "--json",
        ]));
        (v, std::fs::read(out.join("image.exr")).unwrap(), out)
    };
    let (v, exr1, out) = run("one", "1");
    // --export-scene: one OBJ per material and scene.json for peers.
    let ex = dir.join("export");
    json(&itgfx(&[
        "render",
        "cornell-box",
        "--out",
        s(&ex),
        "--size",
        "8x8",
        "--spp",
        "1",
        "--export-scene",
        "--json",
    ]));
    let desc: serde_json::Value = serde_json::from_slice(&std::fs::read(ex.join("scene.json")).unwrap()).unwrap();
    let mats = desc["materials"].as_array().unwrap();
    assert_eq!(mats.iter().map(|m| m["triangles"].as_u64().unwrap()).sum::<u64>(), 34, "17 quads");
    assert!(mats.iter().any(|m| m["radiance"][0].as_f64().unwrap() == 17.0), "the light emits");
    assert_eq!(v["width"], 32);
    assert_eq!(v["height"], 24);
    assert_eq!(v["spp_mean"].as_f64().unwrap(), 8.0);
    assert!(v["mean_luminance"].as_f64().unwrap() > 0.0, "the light emits");
    assert_eq!(&exr1[..4], &[0x76, 0x2f, 0x31, 0x01], "OpenEXR magic");
    for png in ["image.png", "density.png"] {
        assert_eq!(&std::fs::read(out.join(png)).unwrap()[1..4], b"PNG");
    }
    let (_, exr2, _) = run("two", "2");
    assert_eq!(exr1, exr2, "same seed, same EXR with 1 and 2 threads");
    // Another seed: a different image.
    let other = dir.join("seed");
    json(&itgfx(&[
        "render",
        "cornell-box",
        "--out",
        s(&other),
        "--size",
        "32x24",
        "--spp",
        "8",
        "--seed",
        "2",
        "--json",
    ]));
    assert_ne!(std::fs::read(other.join("image.exr")).unwrap(), exr1);
    // --reference: the render against itself in another run is exact.
    let again = dir.join("again");
    let r = json(&itgfx(&[
        "render",
        "cornell-box",
        "--out",
        s(&again),
        "--size",
        "32x24",
        "--spp",
        "8",
        "--reference",
        s(&out.join("image.exr")),
        "--json",
    ]));
    assert_eq!(r["relMSE"].as_f64().unwrap(), 0.0);
    let c = json(&itgfx(&["compare", s(&other.join("image.exr")), s(&out.join("image.exr")), "--json"]));
    assert!(c["RMSE_a"].as_f64().unwrap() > 0.0 && c["PSNR_p"].as_f64().unwrap().is_finite());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_input_is_one_line_exit_2() {
    let dir = temp("bad");
    let out = dir.join("o");
    let o = s(&out);
    fails(&["render", "cube-enclosure:2", "--out", o, "--size", "8x8", "--spp", "1"], "no light");
    // Outside the closed Cornell box, and inside the mirror room's tall block.
    fails(
        &["render", "cornell-box", "--out", o, "--size", "8x8", "--camera", "278,273,-800,278,273,0,0,1,0,40"],
        "outside the closed scene",
    );
    fails(
        &["render", "mirror-room:1", "--out", o, "--size", "8x8", "--camera", "0.6,0.8,1.9,0.6,0.8,5,0,1,0,40"],
        "inside a closed object",
    );
    fails(&["render", "sphere", "--out", o, "--size", "8x8"], "analytic sphere");
    fails(&["render", "cornell-box", "--out", o, "--size", "0x8"], "--size");
    fails(&["render", "cornell-box", "--out", o, "--size", "8"], "--size");
    fails(&["render", "cornell-box", "--out", o, "--size", "8192x8192", "--spp", "65536"], "needs about");
    fails(&["render", "cornell-box", "--out", o, "--spp", "0"], "--spp");
    fails(&["render", "cornell-box", "--out", o, "--camera", "0,0,0,0,0,0,0,1,0,40"], "--camera");
    fails(&["render", "cornell-box", "--out", o, "--camera", "1,2,3"], "--camera");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "magic"], "--sampler");
    fails(&["render", "cornell-box", "--size", "8x8"], "--out");
    fails(&["render", "cornell-box", "--out", o, "--threshold", "0.1"], "adaptive");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "kl", "--spp", "4"], "at least 8");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "kl", "--spp", "12"], "at least 16");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "kl", "--unbiased"], "--unbiased is gone");
    fails(&["render", "cornell-box", "--out", o, "--tutorial-form"], "adaptive");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "kl", "--spp", "16", "--max-spp", "8"], "--max-spp");
    fails(&["render", "cornell-box", "--out", o, "--sampler", "kl", "--threshold=-1"], "--threshold");
    fails(&["render", "--out", o], "scene");
    fails(&["render", "/nonexistent/x.obj", "--out", o], "/nonexistent/x.obj");
    let file = dir.join("file");
    std::fs::write(&file, "x").unwrap();
    fails(&["render", "cornell-box", "--out", s(&file), "--size", "8x8"], "not a directory");
    // A missing MTL is an error, not a grey scene.
    let obj = dir.join("nomtl.obj");
    std::fs::write(&obj, "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    fails(&["render", s(&obj), "--out", o, "--size", "8x8"], "missing.mtl");
    assert!(!out.exists(), "failed runs leave no --out directory behind");
    fails(&["compare", s(&file), s(&file)], "OpenEXR");
    fails(&["compare", "/nonexistent/a.exr", s(&file)], "/nonexistent/a.exr");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn vulkan_renders_the_cpu_image_where_a_device_exists() {
    if !itgfx(&["devices"]).status.success() {
        // CI sets ITGFX_REQUIRE_VULKAN=1 (lavapipe is installed there): no skipping.
        assert!(std::env::var_os("ITGFX_REQUIRE_VULKAN").is_none(), "ITGFX_REQUIRE_VULKAN is set but no device");
        eprintln!("no Vulkan device: the vulkan render is not compared");
        return;
    }
    let dir = temp("vulkan");
    let run = |backend: &str, scene: &str, sampler: &str, spp: &str| {
        let out = dir.join(format!("{backend}-{sampler}"));
        let args = [
            "render",
            scene,
            "--out",
            s(&out),
            "--size",
            "12x8",
            "--spp",
            spp,
            "--sampler",
            sampler,
            "--backend",
            backend,
            "--json",
        ];
        json(&itgfx(&args));
        std::fs::read(out.join("image.exr")).unwrap()
    };
    // Both backends return the same closest hits (the seam's conformance), so
    // the same image; adaptive samplers then take the same decisions.
    for (scene, sampler, spp) in
        [("cornell-box", "uniform", "2"), ("mirror-room:1", "hl-sqrt", "32"), ("mirror-room:1", "ec", "32")]
    {
        assert_eq!(run("vulkan", scene, sampler, spp), run("cpu", scene, sampler, spp), "{sampler}: EXRs differ");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_render_over_the_memory_budget_is_refused_before_any_work() {
    // 4096 x 4096 pixels: about 3.5 GiB by the estimate (224 bytes a
    // pixel, render::job::Settings::memory), against the 2 GiB of address
    // space left to the process: refused at once with the real budget (the
    // fixed 4 GiB ceiling of before let it start and abort).
    let o = temp("memory").join("o");
    let t = std::time::Instant::now();
    let args = ["render", "cornell-box", "--size", "4096x4096", "--spp", "1", "--out", s(&o)];
    let out = under_ulimit(2 << 20, &args);
    let (need, left) = refused_for_memory(&out, "render");
    assert!(need >= 3 << 10 && left < 2 << 10, "{need} MiB against {left} MiB");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("ulimit -v") && err.contains("lower --size"), "{err}");
    assert!(t.elapsed().as_secs() < 20, "refused before tracing");
    assert!(!o.exists(), "nothing made");
    // Far past any machine's memory (60 GiB): refused alike, without a limit.
    fails(&["render", "cornell-box", "--out", s(&o), "--size", "8192x8192", "--spp", "65536"], "lower --size");
}
