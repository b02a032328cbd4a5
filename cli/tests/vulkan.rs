//! `--backend vulkan` and `itgfx devices` as a user runs them. Without a
//! Vulkan device these skip with a printed reason, unless
//! `ITGFX_REQUIRE_VULKAN=1` (CI, on lavapipe) makes them mandatory.

use std::process::{Command, Output};

fn itgfx(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_itgfx"));
    c.args(args);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("run itgfx")
}

fn have_vulkan() -> bool {
    let out = itgfx(&["devices"], &[]);
    if out.status.success() {
        return true;
    }
    let why = String::from_utf8_lossy(&out.stderr);
    assert!(std::env::var_os("ITGFX_REQUIRE_VULKAN").is_none_or(|v| v != "1"), "ITGFX_REQUIRE_VULKAN=1 but: {why}");
    eprintln!("skipping: {why}");
    false
}

/// With the loader hidden, every Vulkan path is one line naming the fix and exit code 2.
#[test]
fn missing_vulkan_is_a_clear_error() {
    let hidden = [("ITGFX_VULKAN_LIBRARY", "/nonexistent/libvulkan.so.1")];
    for args in [
        &["devices"][..],
        &["complexity", "cube", "--lines", "100", "--backend", "vulkan"][..],
        &["volume", "cube:8", "--backend", "vulkan"][..],
    ] {
        let out = itgfx(args, &hidden);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("mesa-vulkan-drivers") && err.lines().count() == 1, "{args:?}: {err}");
    }
    // A loader that finds no driver.
    let out = itgfx(
        &["devices"],
        &[("VK_DRIVER_FILES", "/nonexistent/icd.json"), ("VK_ICD_FILENAMES", "/nonexistent/icd.json")],
    );
    if out.status.code() == Some(2) {
        assert!(String::from_utf8_lossy(&out.stderr).contains("mesa-vulkan-drivers"));
    }
}

/// The JSON of `args --backend backend --json`, with the backend's name
/// checked and removed, and the timings removed.
fn json_on(args: &[&str], backend: &str) -> serde_json::Value {
    let mut all = args.to_vec();
    all.extend(["--backend", backend, "--json"]);
    let out = itgfx(&all, &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let m = v.as_object_mut().unwrap();
    assert_eq!(m.remove("backend").unwrap(), backend);
    m.retain(|k, _| !k.ends_with("seconds"));
    v
}

/// The acceptance command (at 2·10^5 lines): the same JSON on both
/// backends but for the backend's name and the timings.
#[test]
fn complexity_matches_the_cpu_backend() {
    if !have_vulkan() {
        return;
    }
    let args = ["complexity", "cube-enclosure:10", "--lines", "200000", "--seed", "1"];
    assert_eq!(json_on(&args, "cpu"), json_on(&args, "vulkan"));
    let out = itgfx(&["devices", "--json"], &[]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let devices = v["devices"].as_array().unwrap();
    assert!(devices.iter().any(|d| d["used"] == "yes"), "{v}");
}

/// The viewpoint channel traced on Vulkan gives the same JSON as on the CPU.
#[test]
fn viewpoints_match_the_cpu_backend() {
    if !have_vulkan() {
        return;
    }
    let args = ["viewpoints", "table-chairs", "--viewpoints", "42", "--estimator", "grid", "--resolution", "32"];
    assert_eq!(json_on(&args, "cpu"), json_on(&args, "vulkan"));
}

/// The volume channel ray-cast by the Vulkan kernel gives the CPU's JSON
/// (every measure, selection and object of the built-in volumes), but for
/// the backend's name, the timings and the memory estimate (which counts
/// the device's buffers).
#[test]
fn volume_matches_the_cpu_backend() {
    if !have_vulkan() {
        return;
    }
    for args in [
        &["volume", "hydrogen:3,2,0,20", "--viewpoints", "42"][..],
        &["volume", "phantom:16", "--viewpoints", "12", "--focus", "left"][..],
        &["volume", "cube:12", "--tf", "step", "--viewpoints", "12", "--size", "40"][..],
    ] {
        let mut cpu = json_on(args, "cpu");
        let mut gpu = json_on(args, "vulkan");
        let (c, g) = (cpu.as_object_mut().unwrap(), gpu.as_object_mut().unwrap());
        let (mc, mg) = (c.remove("memory_estimate_MiB").unwrap(), g.remove("memory_estimate_MiB").unwrap());
        assert!(g.remove("vulkan_rays_finished_on_host").unwrap().is_u64(), "{args:?}");
        assert!(mg.as_f64().unwrap() > mc.as_f64().unwrap(), "{args:?}: the device's buffers are counted");
        assert_eq!(cpu, gpu, "{args:?}");
    }
}

/// Shards cast on different backends merge into the CPU's single run.
#[test]
fn volume_shards_mix_backends() {
    if !have_vulkan() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("itgfx-vulkan-volume-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let run = ["volume", "hydrogen:3,2,0,16", "--viewpoints", "12"];
    let files: Vec<String> = ["vulkan", "cpu"]
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let f = dir.join(format!("{i}.shard")).display().to_string();
            let shard = format!("{i}/2");
            let out = itgfx(&[&run[..], &["--backend", b, "--shard", &shard, "--save-shard", &f]].concat(), &[]);
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            f
        })
        .collect();
    let merged = json_on(&[&run[..], &["--merge", &files.join(",")]].concat(), "cpu");
    let mut single = json_on(&run, "cpu");
    single.as_object_mut().unwrap().remove("memory_estimate_MiB");
    let mut merged = merged;
    merged.as_object_mut().unwrap().remove("memory_estimate_MiB");
    assert_eq!(merged, single);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A time series and a path between two objects ray-cast by the Vulkan
/// kernel give the CPU's JSON (every frame, the static view, the dynamic
/// path, every path step), but for the backend's name, the timings and the
/// memory estimate.
#[test]
fn volume_series_and_object_paths_match_the_cpu_backend() {
    if !have_vulkan() {
        return;
    }
    for args in [
        &["volume", "--time", "hydrogen-beat:12,3", "--viewpoints", "42"][..],
        &["volume", "phantom:16,1", "--viewpoints", "12", "--path-between", "left,rod", "--path-steps", "4"][..],
    ] {
        let mut cpu = json_on(args, "cpu");
        let mut gpu = json_on(args, "vulkan");
        for r in [&mut cpu, &mut gpu] {
            let m = r.as_object_mut().unwrap();
            m.remove("memory_estimate_MiB");
            m.remove("vulkan_rays_finished_on_host");
        }
        assert_eq!(cpu, gpu, "{args:?}");
    }
}
